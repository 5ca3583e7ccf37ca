/*
 * bodyvib native source core (see bodyvib_table.h): the bv_* API of bodyvib_core.h for a
 * tabulated profile, the C twin of bodyvib.runtime.tabulated.SourceCore.
 *
 * Per instance: the shared state machine (bv_common of bodyvib_fsm.h: state, time, start
 * time, initialization flags) and the speed parameter. Outputs are computed on read at
 * p = speed * time, the time starting at the run's start time. DoStep(t, h) sets the time to
 * t + h (outputs read after it are those of the step's end), as the pythonfmu source FMU
 * does. No inputs, no continuous states: model exchange sets the time and reads the outputs
 * there; input derivatives and directional derivatives are refused.
 */
#include "bodyvib_table.h"
#include "bodyvib_fsm.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct bv_instance {
    bv_common bc; /* first (BV_STATE_IS) */
    const bv_source *tb;
    double speed;
    double periods; /* whole periods of the last position read (a periodic table's hint) */
    double *z, *dz, *d2z, *d3z; /* [signals] scratch: the interpolant and its derivatives */
};

/* The model and table on the hot path (bv_step, bv_get): this binary's, read directly
 * rather than through the instance, so that where the build sees their definitions (the
 * FMUs are linked with link-time optimization) the table's size, spacing and kind are
 * constants. bv_new accepts this model only. */
#define HOT (&bv_model_data)
#define HOT_TABLE (&bv_source_data)

#define say(c, ...) bv_say(&(c)->bc, __VA_ARGS__)

/* numpy's float modulo (np.mod): the sign of the divisor, +0 for an exact multiple. */
static double py_mod(double a, double b)
{
    double r = fmod(a, b);
    if (r != 0.0) {
        if ((b < 0.0) != (r < 0.0))
            r += b;
    } else {
        r = copysign(0.0, b);
    }
    return r;
}

/* py_mod(u, k) for a whole k > 0, starting from a guess of the whole periods in u (updated).
 * With q = floor(u / k) the remainder is u - q k, and q k is exact (a whole number below
 * 2^53); u - q k is then exact for q >= 0 (for q >= 1, q k <= u < 2 q k: Sterbenz), and for
 * q < 0 rounded once, as fmod's exact remainder plus k is in py_mod: the same bits. A guess
 * that does not put the remainder in [0, k) is not the floor: py_mod then, and a new guess.
 * A run moves through the table in order, so the guess of the last read holds: no fmod. */
#define TWO52 4503599627370496.0 /* 2^52 */

/* periodic_mod when the guess misses (a new period, a jump, NaN, infinities): py_mod, and a
 * new guess. Apart from the hot path, whose registers the library calls would claim. */
static BV_COLD double periodic_mod_miss(double u, double k, double *periods)
{
    double r = py_mod(u, k); /* also NaN and infinities */
    *periods = fabs(u) < TWO52 ? floor(u / k) : 0.0;
    return r;
}

/* missed NULL: a miss is resolved by periodic_mod_miss. Else a miss sets *missed and changes
 * nothing: the caller then evaluates again with missed NULL, off its hot path. */
BV_HOT_INLINE double periodic_mod(double u, double k, double *periods, int *missed)
{
    double r;
    if (BV_LIKELY(fabs(u) < TWO52)) {
        r = u - *periods * k;
        if (BV_LIKELY(r >= 0.0 && r < k))
            return r;
    }
    if (missed != NULL) {
        *missed = 1;
        return u;
    }
    return periodic_mod_miss(u, k, periods);
}

/* The segment i and the local coordinate s in [0, 1] of position p, as
 * HermiteTable.evaluate locates them; returns 0 when p is off a non-periodic table (held).
 * periods: the guess of periodic_mod, or NULL (py_mod); missed: as periodic_mod's (the
 * segment is then not set). */
BV_HOT_INLINE int locate(const bv_source *t, double p, int *seg, double *local, double *periods,
                         int *missed)
{
    int k = t->rows - 1, i;
    double u = (p - t->p0) / t->dp, uc;
    int inside;
    if (t->periodic && t->loop == 0)
        u = periods ? periodic_mod(u, (double)k, periods, missed) : py_mod(u, (double)k);
    else if (t->periodic && u > (double)k) /* past the end: back into the repeating part */
        u = t->loop + (periods ? periodic_mod(u - t->loop, (double)(k - t->loop), periods, missed)
                               : py_mod(u - t->loop, (double)(k - t->loop)));
    if (missed != NULL && *missed)
        return 0;
    inside = u >= 0.0 && u <= (double)k;
    uc = u < 0.0 ? 0.0 : (u > (double)k ? (double)k : u);
    if (isnan(u))
        uc = u;
    i = isnan(uc) ? 0 : (int)uc; /* uc >= 0 (or -0): truncation is floor */
    if (i > k - 1)
        i = k - 1;
    *seg = i;
    *local = uc - i;
    return (t->periodic && t->loop == 0) || inside;
}

/* bv_source_evaluate with the periods guess of locate; missed: as locate's (z, dz are then
 * not written; 0 returned). Returns 1 when z, dz are written. */
BV_HOT_INLINE int evaluate(const bv_source *t, double p, double *z, double *dz, double *periods,
                           int *missed)
{
    int S = t->signals, i, c, on;
    double s, s2, s3, dp = t->dp;
    on = locate(t, p, &i, &s, periods, missed);
    if (missed != NULL && *missed)
        return 0;
    s2 = s * s;
    s3 = s * s * s;
    for (c = 0; c < S; c++) {
        double z0 = t->value[(size_t)i * S + c], z1 = t->value[(size_t)(i + 1) * S + c];
        double m0 = t->slope[(size_t)i * S + c] * dp, m1 = t->slope[(size_t)(i + 1) * S + c] * dp;
        /* the same expressions, in the same order, as HermiteTable.evaluate */
        z[c] = (2 * s3 - 3 * s2 + 1) * z0 + (s3 - 2 * s2 + s) * m0 + (3 * s2 - 2 * s3) * z1 +
               (s3 - s2) * m1;
        dz[c] = ((6 * s2 - 6 * s) * (z0 - z1) + (3 * s2 - 4 * s + 1) * m0 + (3 * s2 - 2 * s) * m1) /
                dp;
        if (!on)
            dz[c] = 0.0;
    }
    return 1;
}

void bv_source_evaluate(const bv_source *t, double p, double *z, double *dz)
{
    evaluate(t, p, z, dz, NULL, NULL);
}

void bv_source_curvature(const bv_source *t, double p, double *d2z, double *d3z)
{
    int S = t->signals, i, c, on;
    double s, dp = t->dp;
    on = locate(t, p, &i, &s, NULL, NULL);
    for (c = 0; c < S; c++) {
        double z0 = t->value[(size_t)i * S + c], z1 = t->value[(size_t)(i + 1) * S + c];
        double m0 = t->slope[(size_t)i * S + c] * dp, m1 = t->slope[(size_t)(i + 1) * S + c] * dp;
        d2z[c] = on ? ((12 * s - 6) * (z0 - z1) + (6 * s - 4) * m0 + (6 * s - 2) * m1) / (dp * dp)
                    : 0.0;
        d3z[c] = on ? (12 * (z0 - z1) + 6 * m0 + 6 * m1) / (dp * dp * dp) : 0.0;
    }
}

/* ---------------------------------------------------------------- instances */

bv_instance *bv_new(const bv_model *md, const char *name, bv_log_fn log, void *env)
{
    const bv_source *tb = HOT_TABLE;
    bv_instance *c;
    if (md != HOT || md->no != 2 * tb->signals || md->np != 1 || md->ni != 0 || md->n != 0 || tb->rows < 2 ||
        !(tb->dp > 0.0))
        return NULL; /* a generated model that does not fit its table: a build error */
    c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    c->z = calloc(4 * (size_t)tb->signals, sizeof *c->z);
    if (c->z == NULL) {
        free(c);
        return NULL;
    }
    c->dz = c->z + tb->signals;
    c->d2z = c->dz + tb->signals;
    c->d3z = c->d2z + tb->signals;
    c->tb = tb;
    bv_common_init(&c->bc, md, name, log, env);
    bv_reset(c);
    return c;
}

void bv_free(bv_instance *c)
{
    if (c == NULL)
        return;
    free(c->z);
    free(c);
}

void bv_reset(bv_instance *c)
{
    c->speed = c->bc.md->param_start[0];
    c->periods = 0.0;
    bv_common_clear(&c->bc);
}

static int speed_valid(double v) { return isfinite(v) && v > 0.0; }

bv_status bv_initialize(bv_instance *c)
{
    const bv_model *md = c->bc.md;
    bv_common_begin_initialize(&c->bc);
    if (!speed_valid(c->speed)) {
        char text[32];
        int pvr;
        for (pvr = 0; pvr < md->nvars && md->vr_kind[pvr] != BV_PARAMETER; pvr++)
            ;
        snprintf(c->bc.init_error, BV_MESSAGE,
                 "%s: parameter %s = %s %s is invalid: it must be a positive finite number (the "
                 "FMU's default is %g %s); the instance refuses to step (reset and set a valid "
                 "value)",
                 c->bc.name, md->vr_name[pvr], bv_shortest(c->speed, text), md->param_unit[0],
                 md->param_start[0], md->param_unit[0]);
        return bv_common_failed(&c->bc);
    }
    bv_common_initialized(&c->bc);
    return BV_OK;
}

#define check_vr(c, vr) bv_common_check_vr(&(c)->bc, (vr))

bv_status bv_set(bv_instance *c, const unsigned int vr[], size_t nvr, const double value[])
{
    bv_status status = BV_OK;
    size_t i;
    /* the time or an unknown value reference refuses the call: nothing set. One scan, which
     * stops at the first refusal (a host that passes more references than its arrays hold
     * is not read past the first unknown one) */
    for (i = 0; i < nvr; i++) {
        if (bv_common_is_time(&c->bc, vr[i]))
            return bv_common_time_not_settable(&c->bc);
        if (!check_vr(c, vr[i]))
            return BV_ERROR;
    }
    for (i = 0; i < nvr; i++) {
        if (bv_common_settable(&c->bc, vr[i]))
            c->speed = value[i]; /* the one parameter (no inputs) */
        else
            status = BV_ERROR;
    }
    return status;
}

/* Output idx of the interpolant evaluated into c->z, c->dz: 2 k the profile z_k, 2 k + 1 its
 * rate speed * dz_k/dp. */
BV_HOT_INLINE double output_value(const bv_instance *c, int idx)
{
    unsigned int k = (unsigned int)idx; /* >= 0: halves and parity as shifts */
    return k & 1u ? c->speed * c->dz[k >> 1] : c->z[k >> 1];
}

/* bv_get of a request that is not outputs only: the speed, the time (FMI 3.0), refusals
 * (logged). */
static BV_COLD bv_status get_general(bv_instance *c, const unsigned int vr[], size_t nvr,
                                     double value[])
{
    const bv_model *md = HOT;
    size_t i;
    int evaluated = 0;
    for (i = 0; i < nvr; i++) {
        if (bv_common_is_time(&c->bc, vr[i])) {
            value[i] = c->bc.time;
            continue;
        }
        if (vr[i] >= (unsigned int)md->nvars && !check_vr(c, vr[i])) /* logs the refusal */
            return BV_ERROR;
        if (md->vr_kind[vr[i]] == BV_PARAMETER) {
            value[i] = c->speed;
            continue;
        }
        if (!evaluated) {
            evaluate(HOT_TABLE, c->speed * c->bc.time, c->z, c->dz, &c->periods, NULL);
            evaluated = 1;
        }
        value[i] = output_value(c, md->vr_index[vr[i]]);
    }
    return BV_OK;
}

bv_status bv_get(bv_instance *c, const unsigned int vr[], size_t nvr, double value[])
{
    const bv_model *md = HOT;
    size_t i;
    int evaluated = 0;
    int missed = 0;
    /* the call of every step: outputs only, from one evaluation of the interpolant with the
     * last read's whole periods (any other request, and a read in another period, is read
     * again from its start by get_general) */
    for (i = 0; i < nvr; i++) {
        if (BV_UNLIKELY(vr[i] >= (unsigned int)md->nvars || md->vr_kind[vr[i]] != BV_OUTPUT))
            return get_general(c, vr, nvr, value);
        if (!evaluated) {
            evaluate(HOT_TABLE, c->speed * c->bc.time, c->z, c->dz, &c->periods, &missed);
            if (BV_UNLIKELY(missed))
                return get_general(c, vr, nvr, value);
            evaluated = 1;
        }
        value[i] = output_value(c, md->vr_index[vr[i]]);
    }
    return BV_OK;
}

/* A step refused by its checks (logged: bv_common_step_check). */
static BV_COLD bv_status step_checked(bv_instance *c, double t, double h)
{
    if (bv_common_step_check(&c->bc, t, h) != BV_OK)
        return BV_ERROR;
    c->bc.time = t + h;
    return BV_OK;
}

bv_status bv_step(bv_instance *c, double t, double h)
{
    /* bv_common_step_check's tests inline; its messages when one fails */
    if (BV_UNLIKELY(!(h > 0.0 && h < INFINITY && c->bc.initialized &&
                      bv_common_on_time(&c->bc, t))))
        return step_checked(c, t, h);
    c->bc.time = t + h;
    return BV_OK;
}

/* ---------------------------------------------------------------- interpolation interface */

/* No inputs: every value reference is refused (nothing is set). */
bv_status bv_set_input_derivatives(bv_instance *c, const unsigned int vr[], size_t nvr,
                                   const int order[], const double value[])
{
    (void)order, (void)value;
    if (nvr == 0)
        return BV_OK;
    if (!check_vr(c, vr[0]))
        return BV_ERROR;
    say(c, BV_ERROR, "%s: %s is not an input; input derivatives are for inputs only (this FMU "
                     "has none); call refused",
        c->bc.name, c->bc.md->vr_name[vr[0]]);
    return BV_ERROR;
}

/* Order k of an output is its k-th time derivative at p = speed t: the displacement's
 * orders 1, 2 are speed z'(p) (the rate output) and speed^2 z''(p), the rate's speed^2 z''(p)
 * and speed^3 z'''(p), z the cubic Hermite interpolant. It is continuously differentiable;
 * its second and third derivatives are those of the cubic of the segment p lies in (at a
 * table row, the next segment's: they may jump there). Off a non-periodic table the outputs
 * are held: every derivative is 0. */
bv_status bv_get_output_derivatives(bv_instance *c, const unsigned int vr[], size_t nvr,
                                    const int order[], double value[])
{
    const bv_model *md = c->bc.md;
    double v = c->speed, p = c->speed * c->bc.time;
    size_t i;
    if (bv_common_check_output_orders(&c->bc, vr, nvr, order) != BV_OK)
        return BV_ERROR;
    if (nvr == 0)
        return BV_OK;
    bv_source_evaluate(c->tb, p, c->z, c->dz);
    bv_source_curvature(c->tb, p, c->d2z, c->d3z);
    for (i = 0; i < nvr; i++) {
        int idx = md->vr_index[vr[i]], k = idx / 2, total = order[i] + idx % 2;
        if (total == 1)
            value[i] = v * c->dz[k];
        else if (total == 2)
            value[i] = v * v * c->d2z[k];
        else
            value[i] = v * v * v * c->d3z[k];
    }
    return BV_OK;
}

/* ---------------------------------------------------------------- model exchange */

/* No continuous states (n = 0): the host sets the time and reads the outputs there. */
void bv_me_set_states(bv_instance *c, const double x[]) { (void)c, (void)x; }

void bv_me_get_states(const bv_instance *c, double x[]) { (void)c, (void)x; }

void bv_me_derivatives(bv_instance *c, double dx[]) { (void)c, (void)dx; }

void bv_me_event_indicators(bv_instance *c, double z[]) { (void)c, (void)z; }

int bv_me_update_regime(bv_instance *c) { (void)c; return 0; }

/* No states and no inputs: no knowns to differentiate by (the model description says
 * providesDirectionalDerivative="false"). */
bv_status bv_directional(bv_instance *c, const unsigned int unknowns[], size_t nu,
                         const unsigned int knowns[], size_t nk, const double seed[],
                         double sensitivity[])
{
    (void)unknowns, (void)nu, (void)knowns, (void)nk, (void)seed, (void)sensitivity;
    say(c, BV_ERROR, "%s: directional derivatives: this FMU has no continuous states and no "
                     "inputs, so it provides none (providesDirectionalDerivative is false); "
                     "call refused", c->bc.name);
    return BV_ERROR;
}

/* ---------------------------------------------------------------- snapshots */

/* the head (bodyvib_fsm.h), then doubles time, speed, initialized, init_failed, then the
 * checksum */
static const unsigned char MAGIC[8] = {'B', 'V', 'S', 'O', 'U', 'R', 'C', '1'};
#define STATE_SIZE (BV_SNAPSHOT_HEAD + 4 * 8 + 8)

size_t bv_state_size(const bv_instance *c)
{
    (void)c;
    return STATE_SIZE;
}

void bv_state_write(const bv_instance *c, unsigned char *buf)
{
    double v[4];
    v[0] = c->bc.time;
    v[1] = c->speed;
    v[2] = c->bc.initialized;
    v[3] = c->bc.init_failed;
    memcpy(bv_common_snapshot_head(&c->bc, buf, MAGIC, STATE_SIZE), v, sizeof v);
    bv_common_snapshot_seal(buf, STATE_SIZE);
}

bv_status bv_state_check(const bv_instance *c, const unsigned char *buf, size_t size)
{
    double v[4];
    if (bv_common_snapshot_check(&c->bc, buf, size, MAGIC, STATE_SIZE) != BV_OK)
        return BV_ERROR;
    memcpy(v, buf + BV_SNAPSHOT_HEAD, sizeof v);
    if (!(isfinite(v[0]) && (v[2] == 0.0 || v[2] == 1.0) && (v[3] == 0.0 || v[3] == 1.0) &&
          (v[2] == 0.0 || speed_valid(v[1])))) {
        say(c, BV_ERROR, "%s: the FMU state is invalid (time, speed or flags); refused", c->bc.name);
        return BV_ERROR;
    }
    return BV_OK;
}

bv_status bv_state_read(bv_instance *c, const unsigned char *buf, size_t size)
{
    double v[4];
    if (bv_state_check(c, buf, size) != BV_OK)
        return BV_ERROR;
    memcpy(v, buf + BV_SNAPSHOT_HEAD, sizeof v);
    c->speed = v[1];
    /* the state machine follows the snapshot */
    bv_common_restored(&c->bc, v[0], v[2] != 0.0, v[3] != 0.0, "a valid value");
    return BV_OK;
}
