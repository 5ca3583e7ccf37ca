/*
 * bodyvib native linear core: the instance and what its parts share. The core is split by
 * subject: bodyvib_linalg.c (linear algebra, the matrix exponential), bodyvib_assembly.c
 * (the model assembled for the parameters, its step matrices), bodyvib_state.c (the
 * serialized state) and bodyvib_core.c (the calls the FMI functions make: instances,
 * values, steps, derivatives, model exchange). Internal to the core.
 */
#ifndef BODYVIB_INSTANCE_H
#define BODYVIB_INSTANCE_H

#include "bodyvib_fsm.h"
#include "bodyvib_linalg.h"
#include "bodyvib_regimes.h"

struct bv_instance {
    bv_common bc;       /* first (BV_STATE_IS): state, model, name, logger, time, flags */
    int n, m, ni, no, np;
    int curved;         /* R^2 != 0: some input is a parabola over the step */
    /* parameters */
    double *p, *p_built; /* A, B, Yc are valid for p_built (bv_new builds them) */
    /* continuous time and outputs */
    double *A, *B;
    double *UR, *UR2;   /* U R, U R^2 (m x ni) */
    double *Yc;         /* [Yx | Ys] row-major: y = Yc z, z = [x | s] */
    double *A2, *B2, *Yc2; /* candidates: build() fills these, checks them, then swaps */
    /* step cache */
    double h_key;       /* rounded step the matrices are for; 0: none */
    double h_raw;       /* the last step size seen with that key (skips the rounding); NaN
                         * while no key is valid, so that h == h_raw means "Sc, Ms are for h" */
    double *Sc;         /* [Phi | Gamma0 U + Gamma1 U R + Gamma2 U R^2] row-major: x <- Sc z */
    double *Ms;         /* I + h R + h^2/2 R^2 (ni x ni): s <- Ms s */
    /* what evolves: z = [x | s] contiguous; a step writes the next z into zn and swaps */
    double *x, *s;
    double *x_prev, *h_prev; /* per fallback pair: displacement and step at the last DoStep */
    unsigned char *has_prev, *vel_set, *slope_on, *warned;
    /* a refused step restores these: the fallback bookkeeping and the inputs */
    double *save_x_prev, *save_h_prev, *save_s;
    unsigned char *save_flags;
    double *zd;         /* 3 (n + ni): z and its time derivatives (output derivatives) */
    /* scratch */
    double *zn, *work;
    int *piv;
    struct bv_regimes *rg; /* a nonlinear model's regimes (bodyvib_regimes.c); else NULL */
    const double *Yr, *y0r; /* its regime in force's output rows and constants (y = Yr z + y0r) */
};

/* The model on the hot path (bv_set, bv_step, bv_get): this binary's, bv_model_data, read
 * directly rather than through the instance. Where the build sees its definition (the FMUs
 * are linked with link-time optimization) its sizes and index tables are constants, and the
 * loops of a step are compiled for the model's sizes. bv_new accepts this model only. */
#define HOT (&bv_model_data)

/* The sign test of a nonlinear model's step (inline: it reads HOT). */
#include "bodyvib_regimes_hot.h"

/* Messages. */
#define say(c, ...) bv_say(&(c)->bc, __VA_ARGS__)
#define shortest bv_shortest


/* Model assembly (bodyvib_assembly.c). */
/* The name of the variable of `kind` with that index ("?" if none). */
const char *bv_var_name(const bv_model *md, int kind, int index);
/* Every parameter of p positive and finite; else 0, the reason in c->bc.init_error unless
 * quiet. */
int bv_params_valid(const bv_instance *c, const double *p, int quiet);
/* Assemble the model for the parameters pe (a nonlinear model's: np + 3 ne, the pseudo-
 * parameters of a regime) into A, B, Yc (and af's constants if not NULL); 0 if E is singular
 * or a matrix is not finite. */
int bv_assemble(bv_instance *c, const double *pe, double *A, double *B, double *Yc,
                bv_affine *af);
/* Assemble the descriptor form for p, solve it, form the output rows; 0 if E is singular. */
int bv_build(bv_instance *c, const double *p);
/* E = exp of [[A, B, b, 0..], [0, 0, 0, I, ..], ..] tau with `blocks` input blocks of width
 * q = m (+ 1 with the constant column b, as an input held at 1; b NULL: none), N = n +
 * blocks q; M: N x N scratch, work: 9 N x N, piv: N. 0 if the Pade denominator is singular. */
int bv_expm_augmented(int n, int m, const double *A, const double *B, const double *b,
                      double tau, int blocks, double *E, double *M, double *work, int *piv);
/* The step matrices for h (Sc, Ms), cached by h rounded to 12 digits; 0 if not finite. */
int bv_discretize(bv_instance *c, double h);

#endif
