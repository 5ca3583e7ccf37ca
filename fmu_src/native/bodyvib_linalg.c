/*
 * bodyvib native core: dense linear algebra and the matrix exponential (see
 * bodyvib_linalg.h). Model-independent: no instance, no model data.
 */
#include "bodyvib_linalg.h"

#include <math.h>
#include <string.h>

/* C = A B; A is r x k, B is k x q, all row-major; C must not alias A or B. */
void bv_mul(double *C, const double *A, const double *B, int r, int k, int q)
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
int bv_lu(double *M, int *piv, int n)
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
void bv_lu_solve(const double *LU, const int *piv, int n, double *Bm, int q)
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
    bv_mul(out, M6, W, N, N, N);
    for (i = 0; i < NN; i++)
        out[i] += B13[o + 6] * M6[i] + B13[o + 4] * M4[i] + B13[o + 2] * M2[i];
    for (k = 0; k < N; k++)
        out[(size_t)k * N + k] += B13[o];
}

/* E = exp(M), M N x N, by scaling and squaring with a degree-13 Pade approximant; the
 * scaling from norms of powers of M (Al-Mohy & Higham 2009), as bodyvib.discretize.expm.
 * work: 9 N x N; piv: N. Returns 0 if the Pade denominator is singular. */
int bv_expm(double *E, const double *M, int N, double *work, int *piv)
{
    size_t NN = (size_t)N * N, i;
    double *M2 = work, *M4 = M2 + NN, *M6 = M4 + NN, *T = M6 + NN, *A = T + NN;
    double *W = A + NN, *Uo = W + NN, *V = Uo + NN, *P = V + NN;
    double d6, d8, d10, eta, f2, f4, f6, f1;
    int s = 0, j;

    bv_mul(M2, M, M, N, N, N);
    bv_mul(M4, M2, M2, N, N, N);
    bv_mul(M6, M4, M2, N, N, N);
    d6 = sqrt(cbrt(norm1(M6, N)));
    bv_mul(T, M4, M4, N, N, N);
    d8 = sqrt(sqrt(sqrt(norm1(T, N))));
    bv_mul(T, M4, M6, N, N, N);
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
    bv_mul(Uo, A, T, N, N, N);
    /* V = A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I */
    pade_sum(V, W, M2, M4, M6, N, 0);
    /* (V - U) E = V + U */
    for (i = 0; i < NN; i++) {
        P[i] = V[i] - Uo[i];
        E[i] = V[i] + Uo[i];
    }
    if (!bv_lu(P, piv, N))
        return 0;
    bv_lu_solve(P, piv, N, E, N);
    for (j = 0; j < s; j++) {
        bv_mul(T, E, E, N, N, N);
        memcpy(E, T, NN * sizeof *E);
    }
    return 1;
}
