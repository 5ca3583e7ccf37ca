/*
 * bodyvib native core: the sign test of a nonlinear model's step, inline on the hot path
 * (included by bodyvib_instance.h after HOT; see bodyvib_regimes.h). The number of
 * switching functions and which rows are negated ones are this binary's model's, constants
 * with link-time optimization, so the loops unroll.
 */
#ifndef BODYVIB_REGIMES_HOT_H
#define BODYVIB_REGIMES_HOT_H

/* The switching functions of this binary's model (a stop has two). */
BV_HOT_INLINE int bv_rg_count(void)
{
    int e, k = 0;
    BV_UNROLL
    for (e = 0; e < HOT->ne; e++)
        k += HOT->nl[e].kind == BV_NL_STOP ? 2 : 1;
    return k;
}

/* Function i is a stop's rebound side: its row is the compression side's negated. */
BV_HOT_INLINE int bv_rg_negated(int i)
{
    int e, k = 0;
    BV_UNROLL
    for (e = 0; e < HOT->ne; e++) {
        if (HOT->nl[e].kind == BV_NL_STOP && i == k + 1)
            return 1;
        k += HOT->nl[e].kind == BV_NL_STOP ? 2 : 1;
    }
    return 0;
}

/* Nothing switches in a step whose end has the functions' values ge: each keeps its sign,
 * and no parabola through its last three values (s = -1, 0, 1) dips across zero inside the
 * step. The values are kept times their signs (bodyvib_regimes.h), so keeping the sign is
 * staying >= 0. A sufficient test first, without a branch per function: 4 min(g0, g1) >=
 * max(gm, g1). It holds only where g0, g1 >= 0 (were min(g0, g1) < 0, 4 min(g0, g1) would
 * be below it and below g1); then a = (g1 + gm) / 2 - g0 <= max(gm, g1), and on [0, 1] the
 * parabola p(s) = (1 - s) g0 + s g1 - a s (1 - s) stays above min(g0, g1) - max(a, 0) / 4
 * >= 0. In a run it holds in every step but those near a function's zero (falling to a
 * quarter of its last value, or rising from near zero), where bv_rg_clear_exact decides. */
BV_HOT_INLINE int bv_rg_clear(const bv_regimes *rg)
{
    const int nsw = bv_rg_count();
    int i, ok = 1;
    BV_UNROLL
    for (i = 0; i < nsw; i++) {
        double gm = rg->g_prev[i], g0 = rg->g_now[i], g1 = rg->ge[i];
        double lo = g0 < g1 ? g0 : g1, hi = gm > g1 ? gm : g1;
        ok &= 4.0 * lo >= hi;
    }
    if (BV_UNLIKELY(!ok))
        return bv_rg_clear_exact(rg);
    return 1;
}

/* The functions (times their signs) at the end of the step from z = [x | s] at its start,
 * into ge: P z + q (bodyvib_regimes.h: independent of the step's own arithmetic, so the two
 * overlap). */
BV_HOT_INLINE void bv_rg_ahead(const bv_instance *c, const double *z)
{
    const bv_regimes *rg = c->rg;
    const bv_regime *r = rg->cur;
    const int w = HOT->n + HOT->ni, nsw = bv_rg_count();
    double last = 0.0;
    int i;
    BV_UNROLL
    for (i = 0; i < nsw; i++) {
        double v = bv_rg_negated(i) ? r->f[i] * last : bv_dot(r->P + (size_t)i * w, z, w);
        rg->ge[i] = v + r->q[i];
        last = v;
    }
}

/* After the step to z_new = [x | s] at t + h, with ge from bv_rg_ahead: the sign test, and
 * the events located where it fails. BV_OK (z_new's x may be rewritten) or the refusal (the
 * regime as it was). */
BV_HOT_INLINE bv_status bv_rg_finish(bv_instance *c, double t, double h, double *znew)
{
    bv_regimes *rg = c->rg;
    if (BV_LIKELY(bv_rg_clear(rg))) {
        bv_rg_accept(rg);
        return BV_OK;
    }
    return bv_rg_events(c, t, h, znew);
}

#endif
