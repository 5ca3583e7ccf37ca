/*
 * bodyvib native FMUs: the FMI calls, once for both versions (see bodyvib_calls.h).
 * Compiled into every native FMU, linear or source, FMI 2.0 or 3.0.
 */
#include "bodyvib_calls.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

bv_fmu *bv_fmu_new(const char *name, int me, bv_host_fn logger, void *env, bv_log_fn log)
{
    bv_fmu *f = malloc(sizeof *f);
    if (f == NULL)
        return NULL;
    *f = (bv_fmu){.logger = logger, .env = env, .me = me, .categories = BV_LOG_ALL, .log = log};
    if (name != NULL && (f->name = malloc(strlen(name) + 1)) != NULL)
        strcpy(f->name, name);
    if (name == NULL || f->name != NULL)
        f->core = bv_new(&bv_model_data, name, log, f);
    if (f->core != NULL) {
        if (me)
            bv_set_model_exchange(f->core);
        return f;
    }
    bv_fmu_free(f); /* out of memory, or the model cannot be assembled (logged) */
    return NULL;
}

void bv_fmu_free(bv_fmu *f)
{
    if (f != NULL) {
        bv_free(f->core);
        free(f->name);
    }
    free(f);
}

void bv_fmu_say(bv_fmu *f, int status, const char *fmt, ...)
{
    char text[640];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    f->log(f, status, text);
}

/* The category names, indexed by bit (BV_LOG_WARNING, BV_LOG_ERROR). */
static const char *const CATEGORY[] = {"logStatusWarning", "logStatusError"};

static int category_bit(const char *name)
{
    size_t k;
    for (k = 0; name != NULL && k < sizeof CATEGORY / sizeof CATEGORY[0]; k++)
        if (strcmp(name, CATEGORY[k]) == 0)
            return 1 << k;
    return 0;
}

bv_status bv_fmu_set_logging(bv_fmu *f, const char *function, int on, size_t n,
                             const char *const categories[])
{
    int bits = n == 0 ? BV_LOG_ALL : 0;
    size_t i;
    if (!bv_fmu_arg(f, function, "categories", categories, n))
        return BV_ERROR;
    for (i = 0; i < n; i++) {
        int bit = category_bit(categories[i]);
        if (bit == 0) {
            bv_fmu_say(f, BV_ERROR, "%s: unknown log category %s%s%s (this FMU has %s and %s); "
                                    "call refused, nothing changed", function,
                       categories[i] ? "'" : "", categories[i] ? categories[i] : "NULL",
                       categories[i] ? "'" : "", CATEGORY[0], CATEGORY[1]);
            return BV_ERROR;
        }
        bits |= bit;
    }
    f->categories = on ? f->categories | bits : f->categories & ~bits;
    return BV_OK;
}

int bv_fmu_logs(const bv_fmu *f, int status)
{
    /* the category the wrappers label the message with: errors, else warnings */
    return (f->categories & (status == BV_ERROR ? BV_LOG_ERROR : BV_LOG_WARNING)) != 0;
}

void bv_fmu_null_arg(bv_fmu *f, const char *function, const char *name)
{
    bv_fmu_say(f, BV_ERROR, "%s: %s is NULL; call refused, nothing changed", function, name);
}

int bv_fmu_finite(bv_fmu *f, const char *function, const char *name, const double v[],
                  size_t n)
{
    size_t i;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i])) { /* %g of a non-finite value: nan, inf or -inf */
            if (n == 1)
                bv_fmu_say(f, BV_ERROR, "%s: %s must be finite, got %g; call refused, nothing "
                                        "changed", function, name, v[i]);
            else
                bv_fmu_say(f, BV_ERROR, "%s: %s[%lu] must be finite, got %g; call refused, "
                                        "nothing changed", function, name, (unsigned long)i,
                           v[i]);
            return 0;
        }
    return 1;
}

bv_status bv_fmu_unsupported(bv_fmu *f, const char *function, const char *why)
{
    bv_fmu_say(f, BV_ERROR, "%s: %s; call refused, nothing changed", function, why);
    return BV_ERROR;
}

int bv_fmu_wrong_interface(bv_fmu *f, const char *function)
{
    if (f->me)
        bv_fmu_say(f, BV_ERROR, "%s: the instance was instantiated for model exchange", function);
    else
        bv_fmu_say(f, BV_ERROR, "%s: a model-exchange function called on a co-simulation "
                                "instance", function);
    return 0;
}

/* The arrays a call with n entries reads or writes: all there unless n is 0. */
static int arrays(size_t n, const void *a, const void *b, const void *c)
{
    return n == 0 || (a != NULL && b != NULL && c != NULL);
}

bv_status bv_fmu_get(bv_fmu *f, const unsigned int vr[], size_t nvr, double value[])
{
    return arrays(nvr, vr, value, value) ? bv_get(f->core, vr, nvr, value) : BV_ERROR;
}

bv_status bv_fmu_set(bv_fmu *f, const unsigned int vr[], size_t nvr, const double value[])
{
    return arrays(nvr, vr, value, value) ? bv_set(f->core, vr, nvr, value) : BV_ERROR;
}

bv_status bv_fmu_set_input_derivatives(bv_fmu *f, const unsigned int vr[], size_t nvr,
                                       const int order[], const double value[])
{
    if (!arrays(nvr, vr, order, value))
        return BV_ERROR;
    return bv_set_input_derivatives(f->core, vr, nvr, order, value);
}

bv_status bv_fmu_get_output_derivatives(bv_fmu *f, const unsigned int vr[], size_t nvr,
                                        const int order[], double value[])
{
    if (!arrays(nvr, vr, order, value))
        return BV_ERROR;
    return bv_get_output_derivatives(f->core, vr, nvr, order, value);
}

/* ---------------------------------------------------------------- FMU states */

/* The host's handle of an FMU state: the snapshot and its size. */
typedef struct {
    size_t size;
    unsigned char bytes[1];
} bv_snapshot;

static bv_snapshot *snapshot_new(size_t size)
{
    bv_snapshot *s = malloc(sizeof *s + size);
    if (s != NULL)
        s->size = size;
    return s;
}

bv_status bv_fmu_get_state(bv_fmu *f, const char *function, void **state)
{
    size_t size;
    bv_snapshot *s;
    if (!bv_fmu_arg(f, function, "FMUstate", state, 1))
        return BV_ERROR;
    size = bv_state_size(f->core);
    s = *state;
    if (s == NULL || s->size != size) {
        s = snapshot_new(size);
        if (s == NULL)
            return bv_fmu_unsupported(f, function, "out of memory");
        free(*state);
    }
    bv_state_write(f->core, s->bytes);
    *state = s;
    return BV_OK;
}

bv_status bv_fmu_set_state(bv_fmu *f, const char *function, void *state)
{
    bv_snapshot *s = state;
    if (!bv_fmu_arg(f, function, "FMUstate", state, 1))
        return BV_ERROR;
    return bv_state_read(f->core, s->bytes, s->size);
}

bv_status bv_fmu_free_state(void **state)
{
    if (state != NULL) {
        free(*state);
        *state = NULL;
    }
    return BV_OK;
}

bv_status bv_fmu_state_size(bv_fmu *f, const char *function, void *state, size_t *size)
{
    bv_snapshot *s = state;
    if (!bv_fmu_arg(f, function, "FMUstate", state, 1) || !bv_fmu_arg(f, function, "size", size, 1))
        return BV_ERROR;
    *size = s->size;
    return BV_OK;
}

bv_status bv_fmu_serialize(bv_fmu *f, const char *function, void *state,
                           unsigned char serialized[], size_t size)
{
    bv_snapshot *s = state;
    if (!bv_fmu_arg(f, function, "FMUstate", state, 1) ||
        !bv_fmu_arg(f, function, "serializedState", serialized, 1))
        return BV_ERROR;
    if (size < s->size) {
        bv_fmu_say(f, BV_ERROR, "%s: the buffer holds %lu bytes, the state needs %lu (its "
                                "SerializedFMUstateSize); call refused", function,
                   (unsigned long)size, (unsigned long)s->size);
        return BV_ERROR;
    }
    memcpy(serialized, s->bytes, s->size);
    return BV_OK;
}

bv_status bv_fmu_deserialize(bv_fmu *f, const char *function, const unsigned char serialized[],
                             size_t size, void **state)
{
    bv_snapshot *s;
    if (!bv_fmu_arg(f, function, "FMUstate", state, 1) ||
        !bv_fmu_arg(f, function, "serializedState", serialized, 1) ||
        bv_state_check(f->core, serialized, size) != BV_OK)
        return BV_ERROR;
    s = snapshot_new(size);
    if (s == NULL)
        return bv_fmu_unsupported(f, function, "out of memory");
    memcpy(s->bytes, serialized, size);
    *state = s; /* a new state: the host frees it (and any earlier one) with FreeFMUstate */
    return BV_OK;
}

/* ---------------------------------------------------------------- derivatives */

bv_status bv_fmu_directional(bv_fmu *f, const unsigned int unknowns[], size_t nu,
                             const unsigned int knowns[], size_t nk, const double seed[],
                             double sensitivity[])
{
    if (!arrays(nu, unknowns, sensitivity, sensitivity) || !arrays(nk, knowns, seed, seed))
        return BV_ERROR;
    return bv_directional(f->core, unknowns, nu, knowns, nk, seed, sensitivity);
}

/* ---------------------------------------------------------------- model exchange */

bv_status bv_fmu_vector(bv_fmu *f, const char *function, bv_vector which, const double in[],
                        double out[], size_t nx)
{
    int n = bv_me_nstates(f->core), i;
    if (!bv_fmu_arg(f, function, "x", which == BV_SET_STATES ? (const void *)in : out, nx))
        return BV_ERROR;
    if (nx != (size_t)n) {
        bv_fmu_say(f, BV_ERROR, "%s: %s: %lu continuous states passed, the model has %d",
                   bv_name(f->core), function, (unsigned long)nx, n);
        return BV_ERROR;
    }
    switch (which) {
    case BV_SET_STATES:
        if (!bv_fmu_finite(f, function, "x", in, nx))
            return BV_ERROR;
        bv_me_set_states(f->core, in);
        break;
    case BV_GET_STATES:
        bv_me_get_states(f->core, out);
        break;
    case BV_DERIVATIVES:
        bv_me_derivatives(f->core, out);
        break;
    default: /* SI units; displacements are mm, velocities m/s: no better scale than 1 */
        for (i = 0; i < n; i++)
            out[i] = 1.0;
    }
    return BV_OK;
}

bv_status bv_fmu_event_indicators(bv_fmu *f, const char *function, double z[], size_t ni)
{
    size_t n = (size_t)bv_me_nevents(f->core);
    if (ni != n) {
        bv_fmu_say(f, BV_ERROR, "%s: the model has %u event indicators, not %u", function,
                   (unsigned)n, (unsigned)ni);
        return BV_ERROR;
    }
    if (n)
        bv_me_event_indicators(f->core, z);
    return BV_OK;
}
