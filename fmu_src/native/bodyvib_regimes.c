/*
 * bodyvib native core: regimes and located events (see bodyvib_regimes.h). The port of
 * bodyvib.runtime.regimes.EventStepper: the same sign test and grazing guard, the same
 * cubic-Hermite estimate and safeguarded Newton iteration, the same tolerance.
 */
#include "bodyvib_instance.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRAVITY 9.80665

/* ---------------------------------------------------------------- layout */

static int switch_count(const bv_model *md)
{
    int e, nsw = 0;
    for (e = 0; e < md->ne; e++)
        nsw += md->nl[e].kind == BV_NL_STOP ? 2 : 1;
    return nsw;
}

static double *take(double **d, size_t k)
{
    double *p = *d;
    *d += k;
    return p;
}

static void regime_buffers(bv_regime *r, double **d, int n, int m, int ni, int no, int nsw)
{
    r->P = take(d, (size_t)nsw * (n + ni));
    r->q = take(d, (size_t)nsw);
    r->f = take(d, (size_t)nsw);
    r->A = take(d, (size_t)n * n);
    r->B = take(d, (size_t)n * m);
    r->b = take(d, (size_t)n);
    r->Y = take(d, (size_t)no * (n + ni));
    r->y0 = take(d, (size_t)no);
    r->S = take(d, (size_t)n * (n + ni));
    r->gb = take(d, (size_t)n);
}

static size_t regime_doubles(int n, int m, int ni, int no, int nsw)
{
    return (size_t)nsw * (n + ni + 2) + (size_t)n * n + (size_t)n * m + 2 * (size_t)n + (size_t)no * (n + ni) + no +
           (size_t)n * (n + ni);
}

static void scratch_buffers(bv_regimes *rg, double **d, int n, int m, int ni, int N)
{
    rg->x = take(d, n), rg->xe = take(d, n), rg->xt = take(d, n), rg->rate = take(d, n);
    rg->ub = take(d, m), rg->ue = take(d, m), rg->ut = take(d, m), rg->du = take(d, m);
    rg->v1 = take(d, 5 * (size_t)rg->nsw), rg->v2 = take(d, (size_t)n * ni);
    rg->Phi = take(d, (size_t)n * n), rg->G0 = take(d, (size_t)n * m);
    rg->G1 = take(d, (size_t)n * m), rg->gbt = take(d, n);
    rg->M = take(d, (size_t)N * N), rg->E = take(d, (size_t)N * N);
    rg->work = take(d, 9 * (size_t)N * N);
}

int bv_rg_new(bv_instance *c)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, no = c->no, ne = md->ne, nsw = switch_count(md);
    int w = n + ni, wm = n + m, N = n + 2 * (m + 1), e, s, k;
    size_t total;
    bv_regimes *rg;
    double *d;
    if (nsw > (int)(8 * sizeof(unsigned long)) - 1) {
        say(c, BV_ERROR, "%s: %d switching functions; the native core steps at most %d",
            c->bc.name, nsw, (int)(8 * sizeof(unsigned long)) - 1);
        return 0;
    }
    total = (size_t)c->np + 3 * (size_t)ne + 2 * (size_t)ne + 2 * (size_t)nsw * (wm + w) +
            2 * (size_t)nsw + 4 * (size_t)ne * wm + n + 2 * (size_t)no + 4 * (size_t)nsw +
            (BV_RG_CACHE + 1) * regime_doubles(n, m, ni, no, nsw) + 4 * (size_t)n + 4 * (size_t)m +
            5 * (size_t)nsw + (size_t)n * ni + (size_t)n * n + 2 * (size_t)n * m + n +
            11 * (size_t)N * N;
    rg = calloc(1, sizeof *rg);
    d = calloc(total, sizeof *d);
    if (rg == NULL || d == NULL || (rg->piv = calloc((size_t)N + 1, sizeof(int))) == NULL ||
        (rg->sw_el = calloc(2 * (size_t)nsw + 1, sizeof(int))) == NULL) {
        if (rg != NULL)
            free(rg->piv);
        free(rg);
        free(d);
        return 0;
    }
    c->rg = rg;
    rg->nsw = nsw;
    rg->sw_side = rg->sw_el + nsw;
    for (e = 0, s = 0; e < ne; e++)
        for (k = 0; k < (md->nl[e].kind == BV_NL_STOP ? 2 : 1); k++, s++) {
            rg->sw_el[s] = e;
            rg->sw_side[s] = md->nl[e].kind == BV_NL_CONTACT ? 0
                             : md->nl[e].kind == BV_NL_STOP  ? 1 + k
                                                              : 3;
        }
    rg->pe = d; /* the start of the one block */
    d += c->np + 3 * (size_t)ne;
    rg->F0 = take(&d, ne), rg->F02 = take(&d, ne);
    rg->Gm = take(&d, (size_t)nsw * wm), rg->Gm2 = take(&d, (size_t)nsw * wm);
    rg->Gz = take(&d, (size_t)nsw * w), rg->Gz2 = take(&d, (size_t)nsw * w);
    rg->g0 = take(&d, nsw), rg->g02 = take(&d, nsw);
    rg->probe = take(&d, 4 * (size_t)ne * wm);
    rg->lin_b = take(&d, n), rg->lin_y0 = take(&d, no);
    rg->lin_af.b = rg->lin_b, rg->lin_af.y0 = take(&d, no), rg->lin_af.probe = rg->probe;
    rg->g_prev = take(&d, nsw), rg->g_now = take(&d, nsw), rg->ge = take(&d, nsw);
    rg->sign = take(&d, nsw);
    for (k = 0; k < BV_RG_CACHE; k++)
        regime_buffers(&rg->cache[k], &d, n, m, ni, no, nsw);
    regime_buffers(&rg->lin, &d, n, m, ni, no, nsw); /* its own P, q, f; the rest c's */
    scratch_buffers(rg, &d, n, m, ni, N);
    return 1;
}

void bv_rg_free(bv_instance *c)
{
    if (c->rg == NULL)
        return;
    free(c->rg->pe);
    free(c->rg->piv);
    free(c->rg->sw_el);
    free(c->rg);
    c->rg = NULL;
}

/* ---------------------------------------------------------------- regimes' parameters */

static int bit(unsigned long mask, int i) { return (int)((mask >> i) & 1UL); }

/* The parameters p with the pseudo-parameters of regime `mask` (or, linear, of the linear
 * model: contacts engaged, stops free, asymmetric dampers at their mean) into pe. */
static void pseudo(const bv_instance *c, const double *p, unsigned long mask, int linear,
                   double *pe)
{
    const bv_model *md = c->bc.md;
    int e, s = 0;
    memcpy(pe, p, (size_t)c->np * sizeof *pe);
    for (e = 0; e < md->ne; e++) {
        const bv_nl_element *el = &md->nl[e];
        double *q = pe + c->np + 3 * e, k = el->k >= 0 ? p[el->k] : 0.0;
        double cc = el->c >= 0 ? p[el->c] : 0.0;
        q[0] = q[1] = q[2] = 0.0;
        if (el->kind == BV_NL_CONTACT) {
            if (linear || bit(mask, s))
                q[0] = k, q[1] = cc;
            else
                q[2] = -c->rg->F0[e];
        } else if (el->kind == BV_NL_STOP) {
            int comp = !linear && bit(mask, s), reb = !linear && bit(mask, s + 1);
            if (comp || reb) {
                q[0] = k, q[1] = cc;
                q[2] = comp ? -k * p[el->gap_c] : k * p[el->gap_r];
            }
        } else {
            q[1] = linear ? 0.5 * (p[el->c_comp] + p[el->c_reb])
                          : p[bit(mask, s) ? el->c_reb : el->c_comp];
        }
        s += el->kind == BV_NL_STOP ? 2 : 1;
    }
}

const double *bv_rg_linear_params(bv_instance *c, const double *p)
{
    pseudo(c, p, 0UL, 1, c->rg->pe);
    return c->rg->pe;
}

bv_affine *bv_rg_linear_affine(bv_instance *c) { return &c->rg->lin_af; }

/* ---------------------------------------------------------------- switching functions */

/* The static state under gravity and the static loads: x_s into rg->x, u_s into rg->ub. */
static int statics(bv_instance *c, const double *A, const double *B)
{
    const bv_model *md = c->bc.md;
    bv_regimes *rg = c->rg;
    int n = c->n, m = c->m, i, j;
    memset(rg->ub, 0, (size_t)m * sizeof(double));
    for (i = 0; i < md->nloads; i++) {
        const bv_load *ld = &md->loads[i];
        rg->ub[ld->input] = -GRAVITY * (ld->param >= 0 ? rg->pe[ld->param] : ld->value);
    }
    for (i = 0; i < n; i++) {
        double v = md->grav[i];
        for (j = 0; j < m; j++)
            v += B[i * m + j] * rg->ub[j];
        rg->x[i] = -v;
    }
    memcpy(rg->E, A, (size_t)n * n * sizeof(double));
    if (!bv_lu(rg->E, rg->piv, n))
        return 0;
    bv_lu_solve(rg->E, rg->piv, n, rg->x, 1);
    return 1;
}

/* Element e's compression push k (x_from - x_to) + c (v_from - v_to) on [x | u] into row. */
static void push_row(const bv_instance *c, int e, double *row)
{
    const bv_nl_element *el = &c->bc.md->nl[e];
    int wm = c->n + c->m, j;
    const double *pa = c->rg->probe + (size_t)4 * e * wm, *va = pa + wm, *pb = va + wm,
                 *vb = pb + wm;
    double k = el->k >= 0 ? c->rg->pe[el->k] : 0.0, cc = el->c >= 0 ? c->rg->pe[el->c] : 0.0;
    for (j = 0; j < wm; j++)
        row[j] = k * (pa[j] - pb[j]) + cc * (va[j] - vb[j]);
}

int bv_rg_prepare(bv_instance *c, const double *A, const double *B)
{
    const bv_model *md = c->bc.md;
    bv_regimes *rg = c->rg;
    int n = c->n, m = c->m, ni = c->ni, wm = n + m, w = n + ni, s, j;
    if (!statics(c, A, B))
        return 0;
    for (s = 0; s < rg->nsw; s++) {
        int e = rg->sw_el[s], side = rg->sw_side[s];
        const bv_nl_element *el = &md->nl[e];
        double *row = rg->Gm2 + (size_t)s * wm, k = el->k >= 0 ? rg->pe[el->k] : 0.0;
        if (side == 3) {
            const double *va = rg->probe + (size_t)(4 * e + 1) * wm, *vb = va + 2 * (size_t)wm;
            for (j = 0; j < wm; j++)
                row[j] = -(va[j] - vb[j]);
            rg->g02[s] = 0.0;
        } else {
            push_row(c, e, row);
            if (side == 2)
                for (j = 0; j < wm; j++)
                    row[j] = -row[j];
        }
        if (side == 0) {
            double f = bv_dot(row, rg->x, n) + bv_dot(row + n, rg->ub, m);
            if (!(f > 0.0))
                return 0; /* the contact carries no static load */
            rg->F02[e] = rg->g02[s] = f;
        } else if (side == 1) {
            rg->g02[s] = -k * rg->pe[el->gap_c];
        } else if (side == 2) {
            rg->g02[s] = -k * rg->pe[el->gap_r];
        }
        /* on [x | s]: [Gx | Gu U] */
        memcpy(rg->Gz2 + (size_t)s * w, row, (size_t)n * sizeof(double));
        bv_mul(rg->Gz2 + (size_t)s * w + n, row + n, md->U, 1, m, ni);
    }
    return 1;
}

#define SWAP(a, b)                                                                           \
    do {                                                                                     \
        double *t_ = (a);                                                                    \
        (a) = (b), (b) = t_;                                                                 \
    } while (0)

/* The contact flags of regime `mask` into y0. */
static void flags(const bv_instance *c, unsigned long mask, double *y0)
{
    const bv_model *md = c->bc.md;
    int k, s;
    for (k = 0; k < c->no; k++)
        if (md->out_flag[k] >= 0)
            for (s = 0; s < c->rg->nsw; s++)
                if (c->rg->sw_el[s] == md->out_flag[k])
                    y0[k] = bit(mask, s);
}

static bv_regime *select_regime(bv_instance *c, unsigned long mask);

/* The functions' states `mask` taken: their signs, and the last two values kept times them
 * (a function that changes state changes sign). */
static void take_mask(bv_regimes *rg, unsigned long mask)
{
    int k;
    for (k = 0; k < rg->nsw; k++) {
        if (bit(mask ^ rg->mask, k))
            rg->g_prev[k] = -rg->g_prev[k], rg->g_now[k] = -rg->g_now[k];
        rg->sign[k] = bit(mask, k) ? 1.0 : -1.0;
    }
    rg->mask = mask;
}

/* Regime r (the functions' states `mask`) in force. */
static void take_regime(bv_instance *c, bv_regime *r, unsigned long mask)
{
    c->rg->cur = r;
    c->Yr = r->Y, c->y0r = r->y0;
    take_mask(c->rg, mask);
}

void bv_rg_built(bv_instance *c)
{
    bv_regimes *rg = c->rg;
    int s, k;
    SWAP(rg->Gm, rg->Gm2);
    SWAP(rg->Gz, rg->Gz2);
    SWAP(rg->g0, rg->g02);
    SWAP(rg->F0, rg->F02);
    rg->initial = rg->linear_mask = 0UL;
    rg->linear_alias = 1;
    for (s = 0; s < rg->nsw; s++) {
        if (rg->g0[s] > 0.0)
            rg->initial |= 1UL << s;
        if (rg->sw_side[s] == 0)
            rg->linear_mask |= 1UL << s;
        if (rg->sw_side[s] == 3)
            rg->linear_alias = 0;
    }
    memcpy(rg->lin_y0, rg->lin_af.y0, (size_t)c->no * sizeof(double));
    flags(c, rg->linear_mask, rg->lin_y0);
    rg->lin.A = c->A, rg->lin.B = c->B, rg->lin.b = rg->lin_b, rg->lin.gb = rg->lin_b;
    rg->lin.Y = c->Yc, rg->lin.y0 = rg->lin_y0, rg->lin.S = c->Sc, rg->lin.key = 0.0;
    rg->lin.h = NAN;
    rg->lin.mask = rg->linear_mask, rg->lin.valid = 1, rg->lin.affine = 0;
    for (k = 0; k < BV_RG_CACHE; k++)
        rg->cache[k].valid = 0;
    rg->cur = NULL;
    if (!c->bc.initialized)
        bv_rg_restart(c);
    else if (select_regime(c, rg->mask) == NULL)
        bv_rg_restart(c);
}

void bv_rg_restart(bv_instance *c)
{
    bv_regimes *rg = c->rg;
    int i;
    if (select_regime(c, rg->initial) == NULL) /* only an unusable parameter set fails */
        take_regime(c, &rg->lin, rg->linear_mask);
    for (i = 0; i < rg->nsw; i++)
        rg->g_prev[i] = rg->g_now[i] = rg->sign[i] * rg->g0[i];
}

/* ---------------------------------------------------------------- a regime's matrices */

/* Regime `mask` (assembled once, kept among BV_RG_CACHE), made the one in force; NULL if
 * its model cannot be assembled (logged). */
static bv_regime *select_regime(bv_instance *c, unsigned long mask)
{
    bv_regimes *rg = c->rg;
    bv_regime *r = NULL;
    bv_affine af;
    int k;
    if (rg->linear_alias && mask == rg->linear_mask)
        r = &rg->lin;
    for (k = 0; r == NULL && k < BV_RG_CACHE; k++)
        if (rg->cache[k].valid && rg->cache[k].mask == mask)
            r = &rg->cache[k];
    if (r == NULL) {
        r = &rg->cache[rg->next];
        rg->next = (rg->next + 1) % BV_RG_CACHE;
        pseudo(c, c->p_built, mask, 0, rg->pe);
        af.b = r->b, af.y0 = r->y0, af.probe = NULL;
        r->valid = 0;
        if (!bv_assemble(c, rg->pe, r->A, r->B, r->Y, &af)) {
            say(c, BV_ERROR, "%s: the regime %#lx of the nonlinear elements cannot be assembled "
                             "(singular or not finite)", c->bc.name, mask);
            return NULL;
        }
        flags(c, mask, r->y0);
        r->affine = 0;
        for (k = 0; k < c->n; k++)
            r->affine |= r->b[k] != 0.0;
        r->mask = mask, r->key = 0.0, r->h = NAN, r->valid = 1;
    }
    take_regime(c, r, mask);
    return r;
}

/* exp of [[A, B, b, 0], [0, 0, 0, I], [0, 0, 0, 0]] tau: Phi, Gamma0, Gamma1 and the
 * affine column gb of regime r for a step tau; 0 if not finite. */
static int exact(bv_instance *c, const bv_regime *r, double tau)
{
    bv_regimes *rg = c->rg;
    int n = c->n, m = c->m, mm = m + 1, N = n + 2 * mm, i, j;
    double *E = rg->E;
    if (!bv_expm_augmented(n, m, r->A, r->B, r->b, tau, 2, E, rg->M, rg->work, rg->piv))
        return 0;
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++)
            rg->Phi[i * n + j] = E[i * N + j];
        for (j = 0; j < m; j++) {
            rg->G0[i * m + j] = E[i * N + n + j];
            rg->G1[i * m + j] = E[i * N + n + mm + j];
        }
        rg->gbt[i] = E[i * N + n + m];
    }
    for (i = 0; i < N * N; i++)
        if (!isfinite(E[i]))
            return 0;
    return 1;
}

/* P = sign (Gx S + [0 | Gs Ms]), q = sign (Gx gb + g0) and f of regime r (the inputs' Ms:
 * the step's h; sign: the regime's). */
static void end_functions(bv_instance *c, bv_regime *r)
{
    const bv_regimes *rg = c->rg;
    int n = c->n, ni = c->ni, w = n + ni, i, j, k;
    for (i = 0; i < rg->nsw; i++) {
        const double *g = rg->Gz + (size_t)i * w;
        double *p = r->P + (size_t)i * w, v = 0.0, sg = bit(r->mask, i) ? 1.0 : -1.0;
        for (j = 0; j < w; j++) {
            double a = 0.0;
            for (k = 0; k < n; k++)
                a += g[k] * r->S[(size_t)k * w + j];
            for (k = 0; j >= n && k < ni; k++)
                a += g[n + k] * c->Ms[(size_t)k * ni + (j - n)];
            p[j] = sg * a;
        }
        for (k = 0; k < n; k++)
            v += g[k] * (r->affine ? r->gb[k] : 0.0);
        r->q[i] = sg * (v + rg->g0[i]);
        /* a rebound side: its row is the compression side's (i - 1) negated */
        r->f[i] = rg->sw_side[i] == 2 ? -sg * (bit(r->mask, i - 1) ? 1.0 : -1.0) : 0.0;
    }
    r->h = c->h_raw;
}

int bv_rg_discretize(bv_instance *c)
{
    bv_regimes *rg = c->rg;
    bv_regime *r = rg->cur;
    int n = c->n, m = c->m, ni = c->ni, w = n + ni, i, j;
    if (r == &rg->lin || r->key == c->h_key) {
        if (r->h != c->h_raw) /* the same matrices, a new h for the inputs' Ms */
            end_functions(c, r);
        return 1;
    }
    if (!exact(c, r, c->h_key))
        return 0;
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++)
            r->S[(size_t)i * w + j] = rg->Phi[i * n + j];
    bv_mul(rg->v2, rg->G0, c->bc.md->U, n, m, ni); /* Gamma0 U + Gamma1 U R */
    for (i = 0; i < n; i++)
        for (j = 0; j < ni; j++)
            r->S[(size_t)i * w + n + j] = rg->v2[i * ni + j];
    bv_mul(rg->v2, rg->G1, c->UR, n, m, ni);
    for (i = 0; i < n; i++) {
        for (j = 0; j < ni; j++)
            r->S[(size_t)i * w + n + j] += rg->v2[i * ni + j];
        r->gb[i] = rg->gbt[i];
    }
    r->key = c->h_key;
    end_functions(c, r);
    return 1;
}

/* ---------------------------------------------------------------- the sign test */

/* (The sign test itself is inline on the hot path: bodyvib_regimes_hot.h.) */

static void accept(bv_regimes *rg) { bv_rg_accept(rg); }

int bv_rg_clear_exact(const bv_regimes *rg)
{
    int i;
    for (i = 0; i < rg->nsw; i++) {
        double gm = rg->g_prev[i], g0 = rg->g_now[i], g1 = rg->ge[i];
        double a = 0.5 * (g1 + gm) - g0, d = gm - g1;
        if (g1 < 0.0)
            return 0;
        if (a > 0.0 && d > 0.0 && d < 4.0 * a && 16.0 * a * g0 < d * d)
            return 0;
    }
    return 1;
}

/* ---------------------------------------------------------------- located events */

/* One switching function i (signed: >= 0 allowed) along regime r's exact solution from x
 * with input ut + du tau. */
typedef struct {
    bv_instance *c;
    const bv_regime *r;
    int i;
    double sign;
    const double *x, *ut;
} segment;

/* g_i at [x; u]. */
static double g_at(const bv_instance *c, int i, const double *x, const double *u)
{
    const double *row = c->rg->Gm + (size_t)i * (c->n + c->m);
    return bv_dot(row, x, c->n) + bv_dot(row + c->n, u, c->m) + c->rg->g0[i];
}

/* g_i' at [x; u] in regime r: Gx (A x + B u + b) + Gu du. */
static double g_rate(const bv_instance *c, const bv_regime *r, int i, const double *x,
                     const double *u)
{
    const double *row = c->rg->Gm + (size_t)i * (c->n + c->m);
    int n = c->n, m = c->m, k, j;
    double v = 0.0;
    for (k = 0; k < n; k++) {
        double d = r->b[k];
        for (j = 0; j < n; j++)
            d += r->A[k * n + j] * x[j];
        for (j = 0; j < m; j++)
            d += r->B[k * m + j] * u[j];
        v += row[k] * d;
    }
    return v + bv_dot(row + n, c->rg->du, m);
}

/* The exact state after tau from x with input ut + du tau, into out; 0 if not finite. */
static int step_exact(bv_instance *c, const bv_regime *r, const double *x, const double *ut,
                      double tau, double *out)
{
    bv_regimes *rg = c->rg;
    int n = c->n, m = c->m, i;
    if (!exact(c, r, tau))
        return 0;
    for (i = 0; i < n; i++)
        out[i] = bv_dot(rg->Phi + (size_t)i * n, x, n) + bv_dot(rg->G0 + (size_t)i * m, ut, m) +
                 bv_dot(rg->G1 + (size_t)i * m, rg->du, m) + rg->gbt[i];
    return 1;
}

/* g and g' at tau along the segment, signed. */
static void seg_value(const segment *sg, double tau, double *g, double *dg)
{
    bv_instance *c = sg->c;
    bv_regimes *rg = c->rg;
    int j;
    step_exact(c, sg->r, sg->x, sg->ut, tau, rg->xt);
    for (j = 0; j < c->m; j++)
        rg->ue[j] = sg->ut[j] + rg->du[j] * tau;
    *g = sg->sign * g_at(c, sg->i, rg->xt, rg->ue);
    *dg = sg->sign * g_rate(c, sg->r, sg->i, rg->xt, rg->ue);
}

/* Newton on the exact g(tau) inside the bracket [lo, hi] (bisection outside). */
static double newton(const segment *sg, double lo, double hi, double tau, double h)
{
    int it;
    tau = tau < lo ? lo : tau > hi ? hi : tau;
    for (it = 0; it < 100; it++) {
        double g, dg, nw;
        if (tau <= 0.0)
            tau = 0.5 * (lo + hi);
        seg_value(sg, tau, &g, &dg);
        if (g < 0)
            hi = tau;
        else
            lo = tau;
        nw = dg != 0.0 ? tau - g / dg : 0.5 * (lo + hi);
        if (!(lo < nw && nw < hi))
            nw = 0.5 * (lo + hi);
        if (fabs(nw - tau) <= BV_RG_TOLERANCE * h || hi - lo <= BV_RG_TOLERANCE * h)
            return nw;
        tau = nw;
    }
    return 0.5 * (lo + hi);
}

/* The cubic-Hermite estimate at s in [0, 1] from the ends' values and rates times H. */
static double hermite(double s, const double q[4])
{
    double s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * q[0] + (s3 - 2 * s2 + s) * q[1] + (-2 * s3 + 3 * s2) * q[2] +
           (s3 - s2) * q[3];
}

/* The estimate's root in sample interval j, times H. */
static double cubic_root(int j, const double q[4], double H)
{
    double a = j ? (double)j / BV_RG_SAMPLES : 0.0, b = (double)(j + 1) / BV_RG_SAMPLES;
    int it;
    for (it = 0; it < 30; it++) {
        double mid = 0.5 * (a + b);
        if (hermite(mid, q) >= 0)
            a = mid;
        else
            b = mid;
    }
    return 0.5 * (a + b) * H;
}

/* The first root of the segment's function in (0, H], or -1; q: its signed values and
 * rates times H at the ends (g0, m0, g1, m1). */
static double locate(const segment *sg, double H, const double q[4], double h)
{
    int j, bad = -1, low = 0;
    double vmin = INFINITY, g, dg;
    for (j = 0; j < BV_RG_SAMPLES; j++) {
        double v = hermite((double)(j + 1) / BV_RG_SAMPLES, q);
        if (v < 0 && bad < 0)
            bad = j;
        if (v < vmin)
            vmin = v, low = j;
    }
    if (q[2] < 0) {
        double guess = bad >= 0 ? cubic_root(bad, q, H)
                                : H * q[0] / (q[0] - q[2] > 1e-300 ? q[0] - q[2] : 1e-300);
        return newton(sg, 0.0, H, guess, h);
    }
    if (bad < 0)
        return -1.0;
    /* two crossings inside the segment: is the dip real? */
    seg_value(sg, (double)(low + 1) / BV_RG_SAMPLES * H, &g, &dg);
    if (g >= 0)
        return -1.0;
    return newton(sg, 0.0, (double)(low + 1) / BV_RG_SAMPLES * H, cubic_root(bad, q, H), h);
}

/* The earliest root among the functions on one segment (roots[i], -1: none); -1 if none. */
static double earliest(bv_instance *c, double H, double h, unsigned long fresh, double *roots)
{
    bv_regimes *rg = c->rg;
    const bv_regime *r = rg->cur;
    double best = -1.0, q[4];
    int i, j;
    for (j = 0; j < c->m; j++)
        rg->ue[j] = rg->ut[j] + rg->du[j] * H;
    for (i = 0; i < rg->nsw; i++) {
        segment sg = {c, r, i, bit(rg->mask, i) ? 1.0 : -1.0, rg->x, rg->ut};
        q[0] = bit(fresh, i) ? 0.0 : sg.sign * g_at(c, i, rg->x, rg->ut);
        q[1] = sg.sign * g_rate(c, r, i, rg->x, rg->ut) * H;
        q[2] = sg.sign * g_at(c, i, rg->xe, rg->ue);
        q[3] = sg.sign * g_rate(c, r, i, rg->xe, rg->ue) * H;
        roots[i] = locate(&sg, H, q, h);
        for (j = 0; j < c->m; j++) /* seg_value used ue: the segment's end again */
            rg->ue[j] = rg->ut[j] + rg->du[j] * H;
        if (roots[i] >= 0 && (best < 0 || roots[i] < best))
            best = roots[i];
    }
    return best;
}

/* The step done again with located events, from c->x with inputs U s + U R s tau; the end
 * state into znew[0 .. n). */
bv_status bv_rg_events(bv_instance *c, double t, double h, double *znew)
{
    bv_regimes *rg = c->rg;
    int n = c->n, m = c->m, ni = c->ni, it, i, j;
    unsigned long fresh = 0UL, saved = rg->mask;
    double tau = 0.0, *roots = rg->v1;
    rg->located++;
    memcpy(rg->x, c->x, (size_t)n * sizeof(double));
    bv_matvec(rg->ub, c->bc.md->U, c->s, m, ni);
    bv_matvec(rg->du, c->UR, c->s, m, ni);
    for (it = 0; it < BV_RG_MAX_EVENTS; it++) {
        double H = h - tau, best;
        unsigned long hit = 0UL;
        if (H <= BV_RG_TOLERANCE * h)
            goto done;
        for (j = 0; j < m; j++)
            rg->ut[j] = rg->ub[j] + rg->du[j] * tau;
        if (tau == 0.0)
            memcpy(rg->xe, znew, (size_t)n * sizeof(double));
        else if (!step_exact(c, rg->cur, rg->x, rg->ut, H, rg->xe))
            goto fail;
        best = earliest(c, H, h, fresh, roots);
        if (best < 0) {
            memcpy(rg->x, rg->xe, (size_t)n * sizeof(double));
            goto done;
        }
        if (!step_exact(c, rg->cur, rg->x, rg->ut, best, rg->xt))
            goto fail;
        memcpy(rg->x, rg->xt, (size_t)n * sizeof(double));
        for (i = 0; i < rg->nsw; i++)
            if (roots[i] >= 0 && roots[i] <= best + BV_RG_TOLERANCE * h)
                hit |= 1UL << i;
        fresh = hit;
        if (select_regime(c, rg->mask ^ hit) == NULL)
            goto fail;
        tau += best;
    }
    say(c, BV_ERROR, "%s: more than %d switchings of the nonlinear elements within the step "
                     "from t = %g s (a chattering contact); step refused (discard), state "
                     "unchanged (shorten the step or add damping)",
        c->bc.name, BV_RG_MAX_EVENTS, t);
    goto refuse;
fail:
    say(c, BV_ERROR, "%s: locating the events in the step from t = %g s gave a state that is "
                     "not finite; step refused (discard), state unchanged", c->bc.name, t);
refuse:
    if (select_regime(c, saved) != NULL)
        bv_rg_discretize(c);
    return BV_DISCARD;
done:
    memcpy(znew, rg->x, (size_t)n * sizeof(double));
    for (j = 0; j < m; j++)
        rg->ue[j] = rg->ub[j] + rg->du[j] * h;
    for (i = 0; i < rg->nsw; i++)
        rg->ge[i] = rg->sign[i] * g_at(c, i, rg->x, rg->ue);
    if (!bv_rg_discretize(c))
        goto fail;
    accept(rg);
    return BV_OK;
}

/* ---------------------------------------------------------------- model exchange */

double bv_rg_indicator(const bv_instance *c, int i)
{
    const int w = c->n + c->ni;
    return bv_dot(c->rg->Gz + (size_t)i * w, c->x, w) + c->rg->g0[i]; /* x, s contiguous */
}

int bv_rg_update(bv_instance *c)
{
    bv_regimes *rg = c->rg;
    unsigned long mask = 0UL;
    int i;
    bv_matvec(rg->ub, c->bc.md->U, c->s, c->m, c->ni);
    bv_matvec(rg->du, c->UR, c->s, c->m, c->ni);
    for (i = 0; i < rg->nsw; i++) {
        double g = bv_rg_indicator(c, i);
        /* at a located root g is zero but for the solver's tolerance: its rate decides */
        if (fabs(g) <= 1e-9 * fabs(rg->g0[i]))
            g = g_rate(c, rg->cur, i, c->x, rg->ub);
        if (g > 0.0)
            mask |= 1UL << i;
    }
    if (mask == rg->mask)
        return 0;
    if (select_regime(c, mask) == NULL)
        return 0;
    return 1;
}

/* ---------------------------------------------------------------- serialized state */

size_t bv_rg_state_doubles(const bv_instance *c) { return 1 + 2 * (size_t)c->rg->nsw; }

unsigned char *bv_rg_state_write(const bv_instance *c, unsigned char *q)
{
    const bv_regimes *rg = c->rg;
    double mask = (double)rg->mask, v;
    int i;
    memcpy(q, &mask, sizeof mask);
    q += sizeof mask;
    for (i = 0; i < 2 * rg->nsw; i++, q += sizeof v) { /* the values themselves */
        v = rg->sign[i % rg->nsw] * (i < rg->nsw ? rg->g_prev : rg->g_now)[i % rg->nsw];
        memcpy(q, &v, sizeof v);
    }
    return q;
}

int bv_rg_state_check(const bv_instance *c, const unsigned char *in)
{
    int i, nsw = c->rg->nsw;
    double v;
    memcpy(&v, in, sizeof v);
    if (!(v >= 0.0 && v < ldexp(1.0, nsw) && v == floor(v)))
        return 0;
    for (i = 0; i < 2 * nsw; i++) {
        memcpy(&v, in + sizeof v * (size_t)(1 + i), sizeof v);
        if (!isfinite(v))
            return 0;
    }
    return 1;
}

int bv_rg_state_read(bv_instance *c, const unsigned char *in)
{
    bv_regimes *rg = c->rg;
    double mask, v;
    int i, ok;
    memcpy(&mask, in, sizeof mask);
    ok = select_regime(c, (unsigned long)mask) != NULL;
    for (i = 0; i < 2 * rg->nsw; i++) { /* the values, kept times the signs now in force */
        memcpy(&v, in + sizeof mask + sizeof v * (size_t)i, sizeof v);
        (i < rg->nsw ? rg->g_prev : rg->g_now)[i % rg->nsw] = rg->sign[i % rg->nsw] * v;
    }
    return ok && (c->h_key == 0.0 || bv_rg_discretize(c));
}
