/*
 * bodyvib native core: the model assembled for the parameter values (the stencils summed
 * into the descriptor form, E solved for the explicit state space, the output rows) and its
 * exact discretization for a step (see bodyvib_instance.h).
 */
#include "bodyvib_instance.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *bv_var_name(const bv_model *md, int kind, int index)
{
    int vr;
    for (vr = 0; vr < md->nvars; vr++)
        if (md->vr_kind[vr] == kind && md->vr_index[vr] == index)
            return md->vr_name[vr];
    return "?";
}

int bv_params_valid(const bv_instance *c, const double *p, int quiet)
{
    int j;
    for (j = 0; j < c->np; j++)
        if (!(isfinite(p[j]) && p[j] > 0.0)) {
            if (!quiet) {
                const bv_model *md = c->bc.md;
                char text[32];
                snprintf(((bv_instance *)c)->bc.init_error, BV_MESSAGE,
                         "%s: parameter %s = %s %s is invalid: it must be a positive finite "
                         "number; set a value > 0 (the FMU's default is %g %s)",
                         c->bc.name, bv_var_name(md, BV_PARAMETER, j), shortest(p[j], text),
                         md->param_unit[j], md->param_start[j], md->param_unit[j]);
            }
            return 0;
        }
    return 1;
}

/* Output row k of Yc on z = [x | s] from the carried row's solved form Cr, Dr (C_r = C + Cd A,
 * D_r = D + Cd B); a rate output has d/dt (C_r x + D_r u) = (C_r A) x + (C_r B U + D_r U R) s. */
static void output_row(const bv_instance *c, int k, const double *A, const double *B,
                       const double *Cr, const double *Dr, double *scratch, double *row)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, j;
    double *CrB = scratch, *t1 = CrB + m, *t2 = t1 + ni;
    if (md->out_derivative[k]) {
        bv_mul(row, Cr, A, 1, n, n);
        bv_mul(CrB, Cr, B, 1, n, m);
        bv_mul(t1, CrB, md->U, 1, m, ni);
        bv_mul(t2, Dr, c->UR, 1, m, ni);
        for (j = 0; j < ni; j++)
            row[n + j] = t1[j] + t2[j];
    } else {
        memcpy(row, Cr, (size_t)n * sizeof(double));
        bv_mul(row + n, Dr, md->U, 1, m, ni);
    }
}

/* The solved form of carried row r: Cr = C_r + Cd_r A, Dr = D_r + Cd_r B. */
static void solved_row(int n, int m, int r, const double *Cz, const double *Cd, const double *Dd,
                       const double *A, const double *B, double *Cr, double *Dr)
{
    int i, j;
    for (j = 0; j < n; j++) {
        double v = Cz[r * n + j];
        for (i = 0; i < n; i++)
            v += Cd[r * n + i] * A[i * n + j];
        Cr[j] = v;
    }
    for (j = 0; j < m; j++) {
        double v = Dd[r * m + j];
        for (i = 0; i < n; i++)
            v += Cd[r * n + i] * B[i * m + j];
        Dr[j] = v;
    }
}

/* The stencils summed for the parameters pe into the descriptor form (E, [A | B], C, Cd, D
 * and, for a nonlinear model, the constant terms ec, dc). */
static void sum_stencils(const bv_model *md, const double *pe, int n, int m, double *E,
                         double *AB, double *Cz, double *Cd, double *Dd, double *ec, double *dc)
{
    int k;
    for (k = 0; k < md->nstencils; k++) {
        const bv_stencil *st = &md->stencils[k];
        double v = st->coef * (st->param < 0 ? 1.0 : pe[st->param]);
        if (st->param2 >= 0)
            v *= pe[st->param2];
        if (st->param3 >= 0)
            v *= pe[st->param3];
        switch (st->mat) {
        case BV_E: E[st->row * n + st->col] += v; break;
        case BV_A: AB[st->row * (n + m) + st->col] += v; break;
        case BV_B: AB[st->row * (n + m) + n + st->col] += v; break;
        case BV_C: Cz[st->row * n + st->col] += v; break;
        case BV_CD: Cd[st->row * n + st->col] += v; break;
        case BV_EC: ec[st->row] += v; break;
        case BV_DC: dc[st->row] += v; break;
        default: Dd[st->row * m + st->col] += v; break;
        }
    }
}

/* The nonlinear elements' point rows on [x | u] (n + m each, 4 per element), linear model. */
static void point_rows(const bv_instance *c, const double *Cz, const double *Cd, const double *Dd,
                       const double *A, const double *B, double *probe)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, e, q;
    for (e = 0; e < md->ne; e++)
        for (q = 0; q < 4; q++) {
            int r = md->nl[e].row[q];
            double *row = probe + (size_t)(4 * e + q) * (n + m);
            memset(row, 0, (size_t)(n + m) * sizeof *row);
            if (r < 0)
                row[n + (-1 - r)] = 1.0;
            else
                solved_row(n, m, r, Cz, Cd, Dd, A, B, row, row + n);
        }
}

int bv_assemble(bv_instance *c, const double *pe, double *A, double *B, double *Yc,
                bv_affine *af)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, no = c->no, R = md->rows, w = n + ni, k, i, j;
    double *E = c->work, *AB = E + (size_t)n * n, *Cz = AB + (size_t)n * (n + m);
    double *Cd = Cz + (size_t)R * n, *Dd = Cd + (size_t)R * n;
    double *Cr = Dd + (size_t)R * m, *Dr = Cr + n, *scratch = Dr + m;
    double *ec = scratch + m + 2 * (size_t)ni, *dc = ec + n;
    size_t q;

    memset(c->work, 0, ((size_t)n * n + (size_t)n * (n + m) + 2 * (size_t)R * n + (size_t)R * m) *
                           sizeof(double));
    memset(ec, 0, ((size_t)n + R) * sizeof(double));
    sum_stencils(md, pe, n, m, E, AB, Cz, Cd, Dd, ec, dc);
    if (!bv_lu(E, c->piv, n))
        return 0;
    bv_lu_solve(E, c->piv, n, AB, n + m);
    if (af != NULL)
        bv_lu_solve(E, c->piv, n, ec, 1); /* b = E^-1 e */
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++)
            A[i * n + j] = AB[i * (n + m) + j];
        for (j = 0; j < m; j++)
            B[i * m + j] = AB[i * (n + m) + n + j];
    }
    for (q = 0; q < (size_t)n * n; q++)
        if (!isfinite(A[q]))
            return 0;
    for (q = 0; q < (size_t)n * m; q++)
        if (!isfinite(B[q]))
            return 0;
    for (k = 0; k < no; k++) {
        int r = md->out_row[k];
        double *row = Yc + (size_t)k * w;
        solved_row(n, m, r, Cz, Cd, Dd, A, B, Cr, Dr);
        output_row(c, k, A, B, Cr, Dr, scratch, row);
        if (md->ne && md->out_flag[k] >= 0) /* a contact flag: the regime's constant only */
            memset(row, 0, (size_t)w * sizeof *row);
        if (af != NULL) {
            double v = md->out_derivative[k] ? 0.0 : dc[r];
            const double *cr = md->out_derivative[k] ? Cr : Cd + (size_t)r * n;
            for (i = 0; i < n; i++)
                v += cr[i] * ec[i];
            af->y0[k] = md->out_flag[k] >= 0 ? 0.0 : v;
        }
    }
    for (q = 0; q < (size_t)no * w; q++)
        if (!isfinite(Yc[q]))
            return 0;
    if (af != NULL) {
        memcpy(af->b, ec, (size_t)n * sizeof(double));
        if (af->probe != NULL)
            point_rows(c, Cz, Cd, Dd, A, B, af->probe);
    }
    return 1;
}

/* Assemble the descriptor form for p, solve it, form the output rows; 0 if E is singular. */
int bv_build(bv_instance *c, const double *p)
{
    double *swap;
    const double *pe = HOT->ne ? bv_rg_linear_params(c, p) : p;
    if (!bv_assemble(c, pe, c->A2, c->B2, c->Yc2, HOT->ne ? bv_rg_linear_affine(c) : NULL))
        return 0;
    if (HOT->ne && !bv_rg_prepare(c, c->A2, c->B2))
        return 0;
    /* all finite: only now do they replace the instance's matrices (a refused parameter
     * set leaves the model the instance had) */
    swap = c->A, c->A = c->A2, c->A2 = swap;
    swap = c->B, c->B = c->B2, c->B2 = swap;
    swap = c->Yc, c->Yc = c->Yc2, c->Yc2 = swap;
    memcpy(c->p_built, p, (size_t)c->np * sizeof(double));
    c->h_key = 0.0;
    c->h_raw = NAN;
    if (HOT->ne)
        bv_rg_built(c);
    return 1;
}

/* The powers of ten that are exact doubles. */
static const double P10[23] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11,
                               1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* h rounded to 12 significant digits, as the library's step cache keys it
 * (float(f"{h:.12g}")): the decimal digits are read back exactly, locale-independent. */
static double round12(double h)
{
    char text[40], *q;
    long long mant = 0;
    int e, p;
    snprintf(text, sizeof text, "%.11e", h);
    q = strchr(text, 'e');
    if (q == NULL)
        return h;
    e = atoi(q + 1);
    for (p = 0; text + p < q; p++)
        if (text[p] >= '0' && text[p] <= '9')
            mant = mant * 10 + (text[p] - '0');
    p = e - 11;
    if (p >= 0 && p <= 22)
        return (double)mant * P10[p];
    if (p < 0 && p >= -22)
        return (double)mant / P10[-p]; /* exact powers: one rounding, as strtod */
    return h;
}

int bv_expm_augmented(int n, int m, const double *A, const double *B, const double *b,
                      double tau, int blocks, double *E, double *M, double *work, int *piv)
{
    int q = m + (b != NULL), N = n + blocks * q, i, j, k;
    memset(M, 0, (size_t)N * N * sizeof *M);
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++)
            M[i * N + j] = A[i * n + j] * tau;
        for (j = 0; j < m; j++)
            M[i * N + n + j] = B[i * m + j] * tau;
        if (b != NULL)
            M[i * N + n + m] = b[i] * tau;
    }
    for (k = 1; k < blocks; k++)
        for (j = 0; j < q; j++)
            M[(n + (k - 1) * q + j) * N + n + k * q + j] = tau;
    return bv_expm(E, M, N, work, piv);
}

/* exp of the augmented matrix with `blocks` input blocks ([[A, B, 0..], [0, 0, I, ..], ..] h),
 * as bodyvib.runtime.discretize (blocks 2: Phi, Gamma0, Gamma1; blocks 3: also Gamma2). */
static int augmented(bv_instance *c, double key, int blocks, double *E)
{
    size_t NN = (size_t)(c->n + blocks * c->m) * (c->n + blocks * c->m);
    return bv_expm_augmented(c->n, c->m, c->A, c->B, NULL, key, blocks, E, E + NN, E + 2 * NN,
                             c->piv);
}

/* Step matrices for h (Sc, Ms). */
int bv_discretize(bv_instance *c, double h)
{
    int n = c->n, m = c->m, ni = c->ni, i, j, k;
    int N2 = n + 2 * m, N3 = n + 3 * m;
    double key, *E, *G, *T;
    const double *R = c->bc.md->R;
    if (h == c->h_raw) /* NaN while no key is valid */
        return 1;
    key = round12(h);
    if (c->h_key == key) {
        c->h_raw = h;
        return 1;
    }
    c->h_key = 0.0; /* Sc is rewritten below: no cache is valid until it is complete */
    c->h_raw = NAN;
    E = c->work;
    G = E + 11 * (size_t)N3 * N3; /* past augmented()'s matrix and expm's work */
    T = G + (size_t)n * m;
    if (!augmented(c, key, 2, E))
        return 0;
    for (i = 0; i < n; i++)
        for (j = 0; j < n; j++)
            c->Sc[(size_t)i * (n + ni) + j] = E[i * N2 + j];
    /* Gamma0 U + Gamma1 U R */
    for (i = 0; i < n; i++)
        for (j = 0; j < m; j++)
            G[i * m + j] = E[i * N2 + n + j];
    bv_mul(T, G, c->bc.md->U, n, m, ni);
    for (i = 0; i < n; i++)
        for (j = 0; j < ni; j++)
            c->Sc[(size_t)i * (n + ni) + n + j] = T[i * ni + j];
    for (i = 0; i < n; i++)
        for (j = 0; j < m; j++)
            G[i * m + j] = E[i * N2 + n + m + j];
    bv_mul(T, G, c->UR, n, m, ni);
    for (i = 0; i < n; i++)
        for (j = 0; j < ni; j++)
            c->Sc[(size_t)i * (n + ni) + n + j] += T[i * ni + j];
    if (c->curved) { /* + Gamma2 U R^2, from the three-block exponential */
        if (!augmented(c, key, 3, E))
            return 0;
        for (i = 0; i < n; i++)
            for (j = 0; j < m; j++)
                G[i * m + j] = E[i * N3 + n + 2 * m + j];
        bv_mul(T, G, c->UR2, n, m, ni);
        for (i = 0; i < n; i++)
            for (j = 0; j < ni; j++)
                c->Sc[(size_t)i * (n + ni) + n + j] += T[i * ni + j];
    }
    for (i = 0; i < n * (n + ni); i++)
        if (!isfinite(c->Sc[i]))
            return 0;
    /* inputs at the step's end: (I + h R + h^2/2 R^2) s, with the actual h */
    for (i = 0; i < ni; i++)
        for (j = 0; j < ni; j++) {
            double r2 = 0.0;
            for (k = 0; k < ni; k++)
                r2 += R[i * ni + k] * R[k * ni + j];
            c->Ms[i * ni + j] = (i == j ? 1.0 : 0.0) + h * R[i * ni + j];
            if (c->curved)
                c->Ms[i * ni + j] += 0.5 * h * h * r2;
        }
    c->h_key = key;
    c->h_raw = h;
    return 1;
}
