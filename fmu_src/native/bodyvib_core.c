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
#include "bodyvib_instance.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>


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
 * bv_dot() by column parity: the same sums as the dense product less terms that are 0 z, which
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
               2 * (size_t)m + 2 * (size_t)ni + n + (size_t)R; /* + ec, dc */
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
    bv_mul(c->UR, md->U, md->R, m, ni, ni);
    bv_mul(c->UR2, c->UR, md->R, m, ni, ni);
    for (i = 0; i < ni; i++)
        for (j = 0; j < ni; j++) {
            double r2 = 0.0;
            for (k = 0; k < ni; k++)
                r2 += md->R[i * ni + k] * md->R[k * ni + j];
            if (r2 != 0.0)
                c->curved = 1;
        }
    clear_state(c);
    if (md->ne && !bv_rg_new(c)) {
        bv_free(c);
        return NULL;
    }
    if (!bv_build(c, c->p)) {
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
    bv_rg_free(c);
    free(c->p); /* the start of the one block of doubles */
    free(c->piv);
    free(c->has_prev);
    free(c);
}

void bv_reset(bv_instance *c)
{
    clear_state(c);
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0)
        bv_build(c, c->p); /* the defaults always build (checked at instantiation) */
    if (HOT->ne)
        bv_rg_restart(c);
}

bv_status bv_initialize(bv_instance *c)
{
    bv_common_begin_initialize(&c->bc);
    if (!bv_params_valid(c, c->p, 0)) {
        size_t l = strlen(c->bc.init_error);
        snprintf(c->bc.init_error + l, BV_MESSAGE - l,
                 "; the instance refuses to step (reset and set valid parameters)");
        return bv_common_failed(&c->bc);
    }
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0) {
        if (!bv_build(c, c->p)) {
            snprintf(c->bc.init_error, BV_MESSAGE,
                     "%s: the parameters give a singular or unusable model (a massless node "
                     "without damping, a parameter so small or large that the model's "
                     "matrices are not finite, or a contact that carries no static load); the instance refuses to step (reset and set "
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
    return vr >= first && vr < first + 2u * (unsigned int)HOT->n +
                                    (HOT->ne ? (unsigned int)c->rg->nsw : 0u);
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
    if (HOT->ne) /* the regime in force's rows and constants */
        return bv_dot(c->Yr + (size_t)idx * w, c->x, w) + c->y0r[idx];
    return bv_dot(c->Yc + (size_t)idx * w, c->x, w);
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
    const char *dname = bv_var_name(c->bc.md, BV_INPUT, pr->value);
    const char *vname = bv_var_name(c->bc.md, BV_INPUT, pr->rate);
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
                c->bc.name, bv_var_name(c->bc.md, BV_INPUT, j), c->s[j], t);
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
    if (HOT->ne) { /* the regime in force: its step and its affine column */
        const bv_regime *r = c->rg->cur;
        bv_rg_ahead(c, c->x); /* the switching functions at the step's end */
        bv_matvec(zn, r->S, c->x, n, w);
        if (r->affine)
            for (i = 0; i < n; i++)
                zn[i] += r->gb[i];
    } else {
        bv_matvec(zn, c->Sc, c->x, n, w);
    }
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
    if (HOT->ne) { /* the sign test; events located where it fails */
        bv_status st = bv_rg_finish(c, t, h, zn);
        if (BV_UNLIKELY(st != BV_OK)) {
            save_bookkeeping(c, 1);
            return st;
        }
    }
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
    if (!bv_discretize(c, h) || (HOT->ne && !bv_rg_discretize(c))) {
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

/* The model in force: a nonlinear model's regime, else the linear model. */
static const double *model_A(const bv_instance *c)
{
    return c->bc.md->ne ? c->rg->cur->A : c->A;
}

static const double *model_B(const bv_instance *c)
{
    return c->bc.md->ne ? c->rg->cur->B : c->B;
}

/* z' = [A x + B U s (+ b, affine), R s] for z = [x | s] (the state equations and the in-step
 * rates; a nonlinear model's regime in force, its constant b for the state, not for a rate). */
static void zdot(const bv_instance *c, const double *z, double *out, int affine)
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
    const double *A = model_A(c), *B = model_B(c);
    for (i = 0; i < n; i++) {
        double v = md->ne && affine ? c->rg->cur->b[i] : 0.0;
        for (j = 0; j < n; j++)
            v += A[(size_t)i * n + j] * z[j];
        for (j = 0; j < m; j++)
            v += B[(size_t)i * m + j] * u[j];
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
    zdot(c, c->x, z1, 1);  /* c->x, c->s contiguous: z */
    zdot(c, z1, z2, 0);
    for (i = 0; i < nvr; i++) {
        const double *Y = md->ne ? c->rg->cur->Y : c->Yc;
        const double *row = Y + (size_t)md->vr_index[vr[i]] * w, *z = order[i] == 1 ? z1 : z2;
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

/* ---------------------------------------------------------------- model exchange */

/* Follow parameters set before initialization (bv_get, derivatives, Jacobians), so what
 * is read in initialization mode is that of the parameters set. */
static BV_COLD void follow_parameters(bv_instance *c)
{
    if (!c->bc.initialized && memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0 &&
        bv_params_valid(c, c->p, 1))
        bv_build(c, c->p);
}

/* Row i of the derivative on z = [x | s]: [A_i | (B U)_i], into row (n + ni). */
static void derivative_row(const bv_instance *c, int i, double *row)
{
    const bv_model *md = c->bc.md;
    const double *A = model_A(c), *B = model_B(c);
    int n = c->n, m = c->m, ni = c->ni, j, l;
    for (j = 0; j < n; j++)
        row[j] = A[(size_t)i * n + j];
    for (j = 0; j < ni; j++) {
        double v = 0.0;
        for (l = 0; l < m; l++)
            v += B[(size_t)i * m + l] * md->U[(size_t)l * ni + j];
        row[n + j] = v;
    }
}

static double derivative_value(const bv_instance *c, int i)
{
    const bv_model *md = c->bc.md;
    const double *A = model_A(c), *B = model_B(c);
    int n = c->n, m = c->m, ni = c->ni, j, l;
    double v = md->ne ? c->rg->cur->b[i] : 0.0;
    for (j = 0; j < n; j++)
        v += A[(size_t)i * n + j] * c->x[j];
    for (l = 0; l < m; l++) {
        double u = 0.0;
        for (j = 0; j < ni; j++)
            u += md->U[(size_t)l * ni + j] * c->s[j];
        v += B[(size_t)i * m + l] * u;
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
    zdot(c, c->x, c->zd, 1);
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
    } else if (vr >= first + 2u * (unsigned int)c->n) { /* an event indicator */
        *value = bv_rg_indicator(c, (int)(vr - first) - 2 * c->n);
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
        say(c, BV_ERROR, "%s: a state derivative or an event indicator (value reference %u) is "
                         "calculated and cannot "
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
            const double *Y = md->ne ? c->rg->cur->Y : c->Yc;
            memcpy(row, Y + (size_t)md->vr_index[vr] * w, (size_t)w * sizeof *row);
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

/* ---------------------------------------------------------------- event indicators */

void bv_me_event_indicators(bv_instance *c, double z[])
{
    int i;
    for (i = 0; c->rg != NULL && i < c->rg->nsw; i++)
        z[i] = bv_rg_indicator(c, i);
}

int bv_me_update_regime(bv_instance *c) { return c->rg != NULL && bv_rg_update(c); }
