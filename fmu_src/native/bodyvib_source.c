/*
 * bodyvib native source core (see bodyvib_source.h): the bv_* API of bodyvib_core.h for a
 * tabulated profile, the C twin of bodyvib.runtime.source.SourceCore.
 *
 * Per instance: the speed parameter, the time, whether it is initialized. Outputs are
 * computed on read at p = speed * time. DoStep(t, h) sets the time to t + h (outputs read
 * after it are those of the step's end), as the pythonfmu source FMU does.
 */
#include "bodyvib_source.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BV_MESSAGE 640

struct bv_instance {
    const bv_model *md;
    const bv_source *tb;
    char name[128];
    bv_log_fn log;
    void *env;
    double speed;
    double time;
    int initialized;
    int init_failed;
    char init_error[BV_MESSAGE];
    double *z, *dz; /* [signals] scratch */
};

static void say(const bv_instance *c, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

static void say(const bv_instance *c, int status, const char *fmt, ...)
{
    char text[BV_MESSAGE];
    va_list ap;
    if (c->log == NULL)
        return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    c->log(c->env, status, text);
}

/* The shortest %g text that reads back as v (as Python's repr), into buf[32]. */
static const char *shortest(double v, char *buf)
{
    int p;
    for (p = 1; p <= 17; p++) {
        snprintf(buf, 32, "%.*g", p, v);
        if (strtod(buf, NULL) == v)
            break;
    }
    return buf;
}

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

void bv_source_evaluate(const bv_source *t, double p, double *z, double *dz)
{
    int k = t->rows - 1, S = t->signals, i, c;
    double u = (p - t->p0) / t->dp, uc, s, s2, s3, dp = t->dp;
    int inside;
    if (t->periodic)
        u = py_mod(u, (double)k);
    inside = u >= 0.0 && u <= (double)k;
    uc = u < 0.0 ? 0.0 : (u > (double)k ? (double)k : u);
    if (isnan(u))
        uc = u;
    i = isnan(uc) ? 0 : (int)floor(uc);
    if (i > k - 1)
        i = k - 1;
    s = uc - i;
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
        if (!t->periodic && !inside)
            dz[c] = 0.0;
    }
}

bv_instance *bv_new(const bv_model *md, const char *name, bv_log_fn log, void *env)
{
    const bv_source *tb = &bv_source_data;
    bv_instance *c;
    if (md->no != 2 * tb->signals || md->np != 1 || md->ni != 0 || tb->rows < 2 ||
        !(tb->dp > 0.0))
        return NULL; /* a generated model that does not fit its table: a build error */
    c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    c->z = calloc(2 * (size_t)tb->signals, sizeof *c->z);
    if (c->z == NULL) {
        free(c);
        return NULL;
    }
    c->dz = c->z + tb->signals;
    c->md = md;
    c->tb = tb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : md->model_name);
    c->log = log;
    c->env = env;
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
    c->speed = c->md->param_start[0];
    c->time = 0.0;
    c->initialized = 0;
    c->init_failed = 0;
    c->init_error[0] = '\0';
}

double bv_time(const bv_instance *c) { return c->time; }

static int speed_valid(double v) { return isfinite(v) && v > 0.0; }

bv_status bv_initialize(bv_instance *c)
{
    const bv_model *md = c->md;
    c->initialized = 0;
    if (!speed_valid(c->speed)) {
        char text[32];
        int pvr;
        for (pvr = 0; pvr < md->nvars && md->vr_kind[pvr] != BV_PARAMETER; pvr++)
            ;
        snprintf(c->init_error, BV_MESSAGE,
                 "%s: parameter %s = %s %s is invalid: it must be a positive finite number (the "
                 "FMU's default is %g %s); the instance refuses to step (reset and set a valid "
                 "value)",
                 c->name, md->vr_name[pvr], shortest(c->speed, text), md->param_unit[0],
                 md->param_start[0], md->param_unit[0]);
        c->init_failed = 1;
        say(c, BV_ERROR, "%s", c->init_error);
        return BV_ERROR;
    }
    c->init_failed = 0;
    c->init_error[0] = '\0';
    c->initialized = 1;
    return BV_OK;
}

static int check_vr(const bv_instance *c, unsigned int vr)
{
    if (vr >= (unsigned int)c->md->nvars) {
        say(c, BV_ERROR, "%s: no variable with value reference %u", c->name, vr);
        return 0;
    }
    return 1;
}

bv_status bv_set(bv_instance *c, const unsigned int vr[], size_t nvr, const double value[])
{
    const bv_model *md = c->md;
    bv_status status = BV_OK;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (!check_vr(c, vr[i]))
            return BV_ERROR;
        if (md->vr_kind[vr[i]] == BV_PARAMETER) {
            if (c->initialized) {
                say(c, BV_ERROR, "%s: parameter %s is fixed after initialization; set it "
                                 "before ExitInitializationMode (ignored)",
                    c->name, md->vr_name[vr[i]]);
                status = BV_ERROR;
            } else {
                c->speed = value[i];
            }
        } else {
            say(c, BV_ERROR, "%s: %s is an output and cannot be set (ignored)", c->name,
                md->vr_name[vr[i]]);
            status = BV_ERROR;
        }
    }
    return status;
}

bv_status bv_get(bv_instance *c, const unsigned int vr[], size_t nvr, double value[])
{
    const bv_model *md = c->md;
    size_t i;
    int evaluated = 0;
    for (i = 0; i < nvr; i++) {
        int idx;
        if (!check_vr(c, vr[i]))
            return BV_ERROR;
        idx = md->vr_index[vr[i]];
        if (md->vr_kind[vr[i]] == BV_PARAMETER) {
            value[i] = c->speed;
            continue;
        }
        if (!evaluated) {
            bv_source_evaluate(c->tb, c->speed * c->time, c->z, c->dz);
            evaluated = 1;
        }
        value[i] = idx % 2 == 0 ? c->z[idx / 2] : c->speed * c->dz[idx / 2];
    }
    return BV_OK;
}

bv_status bv_step(bv_instance *c, double t, double h)
{
    if (!(h > 0.0 && h < INFINITY)) {
        char text[32];
        say(c, BV_ERROR, "%s: communication step size must be positive and finite, got %s s",
            c->name, shortest(h, text));
        return BV_ERROR;
    }
    if (!c->initialized) {
        if (c->init_failed)
            say(c, BV_ERROR, "%s", c->init_error);
        else
            say(c, BV_ERROR, "%s: DoStep before initialization; call ExitInitializationMode "
                             "first", c->name);
        return BV_ERROR;
    }
    c->time = t + h;
    return BV_OK;
}

/* ---------------------------------------------------------------- snapshots */

/* magic, size, token hash, then doubles time, speed, initialized, init_failed, checksum */
static const unsigned char MAGIC[8] = {'B', 'V', 'S', 'O', 'U', 'R', 'C', '1'};
#define STATE_SIZE (24 + 4 * 8 + 8)

static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 1469598103934665603ULL;
    size_t i;
    for (i = 0; i < n; i++) {
        h ^= p[i];
        h *= 1099511628211ULL;
    }
    return h;
}

static uint64_t token_hash(const bv_instance *c)
{
    return fnv1a((const unsigned char *)c->md->token, strlen(c->md->token));
}

size_t bv_state_size(const bv_instance *c) { return STATE_SIZE; }

void bv_state_write(const bv_instance *c, unsigned char *buf)
{
    uint64_t size = STATE_SIZE, token = token_hash(c), sum;
    double v[4];
    v[0] = c->time;
    v[1] = c->speed;
    v[2] = c->initialized;
    v[3] = c->init_failed;
    memcpy(buf, MAGIC, 8);
    memcpy(buf + 8, &size, 8);
    memcpy(buf + 16, &token, 8);
    memcpy(buf + 24, v, sizeof v);
    sum = fnv1a(buf, STATE_SIZE - 8);
    memcpy(buf + STATE_SIZE - 8, &sum, 8);
}

bv_status bv_state_check(const bv_instance *c, const unsigned char *buf, size_t size)
{
    uint64_t got, token, sum;
    double v[4];
    if (buf == NULL || size < 24 || memcmp(buf, MAGIC, 8) != 0) {
        say(c, BV_ERROR, "%s: not a bodyvib FMU state (bad magic)", c->name);
        return BV_ERROR;
    }
    memcpy(&got, buf + 8, 8);
    memcpy(&token, buf + 16, 8);
    if (got != STATE_SIZE || size != STATE_SIZE || token != token_hash(c)) {
        say(c, BV_ERROR, "%s: the FMU state belongs to another model or version (size %llu, "
                         "expected %llu); refused", c->name, (unsigned long long)size,
            (unsigned long long)STATE_SIZE);
        return BV_ERROR;
    }
    memcpy(&sum, buf + STATE_SIZE - 8, 8);
    if (sum != fnv1a(buf, STATE_SIZE - 8)) {
        say(c, BV_ERROR, "%s: the FMU state is corrupt (checksum mismatch); refused", c->name);
        return BV_ERROR;
    }
    memcpy(v, buf + 24, sizeof v);
    if (!(isfinite(v[0]) && (v[2] == 0.0 || v[2] == 1.0) && (v[3] == 0.0 || v[3] == 1.0) &&
          (v[2] == 0.0 || speed_valid(v[1])))) {
        say(c, BV_ERROR, "%s: the FMU state is invalid (time, speed or flags); refused", c->name);
        return BV_ERROR;
    }
    return BV_OK;
}

bv_status bv_state_read(bv_instance *c, const unsigned char *buf, size_t size)
{
    double v[4];
    if (bv_state_check(c, buf, size) != BV_OK)
        return BV_ERROR;
    memcpy(v, buf + 24, sizeof v);
    c->time = v[0];
    c->speed = v[1];
    c->initialized = v[2] != 0.0;
    c->init_failed = v[3] != 0.0;
    if (c->init_failed)
        snprintf(c->init_error, BV_MESSAGE, "%s: the restored state was not initialized "
                 "successfully; reset and set a valid value", c->name);
    return BV_OK;
}
