/*
 * bodyvib native core: the regimes of a model with nonlinear elements (contacts, stops,
 * asymmetric dampers), stepped exactly with located events, as
 * bodyvib.runtime.regimes.EventStepper steps them.
 *
 * Each nonlinear element is a linear element whose stiffness, damping and constant force
 * are pseudo-parameters (parameters np + 3 e + 0, 1, 2 of the stencils), set per regime
 * from the element's parameters (and a contact's static preload, solved from gravity when
 * the parameters change). A regime is the state of the switching functions, one bit each
 * (a contact: engaged; a stop's compression and rebound sides: engaged; an asymmetric
 * damper: extending), g = G [x; u] + g0:
 *   contact             F0 + k (x_from - x_to) + c (v_from - v_to)
 *   stop, side s = +-1  -k gap + s (k (x_from - x_to) + c (v_from - v_to))
 *   asymmetric damper   v_to - v_from
 * The regime x' = A x + B u + b, y = Yc z + y0 is assembled from the stencils with the
 * regime's pseudo-parameters, and its step matrices for the step size are computed once
 * and cached (BV_RG_CACHE regimes); the regime with the contacts engaged and the stops free
 * is the linear model's own matrices (a run that never switches is the linear run bit for
 * bit).
 *
 * A step: the exact step of the regime in force, then one sign test per function on the
 * end state and the guard from its last three values (a parabola through g at t - h, t,
 * t + h whose extremum inside the step crosses zero). Only when that fails is the step
 * done again with located events: a cubic-Hermite estimate of each function on the
 * segment, then safeguarded Newton on the regime's exact solution (one matrix exponential
 * per iterate) to BV_RG_TOLERANCE of the step; the switching element changes regime there
 * and the step continues in the new regime. Inputs rise linearly over a step (no input
 * curvature: build_native_fmu refuses a nonlinear model whose inputs curve).
 */
#ifndef BODYVIB_REGIMES_H
#define BODYVIB_REGIMES_H

#include "bodyvib_core.h"

#define BV_RG_CACHE 8            /* regimes whose matrices are kept */
#define BV_RG_MAX_EVENTS 64      /* switchings in one step; more: a chattering contact */
#define BV_RG_TOLERANCE 1e-10    /* located event times, as a fraction of the step */
#define BV_RG_SAMPLES 16         /* points of a segment's cubic-Hermite estimate */

/* A regime's constant terms: b (n, x' = A x + B u + b), y0 (no, outputs' constants) and,
 * for the linear model, its nonlinear elements' point rows (probe, 4 ne x (n + m)). */
typedef struct {
    double *b, *y0, *probe;
} bv_affine;

/* One regime: its model and its step matrices for the step size `key`. */
typedef struct {
    unsigned long mask;  /* the switching functions' states */
    int valid, affine;
    double *A, *B, *b;   /* x' = A x + B u + b */
    double *Y, *y0;      /* y = Y [x | s] + y0 */
    double *S, *gb;      /* [x | s] -> x over the step: S z + gb */
    double *P, *q, *f;   /* the functions at the step's end from the start, each times its
                          * sign in this regime (+1 in force, -1 not): row i of P z + q, with
                          * P = sign (Gx S + [0 | Gs Ms]) and q = sign (Gx gb + g0); a stop's
                          * rebound side (bv_rg_negated) is f times its compression side's row
                          * (f = -1 where both sides have the same sign). The sign test's values
                          * need not wait for the step, and are tested as they come */
    double key;          /* rounded step the S is for; 0: none */
    double h;            /* the step P is for (NaN: none) */
} bv_regime;

typedef struct bv_regimes {
    int nsw;                 /* switching functions */
    int *sw_el, *sw_side;    /* per function: element, side (0 contact, 1 compression,
                              * 2 rebound, 3 rate) */
    double *pe;              /* np + 3 ne: the parameters and a regime's pseudo-parameters */
    double *F0;              /* [ne] contacts' static preloads, N */
    double *Gm, *Gm2;        /* nsw x (n + m): the functions on [x | u] (and the candidate) */
    double *Gz, *Gz2;        /* nsw x (n + ni): on [x | s] */
    double *g0, *g02, *F02;  /* constants (candidates) */
    double *probe;           /* 4 ne x (n + m): the elements' point rows */
    double *lin_b, *lin_y0;  /* the linear model's constants (b = 0, y0: contact flags) */
    bv_affine lin_af;        /* where the linear assembly writes its constants and points */
    unsigned long mask, initial, linear_mask;
    int linear_alias;        /* the linear regime is the linear model (no asymmetric damper) */
    double *g_prev, *g_now, *ge; /* the functions at t - h, t, t + h, each times its sign */
    double *sign;            /* per function: +1 in force ("on"), -1 not (the mask's bits) */
    bv_regime lin, cache[BV_RG_CACHE];
    bv_regime *cur;
    int next;
    long located;            /* steps that took the event path */
    /* scratch of the event path */
    double *x, *xe, *xt, *ub, *ue, *ut, *du, *v1, *v2, *rate;
    double *Phi, *G0, *G1, *gbt, *M, *E, *work;
    int *piv;
} bv_regimes;

int bv_rg_new(bv_instance *c);
void bv_rg_free(bv_instance *c);
/* The parameters with the pseudo-parameters of the linear model; its constants' buffers. */
const double *bv_rg_linear_params(bv_instance *c, const double *p);
bv_affine * bv_rg_linear_affine(bv_instance *c);
/* After the linear model is assembled into A, B: preloads and switching functions (into
 * candidates); 0 if a contact carries no static load. */
int bv_rg_prepare(bv_instance *c, const double *A, const double *B);
/* After the new model replaced the old one: the candidates taken, the regimes rebuilt. */
void bv_rg_built(bv_instance *c);
/* Back to the regime of static equilibrium (reset). */
void bv_rg_restart(bv_instance *c);
/* The regime in force's step matrices for the instance's step key; 0 if not finite. */
int bv_rg_discretize(bv_instance *c);
/* The step done again with located events, from the instance's x and inputs; the end state
 * into z_new's x. BV_OK or the refusal (the regime as it was). The sign test that calls it:
 * bv_rg_finish (bodyvib_regimes_hot.h, inline on the hot path). */
bv_status bv_rg_events(bv_instance *c, double t, double h, double *znew) BV_COLD;
/* The sign test in full (bodyvib_regimes_hot.h tries a cheaper sufficient test first): each
 * function keeps its sign, and no parabola through its last three values (s = -1, 0, 1)
 * has its minimum inside the step below zero: with a > 0 at m = (gm - g1) / (4 a), below
 * zero where 16 a g0 < (gm - g1)^2. */
int bv_rg_clear_exact(const bv_regimes *rg) BV_COLD;
/* Model exchange: switching function i at the current state and inputs; the regime of their
 * signs taken (a function within rounding of 0 by the sign of its rate), 1 if it changed. */
double bv_rg_indicator(const bv_instance *c, int i);
int bv_rg_update(bv_instance *c);
/* The values ge taken as the functions' at the end of the step (g_prev, g_now move on). */
static inline void bv_rg_accept(bv_regimes *rg)
{
    double *t = rg->g_prev;
    rg->g_prev = rg->g_now, rg->g_now = rg->ge, rg->ge = t;
}

/* The serialized regime (mask, g at the last two steps): its size in doubles, written at q
 * (returns past it), checked, read (after the model is built: the regime assembled and
 * discretized). */
size_t bv_rg_state_doubles(const bv_instance *c);
unsigned char *bv_rg_state_write(const bv_instance *c, unsigned char *q);
int bv_rg_state_check(const bv_instance *c, const unsigned char *in);
int bv_rg_state_read(bv_instance *c, const unsigned char *in);

#endif
