/*
 * bodyvib native core: dense linear algebra and the matrix exponential (bodyvib_linalg.c),
 * and the row products of every step, inline here so that the step's loops unroll for
 * the model's sizes. Internal to the linear core; all matrices are row-major doubles.
 */
#ifndef BODYVIB_LINALG_H
#define BODYVIB_LINALG_H

#include <stddef.h>

/* C = A B; A is r x k, B is k x q; C must not alias A or B. */
void bv_mul(double *C, const double *A, const double *B, int r, int k, int q);
/* LU factorization with partial pivoting in place (n x n); 0 if singular. */
int bv_lu(double *M, int *piv, int n);
/* Solve (LU) X = Bm in place, Bm n x q. */
void bv_lu_solve(const double *LU, const int *piv, int n, double *Bm, int q);
/* E = exp(M), M N x N (Pade(13), scaling and squaring); work: 9 N x N; piv: N. Returns 0
 * if the Pade denominator is singular. */
int bv_expm(double *E, const double *M, int N, double *work, int *piv);

/* Loops over the model's sizes on the hot path: unrolled where the sizes are constants (the core's
 * model, with link-time optimization), so that a step is straight-line code. */
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 8
#define BV_UNROLL _Pragma("GCC unroll 16")
#else
#define BV_UNROLL
#endif

/* r . z over cols entries, two accumulators (even and odd columns) added at the end. */
static inline double bv_dot(const double *restrict r, const double *restrict z, int cols)
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

/* out = M z, M row-major (rows x cols); rows independent, each a bv_dot(). */
static inline void bv_matvec(double *restrict out, const double *restrict M, const double *restrict z,
                   int rows, int cols)
{
    int i;
    BV_UNROLL
    for (i = 0; i < rows; i++)
        out[i] = bv_dot(M + (size_t)i * cols, z, cols);
}

#endif
