/*
 * bodyvib native FMUs: the FMI state machine and messages both cores share (see
 * bodyvib_fsm.h). Compiled into every native FMU, linear or source.
 */
#include "bodyvib_fsm.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void bv_say(const bv_common *b, int status, const char *fmt, ...)
{
    char text[BV_MESSAGE];
    va_list ap;
    if (b->log == NULL)
        return;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    b->log(b->env, status, text);
}

const char *bv_shortest(double v, char *buf)
{
    int p;
    for (p = 1; p <= 17; p++) {
        snprintf(buf, 32, "%.*g", p, v);
        if (strtod(buf, NULL) == v)
            break;
    }
    return buf;
}

void bv_common_init(bv_common *b, const bv_model *md, const char *name, bv_log_fn log,
                    void *env)
{
    b->md = md;
    b->me = 0;
    b->time_vr = -1;
    snprintf(b->name, sizeof b->name, "%s", name ? name : md->model_name);
    b->log = log;
    b->env = env;
    bv_common_clear(b);
}

void bv_common_clear(bv_common *b)
{
    b->mode = BV_INSTANTIATED;
    b->time = 0.0;
    b->start_time = 0.0;
    b->initialized = 0;
    b->init_failed = 0;
    b->init_error[0] = '\0';
}

double bv_time(const bv_instance *c) { return BV_COMMON(c)->time; }

const char *bv_name(const bv_instance *c) { return BV_COMMON(c)->name; }

/* The models are time-invariant: in model exchange the time only labels the state. */
void bv_me_set_time(bv_instance *c, double t) { BV_COMMON(c)->time = t; }

int bv_me_nstates(const bv_instance *c) { return BV_COMMON(c)->md->n; }

int bv_me_nevents(const bv_instance *c)
{
    const bv_model *md = BV_COMMON(c)->md;
    int e, k = 0;
    for (e = 0; e < md->ne; e++)
        k += md->nl[e].kind == BV_NL_STOP ? 2 : 1;
    return k;
}

static const char *mode_name(const bv_common *b, int mode)
{
    switch (mode) {
    case BV_INSTANTIATED: return "Instantiated";
    case BV_INITIALIZATION: return "InitializationMode";
    case BV_EVENT: return "EventMode";
    case BV_STEPPING: return b->me ? "ContinuousTimeMode" : "StepMode (stepComplete)";
    case BV_TERMINATED: return "Terminated";
    default: return "Error (initialization failed)";
    }
}

/* The states in the order a message lists them. */
static const int MODES[] = {BV_INSTANTIATED, BV_INITIALIZATION, BV_EVENT, BV_STEPPING,
                            BV_TERMINATED, BV_FAILED};

void bv_set_model_exchange(bv_instance *c) { BV_COMMON(c)->me = 1; }

void bv_set_time_variable(bv_instance *c, unsigned int vr) { BV_COMMON(c)->time_vr = vr; }

bv_status bv_common_time_not_settable(const bv_common *b)
{
    bv_say(b, BV_ERROR, "time is the independent variable and cannot be set");
    return BV_ERROR;
}

void bv_me_enter(bv_instance *c, int mode) { BV_COMMON(c)->mode = mode; }

int bv_allowed(bv_instance *c, const char *function, int mask)
{
    bv_common *b = BV_COMMON(c);
    char text[200];
    size_t l = 0;
    size_t k;
    if (b->mode & mask)
        return 1;
    text[0] = '\0';
    for (k = 0; k < sizeof MODES / sizeof MODES[0]; k++)
        if (mask & MODES[k] && (b->me || MODES[k] != BV_EVENT)) /* no Event Mode in CS */
            l += (size_t)snprintf(text + l, sizeof text - l, "%s%s", l ? ", " : "",
                                  mode_name(b, MODES[k]));
    if (l == 0)
        snprintf(text, sizeof text, "none: this FMU never needs it");
    if (b->mode == BV_FAILED && b->init_failed && b->init_error[0])
        bv_say(b, BV_ERROR, "%s", b->init_error);
    bv_say(b, BV_ERROR, "%s: %s is not allowed in state %s (allowed in: %s); call refused, "
                        "nothing changed", b->name, function, mode_name(b, b->mode), text);
    return 0;
}

bv_status bv_setup(bv_instance *c, double start_time)
{
    bv_common *b = BV_COMMON(c);
    char text[32];
    if (!isfinite(start_time)) {
        bv_say(b, BV_ERROR, "%s: the start time must be finite, got %s s", b->name,
               bv_shortest(start_time, text));
        return BV_ERROR;
    }
    b->start_time = start_time;
    b->time = start_time;
    return BV_OK;
}

void bv_enter_initialization(bv_instance *c) { BV_COMMON(c)->mode = BV_INITIALIZATION; }

void bv_terminate(bv_instance *c) { BV_COMMON(c)->mode = BV_TERMINATED; }

void bv_common_begin_initialize(bv_common *b)
{
    b->initialized = 0;
    b->time = b->start_time;
    b->mode = BV_FAILED; /* until the core's checks pass */
}

bv_status bv_common_failed(bv_common *b)
{
    b->initialized = 0;
    b->init_failed = 1;
    b->mode = BV_FAILED;
    bv_say(b, BV_ERROR, "%s", b->init_error);
    return BV_ERROR;
}

void bv_common_initialized(bv_common *b)
{
    b->init_failed = 0;
    b->init_error[0] = '\0';
    b->initialized = 1;
    b->mode = b->me ? BV_EVENT : BV_STEPPING;
}

bv_status bv_common_step_check(bv_common *b, double t, double h)
{
    char text[32], text2[32];
    if (!(h > 0.0 && h < INFINITY)) {
        bv_say(b, BV_ERROR, "%s: communication step size must be positive and finite, got %s s",
               b->name, bv_shortest(h, text));
        return BV_ERROR;
    }
    if (!b->initialized) {
        if (b->init_failed)
            bv_say(b, BV_ERROR, "%s", b->init_error);
        else
            bv_say(b, BV_ERROR, "%s: DoStep before initialization; call "
                                "ExitInitializationMode first", b->name);
        return BV_ERROR;
    }
    if (!bv_common_on_time(b, t)) {
        bv_say(b, BV_ERROR, "%s: DoStep from t = %s s, but the model is at t = %s s (the start "
                            "time or the end of the last step); step refused, state unchanged",
               b->name, bv_shortest(t, text), bv_shortest(b->time, text2));
        return BV_ERROR;
    }
    return BV_OK;
}

void bv_common_restored(bv_common *b, double time, int initialized, int init_failed,
                        const char *fix)
{
    b->time = time;
    b->initialized = initialized;
    b->init_failed = init_failed;
    if (initialized) { /* model exchange: in the mode it is in, else Event Mode */
        if (b->mode != BV_STEPPING && b->mode != BV_EVENT)
            b->mode = b->me ? BV_EVENT : BV_STEPPING;
    }
    else if (init_failed)
        b->mode = BV_FAILED;
    else if (b->mode != BV_INITIALIZATION)
        b->mode = BV_INSTANTIATED;
    if (init_failed)
        snprintf(b->init_error, BV_MESSAGE, "%s: the restored state was not initialized "
                 "successfully; reset and set %s", b->name, fix);
}

bv_status bv_common_not_finite(const bv_common *b, unsigned int vr, double value)
{
    bv_say(b, BV_ERROR, "%s: %s = %g is not finite; call refused, nothing changed (set a "
                        "finite value)", b->name, b->md->vr_name[vr], value);
    return BV_ERROR;
}

int bv_common_check_vr(const bv_common *b, unsigned int vr)
{
    if (vr >= (unsigned int)b->md->nvars) {
        bv_say(b, BV_ERROR, "%s: no variable with value reference %u", b->name, vr);
        return 0;
    }
    return 1;
}

int bv_common_settable(const bv_common *b, unsigned int vr)
{
    int kind = b->md->vr_kind[vr];
    if (kind == BV_INPUT)
        return 1;
    if (kind != BV_PARAMETER)
        bv_say(b, BV_ERROR, "%s: %s is an output and cannot be set (ignored)", b->name,
               b->md->vr_name[vr]);
    else if (b->initialized)
        bv_say(b, BV_ERROR, "%s: parameter %s is fixed after initialization; set it before "
                            "ExitInitializationMode (ignored)", b->name, b->md->vr_name[vr]);
    else
        return 1;
    return 0;
}

bv_status bv_common_check_output_orders(const bv_common *b, const unsigned int vr[],
                                        size_t nvr, const int order[])
{
    const bv_model *md = b->md;
    size_t i;
    for (i = 0; i < nvr; i++) {
        if (!bv_common_check_vr(b, vr[i]))
            return BV_ERROR;
        if (md->vr_kind[vr[i]] != BV_OUTPUT) {
            bv_say(b, BV_ERROR, "%s: %s is not an output; output derivatives are for outputs "
                                "only", b->name, md->vr_name[vr[i]]);
            return BV_ERROR;
        }
        if (order[i] < 1 || order[i] > BV_MAX_OUTPUT_ORDER) {
            bv_say(b, BV_ERROR, "%s: derivative order %d of %s: this FMU gives orders 1 to %d "
                                "(maxOutputDerivativeOrder)",
                   b->name, order[i], md->vr_name[vr[i]], BV_MAX_OUTPUT_ORDER);
            return BV_ERROR;
        }
    }
    return BV_OK;
}

/* ---------------------------------------------------------------- snapshots */

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

static uint64_t token_hash(const bv_common *b)
{
    return fnv1a((const unsigned char *)b->md->token, strlen(b->md->token));
}

unsigned char *bv_common_snapshot_head(const bv_common *b, unsigned char *buf,
                                       const unsigned char magic[8], uint64_t size)
{
    uint64_t token = token_hash(b);
    memcpy(buf, magic, 8);
    memcpy(buf + 8, &size, 8);
    memcpy(buf + 16, &token, 8);
    return buf + BV_SNAPSHOT_HEAD;
}

void bv_common_snapshot_seal(unsigned char *buf, size_t size)
{
    uint64_t sum = fnv1a(buf, size - 8);
    memcpy(buf + size - 8, &sum, 8);
}

bv_status bv_common_snapshot_check(const bv_common *b, const unsigned char *buf, size_t size,
                                   const unsigned char magic[8], uint64_t want)
{
    uint64_t got, token, sum;
    if (buf == NULL || size < BV_SNAPSHOT_HEAD || memcmp(buf, magic, 8) != 0) {
        bv_say(b, BV_ERROR, "%s: not a bodyvib FMU state (bad magic)", b->name);
        return BV_ERROR;
    }
    memcpy(&got, buf + 8, 8);
    memcpy(&token, buf + 16, 8);
    if (got != want || size != want || token != token_hash(b)) {
        bv_say(b, BV_ERROR, "%s: the FMU state belongs to another model or version (size %llu, "
                            "expected %llu); refused", b->name, (unsigned long long)size,
               (unsigned long long)want);
        return BV_ERROR;
    }
    memcpy(&sum, buf + want - 8, 8);
    if (sum != fnv1a(buf, (size_t)want - 8)) {
        bv_say(b, BV_ERROR, "%s: the FMU state is corrupt (checksum mismatch); refused", b->name);
        return BV_ERROR;
    }
    return BV_OK;
}
