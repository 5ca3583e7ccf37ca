/*
 * SkyhookController: a stateless FMI 2.0 co-simulation FMU, the skyhook/groundhook law.
 *
 * For each of BV_ACTUATORS actuators i (a compile-time constant):
 *     force_i = -c_sky * vu_i + c_ground * vl_i                                 [N]
 *     force_rate_i = -c_sky * upper_acceleration_i + c_ground * lower_acceleration_i
 * positive pushing the actuator's points apart (the car files' sign convention), with
 *     vu_i = upper_velocity_i + upper_acceleration_i * h,  vl_i likewise,
 * h the last communication step (0 before the first): a host that sets the velocities of
 * the previous communication point (a Jacobi host) gets the force at the current one to
 * second order; a host that sets the current velocities leaves the accelerations at 0.
 * With semi_active true a force a passive damper cannot give, one with the sign of the
 * relative velocity vu - vl, is set to 0 (on-off law), and its rate too. The outputs are
 * feedthrough: computed on read from the inputs set last; doStep records h.
 *
 * Value references (Real), N = BV_ACTUATORS: inputs 4i upper_velocity, 4i+1
 * lower_velocity, 4i+2 upper_acceleration, 4i+3 lower_acceleration; outputs 4N + i
 * actuator_force, 5N + i actuator_force_rate; parameters 6N c_sky, 6N+1 c_ground.
 * Boolean: 0 (semi_active). modelDescription.xml and the config header are written by
 * bodyvib.fmu.controller.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

/* BV_ACTUATORS, BV_TOKEN (the GUID) and the parameters' start values BV_C_SKY,
   BV_C_GROUND, BV_SEMI_ACTIVE: written by the build next to this file. */
#include "bodyvib_skyhook_config.h"

#define N_IN (4 * BV_ACTUATORS)
#define VR_FORCE N_IN
#define VR_RATE (5 * BV_ACTUATORS)
#define VR_CSKY (6 * BV_ACTUATORS)
#define VR_CGND (6 * BV_ACTUATORS + 1)
#define N_REAL (6 * BV_ACTUATORS + 2)

typedef struct {
    fmi2CallbackFunctions cb;
    char *name;
    double real[N_REAL];
    fmi2Boolean semi;
    double time;
    double h; /* the last communication step */
    int initialized;
} Instance;

static void logf_(Instance *c, fmi2Status s, const char *msg) {
    if (c && c->cb.logger) c->cb.logger(c->cb.componentEnvironment, c->name, s, "error", msg);
}

/* The force (rate = 0) or its rate (rate = 1) of actuator i. */
static double law(const Instance *c, int i, int rate) {
    const double *u = c->real + 4 * i; /* upper, lower velocity; upper, lower acceleration */
    double vu = u[0] + u[2] * c->h, vl = u[1] + u[3] * c->h;
    double f = -c->real[VR_CSKY] * vu + c->real[VR_CGND] * vl;
    if (c->semi && f * (vu - vl) > 0.0) return 0.0;
    return rate ? -c->real[VR_CSKY] * u[2] + c->real[VR_CGND] * u[3] : f;
}

FMI2_Export const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
FMI2_Export const char *fmi2GetVersion(void) { return fmi2Version; }

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                                           const fmi2String cat[]) {
    (void)on, (void)n, (void)cat;
    return c ? fmi2OK : fmi2Error;
}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String token,
                                          fmi2String resources,
                                          const fmi2CallbackFunctions *cb, fmi2Boolean visible,
                                          fmi2Boolean logging) {
    (void)resources, (void)visible, (void)logging;
    if (!cb || !name || type != fmi2CoSimulation || !token || strcmp(token, BV_TOKEN) != 0) {
        if (cb && cb->logger)
            cb->logger(cb->componentEnvironment, name ? name : "?", fmi2Error, "error",
                       "SkyhookController: co-simulation only, and the GUID must match");
        return NULL;
    }
    Instance *c = calloc(1, sizeof(Instance));
    if (!c) return NULL;
    c->name = malloc(strlen(name) + 1);
    if (!c->name) {
        free(c);
        return NULL;
    }
    strcpy(c->name, name);
    c->cb = *cb;
    c->real[VR_CSKY] = BV_C_SKY;
    c->real[VR_CGND] = BV_C_GROUND;
    c->semi = BV_SEMI_ACTIVE;
    return c;
}

FMI2_Export void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    free(((Instance *)c)->name);
    free(c);
}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol_defined,
                                           fmi2Real tol, fmi2Real start, fmi2Boolean stop_defined,
                                           fmi2Real stop) {
    (void)tol_defined, (void)tol, (void)stop_defined, (void)stop;
    if (!c) return fmi2Error;
    ((Instance *)c)->time = start;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return c ? fmi2OK : fmi2Error;
}

FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *s = c;
    if (!s) return fmi2Error;
    if (!(s->real[VR_CSKY] >= 0.0) || !(s->real[VR_CGND] >= 0.0) || !isfinite(s->real[VR_CSKY]) ||
        !isfinite(s->real[VR_CGND])) {
        logf_(s, fmi2Error, "c_sky and c_ground must be finite numbers >= 0 (N s/m)");
        return fmi2Error;
    }
    s->initialized = 1;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) { return c ? fmi2OK : fmi2Error; }

FMI2_Export fmi2Status fmi2Reset(fmi2Component c) {
    Instance *s = c;
    if (!s) return fmi2Error;
    memset(s->real, 0, sizeof(s->real));
    s->real[VR_CSKY] = BV_C_SKY;
    s->real[VR_CGND] = BV_C_GROUND;
    s->semi = BV_SEMI_ACTIVE;
    s->time = 0.0;
    s->h = 0.0;
    s->initialized = 0;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                   fmi2Real value[]) {
    Instance *s = c;
    if (!s || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= N_REAL) return fmi2Error;
        if (vr[k] >= VR_FORCE && vr[k] < VR_CSKY)
            value[k] = law(s, (int)((vr[k] - VR_FORCE) % BV_ACTUATORS), vr[k] >= VR_RATE);
        else
            value[k] = s->real[vr[k]];
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                   const fmi2Real value[]) {
    Instance *s = c;
    if (!s || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        int input = vr[k] < N_IN, parameter = vr[k] == VR_CSKY || vr[k] == VR_CGND;
        if (!(input || (parameter && !s->initialized))) {
            logf_(s, fmi2Error, "fmi2SetReal: not an input (or a parameter before initialization)");
            return fmi2Error;
        }
        if (!isfinite(value[k])) {
            logf_(s, fmi2Error, "fmi2SetReal: a value is not finite");
            return fmi2Error;
        }
    }
    for (size_t k = 0; k < n; k++) s->real[vr[k]] = value[k];
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                      fmi2Boolean value[]) {
    Instance *s = c;
    if (!s || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0) return fmi2Error;
        value[k] = s->semi;
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                      const fmi2Boolean value[]) {
    Instance *s = c;
    if (!s || (n && (!vr || !value))) return fmi2Error;
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != 0 || s->initialized) return fmi2Error;
        s->semi = value[k];
    }
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                      fmi2Integer value[]) {
    (void)vr, (void)value;
    return c && n == 0 ? fmi2OK : fmi2Error;
}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                      const fmi2Integer value[]) {
    (void)vr, (void)value;
    return c && n == 0 ? fmi2OK : fmi2Error;
}

FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                     fmi2String value[]) {
    (void)vr, (void)value;
    return c && n == 0 ? fmi2OK : fmi2Error;
}

FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                     const fmi2String value[]) {
    (void)vr, (void)value;
    return c && n == 0 ? fmi2OK : fmi2Error;
}

/* No state to save: stateless. */
FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *st) {
    (void)c, (void)st;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate st) {
    (void)c, (void)st;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *st) {
    (void)c, (void)st;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate st, size_t *n) {
    (void)c, (void)st, (void)n;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate st, fmi2Byte b[],
                                             size_t n) {
    (void)c, (void)st, (void)b, (void)n;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                               fmi2FMUstate *st) {
    (void)c, (void)b, (void)n, (void)st;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c,
                                                    const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz,
                                                    const fmi2Real dv[], fmi2Real dz[]) {
    (void)c, (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    return fmi2Error;
}

/* Co-simulation. */
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                                   size_t n, const fmi2Integer order[],
                                                   const fmi2Real value[]) {
    (void)c, (void)vr, (void)n, (void)order, (void)value;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c,
                                                    const fmi2ValueReference vr[], size_t n,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)c, (void)vr, (void)n, (void)order, (void)value;
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noset) {
    Instance *s = c;
    (void)noset;
    if (!s || !s->initialized || !(h >= 0.0)) return fmi2Error;
    s->time = t + h;
    s->h = h;
    return fmi2OK;
}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {
    (void)c;
    return fmi2Error;
}

FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) {
    (void)k;
    if (!c || !v) return fmi2Error;
    *v = fmi2OK;
    return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) {
    if (!c || !v || k != fmi2LastSuccessfulTime) return fmi2Error;
    *v = ((Instance *)c)->time;
    return fmi2OK;
}
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k,
                                            fmi2Integer *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k,
                                            fmi2Boolean *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k,
                                           fmi2String *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
