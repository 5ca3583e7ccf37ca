/*
 * SkyhookController: an FMI 2.0 co-simulation FMU, the skyhook/groundhook law.
 *
 * For each of BV_ACTUATORS actuators i (a compile-time constant):
 *     force_i = -c_sky * vu_i + c_ground * vl_i                                 [N]
 *     force_rate_i = -c_sky * upper_acceleration_i + c_ground * lower_acceleration_i
 * positive pushing the actuator's points apart (the car files' sign convention), vu_i and
 * vl_i the velocities in force: those the host set last, carried over each communication
 * step along the acceleration inputs (vu_i <- vu_i + upper_acceleration_i * h at DoStep).
 * A host that sets the velocities of the previous communication point and reads after the
 * step (a Jacobi host) gets the force at the current point to second order; a host that
 * sets the current velocities before it reads (OMSimulator) gets the law of those values,
 * whatever it set before: outputs follow new inputs at once. With semi_active true a force
 * a passive damper cannot give, one with the sign of the relative velocity vu - vl, is set
 * to 0 (on-off law), and its rate too. The outputs are computed on read.
 *
 * The FMI state machine, its messages and the step's checks are those of every bodyvib
 * native FMU (bodyvib_fsm.c, the states of bodyvib_calls.h): a call out of order, a step
 * that is not from the model's time, a non-finite or non-positive step, a non-finite start
 * time or input, and a force or velocity that would not be finite are refused with
 * fmi2Error, one log line, and nothing changed.
 *
 * Value references (Real), N = BV_ACTUATORS: inputs 4i upper_velocity, 4i+1
 * lower_velocity, 4i+2 upper_acceleration, 4i+3 lower_acceleration; outputs 4N + i
 * actuator_force, 5N + i actuator_force_rate; parameters 6N c_sky, 6N+1 c_ground.
 * Boolean: 0 (semi_active). modelDescription.xml and the configuration header (the sizes,
 * the token, the variables' names and kinds, the start values) are written by
 * bodyvib.fmu.controller.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "bodyvib_calls.h" /* the states each FMI function is allowed in (BV_ON_*) */
#include "bodyvib_fsm.h"

/* BV_ACTUATORS, BV_TOKEN, BV_VR_KINDS, BV_VR_NAMES and the parameters' start values
   BV_C_SKY, BV_C_GROUND, BV_SEMI_ACTIVE: written by the build next to this file. */
#include "bodyvib_skyhook_config.h"

#define N_IN (4 * BV_ACTUATORS)
#define VR_FORCE N_IN
#define VR_RATE (5 * BV_ACTUATORS)
#define VR_CSKY (6 * BV_ACTUATORS)
#define VR_CGND (6 * BV_ACTUATORS + 1)
#define N_REAL (6 * BV_ACTUATORS + 2)

static const int vr_kind[N_REAL] = {BV_VR_KINDS};
static const char *const vr_name[N_REAL] = {BV_VR_NAMES};
/* What the shared state machine reads of a model: its names, kinds and token. */
static const bv_model MODEL = {
    .model_name = "SkyhookController",
    .token = BV_TOKEN,
    .ni = N_IN,
    .no = 2 * BV_ACTUATORS,
    .np = 2,
    .nvars = N_REAL,
    .vr_kind = vr_kind,
    .vr_name = vr_name,
};

struct bv_instance {
    bv_common bc; /* first (BV_STATE_IS): state, model, name, logger, time, flags */
    fmi2CallbackFunctions cb;
    int categories;             /* BV_LOG_* switched on (fmi2SetDebugLogging) */
    double real[N_REAL];        /* as set (inputs, parameters) */
    double v[2 * BV_ACTUATORS]; /* the velocities in force: upper, lower per actuator */
    fmi2Boolean semi;
};
typedef struct bv_instance Instance;

static void logger(void *env, int status, const char *message)
{
    Instance *c = env;
    if (c->cb.logger == NULL || !(c->categories & (status == BV_ERROR ? BV_LOG_ERROR
                                                                      : BV_LOG_WARNING)))
        return;
    c->cb.logger(c->cb.componentEnvironment, c->bc.name, (fmi2Status)status,
                 status == BV_ERROR ? "logStatusError" : "logStatusWarning", "%s", message);
}

#define say(c, ...) bv_say(&(c)->bc, __VA_ARGS__)

/* The instance of a function allowed in the states of `mask`, else fmi2Error (logged). */
#define ENTER(component, function, mask)                                                     \
    Instance *c = (Instance *)(component);                                                   \
    if (c == NULL)                                                                           \
        return fmi2Error;                                                                    \
    if (!BV_STATE_IS(c, mask)) {                                                             \
        bv_allowed(c, #function, mask);                                                      \
        return fmi2Error;                                                                    \
    }
/* A pointer argument through which the call reads or writes n entries. */
#define NEED(p, n)                                                                           \
    if ((p) == NULL && (n) > 0) {                                                            \
        say(c, BV_ERROR, "%s: %s is NULL; call refused, nothing changed", __func__, #p);     \
        return fmi2Error;                                                                    \
    }
/* ENTER for a call that reads or writes the n values of the n value references vr[]. */
#define ENTER_VALUES(component, function, mask)                                              \
    ENTER(component, function, mask);                                                        \
    size_t k;                                                                                \
    NEED(vr, n);                                                                             \
    NEED(value, n)

/* The force (rate = 0) or its rate (rate = 1) of actuator i from velocities v. */
static double law(const Instance *c, const double *v, int i, int rate)
{
    const double *a = c->real + 4 * i + 2; /* upper, lower acceleration */
    double vu = v[2 * i], vl = v[2 * i + 1];
    double f = -c->real[VR_CSKY] * vu + c->real[VR_CGND] * vl;
    if (c->semi && f * (vu - vl) > 0.0)
        return 0.0;
    return rate ? -c->real[VR_CSKY] * a[0] + c->real[VR_CGND] * a[1] : f;
}

/* Every output from velocities v is finite: 1, else 0 with the reason logged. */
static int outputs_finite(const Instance *c, const double *v, const char *function)
{
    int i, k;
    for (i = 0; i < BV_ACTUATORS; i++)
        for (k = 0; k < 2; k++) {
            double y = law(c, v, i, k);
            if (!isfinite(y) || !isfinite(v[2 * i + k])) {
                say(c, BV_ERROR, "%s: %s: %s = %g is not finite (inputs too large); call "
                                 "refused, nothing changed", c->bc.name, function,
                    vr_name[isfinite(y) ? 4 * i + k : (k ? VR_RATE : VR_FORCE) + i], y);
                return 0;
            }
        }
    return 1;
}

static void clear(Instance *c)
{
    memset(c->real, 0, sizeof c->real);
    memset(c->v, 0, sizeof c->v);
    c->real[VR_CSKY] = BV_C_SKY;
    c->real[VR_CGND] = BV_C_GROUND;
    c->semi = BV_SEMI_ACTIVE;
    bv_common_clear(&c->bc);
}

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean on, size_t n,
                                           const fmi2String cat[])
{
    ENTER(component, fmi2SetDebugLogging, BV_ANY_STATE);
    int bits = n == 0 ? BV_LOG_ALL : 0;
    size_t k;
    NEED(cat, n);
    for (k = 0; k < n; k++) {
        int bit = cat[k] == NULL ? 0 : strcmp(cat[k], "logStatusWarning") == 0 ? BV_LOG_WARNING
                                     : strcmp(cat[k], "logStatusError") == 0     ? BV_LOG_ERROR
                                                                                 : 0;
        if (bit == 0) {
            say(c, BV_ERROR, "fmi2SetDebugLogging: unknown log category (this FMU has "
                             "logStatusWarning and logStatusError); call refused, nothing "
                             "changed");
            return fmi2Error;
        }
        bits |= bit;
    }
    c->categories = on ? c->categories | bits : c->categories & ~bits;
    return fmi2OK;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String token,
                                          fmi2String resources,
                                          const fmi2CallbackFunctions *cb, fmi2Boolean visible,
                                          fmi2Boolean logging)
{
    Instance *c;
    (void)resources, (void)visible, (void)logging;
    if (type != fmi2CoSimulation || token == NULL || strcmp(token, BV_TOKEN) != 0) {
        if (cb != NULL && cb->logger != NULL)
            cb->logger(cb->componentEnvironment, name ? name : "", fmi2Error, "logStatusError",
                       "SkyhookController: co-simulation only, and the GUID must be %s",
                       BV_TOKEN);
        return NULL;
    }
    c = calloc(1, sizeof *c);
    if (c == NULL)
        return NULL;
    if (cb != NULL)
        c->cb = *cb;
    c->categories = BV_LOG_ALL;
    bv_common_init(&c->bc, &MODEL, name ? name : "", logger, c);
    clear(c);
    return c;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) { free(c); }

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean tol_defined,
                                           fmi2Real tol, fmi2Real start, fmi2Boolean stop_defined,
                                           fmi2Real stop)
{
    ENTER(component, fmi2SetupExperiment, BV_INSTANTIATED);
    (void)tol_defined, (void)tol, (void)stop_defined, (void)stop;
    return (fmi2Status)bv_setup(c, start);
}

/* An entry point of the instance alone that, allowed in the instance's state, makes one
 * call that cannot fail. */
#define STATE_CHANGE(function, mask, call)                                                   \
    FMI2_Export fmi2Status function(fmi2Component component)                                 \
    {                                                                                        \
        ENTER(component, function, mask);                                                    \
        call;                                                                                \
        return fmi2OK;                                                                       \
    }

STATE_CHANGE(fmi2EnterInitializationMode, BV_INSTANTIATED, bv_enter_initialization(c))

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component component)
{
    ENTER(component, fmi2ExitInitializationMode, BV_INITIALIZATION);
    bv_common_begin_initialize(&c->bc);
    if (!(c->real[VR_CSKY] >= 0.0 && c->real[VR_CGND] >= 0.0 && isfinite(c->real[VR_CSKY]) &&
          isfinite(c->real[VR_CGND]))) {
        snprintf(c->bc.init_error, BV_MESSAGE, "%s: c_sky = %g and c_ground = %g must be "
                 "finite numbers >= 0 (N s/m); the instance refuses to step (reset and set "
                 "valid gains)", c->bc.name, c->real[VR_CSKY], c->real[VR_CGND]);
        return (fmi2Status)bv_common_failed(&c->bc);
    }
    bv_common_initialized(&c->bc);
    return fmi2OK;
}

STATE_CHANGE(fmi2Terminate, BV_ON_TERMINATE, bv_terminate(c))
STATE_CHANGE(fmi2Reset, BV_ANY_STATE, clear(c))

FMI2_Export fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[],
                                   size_t n, fmi2Real value[])
{
    ENTER_VALUES(component, fmi2GetReal, BV_ON_GET);
    for (k = 0; k < n; k++) {
        if (!bv_common_check_vr(&c->bc, vr[k]))
            return fmi2Error;
        if (vr[k] < VR_FORCE || vr[k] >= VR_CSKY) {
            value[k] = c->real[vr[k]];
            continue;
        }
        value[k] = law(c, c->v, (int)((vr[k] - VR_FORCE) % BV_ACTUATORS), vr[k] >= VR_RATE);
        if (!isfinite(value[k])) {
            say(c, BV_ERROR, "%s: fmi2GetReal: %s = %g is not finite (inputs too large); set "
                             "smaller inputs", c->bc.name, vr_name[vr[k]], value[k]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[],
                                   size_t n, const fmi2Real value[])
{
    ENTER_VALUES(component, fmi2SetReal, BV_ON_SET);
    /* every reference and value checked before any is set; the scan stops at the first
     * refusal (a host that passes more references than its arrays hold is not read past) */
    for (k = 0; k < n; k++) {
        if (!bv_common_check_vr(&c->bc, vr[k]) || !bv_common_settable(&c->bc, vr[k]))
            return fmi2Error;
        if (!isfinite(value[k]))
            return (fmi2Status)bv_common_not_finite(&c->bc, vr[k], value[k]);
    }
    for (k = 0; k < n; k++) {
        c->real[vr[k]] = value[k];
        if (vr[k] < N_IN && vr[k] % 4 < 2) /* a velocity: in force as set */
            c->v[vr[k] / 4 * 2 + vr[k] % 4] = value[k];
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[],
                                      size_t n, fmi2Boolean value[])
{
    ENTER_VALUES(component, fmi2GetBoolean, BV_ON_GET);
    for (k = 0; k < n; k++)
        if (vr[k] != 0) {
            say(c, BV_ERROR, "%s: no Boolean variable with value reference %u (semi_active "
                             "is 0)", c->bc.name, vr[k]);
            return fmi2Error;
        }
    for (k = 0; k < n; k++)
        value[k] = c->semi;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[],
                                      size_t n, const fmi2Boolean value[])
{
    ENTER_VALUES(component, fmi2SetBoolean, BV_ON_SET);
    for (k = 0; k < n; k++)
        if (vr[k] != 0 || c->bc.initialized) {
            say(c, BV_ERROR, "%s: semi_active (Boolean value reference 0) is a parameter, "
                             "set before ExitInitializationMode; call refused", c->bc.name);
            return fmi2Error;
        }
    for (k = 0; k < n; k++)
        c->semi = value[k];
    return fmi2OK;
}

/* No Integer or String variables: an empty request only. */
#define NO_VARIABLES(fn, T, CONST, MASK)                                                     \
    FMI2_Export fmi2Status fn(fmi2Component component, const fmi2ValueReference vr[],        \
                              size_t n, CONST T value[])                                     \
    {                                                                                        \
        ENTER(component, fn, MASK);                                                          \
        (void)vr, (void)value;                                                               \
        if (n == 0)                                                                          \
            return fmi2OK;                                                                   \
        say(c, BV_ERROR, "%s: the FMU has no such variables; call refused", #fn);            \
        return fmi2Error;                                                                    \
    }
NO_VARIABLES(fmi2GetInteger, fmi2Integer, , BV_ON_GET)
NO_VARIABLES(fmi2GetString, fmi2String, , BV_ON_GET)
NO_VARIABLES(fmi2SetInteger, fmi2Integer, const, BV_ON_SET)
NO_VARIABLES(fmi2SetString, fmi2String, const, BV_ON_SET)

/* A function this FMU does not provide (its model description says so): fmi2Error, logged. */
static fmi2Status unsupported(fmi2Component component, const char *function)
{
    Instance *c = component;
    if (c != NULL)
        say(c, BV_ERROR, "%s: not provided by this FMU (see its model description); call "
                         "refused", function);
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *st)
{
    (void)st;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate st)
{
    (void)st;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *st)
{
    (void)st;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate st, size_t *n)
{
    (void)st, (void)n;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate st, fmi2Byte b[],
                                             size_t n)
{
    (void)st, (void)b, (void)n;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                               fmi2FMUstate *st)
{
    (void)b, (void)n, (void)st;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                                    const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz,
                                                    const fmi2Real dv[], fmi2Real dz[])
{
    (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                   size_t n, const fmi2Integer order[],
                                                   const fmi2Real value[])
{
    (void)vr, (void)n, (void)order, (void)value;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c,
                                                    const fmi2ValueReference vr[], size_t n,
                                                    const fmi2Integer order[], fmi2Real value[])
{
    (void)vr, (void)n, (void)order, (void)value;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, __func__); }

/* The step carries the velocities in force along the accelerations; it is refused (nothing
 * changed) by the checks every bodyvib FMU's step makes, and when a velocity or an output
 * at its end would not be finite. */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component component, fmi2Real t, fmi2Real h,
                                  fmi2Boolean noset)
{
    ENTER(component, fmi2DoStep, BV_STEPPING);
    double v[2 * BV_ACTUATORS];
    int j;
    (void)noset;
    if (bv_common_step_check(&c->bc, t, h) != BV_OK)
        return fmi2Error;
    for (j = 0; j < 2 * BV_ACTUATORS; j++)
        v[j] = c->v[j] + c->real[4 * (j / 2) + 2 + j % 2] * h;
    if (!outputs_finite(c, v, "fmi2DoStep"))
        return fmi2Error;
    memcpy(c->v, v, sizeof v);
    c->bc.time = t + h;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component component, const fmi2StatusKind k,
                                         fmi2Real *v)
{
    ENTER(component, fmi2GetRealStatus, BV_STEPPING | BV_TERMINATED);
    NEED(v, 1);
    if (k != fmi2LastSuccessfulTime)
        return unsupported(c, __func__);
    *v = c->bc.time;
    return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetStatus(fmi2Component component, const fmi2StatusKind k,
                                     fmi2Status *v)
{
    ENTER(component, fmi2GetStatus, BV_STEPPING | BV_TERMINATED);
    NEED(v, 1);
    (void)k;
    *v = fmi2OK; /* no asynchronous step: nothing pending */
    return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k,
                                            fmi2Integer *v)
{
    (void)k, (void)v;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k,
                                            fmi2Boolean *v)
{
    (void)k, (void)v;
    return unsupported(c, __func__);
}
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k,
                                           fmi2String *v)
{
    (void)k, (void)v;
    return unsupported(c, __func__);
}
