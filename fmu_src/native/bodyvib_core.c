/*
 * bodyvib native FMU core (see bodyvib_core.h).
 *
 * Per instance: the parameter values; the explicit state space A, B built from the
 * stencils; the output rows on z = [x | s] (state, FMU inputs); the step matrices for the
 * last step size (recomputed when the step size, rounded to 12 significant digits like
 * the library's cache, changes); the state x, the inputs s, and the bookkeeping of the
 * unconnected-velocity fallback. The same scheme as bodyvib.runtime.engine.FmuCore.
 *
 * Stepping over [t, t + h]: the FMU inputs s rise at their rates R s (R from the
 * contract's rate pairs: a displacement at its velocity input, a velocity at its
 * acceleration input, the car's seat force at seat_force_rate), curving at R^2 s where a
 * rate itself has a rate; every other input is held. With u = U s the state is advanced
 * exactly,
 *     x <- Phi x + (Gamma0 U + Gamma1 U R + Gamma2 U R^2) s,
 * and the inputs are left at their extrapolated values (I + h R + h^2/2 R^2) s, so outputs
 * read right after the step are those of the step's end. Outputs are computed on read,
 *     y = Yx x + Ys s,
 * an output declared as the time derivative of a model output row r having the rows
 * d/dt (C_r x + D_r u) = C_r A x + (C_r B U + D_r U R) s.
 *
 * Unconnected velocity (the contract's slope_fallback pairs): while a velocity input was
 * never set to a non-zero value, a DoStep that sees its displacement differ from the
 * value at the previous DoStep switches to the slope (x_now - x_prev) / h_prev, written
 * into the velocity input for that step and the rest of the run (until a non-zero
 * velocity is set); the input reads back as 0, and one warning is logged.
 */
#include "bodyvib_fsm.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


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
};

/* The model on the hot path (bv_set, bv_step, bv_get): this binary's, bv_model_data, read
 * directly rather than through the instance. Where the build sees its definition (the FMUs
 * are linked with link-time optimization) its sizes and index tables are constants, and the
 * loops of a step are compiled for the model's sizes. bv_new accepts this model only. */
#define HOT (&bv_model_data)

/* ---------------------------------------------------------------- messages */

#define say(c, ...) bv_say(&(c)->bc, __VA_ARGS__)
#define shortest bv_shortest

/* ---------------------------------------------------------------- dense linear algebra */

/* C = A B; A is r x k, B is k x q, all row-major; C must not alias A or B. */
static void mul(double *C, const double *A, const double *B, int r, int k, int q)
{
    int i, j, l;
    for (i = 0; i < r; i++) {
        double *ci = C + (size_t)i * q;
        for (j = 0; j < q; j++)
            ci[j] = 0.0;
        for (l = 0; l < k; l++) {
            double a = A[(size_t)i * k + l];
            const double *bl = B + (size_t)l * q;
            if (a == 0.0)
                continue;
            for (j = 0; j < q; j++)
                ci[j] += a * bl[j];
        }
    }
}

/* LU factorization with partial pivoting in place (n x n); 0 if singular. */
static int lu(double *M, int *piv, int n)
{
    int i, j, k;
    for (k = 0; k < n; k++) {
        int p = k;
        double best = fabs(M[(size_t)k * n + k]);
        for (i = k + 1; i < n; i++) {
            double v = fabs(M[(size_t)i * n + k]);
            if (v > best) {
                best = v;
                p = i;
            }
        }
        if (!(best > 0.0) || !isfinite(best))
            return 0;
        piv[k] = p;
        if (p != k)
            for (j = 0; j < n; j++) {
                double t = M[(size_t)k * n + j];
                M[(size_t)k * n + j] = M[(size_t)p * n + j];
                M[(size_t)p * n + j] = t;
            }
        for (i = k + 1; i < n; i++) {
            double f = M[(size_t)i * n + k] /= M[(size_t)k * n + k];
            if (f != 0.0)
                for (j = k + 1; j < n; j++)
                    M[(size_t)i * n + j] -= f * M[(size_t)k * n + j];
        }
    }
    return 1;
}

/* Solve (LU) X = Bm in place, Bm n x q. */
static void lu_solve(const double *LU, const int *piv, int n, double *Bm, int q)
{
    int i, j, k;
    for (k = 0; k < n; k++)
        if (piv[k] != k)
            for (j = 0; j < q; j++) {
                double t = Bm[(size_t)k * q + j];
                Bm[(size_t)k * q + j] = Bm[(size_t)piv[k] * q + j];
                Bm[(size_t)piv[k] * q + j] = t;
            }
    for (i = 0; i < n; i++)
        for (k = 0; k < i; k++) {
            double f = LU[(size_t)i * n + k];
            if (f != 0.0)
                for (j = 0; j < q; j++)
                    Bm[(size_t)i * q + j] -= f * Bm[(size_t)k * q + j];
        }
    for (i = n - 1; i >= 0; i--) {
        for (k = i + 1; k < n; k++) {
            double f = LU[(size_t)i * n + k];
            if (f != 0.0)
                for (j = 0; j < q; j++)
                    Bm[(size_t)i * q + j] -= f * Bm[(size_t)k * q + j];
        }
        for (j = 0; j < q; j++)
            Bm[(size_t)i * q + j] /= LU[(size_t)i * n + i];
    }
}

static double norm1(const double *M, int n)
{
    double best = 0.0;
    int i, j;
    for (j = 0; j < n; j++) {
        double s = 0.0;
        for (i = 0; i < n; i++)
            s += fabs(M[(size_t)i * n + j]);
        if (s > best)
            best = s;
    }
    return best;
}

/* Loops over the model's sizes on the hot path: unrolled where the sizes are constants (HOT
 * above, with link-time optimization), so that a step is straight-line code. */
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 8
#define BV_UNROLL _Pragma("GCC unroll 16")
#else
#define BV_UNROLL
#endif

/* r . z over cols entries, two accumulators (even and odd columns) added at the end. */
static inline double dot(const double *restrict r, const double *restrict z, int cols)
{
    double a = 0.0, b = 0.0;
    int j;
    BV_UNROLL
    for (j = 0; j + 1 < cols; j += 2) {
        a += r[j] * z[j];
        b += r[j + 1] * z[j + 1];
    }
    if (j < cols)
        a += r[j] * z[j];
    return a + b;
}

/* out = M z, M row-major (rows x cols); rows independent, each a dot(). */
static void matvec(double *restrict out, const double *restrict M, const double *restrict z,
                   int rows, int cols)
{
    int i;
    BV_UNROLL
    for (i = 0; i < rows; i++)
        out[i] = dot(M + (size_t)i * cols, z, cols);
}

/* Whether entry (i, j) of the inputs' step matrix Ms = I + h R + h^2/2 R^2 (ni x ni) can be
 * non-zero: on the diagonal, or where R or R^2 has a non-zero entry. R is this binary's
 * model's (HOT, a constant with link-time optimization), so the pattern is known where the
 * step is compiled. */
BV_HOT_INLINE int ms_entry(const bv_model *md, int i, int j)
{
    const int ni = md->ni;
    int k, r2 = 0;
    BV_UNROLL
    for (k = 0; k < ni; k++)
        r2 |= md->R[i * ni + k] != 0.0 && md->R[k * ni + j] != 0.0;
    return i == j || md->R[i * ni + j] != 0.0 || r2;
}

/* out = Ms z (ni x ni) over the entries Ms can hold (ms_entry), with the accumulators of
 * dot() by column parity: the same sums as the dense product less terms that are 0 z, which
 * add nothing to a finite sum (a sum from +0 never is -0, so adding +-0 leaves it as it
 * is); with z not finite the result is not finite either way, and the step is refused. With
 * the model's sizes and R constants the loops unroll into the pattern's terms only. */
BV_HOT_INLINE void ms_matvec(double *restrict out, const double *restrict M,
                             const double *restrict z)
{
    const bv_model *md = HOT;
    const int n = md->ni;
    int i, j;
    BV_UNROLL
    for (i = 0; i < n; i++) {
        double a = 0.0, b = 0.0;
        BV_UNROLL
        for (j = 0; j < n; j++) {
            if (!ms_entry(md, i, j))
                continue;
            if (j & 1)
                b += M[(size_t)i * n + j] * z[j];
            else
                a += M[(size_t)i * n + j] * z[j];
        }
        out[i] = a + b;
    }
}

/* Roots without pow(), exp() or log(): those carry the glibc 2.29 symbol version, while
 * sqrt, cbrt, frexp and ldexp keep the binary loadable by glibc 2.14 (RHEL 7/8, Debian 10). */
static double root5(double x)
{
    int e, q, r, i;
    double t, y = 1.2;
    if (!(x > 0.0) || !isfinite(x))
        return x;
    t = frexp(x, &e); /* x = t 2^e, t in [0.5, 1) */
    q = e / 5;
    r = e % 5;
    if (r < 0) {
        r += 5;
        q -= 1;
    }
    t = ldexp(t, r); /* x = t 2^(5 q), t in [0.5, 16): its fifth root is in [0.87, 1.75) */
    for (i = 0; i < 60; i++) { /* Newton, quadratic from y = 1.2 */
        double y4 = y * y * y * y, yn = y - (y4 * y - t) / (5.0 * y4);
        if (yn == y)
            break;
        y = yn;
    }
    return ldexp(y, q);
}

/* ceil(log2(v)) for v > 0, exactly: v = m 2^e with m in [0.5, 1) */
static int ceil_log2(double v)
{
    int e;
    double m = frexp(v, &e);
    return m == 0.5 ? e - 1 : e;
}

/* Pade(13) coefficients and the scaling threshold theta_13 (Higham 2005). */
static const double B13[14] = {
    64764752532480000., 32382376266240000., 7771770303897600., 1187353796428800.,
    129060195264000., 10559470521600., 670442572800., 33522128640., 1323241920.,
    40840800., 960960., 16380., 182., 1.};
#define THETA13 5.371920351148152

/* One sum of the Pade(13) approximant from the coefficient b_o (o = 1: the odd ones, U
 * before its factor A; o = 0: the even ones, V):
 *     out = A6 (b_{o+12} A6 + b_{o+10} A4 + b_{o+8} A2) + b_{o+6} A6 + b_{o+4} A4
 *           + b_{o+2} A2 + b_o I,
 * with A2, A4, A6 the scaled powers M2, M4, M6 (N x N); W: N x N scratch. */
static void pade_sum(double *out, double *W, const double *M2, const double *M4,
                     const double *M6, int N, int o)
{
    size_t NN = (size_t)N * N, i;
    int k;
    for (i = 0; i < NN; i++)
        W[i] = B13[o + 12] * M6[i] + B13[o + 10] * M4[i] + B13[o + 8] * M2[i];
    mul(out, M6, W, N, N, N);
    for (i = 0; i < NN; i++)
        out[i] += B13[o + 6] * M6[i] + B13[o + 4] * M4[i] + B13[o + 2] * M2[i];
    for (k = 0; k < N; k++)
        out[(size_t)k * N + k] += B13[o];
}

/* E = exp(M), M N x N, by scaling and squaring with a degree-13 Pade approximant; the
 * scaling from norms of powers of M (Al-Mohy & Higham 2009), as bodyvib.discretize.expm.
 * work: 9 N x N; piv: N. Returns 0 if the Pade denominator is singular. */
static int expm(double *E, const double *M, int N, double *work, int *piv)
{
    size_t NN = (size_t)N * N, i;
    double *M2 = work, *M4 = M2 + NN, *M6 = M4 + NN, *T = M6 + NN, *A = T + NN;
    double *W = A + NN, *Uo = W + NN, *V = Uo + NN, *P = V + NN;
    double d6, d8, d10, eta, f2, f4, f6, f1;
    int s = 0, j;

    mul(M2, M, M, N, N, N);
    mul(M4, M2, M2, N, N, N);
    mul(M6, M4, M2, N, N, N);
    d6 = sqrt(cbrt(norm1(M6, N)));
    mul(T, M4, M4, N, N, N);
    d8 = sqrt(sqrt(sqrt(norm1(T, N))));
    mul(T, M4, M6, N, N, N);
    d10 = sqrt(root5(norm1(T, N)));
    eta = fmin(fmax(d6, d8), fmax(d8, d10));
    if (eta > 0.0 && isfinite(eta)) {
        int l = ceil_log2(eta / THETA13);
        s = l > 0 ? l : 0;
    }
    f1 = ldexp(1.0, -s);
    f2 = ldexp(1.0, -2 * s);
    f4 = ldexp(1.0, -4 * s);
    f6 = ldexp(1.0, -6 * s);
    for (i = 0; i < NN; i++) {
        A[i] = M[i] * f1;
        M2[i] *= f2;
        M4[i] *= f4;
        M6[i] *= f6;
    }
    /* U = A (A6 (b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 + b3 A2 + b1 I) */
    pade_sum(T, W, M2, M4, M6, N, 1);
    mul(Uo, A, T, N, N, N);
    /* V = A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I */
    pade_sum(V, W, M2, M4, M6, N, 0);
    /* (V - U) E = V + U */
    for (i = 0; i < NN; i++) {
        P[i] = V[i] - Uo[i];
        E[i] = V[i] + Uo[i];
    }
    if (!lu(P, piv, N))
        return 0;
    lu_solve(P, piv, N, E, N);
    for (j = 0; j < s; j++) {
        mul(T, E, E, N, N, N);
        memcpy(E, T, NN * sizeof *E);
    }
    return 1;
}

/* ---------------------------------------------------------------- model assembly */

static const char *var_name(const bv_model *md, int kind, int index)
{
    int vr;
    for (vr = 0; vr < md->nvars; vr++)
        if (md->vr_kind[vr] == kind && md->vr_index[vr] == index)
            return md->vr_name[vr];
    return "?";
}

static int params_valid(const bv_instance *c, const double *p, int quiet)
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
                         c->bc.name, var_name(md, BV_PARAMETER, j), shortest(p[j], text),
                         md->param_unit[j], md->param_start[j], md->param_unit[j]);
            }
            return 0;
        }
    return 1;
}

/* Assemble the descriptor form for p, solve it, form the output rows; 0 if E is singular. */
static int build(bv_instance *c, const double *p)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, no = c->no, R = md->rows, w = n + ni, k, i, j;
    double *E = c->work, *AB = E + (size_t)n * n, *Cz = AB + (size_t)n * (n + m);
    double *Cd = Cz + (size_t)R * n, *Dd = Cd + (size_t)R * n;
    double *Cr = Dd + (size_t)R * m, *Dr = Cr + n, *CrB = Dr + m, *t1 = CrB + m, *t2 = t1 + ni;
    double *A = c->A2, *B = c->B2, *Yc = c->Yc2, *swap;
    size_t q;

    memset(c->work, 0, ((size_t)n * n + (size_t)n * (n + m) + 2 * (size_t)R * n + (size_t)R * m) *
                           sizeof(double));
    for (k = 0; k < md->nstencils; k++) {
        const bv_stencil *st = &md->stencils[k];
        double v = st->coef * (st->param < 0 ? 1.0 : p[st->param]);
        if (st->param2 >= 0)
            v *= p[st->param2];
        if (st->param3 >= 0)
            v *= p[st->param3];
        switch (st->mat) {
        case BV_E: E[st->row * n + st->col] += v; break;
        case BV_A: AB[st->row * (n + m) + st->col] += v; break;
        case BV_B: AB[st->row * (n + m) + n + st->col] += v; break;
        case BV_C: Cz[st->row * n + st->col] += v; break;
        case BV_CD: Cd[st->row * n + st->col] += v; break;
        default: Dd[st->row * m + st->col] += v; break;
        }
    }
    if (!lu(E, c->piv, n))
        return 0;
    lu_solve(E, c->piv, n, AB, n + m);
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
        /* row r with z' substituted: C_r = C + Cd A, D_r = D + Cd B */
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
        if (md->out_derivative[k]) {
            /* d/dt (C_r x + D_r u) = (C_r A) x + (C_r B U + D_r U R) s */
            mul(row, Cr, A, 1, n, n);
            mul(CrB, Cr, B, 1, n, m);
            mul(t1, CrB, md->U, 1, m, ni);
            mul(t2, Dr, c->UR, 1, m, ni);
            for (j = 0; j < ni; j++)
                row[n + j] = t1[j] + t2[j];
        } else {
            memcpy(row, Cr, (size_t)n * sizeof(double));
            mul(row + n, Dr, md->U, 1, m, ni);
        }
    }
    for (q = 0; q < (size_t)no * w; q++)
        if (!isfinite(Yc[q]))
            return 0;
    /* all finite: only now do they replace the instance's matrices (a refused parameter
     * set leaves the model the instance had) */
    swap = c->A, c->A = A, c->A2 = swap;
    swap = c->B, c->B = B, c->B2 = swap;
    swap = c->Yc, c->Yc = Yc, c->Yc2 = swap;
    memcpy(c->p_built, p, (size_t)c->np * sizeof(double));
    c->h_key = 0.0;
    c->h_raw = NAN;
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

/* exp of the augmented matrix with `blocks` input blocks ([[A, B, 0..], [0, 0, I, ..], ..] h),
 * as bodyvib.runtime.discretize (blocks 2: Phi, Gamma0, Gamma1; blocks 3: also Gamma2). */
static int augmented(bv_instance *c, double key, int blocks, double *E)
{
    int n = c->n, m = c->m, N = n + blocks * m, i, j, b;
    double *M = E + (size_t)N * N;
    memset(M, 0, (size_t)N * N * sizeof *M);
    for (i = 0; i < n; i++) {
        for (j = 0; j < n; j++)
            M[i * N + j] = c->A[i * n + j] * key;
        for (j = 0; j < m; j++)
            M[i * N + n + j] = c->B[i * m + j] * key;
    }
    for (b = 1; b < blocks; b++)
        for (j = 0; j < m; j++)
            M[(n + (b - 1) * m + j) * N + n + b * m + j] = key;
    return expm(E, M, N, M + (size_t)N * N, c->piv);
}

/* Step matrices for h (Sc, Ms). */
static int discretize(bv_instance *c, double h)
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
    mul(T, G, c->bc.md->U, n, m, ni);
    for (i = 0; i < n; i++)
        for (j = 0; j < ni; j++)
            c->Sc[(size_t)i * (n + ni) + n + j] = T[i * ni + j];
    for (i = 0; i < n; i++)
        for (j = 0; j < m; j++)
            G[i * m + j] = E[i * N2 + n + m + j];
    mul(T, G, c->UR, n, m, ni);
    for (i = 0; i < n; i++)
        for (j = 0; j < ni; j++)
            c->Sc[(size_t)i * (n + ni) + n + j] += T[i * ni + j];
    if (c->curved) { /* + Gamma2 U R^2, from the three-block exponential */
        if (!augmented(c, key, 3, E))
            return 0;
        for (i = 0; i < n; i++)
            for (j = 0; j < m; j++)
                G[i * m + j] = E[i * N3 + n + 2 * m + j];
        mul(T, G, c->UR2, n, m, ni);
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

/* ---------------------------------------------------------------- instances */

static void clear_state(bv_instance *c)
{
    int j, np1 = c->bc.md->npairs + 1;
    for (j = 0; j < c->np; j++)
        c->p[j] = c->bc.md->param_start[j];
    memset(c->x, 0, (size_t)c->n * sizeof(double));
    memset(c->s, 0, (size_t)c->ni * sizeof(double));
    memset(c->x_prev, 0, (size_t)np1 * sizeof(double));
    memset(c->h_prev, 0, (size_t)np1 * sizeof(double));
    memset(c->has_prev, 0, 4 * (size_t)np1);
    bv_common_clear(&c->bc);
}

bv_instance *bv_new(const bv_model *md, const char *name, bv_log_fn log, void *env)
{
    bv_instance *c;
    int n = md->n, m = md->m, ni = md->ni, no = md->no, np = md->np, R = md->rows;
    int N = n + 3 * m, np1 = md->npairs + 1, i, j, k; /* N: the largest augmented matrix */
    size_t nd, nw, assembly;
    double *d;
    if (md != HOT) /* the hot path reads this binary's model (HOT) */
        return NULL;
    c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    bv_common_init(&c->bc, md, name, log, env);
    c->n = n, c->m = m, c->ni = ni, c->no = no, c->np = np;
    /* work: the larger of the assembly (E, [A|B], C, Cd, D, a few rows) and the
     * discretization (E, M, expm's 9 matrices, two n x max(m, ni) blocks) */
    assembly = (size_t)n * n + (size_t)n * (n + m) + 2 * (size_t)R * n + (size_t)R * m + n +
               2 * (size_t)m + 2 * (size_t)ni;
    nw = (size_t)N * N * 11 + (size_t)n * m + (size_t)n * (m > ni ? m : ni);
    if (assembly > nw)
        nw = assembly;
    nd = 2 * (size_t)np + (size_t)n * n + (size_t)n * m + 2 * (size_t)m * ni +
         (size_t)no * (n + ni) + (size_t)n * (n + ni) + (size_t)ni * ni + n + ni +
         2 * (size_t)np1 + n + ni + nw;
    nd += (size_t)n * n + (size_t)n * m + (size_t)no * (n + ni); /* candidates A2, B2, Yc2 */
    nd += 3 * (size_t)np1 + 3 * ((size_t)n + ni);                /* saved bookkeeping, zd */
    d = calloc(nd, sizeof *d);
    c->piv = calloc((size_t)N + 1, sizeof *c->piv);
    c->has_prev = calloc(8 * (size_t)np1, 1);
    if (d == NULL || c->piv == NULL || c->has_prev == NULL) {
        free(d);
        free(c->piv);
        free(c->has_prev);
        free(c);
        return NULL;
    }
    c->vel_set = c->has_prev + np1;
    c->slope_on = c->vel_set + np1;
    c->warned = c->slope_on + np1;
    c->save_flags = c->warned + np1; /* 4 np1: has_prev, vel_set, slope_on, warned */
    c->p = d; d += np;
    c->p_built = d; d += np;
    c->A = d; d += (size_t)n * n;
    c->B = d; d += (size_t)n * m;
    c->UR = d; d += (size_t)m * ni;
    c->UR2 = d; d += (size_t)m * ni;
    c->Yc = d; d += (size_t)no * (n + ni);
    c->Sc = d; d += (size_t)n * (n + ni);
    c->Ms = d; d += (size_t)ni * ni;
    c->x = d; d += n; /* x, s contiguous: z */
    c->s = d; d += ni;
    c->x_prev = d; d += np1;
    c->h_prev = d; d += np1;
    c->zn = d; d += n + ni;
    c->A2 = d; d += (size_t)n * n;
    c->B2 = d; d += (size_t)n * m;
    c->Yc2 = d; d += (size_t)no * (n + ni);
    c->save_x_prev = d; d += np1;
    c->save_h_prev = d; d += np1;
    c->save_s = d; d += np1;
    c->zd = d; d += 3 * ((size_t)n + ni);
    c->work = d;
    /* U R and U R^2; curved if R^2 != 0 */
    mul(c->UR, md->U, md->R, m, ni, ni);
    mul(c->UR2, c->UR, md->R, m, ni, ni);
    for (i = 0; i < ni; i++)
        for (j = 0; j < ni; j++) {
            double r2 = 0.0;
            for (k = 0; k < ni; k++)
                r2 += md->R[i * ni + k] * md->R[k * ni + j];
            if (r2 != 0.0)
                c->curved = 1;
        }
    clear_state(c);
    if (!build(c, c->p)) {
        say(c, BV_ERROR, "%s: the model with its default parameters cannot be assembled "
                         "(singular descriptor matrix)", c->bc.name);
        bv_free(c);
        return NULL;
    }
    return c;
}

void bv_free(bv_instance *c)
{
    if (c == NULL)
        return;
    free(c->p); /* the start of the one block of doubles */
    free(c->piv);
    free(c->has_prev);
    free(c);
}

void bv_reset(bv_instance *c)
{
    clear_state(c);
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0)
        build(c, c->p); /* the defaults always build (checked at instantiation) */
}

bv_status bv_initialize(bv_instance *c)
{
    bv_common_begin_initialize(&c->bc);
    if (!params_valid(c, c->p, 0)) {
        size_t l = strlen(c->bc.init_error);
        snprintf(c->bc.init_error + l, BV_MESSAGE - l,
                 "; the instance refuses to step (reset and set valid parameters)");
        return bv_common_failed(&c->bc);
    }
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0) {
        if (!build(c, c->p)) {
            snprintf(c->bc.init_error, BV_MESSAGE,
                     "%s: the parameters give a singular or unusable model (a massless node "
                     "without damping, or a parameter so small or large that the model's "
                     "matrices are not finite); the instance refuses to step (reset and set "
                     "valid parameters)",
                     c->bc.name);
            return bv_common_failed(&c->bc);
        }
    }
    bv_common_initialized(&c->bc);
    return BV_OK;
}

/* Parameters set before initialization: rebuild the model for them if valid. */
static BV_COLD void follow_parameters(bv_instance *c);

/* Model-exchange variables (states, derivatives): me_var_get -1 if vr is not one, else a
 * bv_status; me_var_set only for one (is_me_var), a bv_status. */
static int me_var_get(bv_instance *c, unsigned int vr, double *value);
static int me_var_set(bv_instance *c, unsigned int vr, double value);

/* A value reference of the model-exchange states or their derivatives. */
static int is_me_var(const bv_instance *c, unsigned int vr)
{
    unsigned int first = (unsigned int)BV_STATE_VR(HOT, 0);
    (void)c;
    return vr >= first && vr < first + 2u * (unsigned int)HOT->n;
}

#define check_vr(c, vr) bv_common_check_vr(&(c)->bc, (vr))

/* FMU input idx set to v: a velocity of a fallback pair set to a non-zero value is connected
 * (its slope fallback ends). */
static inline void set_input(bv_instance *c, int idx, double v)
{
    const bv_model *md = HOT;
    int k;
    c->s[idx] = v;
    BV_UNROLL
    for (k = 0; k < md->npairs; k++) /* the pairs are constants of this binary's model */
        if (md->pairs[k].rate == idx && v != 0.0) {
            c->vel_set[k] = 1;
            c->slope_on[k] = 0;
        }
}

static BV_COLD bv_status set_general(bv_instance *c, const unsigned int vr[], size_t nvr,
                                     const double value[]);

bv_status bv_set(bv_instance *c, const unsigned int vr[], size_t nvr, const double value[])
{
    const bv_model *md = HOT;
    const unsigned int nvars = (unsigned int)md->nvars;
    size_t i;
    /* the call of every co-simulation step: inputs only (always settable), checked before
     * any is set; model exchange checks every input's value (set_general) */
    for (i = 0; i < nvr; i++)
        if (vr[i] >= nvars || md->vr_kind[vr[i]] != BV_INPUT)
            break;
    if (BV_UNLIKELY(i != nvr || c->bc.me))
        return set_general(c, vr, nvr, value);
    for (i = 0; i < nvr; i++)
        set_input(c, md->vr_index[vr[i]], value[i]);
    return BV_OK;
}

/* bv_set of a request that is not inputs only: parameters, model-exchange states, refusals. */
static BV_COLD bv_status set_general(bv_instance *c, const unsigned int vr[], size_t nvr,
                                     const double value[])
{
    const bv_model *md = HOT;
    const unsigned int nvars = (unsigned int)md->nvars;
    bv_status status = BV_OK;
    size_t i;
    /* the time, an unknown value reference (the contract's variables are below nvars, the
     * model-exchange ones above) or, in model exchange, an input that is not finite refuses
     * the call: nothing set. One scan, which stops at the first refusal: a host that
     * passes more references than its arrays hold is not read past the first unknown one. */
    for (i = 0; i < nvr; i++) {
        if (bv_common_is_time(&c->bc, vr[i]))
            return bv_common_time_not_settable(&c->bc);
        if (vr[i] >= nvars && !is_me_var(c, vr[i])) {
            check_vr(c, vr[i]); /* logs the refusal */
            return BV_ERROR;
        }
        if (c->bc.me && vr[i] < nvars && md->vr_kind[vr[i]] == BV_INPUT && !isfinite(value[i]))
            return bv_common_not_finite(&c->bc, vr[i], value[i]);
    }
    for (i = 0; i < nvr; i++) {
        int idx;
        if (vr[i] >= nvars) { /* a model-exchange state or its derivative */
            if (me_var_set(c, vr[i], value[i]) != BV_OK)
                status = BV_ERROR;
            continue;
        }
        idx = md->vr_index[vr[i]];
        if (md->vr_kind[vr[i]] == BV_INPUT) { /* always settable */
            set_input(c, idx, value[i]);
        } else if (!bv_common_settable(&c->bc, vr[i])) {
            status = BV_ERROR;
        } else {
            c->p[idx] = value[i]; /* a parameter */
        }
    }
    return status;
}

/* Output idx, computed on read: y_idx = Yc_idx . [x | s]. */
BV_HOT_INLINE double output_value(const bv_instance *c, int idx)
{
    const int w = HOT->n + HOT->ni;
    return dot(c->Yc + (size_t)idx * w, c->x, w);
}

/* The value of a contract variable (vr < nvars): an output, an input (an unconnected
 * velocity whose slope stands in reads as set: 0) or a parameter. */
BV_HOT_INLINE double variable_value(const bv_instance *c, unsigned int vr)
{
    const bv_model *md = HOT;
    int idx = md->vr_index[vr], kind = md->vr_kind[vr], k;
    double v;
    if (kind == BV_OUTPUT)
        return output_value(c, idx);
    if (kind != BV_INPUT)
        return c->p[idx];
    v = c->s[idx];
    BV_UNROLL
    for (k = 0; k < md->npairs; k++) /* the pairs are constants of this binary's model */
        if (md->pairs[k].rate == idx && c->slope_on[k])
            v = 0.0;
    return v;
}

/* bv_get of a request the fast path does not finish: before initialization (the model
 * follows the parameters set), the model-exchange variables, refusals (logged). */
static BV_COLD bv_status get_general(bv_instance *c, const unsigned int vr[], size_t nvr,
                                     double value[])
{
    const bv_model *md = HOT;
    const unsigned int nvars = (unsigned int)md->nvars;
    bv_status status = BV_OK;
    size_t i;
    follow_parameters(c);
    for (i = 0; i < nvr; i++) {
        if (bv_common_is_time(&c->bc, vr[i])) {
            value[i] = c->bc.time;
            continue;
        }
        if (vr[i] >= nvars) { /* a model-exchange variable, or none */
            int me = me_var_get(c, vr[i], &value[i]);
            if (me < 0)
                check_vr(c, vr[i]); /* logs the refusal */
            if (me != BV_OK)
                return BV_ERROR;
            continue;
        }
        value[i] = variable_value(c, vr[i]);
        if (md->vr_kind[vr[i]] == BV_OUTPUT && !isfinite(value[i]) && status == BV_OK) {
            say(c, BV_ERROR, "%s: output %s is not finite: an input is not finite or too "
                             "large (set finite inputs of physical size)",
                c->bc.name, md->vr_name[vr[i]]);
            status = BV_ERROR;
        }
    }
    return status;
}

bv_status bv_get(bv_instance *c, const unsigned int vr[], size_t nvr, double value[])
{
    const unsigned int nvars = (unsigned int)HOT->nvars;
    size_t i;
    /* the call of every step: the contract's variables of an initialized instance, every
     * value finite (an output that is not is reported by get_general, which reads the
     * request again from its start) */
    if (BV_UNLIKELY(!c->bc.initialized))
        return get_general(c, vr, nvr, value);
    for (i = 0; i < nvr; i++) {
        double v;
        if (BV_UNLIKELY(vr[i] >= nvars))
            return get_general(c, vr, nvr, value);
        v = variable_value(c, vr[i]);
        if (BV_UNLIKELY(!isfinite(v)))
            return get_general(c, vr, nvr, value);
        value[i] = v;
    }
    return BV_OK;
}

/* The one warning of fallback pair k: its displacement moves at time t but its velocity was
 * never set; what the FMU does about it, co-simulation (me 0) or model exchange (me 1). */
static BV_COLD void warn_unconnected(bv_instance *c, int k, double t, int me)
{
    const bv_pair *pr = &c->bc.md->pairs[k];
    const char *dname = var_name(c->bc.md, BV_INPUT, pr->value);
    const char *vname = var_name(c->bc.md, BV_INPUT, pr->rate);
    c->warned[k] = 1;
    if (me)
        say(c, BV_WARNING, "%s: %s moves (t = %g s) but %s was never set: in model exchange "
                           "the velocity input is used as given (0); set %s to the time "
                           "derivative of %s",
            c->bc.name, dname, t, vname, vname, dname);
    else
        say(c, BV_WARNING, "%s: %s moves (t = %g s) but %s was never set: using the slope of "
                           "successive %s values as its in-step rate; connect %s for the exact "
                           "coupling",
            c->bc.name, dname, t, vname, dname, vname);
}

/* The unconnected-velocity rule, before a step (bodyvib.runtime.engine's _slope_fallback). */
BV_HOT_INLINE void slope_fallback(bv_instance *c, double t, double h)
{
    const bv_model *md = HOT;
    int k;
    for (k = 0; k < md->npairs; k++) {
        const bv_pair *pr = &md->pairs[k];
        double x = c->s[pr->value];
        if (c->vel_set[k])
            continue;
        if (c->has_prev[k] && x != c->x_prev[k] && !c->slope_on[k]) {
            c->slope_on[k] = 1;
            if (!c->warned[k])
                warn_unconnected(c, k, t, 0);
        }
        if (c->slope_on[k])
            c->s[pr->rate] = (x - c->x_prev[k]) / c->h_prev[k];
        c->x_prev[k] = x;
        c->h_prev[k] = h;
        c->has_prev[k] = 1;
    }
}

/* The fallback bookkeeping (and the velocity inputs it writes), saved before a step and
 * restored if the step is refused: a refused step changes nothing. A pair whose velocity
 * was set is left alone by slope_fallback (and stays set through the step): nothing to save.
 * Per pair, plain loops: the hot path makes no library calls. */
BV_HOT_INLINE void save_bookkeeping(bv_instance *c, int restore)
{
    const bv_model *md = HOT;
    int k, np1 = md->npairs + 1;
    unsigned char *f = c->save_flags;
    for (k = 0; k < md->npairs; k++) {
        int r = md->pairs[k].rate;
        if (c->vel_set[k])
            continue;
        if (!restore) {
            c->save_x_prev[k] = c->x_prev[k];
            c->save_h_prev[k] = c->h_prev[k];
            c->save_s[k] = c->s[r];
            f[k] = c->has_prev[k];
            f[2 * np1 + k] = c->slope_on[k], f[3 * np1 + k] = c->warned[k];
        } else {
            c->x_prev[k] = c->save_x_prev[k];
            c->h_prev[k] = c->save_h_prev[k];
            c->s[r] = c->save_s[k];
            c->has_prev[k] = f[k];
            c->slope_on[k] = f[2 * np1 + k], c->warned[k] = f[3 * np1 + k];
        }
    }
}

/* A step whose new state is not finite, refused: the fallback bookkeeping restored, the
 * reason logged (a non-finite input: BV_ERROR; else BV_DISCARD). */
static BV_COLD bv_status refuse_step(bv_instance *c, double t)
{
    int j;
    save_bookkeeping(c, 1);
    for (j = 0; j < c->ni; j++)
        if (!isfinite(c->s[j])) {
            say(c, BV_ERROR, "%s: input %s = %g at t = %g s is not finite; step refused, "
                             "state unchanged (set a finite value and step again)",
                c->bc.name, var_name(c->bc.md, BV_INPUT, j), c->s[j], t);
            return BV_ERROR;
        }
    say(c, BV_ERROR, "%s: the state after the step from t = %g s is not finite (inputs or "
                     "state too large); step refused (discard), state unchanged",
        c->bc.name, t);
    return BV_DISCARD;
}

/* The step over [t, t + h] with the step matrices for h: z <- [Sc z; Ms s], accepted if the
 * new z is finite. z.z is finite iff no component exceeds about 1e154 (as the pythonfmu FMU
 * checks): no overflow, and room for the outputs, whose coefficients are far below 1e150.
 * Every input reaches the new z (Ms holds I), so a non-finite input is refused too. z.z is
 * summed as the components are made (even ones into zz, odd ones into zz2, in order). */
BV_HOT_INLINE bv_status advance(bv_instance *c, double t, double h)
{
    const int n = HOT->n, ni = HOT->ni, w = n + ni;
    double *restrict zn = c->zn, zz = 0.0, zz2 = 0.0;
    int i;
    matvec(zn, c->Sc, c->x, n, w);
    ms_matvec(zn + n, c->Ms, c->s);
    BV_UNROLL
    for (i = 0; i < w; i++) {
        if (i & 1)
            zz2 += zn[i] * zn[i];
        else
            zz += zn[i] * zn[i];
    }
    zz += zz2;
    if (BV_UNLIKELY(!(zz < INFINITY))) /* NaN or inf */
        return refuse_step(c, t);
    c->zn = c->x; /* zn is the new z: swap the buffers */
    c->x = zn;
    c->s = zn + n;
    c->bc.time = t + h;
    return BV_OK;
}

/* A step the fast path of bv_step does not take: its checks with their messages, and new
 * step matrices (the first step, a new step size). */
static BV_COLD bv_status step_prepare(bv_instance *c, double t, double h)
{
    char text[32];
    if (bv_common_step_check(&c->bc, t, h) != BV_OK)
        return BV_ERROR;
    save_bookkeeping(c, 0);
    if (HOT->npairs)
        slope_fallback(c, t, h);
    if (!discretize(c, h)) {
        save_bookkeeping(c, 1);
        say(c, BV_ERROR, "%s: a step of %s s overflows the exact discretization (not "
                         "finite); step refused (discard), state unchanged (use shorter steps)",
            c->bc.name, shortest(h, text));
        return BV_DISCARD;
    }
    return advance(c, t, h);
}

bv_status bv_step(bv_instance *c, double t, double h)
{
    /* h == h_raw: the step matrices are for h, which passed the step's checks when they were
     * made (positive, finite); then the checks left are the instance's and the time's */
    if (BV_UNLIKELY(!(h == c->h_raw && c->bc.initialized && bv_common_on_time(&c->bc, t))))
        return step_prepare(c, t, h);
    save_bookkeeping(c, 0);
    if (HOT->npairs)
        slope_fallback(c, t, h);
    return advance(c, t, h);
}

/* ---------------------------------------------------------------- input and output derivatives */

/* The input that is the in-step rate of input i (R[i][r] != 0), or -1. */
static int rate_of(const bv_model *md, int i, double *coef)
{
    int r;
    for (r = 0; r < md->ni; r++)
        if (md->R[(size_t)i * md->ni + r] != 0.0) {
            *coef = md->R[(size_t)i * md->ni + r];
            return r;
        }
    return -1;
}

/* Walk `order` rate pairs down input j's chain: the input the last one reaches (-1 if the
 * chain is shorter), with *coef the product of the rates' coefficients along it. */
static int chain(const bv_model *md, int j, int order, double *coef)
{
    int r = -1, o;
    double cf;
    *coef = 1.0;
    for (o = 0; o < order && j >= 0; o++) {
        r = rate_of(md, j, &cf);
        if (r >= 0)
            *coef *= cf;
        j = r;
    }
    return r;
}

bv_status bv_set_input_derivatives(bv_instance *c, const unsigned int vr[], size_t nvr,
                                   const int order[], const double value[])
{
    const bv_model *md = c->bc.md;
    size_t i;
    int k;
    /* all checked before any is applied: a refused call changes nothing */
    for (i = 0; i < nvr; i++) {
        double coef;
        if (!check_vr(c, vr[i]))
            return BV_ERROR;
        if (md->vr_kind[vr[i]] != BV_INPUT) {
            say(c, BV_ERROR, "%s: %s is not an input; input derivatives are for inputs only",
                c->bc.name, md->vr_name[vr[i]]);
            return BV_ERROR;
        }
        if (order[i] < 1) {
            say(c, BV_ERROR, "%s: derivative order %d of %s: the order must be 1 or more",
                c->bc.name, order[i], md->vr_name[vr[i]]);
            return BV_ERROR;
        }
        if (chain(md, md->vr_index[vr[i]], order[i], &coef) < 0 && value[i] != 0.0) {
            say(c, BV_ERROR, "%s: %s has no in-step derivative of order %d (its rate chain is "
                             "shorter; orders it has: see canInterpolateInputs in the documentation); "
                             "call refused",
                c->bc.name, md->vr_name[vr[i]], order[i]);
            return BV_ERROR;
        }
        if (!isfinite(value[i])) {
            say(c, BV_ERROR, "%s: derivative order %d of %s is not finite; call refused",
                c->bc.name, order[i], md->vr_name[vr[i]]);
            return BV_ERROR;
        }
    }
    for (i = 0; i < nvr; i++) {
        double coef;
        int r = chain(md, md->vr_index[vr[i]], order[i], &coef);
        if (r < 0)
            continue; /* a zero derivative the input has no rate for: it is held anyway */
        c->s[r] = value[i] / coef;
        /* a velocity given as a derivative is connected, whatever its value */
        for (k = 0; k < md->npairs; k++)
            if (md->pairs[k].rate == r) {
                c->vel_set[k] = 1;
                c->slope_on[k] = 0;
            }
    }
    return BV_OK;
}

/* z' = [A x + B U s, R s] for z = [x | s] (the state equations and the in-step rates). */
static void zdot(const bv_instance *c, const double *z, double *out)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, i, j;
    double *u = out + n + ni; /* m doubles of scratch past out (zd has room) */
    /* plain loops, not matvec: matvec stays inlined where the steps need it */
    for (i = 0; i < m; i++) {
        double v = 0.0;
        for (j = 0; j < ni; j++)
            v += md->U[(size_t)i * ni + j] * z[n + j];
        u[i] = v;
    }
    for (i = 0; i < n; i++) {
        double v = 0.0;
        for (j = 0; j < n; j++)
            v += c->A[(size_t)i * n + j] * z[j];
        for (j = 0; j < m; j++)
            v += c->B[(size_t)i * m + j] * u[j];
        out[i] = v;
    }
    for (i = 0; i < ni; i++) {
        double v = 0.0;
        for (j = 0; j < ni; j++)
            v += md->R[(size_t)i * ni + j] * z[n + j];
        out[n + i] = v;
    }
}

bv_status bv_get_output_derivatives(bv_instance *c, const unsigned int vr[], size_t nvr,
                                    const int order[], double value[])
{
    const bv_model *md = c->bc.md;
    int w = c->n + c->ni;
    size_t i;
    double *z1 = c->zd, *z2 = c->zd + w;
    bv_status status = BV_OK;
    if (bv_common_check_output_orders(&c->bc, vr, nvr, order) != BV_OK)
        return BV_ERROR;
    zdot(c, c->x, z1);  /* c->x, c->s contiguous: z */
    zdot(c, z1, z2);
    for (i = 0; i < nvr; i++) {
        const double *row = c->Yc + (size_t)md->vr_index[vr[i]] * w, *z = order[i] == 1 ? z1 : z2;
        double v = 0.0;
        int j;
        for (j = 0; j < w; j++)
            v += row[j] * z[j];
        value[i] = v;
        if (!isfinite(v) && status == BV_OK) {
            say(c, BV_ERROR, "%s: derivative %d of output %s is not finite (inputs too large)",
                c->bc.name, order[i], md->vr_name[vr[i]]);
            status = BV_ERROR;
        }
    }
    return status;
}

/* ---------------------------------------------------------------- snapshots */

static const unsigned char MAGIC[8] = {'B', 'V', 'S', 'T', 'A', 'T', 'E', '2'};

/* Payload: doubles time, initialized, init_failed, p[np], x[n], s[ni], then per fallback
 * pair x_prev, h_prev, has_prev, vel_set, slope_on, warned. */
static size_t payload_doubles(const bv_instance *c)
{
    return 3 + (size_t)c->np + (size_t)c->n + (size_t)c->ni + 6 * (size_t)c->bc.md->npairs;
}

size_t bv_state_size(const bv_instance *c)
{
    return BV_SNAPSHOT_HEAD + 8 * payload_doubles(c) + 8;
}

static unsigned char *put(unsigned char *q, const double *v, size_t k)
{
    memcpy(q, v, k * sizeof *v);
    return q + k * sizeof *v;
}

void bv_state_write(const bv_instance *c, unsigned char *buf)
{
    int k;
    size_t size = bv_state_size(c);
    double head[3], pair[6];
    unsigned char *q = bv_common_snapshot_head(&c->bc, buf, MAGIC, size);
    head[0] = c->bc.time;
    head[1] = c->bc.initialized;
    head[2] = c->bc.init_failed;
    q = put(q, head, 3);
    q = put(q, c->p, (size_t)c->np);
    q = put(q, c->x, (size_t)c->n);
    q = put(q, c->s, (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        pair[0] = c->x_prev[k];
        pair[1] = c->h_prev[k];
        pair[2] = c->has_prev[k];
        pair[3] = c->vel_set[k];
        pair[4] = c->slope_on[k];
        pair[5] = c->warned[k];
        q = put(q, pair, 6);
    }
    bv_common_snapshot_seal(buf, size);
}

static int flag_ok(double v) { return v == 0.0 || v == 1.0; }

bv_status bv_state_check(const bv_instance *c, const unsigned char *buf, size_t size)
{
    size_t off, i;
    int k;
    double head[3], pair[6], *p, v;
    if (bv_common_snapshot_check(&c->bc, buf, size, MAGIC, bv_state_size(c)) != BV_OK)
        return BV_ERROR;
    memcpy(head, buf + BV_SNAPSHOT_HEAD, sizeof head);
    off = BV_SNAPSHOT_HEAD + sizeof head;
    if (!(isfinite(head[0]) && flag_ok(head[1]) && flag_ok(head[2]))) {
        say(c, BV_ERROR, "%s: the FMU state is invalid (time or flags); refused", c->bc.name);
        return BV_ERROR;
    }
    p = malloc((size_t)c->np * sizeof *p + 1);
    if (p == NULL)
        return BV_ERROR;
    memcpy(p, buf + off, (size_t)c->np * sizeof *p);
    if (head[1] != 0.0 && !params_valid(c, p, 1)) {
        free(p);
        say(c, BV_ERROR, "%s: the FMU state holds invalid parameters; refused", c->bc.name);
        return BV_ERROR;
    }
    free(p);
    off += (size_t)c->np * 8;
    for (i = 0; i < (size_t)c->n; i++) {
        memcpy(&v, buf + off + 8 * i, 8);
        if (!isfinite(v)) {
            say(c, BV_ERROR, "%s: the FMU state holds a non-finite model state; refused",
                c->bc.name);
            return BV_ERROR;
        }
    }
    off += 8 * ((size_t)c->n + (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        memcpy(pair, buf + off + sizeof pair * (size_t)k, sizeof pair);
        /* consistent as only stepping makes it: a slope in use was seen (a previous
         * displacement and a normal positive step to divide by), never with the velocity
         * set, and warned about; no previous value, no step */
        int has_prev = pair[2] != 0.0, vel_set = pair[3] != 0.0, slope_on = pair[4] != 0.0;
        if (!(flag_ok(pair[2]) && flag_ok(pair[3]) && flag_ok(pair[4]) && flag_ok(pair[5]) &&
              isfinite(pair[0]) && isfinite(pair[1]) &&
              (has_prev ? isnormal(pair[1]) && pair[1] > 0.0
                        : pair[0] == 0.0 && pair[1] == 0.0) &&
              (!slope_on || (has_prev && !vel_set && pair[5] != 0.0)))) {
            say(c, BV_ERROR, "%s: the FMU state is invalid (fallback bookkeeping); refused",
                c->bc.name);
            return BV_ERROR;
        }
    }
    return BV_OK;
}

static const unsigned char *get(const unsigned char *q, double *v, size_t k)
{
    memcpy(v, q, k * sizeof *v);
    return q + k * sizeof *v;
}

bv_status bv_state_read(bv_instance *c, const unsigned char *buf, size_t size)
{
    int k;
    double head[3], pair[6];
    const unsigned char *q;
    if (bv_state_check(c, buf, size) != BV_OK)
        return BV_ERROR;
    q = get(buf + BV_SNAPSHOT_HEAD, head, 3);
    q = get(q, c->p, (size_t)c->np);
    q = get(q, c->x, (size_t)c->n);
    q = get(q, c->s, (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        q = get(q, pair, 6);
        c->x_prev[k] = pair[0];
        c->h_prev[k] = pair[1];
        c->has_prev[k] = (unsigned char)(pair[2] != 0.0);
        c->vel_set[k] = (unsigned char)(pair[3] != 0.0);
        c->slope_on[k] = (unsigned char)(pair[4] != 0.0);
        c->warned[k] = (unsigned char)(pair[5] != 0.0);
    }
    /* the state machine follows the snapshot */
    bv_common_restored(&c->bc, head[0], head[1] != 0.0, head[2] != 0.0, "valid parameters");
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0 && params_valid(c, c->p, 1))
        if (!build(c, c->p) && c->bc.initialized) {
            c->bc.initialized = 0;
            say(c, BV_ERROR, "%s: the restored parameters give a singular model", c->bc.name);
            return BV_ERROR;
        }
    return BV_OK;
}

/* ---------------------------------------------------------------- model exchange */

/* Follow parameters set before initialization (bv_get, derivatives, Jacobians), so what
 * is read in initialization mode is that of the parameters set. */
static BV_COLD void follow_parameters(bv_instance *c)
{
    if (!c->bc.initialized && memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0 &&
        params_valid(c, c->p, 1))
        build(c, c->p);
}

/* Row i of the derivative on z = [x | s]: [A_i | (B U)_i], into row (n + ni). */
static void derivative_row(const bv_instance *c, int i, double *row)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, j, l;
    for (j = 0; j < n; j++)
        row[j] = c->A[(size_t)i * n + j];
    for (j = 0; j < ni; j++) {
        double v = 0.0;
        for (l = 0; l < m; l++)
            v += c->B[(size_t)i * m + l] * md->U[(size_t)l * ni + j];
        row[n + j] = v;
    }
}

static double derivative_value(const bv_instance *c, int i)
{
    const bv_model *md = c->bc.md;
    int n = c->n, m = c->m, ni = c->ni, j, l;
    double v = 0.0;
    for (j = 0; j < n; j++)
        v += c->A[(size_t)i * n + j] * c->x[j];
    for (l = 0; l < m; l++) {
        double u = 0.0;
        for (j = 0; j < ni; j++)
            u += md->U[(size_t)l * ni + j] * c->s[j];
        v += c->B[(size_t)i * m + l] * u;
    }
    return v;
}

void bv_me_set_states(bv_instance *c, const double x[])
{
    int i;
    for (i = 0; i < c->n; i++)
        c->x[i] = x[i];
}

void bv_me_get_states(const bv_instance *c, double x[])
{
    int i;
    for (i = 0; i < c->n; i++)
        x[i] = c->x[i];
}

/* The unconnected velocity in model exchange: no slope fallback (the host owns the input
 * signals), but the same single warning when a displacement moves while its velocity was
 * never set to a non-zero value. The fallback bookkeeping of DoStep (x_prev, has_prev) is
 * unused in model exchange and holds the first displacement seen. */
static void me_unconnected_velocity(bv_instance *c)
{
    const bv_model *md = c->bc.md;
    int k;
    for (k = 0; k < md->npairs; k++) {
        const bv_pair *pr = &md->pairs[k];
        double x = c->s[pr->value];
        if (c->vel_set[k] || c->warned[k])
            continue;
        if (!c->has_prev[k]) {
            c->x_prev[k] = x;
            c->has_prev[k] = 1;
        } else if (x != c->x_prev[k]) {
            warn_unconnected(c, k, c->bc.time, 1);
        }
    }
}

void bv_me_derivatives(bv_instance *c, double dx[])
{
    follow_parameters(c);
    if (c->bc.md->npairs)
        me_unconnected_velocity(c);
    /* u = U s once for all rows (zd: n + ni out, m of scratch after; 3 (n + ni) >= that as
     * zdot's second use needs); same sums in the same order as derivative_value */
    zdot(c, c->x, c->zd);
    memcpy(dx, c->zd, (size_t)c->n * sizeof *dx);
}

static int me_var_get(bv_instance *c, unsigned int vr, double *value)
{
    const bv_model *md = c->bc.md;
    unsigned int first = (unsigned int)BV_STATE_VR(md, 0);
    if (!is_me_var(c, vr))
        return -1;
    if (vr < first + (unsigned int)c->n) {
        *value = c->x[vr - first];
    } else {
        follow_parameters(c);
        *value = derivative_value(c, (int)(vr - first) - c->n);
    }
    return BV_OK;
}

static int me_var_set(bv_instance *c, unsigned int vr, double value)
{
    const bv_model *md = c->bc.md;
    unsigned int first = (unsigned int)BV_STATE_VR(md, 0);
    if (vr >= first + (unsigned int)c->n) {
        say(c, BV_ERROR, "%s: a state derivative (value reference %u) is calculated and cannot "
                         "be set (ignored)", c->bc.name, vr);
        return BV_ERROR;
    }
    if (c->bc.initialized) {
        say(c, BV_ERROR, "%s: a state's start value (value reference %u) can be set only before "
                         "ExitInitializationMode; in model exchange use SetContinuousStates "
                         "(ignored)", c->bc.name, vr);
        return BV_ERROR;
    }
    c->x[vr - first] = value;
    return BV_OK;
}

/* Column of a known on z = [x | s]: a state or an input; -1 otherwise. */
static int known_column(const bv_instance *c, unsigned int vr)
{
    const bv_model *md = c->bc.md;
    unsigned int first = (unsigned int)BV_STATE_VR(md, 0);
    if (vr >= first && vr < first + (unsigned int)c->n)
        return (int)(vr - first);
    if (vr < (unsigned int)md->nvars && md->vr_kind[vr] == BV_INPUT)
        return c->n + md->vr_index[vr];
    return -1;
}

bv_status bv_directional(bv_instance *c, const unsigned int unknowns[], size_t nu,
                         const unsigned int knowns[], size_t nk, const double seed[],
                         double sensitivity[])
{
    const bv_model *md = c->bc.md;
    unsigned int first = (unsigned int)BV_STATE_VR(md, 0);
    int w = c->n + c->ni;
    size_t a, b;
    double *row = c->zn; /* scratch of n + ni */
    for (b = 0; b < nk; b++)
        if (known_column(c, knowns[b]) < 0) {
            say(c, BV_ERROR, "%s: directional derivative: value reference %u is not a known "
                             "(a continuous state or an input)", c->bc.name, knowns[b]);
            return BV_ERROR;
        }
    follow_parameters(c);
    for (a = 0; a < nu; a++) {
        unsigned int vr = unknowns[a];
        double v = 0.0;
        if (vr >= first + (unsigned int)c->n && vr < first + 2u * (unsigned int)c->n) {
            derivative_row(c, (int)(vr - first) - c->n, row);
        } else if (vr < (unsigned int)md->nvars && md->vr_kind[vr] == BV_OUTPUT) {
            memcpy(row, c->Yc + (size_t)md->vr_index[vr] * w, (size_t)w * sizeof *row);
        } else {
            say(c, BV_ERROR, "%s: directional derivative: value reference %u is not an unknown "
                             "(a state derivative or an output)", c->bc.name, vr);
            return BV_ERROR;
        }
        for (b = 0; b < nk; b++)
            v += row[known_column(c, knowns[b])] * seed[b];
        sensitivity[a] = v;
    }
    return BV_OK;
}
