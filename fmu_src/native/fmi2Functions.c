/*
 * FMI 2.0 co-simulation and model-exchange interface of the bodyvib native FMUs: a thin
 * wrapper of the version-neutral FMI calls (bodyvib_calls.c) and the model-independent core
 * (bodyvib_core.c): FMI 2.0's names, argument lists, state table, logger and status enum.
 * Real variables only; the other types accept empty requests and refuse any value reference.
 *
 * Status: a call the standard's state table does not allow in the instance's state returns
 * fmi2Error (reason logged, nothing changed); a non-finite input, a non-positive step or a
 * step not from the model's time makes fmi2DoStep return fmi2Error, a step whose state would
 * not be finite fmi2Discard (state unchanged either way, the instance may step again); an
 * invalid parameter makes fmi2ExitInitializationMode return fmi2Error (the instance is then
 * in the error state until Reset); a foreign or corrupt FMU state is refused with
 * fmi2Error. Every argument is checked before anything changes: a NULL pointer the call
 * needs, a non-finite time or continuous state, a co-simulation function called on a
 * model-exchange instance (and the reverse) are refused with fmi2Error, the reason logged.
 *
 * Logging: every refusal is logged under the category of its status (logStatusError,
 * logStatusWarning). Both categories are on from fmi2Instantiate whatever loggingOn says (the
 * FMU has no debug messages; these are status reports); fmi2SetDebugLogging switches them.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "bodyvib_calls.h"

/* The logger is printf-like: the message goes as the format, any '%' doubled (hosts that
 * format it print the text; hosts that do not still get the text, not a bare "%s"). */
static void fmu_log(void *env, int status, const char *message)
{
    bv_fmu *f = env;
    char text[1300];
    size_t i = 0;
    if (f->logger == NULL || !bv_fmu_logs(f, status))
        return;
    for (; *message && i + 2 < sizeof text; message++) {
        if (*message == '%')
            text[i++] = '%';
        text[i++] = *message;
    }
    text[i] = '\0';
    ((fmi2CallbackLogger)f->logger)(f->env, f->name, (fmi2Status)status,
                                    status == BV_ERROR ? "logStatusError" : "logStatusWarning",
                                    text);
}

static fmi2Status st(bv_status s) { return (fmi2Status)s; }

/* The states of the FMI 2.0 functions not in bodyvib_calls.h's shared table. */
#define S_OUTPUT_DERIVATIVES (BV_STEPPING | BV_TERMINATED | BV_FAILED | BV_CS_ONLY)
#define S_STATUS (BV_STEPPING | BV_TERMINATED | BV_CS_ONLY)
#define S_INPUT_DERIVATIVES (BV_ON_SET | BV_CS_ONLY)
#define S_CANCEL (BV_ANY_STATE | BV_CS_ONLY)
/* FMI 2.0 allows fmi2EnterEventMode in Event Mode too (FMI 3.0 only in Continuous-Time Mode). */
#define S_ENTER_EVENT_MODE (BV_EVENT | BV_STEPPING | BV_ME_ONLY)

/* The instance f of a function allowed in every state. */
#define INSTANCE(c)                                                                          \
    bv_fmu *f = (bv_fmu *)(c);                                                               \
    if (f == NULL)                                                                           \
        return fmi2Error
/* The instance f of a function allowed in the states of `mask` (bodyvib_calls.h). */
#define CHECKED(c, function, mask)                                                           \
    INSTANCE(c);                                                                             \
    if (!bv_fmu_enter(f, #function, mask))                                                   \
        return fmi2Error
/* A pointer argument of the current function through which it reads or writes n entries. */
#define NEED(p, n)                                                                           \
    if (!bv_fmu_arg(f, __func__, #p, p, n))                                                  \
        return fmi2Error

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    INSTANCE(c);
    return st(bv_fmu_set_logging(f, __func__, loggingOn, nCategories, categories));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation;
    (void)visible;
    (void)loggingOn;
    if (functions != NULL && functions->logger != NULL) {
        if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "%s: unknown fmuType %d (co-simulation or model exchange)", name,
                              (int)fmuType);
            return NULL;
        }
        if (fmuGUID == NULL || strcmp(fmuGUID, bv_model_data.token) != 0) {
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              "%s: GUID %s does not match this FMU's %s", name,
                              fmuGUID ? fmuGUID : "(null)", bv_model_data.token);
            return NULL;
        }
    } else if ((fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) || fmuGUID == NULL ||
               strcmp(fmuGUID, bv_model_data.token) != 0) {
        return NULL;
    }
    return bv_fmu_new(name, fmuType == fmi2ModelExchange,
                      functions ? (bv_host_fn)functions->logger : NULL,
                      functions ? functions->componentEnvironment : NULL, fmu_log);
}

void fmi2FreeInstance(fmi2Component c) { bv_fmu_free((bv_fmu *)c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    CHECKED(c, fmi2SetupExperiment, BV_INSTANTIATED);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return st(bv_setup(f->core, startTime)); /* the model's time starts there */
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    CHECKED(c, fmi2EnterInitializationMode, BV_INSTANTIATED);
    bv_enter_initialization(f->core);
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    CHECKED(c, fmi2ExitInitializationMode, BV_INITIALIZATION);
    return st(bv_initialize(f->core));
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    CHECKED(c, fmi2Terminate, BV_ON_TERMINATE);
    bv_terminate(f->core);
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    INSTANCE(c);
    bv_reset(f->core);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    CHECKED(c, fmi2GetReal, BV_ON_GET);
    NEED(vr, nvr);
    NEED(value, nvr);
    return st(bv_fmu_get(f, vr, nvr, value));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    CHECKED(c, fmi2SetReal, BV_ON_SET);
    NEED(vr, nvr);
    NEED(value, nvr);
    return st(bv_fmu_set(f, vr, nvr, value));
}

/* No Integer, Boolean or String variables: an empty request only. */
#define NO_VARIABLES(fn, T, CONST, MASK)                                                       \
    fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, CONST T value[]) \
    {                                                                                          \
        CHECKED(c, fn, MASK);                                                                  \
        NEED(vr, nvr);                                                                         \
        NEED(value, nvr);                                                                      \
        if (nvr == 0)                                                                          \
            return fmi2OK;                                                                     \
        return st(bv_fmu_unsupported(f, #fn, "the FMU has Real variables only"));              \
    }
NO_VARIABLES(fmi2GetInteger, fmi2Integer, , BV_ON_GET)
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, , BV_ON_GET)
NO_VARIABLES(fmi2GetString, fmi2String, , BV_ON_GET)
NO_VARIABLES(fmi2SetInteger, fmi2Integer, const, BV_ON_SET)
NO_VARIABLES(fmi2SetBoolean, fmi2Boolean, const, BV_ON_SET)
NO_VARIABLES(fmi2SetString, fmi2String, const, BV_ON_SET)

/* ------------------------------------------------------------------ FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    INSTANCE(c);
    return st(bv_fmu_get_state(f, __func__, FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    INSTANCE(c);
    return st(bv_fmu_set_state(f, __func__, FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    INSTANCE(c);
    return st(bv_fmu_free_state(FMUstate));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    INSTANCE(c);
    return st(bv_fmu_state_size(f, __func__, FMUstate, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size)
{
    INSTANCE(c);
    return st(bv_fmu_serialize(f, __func__, FMUstate, (unsigned char *)serializedState, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    INSTANCE(c);
    return st(bv_fmu_deserialize(f, __func__, (const unsigned char *)serializedState, size, FMUstate));
}

/* Exact: the rows of A, B U (state derivatives) and of the output matrices on the columns
 * of the knowns (continuous states, inputs); both interfaces. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    INSTANCE(c);
    NEED(vUnknown_ref, nUnknown);
    NEED(dvUnknown, nUnknown);
    NEED(vKnown_ref, nKnown);
    NEED(dvKnown, nKnown);
    if (!bv_fmu_finite(f, __func__, "dvKnown", dvKnown, nKnown))
        return fmi2Error;
    return st(bv_fmu_directional(f, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                                 dvUnknown));
}

/* ------------------------------------------------------------------ co-simulation */

/* Input derivatives (canInterpolateInputs): order k of an input sets the input k rate pairs
 * down its chain (seat_displacement: 1 seat_velocity, 2 seat_acceleration). */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    CHECKED(c, fmi2SetRealInputDerivatives, S_INPUT_DERIVATIVES);
    NEED(vr, nvr);
    NEED(order, nvr);
    NEED(value, nvr);
    return st(bv_fmu_set_input_derivatives(f, vr, nvr, (const int *)order, value));
}

/* Output derivatives (maxOutputDerivativeOrder 2): exact, from the state equations. */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    CHECKED(c, fmi2GetRealOutputDerivatives, S_OUTPUT_DERIVATIVES);
    NEED(vr, nvr);
    NEED(order, nvr);
    NEED(value, nvr);
    return st(bv_fmu_get_output_derivatives(f, vr, nvr, (const int *)order, value));
}

/* A step whose result is not finite returns fmi2Discard (fmi2LastSuccessfulTime: the step's
 * start); like every refused step it changes nothing and the instance may step again. */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    CHECKED(c, fmi2DoStep, BV_ON_STEP);
    (void)noSetFMUStatePriorToCurrentPoint;
    return st(bv_step(f->core, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    CHECKED(c, fmi2CancelStep, S_CANCEL);
    return st(bv_fmu_unsupported(f, __func__, "fmi2DoStep never returns fmi2Pending"));
}

/* A status this FMU does not report (the standard's answer: fmi2Discard), logged. */
static fmi2Status no_status(bv_fmu *f, const char *function, int kind)
{
    bv_fmu_say(f, BV_WARNING, "%s: status kind %d is not available (this FMU reports only "
                              "fmi2LastSuccessfulTime, by fmi2GetRealStatus)", function, kind);
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    CHECKED(c, fmi2GetRealStatus, S_STATUS);
    NEED(value, 1);
    if (s == fmi2LastSuccessfulTime) {
        *value = bv_time(f->core);
        return fmi2OK;
    }
    return no_status(f, __func__, (int)s);
}

/* Nothing to report but fmi2LastSuccessfulTime. */
#define NO_STATUS(fn, T)                                                                     \
    fmi2Status fn(fmi2Component c, const fmi2StatusKind s, T *value)                         \
    {                                                                                        \
        CHECKED(c, fn, S_STATUS);                                                            \
        NEED(value, 1);                                                                      \
        return no_status(f, #fn, (int)s);                                                    \
    }
NO_STATUS(fmi2GetStatus, fmi2Status)
NO_STATUS(fmi2GetIntegerStatus, fmi2Integer)
NO_STATUS(fmi2GetBooleanStatus, fmi2Boolean)
NO_STATUS(fmi2GetStringStatus, fmi2String)

/* ------------------------------------------------------------------ model exchange
 *
 * x' = A x + B U s with the inputs s the host set for the current time: the velocity
 * inputs are taken as given (the host provides the input's derivative as its value),
 * rate-only inputs (seat_acceleration, seat_force_rate) enter only the outputs that are
 * exact time derivatives. A nonlinear model's switching functions are its event
 * indicators; fmi2NewDiscreteStates takes the regime of their signs (the continuous states
 * do not jump). No time events. The instance is in Event Mode after fmi2ExitInitializationMode and moves between it
 * and Continuous-Time Mode as the host calls fmi2EnterContinuousTimeMode / fmi2EnterEventMode;
 * a call the other mode allows (fmi2SetContinuousStates, fmi2CompletedIntegratorStep in
 * Event Mode; fmi2NewDiscreteStates in Continuous-Time Mode) returns fmi2Error, logged. */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    CHECKED(c, fmi2EnterEventMode, S_ENTER_EVENT_MODE);
    bv_me_enter(f->core, BV_EVENT);
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    CHECKED(c, fmi2NewDiscreteStates, BV_ON_EVENT_MODE);
    NEED(eventInfo, 1);
    /* The regime of the switching functions' signs. Where it changes the states keep their
     * values but the right-hand side switches: the importer must restart its integrator (a
     * multistep method's history spans the switch), which this flag asks of it. */
    const int switched = bv_me_update_regime(f->core);
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = switched ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    CHECKED(c, fmi2EnterContinuousTimeMode, BV_ON_EVENT_MODE);
    bv_me_enter(f->core, BV_STEPPING);
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation)
{
    CHECKED(c, fmi2CompletedIntegratorStep, BV_ON_CT_MODE);
    NEED(enterEventMode, 1);
    NEED(terminateSimulation, 1);
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    CHECKED(c, fmi2SetTime, BV_ON_TIME);
    if (!bv_fmu_finite(f, __func__, "time", &time, 1))
        return fmi2Error;
    bv_me_set_time(f->core, time);
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    CHECKED(c, fmi2GetEventIndicators, BV_ON_ME_GET);
    NEED(eventIndicators, ni);
    return st(bv_fmu_event_indicators(f, "fmi2GetEventIndicators", eventIndicators, ni));
}

/* The continuous-state vectors: set, get, derivatives, nominals (bv_fmu_vector). */
BV_VECTOR_FUNCTIONS(fmi2Status, fmi2Component, fmi2Real, fmi2SetContinuousStates,
                    fmi2GetContinuousStates, fmi2GetDerivatives, fmi2GetNominalsOfContinuousStates)
