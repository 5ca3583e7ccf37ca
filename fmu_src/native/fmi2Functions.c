/*
 * FMI 2.0 co-simulation and model-exchange interface of the bodyvib native FMUs: a thin
 * wrapper of the model-independent core (bodyvib_core.c). Real variables only; the other
 * types accept empty requests and refuse any value reference.
 *
 * Status: a call the standard's state table does not allow in the instance's state returns
 * fmi2Error (reason logged, nothing changed); a non-finite input, a non-positive step or a
 * step not from the model's time makes fmi2DoStep return fmi2Error, a step whose state would
 * not be finite fmi2Discard (state unchanged either way, the instance may step again); an
 * invalid parameter makes fmi2ExitInitializationMode return fmi2Error (the instance is then
 * in the error state until Reset); a foreign or corrupt FMU state is refused with
 * fmi2Error. Errors and warnings are always passed to the logger (they are not debug
 * messages), whatever loggingOn says.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "bodyvib_core.h"

typedef struct {
    bv_instance *core;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    char *name;
    int logging_on;
    int me; /* instantiated for model exchange */
} Fmu2;

typedef struct {
    size_t size;
    unsigned char bytes[1];
} State2;

/* The logger is printf-like: the message goes as the format, any '%' doubled (hosts that
 * format it print the text; hosts that do not still get the text, not a bare "%s"). */
static void fmu_log(void *env, int status, const char *message)
{
    Fmu2 *f = env;
    char text[1300];
    size_t i = 0;
    if (f->logger == NULL)
        return;
    for (; *message && i + 2 < sizeof text; message++) {
        if (*message == '%')
            text[i++] = '%';
        text[i++] = *message;
    }
    text[i] = '\0';
    f->logger(f->env, f->name, (fmi2Status)status,
              status == BV_ERROR ? "logStatusError" : "logStatusWarning", text);
}

static fmi2Status st(bv_status s) { return (fmi2Status)s; }

#define INSTANCE(c)                                                                          \
    Fmu2 *f = (Fmu2 *)(c);                                                                   \
    if (f == NULL)                                                                           \
        return fmi2Error

/* The FMI 2.0 co-simulation state machine (the standard's table of which function is
 * allowed in which state), checked by the core: a call out of order returns fmi2Error with
 * the reason logged, and changes nothing. */
#define S_ANY BV_ANY_STATE
#define S_SETUP BV_INSTANTIATED
#define S_GET (BV_INITIALIZATION | BV_STEPPING | BV_TERMINATED | BV_FAILED)
#define S_SET (BV_INSTANTIATED | BV_INITIALIZATION | BV_STEPPING)
#define S_OUTPUT_DERIVATIVES (BV_STEPPING | BV_TERMINATED | BV_FAILED)
#define S_STATUS (BV_STEPPING | BV_TERMINATED)

#define CHECKED(c, function, mask)                                                          \
    INSTANCE(c);                                                                             \
    if (!BV_STATE_IS(f->core, mask) && !bv_allowed(f->core, function, mask))                \
        return fmi2Error

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    INSTANCE(c);
    (void)nCategories;
    (void)categories;
    f->logging_on = loggingOn != fmi2False;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    Fmu2 *f;
    const char *name = instanceName ? instanceName : "";
    (void)fmuResourceLocation;
    (void)visible;
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
    f = calloc(1, sizeof *f);
    if (f == NULL)
        return NULL;
    f->name = malloc(strlen(name) + 1);
    if (f->name == NULL) {
        free(f);
        return NULL;
    }
    strcpy(f->name, name);
    f->logger = functions ? functions->logger : NULL;
    f->env = functions ? functions->componentEnvironment : NULL;
    f->logging_on = loggingOn != fmi2False;
    f->me = fmuType == fmi2ModelExchange;
    f->core = bv_new(&bv_model_data, name, fmu_log, f);
    if (f->core == NULL) {
        free(f->name);
        free(f);
        return NULL;
    }
    return f;
}

void fmi2FreeInstance(fmi2Component c)
{
    Fmu2 *f = (Fmu2 *)c;
    if (f == NULL)
        return;
    bv_free(f->core);
    free(f->name);
    free(f);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    CHECKED(c, "fmi2SetupExperiment", S_SETUP);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    return st(bv_setup(f->core, startTime)); /* the model's time starts there */
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    CHECKED(c, "fmi2EnterInitializationMode", BV_INSTANTIATED);
    bv_enter_initialization(f->core);
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    CHECKED(c, "fmi2ExitInitializationMode", BV_INITIALIZATION);
    return st(bv_initialize(f->core));
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    CHECKED(c, "fmi2Terminate", BV_STEPPING);
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
    CHECKED(c, "fmi2GetReal", S_GET);
    if (nvr > 0 && (vr == NULL || value == NULL))
        return fmi2Error;
    return st(bv_get(f->core, vr, nvr, value));
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    CHECKED(c, "fmi2SetReal", S_SET);
    if (nvr > 0 && (vr == NULL || value == NULL))
        return fmi2Error;
    return st(bv_set(f->core, vr, nvr, value));
}

/* No Integer, Boolean or String variables. */
#define NO_VARIABLES(fn, T, CONST, MASK)                                                       \
    fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, CONST T value[]) \
    {                                                                                          \
        CHECKED(c, #fn, MASK);                                                                 \
        (void)vr, (void)value;                                                                 \
        return nvr == 0 ? fmi2OK : fmi2Error;                                                  \
    }
NO_VARIABLES(fmi2GetInteger, fmi2Integer, , S_GET)
NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, , S_GET)
NO_VARIABLES(fmi2GetString, fmi2String, , S_GET)
NO_VARIABLES(fmi2SetInteger, fmi2Integer, const, S_SET)
NO_VARIABLES(fmi2SetBoolean, fmi2Boolean, const, S_SET)
NO_VARIABLES(fmi2SetString, fmi2String, const, S_SET)

/* ------------------------------------------------------------------ FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    size_t size;
    State2 *s;
    INSTANCE(c);
    if (FMUstate == NULL)
        return fmi2Error;
    size = bv_state_size(f->core);
    s = *FMUstate;
    if (s == NULL || s->size != size) {
        free(s);
        *FMUstate = NULL;
        s = malloc(sizeof *s + size);
        if (s == NULL)
            return fmi2Error;
        s->size = size;
    }
    bv_state_write(f->core, s->bytes);
    *FMUstate = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    State2 *s = FMUstate;
    INSTANCE(c);
    if (s == NULL)
        return fmi2Error;
    return st(bv_state_read(f->core, s->bytes, s->size));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    INSTANCE(c);
    if (FMUstate != NULL) {
        free(*FMUstate);
        *FMUstate = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    State2 *s = FMUstate;
    INSTANCE(c);
    if (s == NULL || size == NULL)
        return fmi2Error;
    *size = s->size;
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size)
{
    State2 *s = FMUstate;
    INSTANCE(c);
    if (s == NULL || serializedState == NULL || size < s->size)
        return fmi2Error;
    memcpy(serializedState, s->bytes, s->size);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    State2 *s;
    INSTANCE(c);
    if (FMUstate == NULL ||
        bv_state_check(f->core, (const unsigned char *)serializedState, size) != BV_OK)
        return fmi2Error;
    s = malloc(sizeof *s + size);
    if (s == NULL)
        return fmi2Error;
    s->size = size;
    memcpy(s->bytes, serializedState, size);
    *FMUstate = s; /* a new state: the host frees it (and any earlier one) with fmi2FreeFMUstate */
    return fmi2OK;
}

/* Exact: the rows of A, B U (state derivatives) and of the output matrices on the columns
 * of the knowns (continuous states, inputs); both interfaces. */
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    INSTANCE(c);
    if ((nUnknown > 0 && (vUnknown_ref == NULL || dvUnknown == NULL)) ||
        (nKnown > 0 && (vKnown_ref == NULL || dvKnown == NULL)))
        return fmi2Error;
    return st(bv_directional(f->core, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                             dvUnknown));
}

/* ------------------------------------------------------------------ co-simulation */

/* Input derivatives (canInterpolateInputs): order k of an input sets the input k rate pairs
 * down its chain (seat_displacement: 1 seat_velocity, 2 seat_acceleration). */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    CHECKED(c, "fmi2SetRealInputDerivatives", S_SET);
    if (nvr > 0 && (vr == NULL || order == NULL || value == NULL))
        return fmi2Error;
    return st(bv_set_input_derivatives(f->core, vr, nvr, (const int *)order, value));
}

/* Output derivatives (maxOutputDerivativeOrder 2): exact, from the state equations. */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    CHECKED(c, "fmi2GetRealOutputDerivatives", S_OUTPUT_DERIVATIVES);
    if (nvr > 0 && (vr == NULL || order == NULL || value == NULL))
        return fmi2Error;
    return st(bv_get_output_derivatives(f->core, vr, nvr, (const int *)order, value));
}

/* A step whose result is not finite returns fmi2Discard (fmi2LastSuccessfulTime: the step's
 * start); like every refused step it changes nothing and the instance may step again. */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    CHECKED(c, "fmi2DoStep", BV_STEPPING);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (f->me) {
        fmu_log(f, BV_ERROR, "fmi2DoStep: the instance was instantiated for model exchange");
        return fmi2Error;
    }
    return st(bv_step(f->core, currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    INSTANCE(c);
    return fmi2Error; /* doStep never returns fmi2Pending */
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    CHECKED(c, "fmi2GetStatus", S_STATUS);
    (void)s, (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    CHECKED(c, "fmi2GetRealStatus", S_STATUS);
    if (s == fmi2LastSuccessfulTime && value != NULL) {
        *value = bv_time(f->core);
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    CHECKED(c, "fmi2GetIntegerStatus", S_STATUS);
    (void)s, (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    CHECKED(c, "fmi2GetBooleanStatus", S_STATUS);
    (void)s, (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    CHECKED(c, "fmi2GetStringStatus", S_STATUS);
    (void)s, (void)value;
    return fmi2Discard;
}


/* ------------------------------------------------------------------ model exchange
 *
 * x' = A x + B U s with the inputs s the host set for the current time: the velocity
 * inputs are taken as given (the host provides the input's derivative as its value),
 * rate-only inputs (seat_acceleration, seat_force_rate) enter only the outputs that are
 * exact time derivatives. No events: no event indicators, no discrete states, no time
 * events; the mode functions only acknowledge the host's calls. */

/* Entry of every model-exchange function: the instance exists and is a model-exchange
 * instance (the place for the state machine's checks). */
static int me_entry(Fmu2 *f, const char *function)
{
    char text[160];
    if (f == NULL)
        return 0;
    if (!f->me) {
        snprintf(text, sizeof text, "%s: a model-exchange function called on a co-simulation "
                                    "instance", function);
        fmu_log(f, BV_ERROR, text);
        return 0;
    }
    return 1;
}

/* Model exchange: the standard's Event Mode and Continuous-Time Mode are both the core's
 * BV_STEPPING (the models have no events); the calls are checked against it as the
 * co-simulation ones are. */
#define S_ME_MODES BV_STEPPING
#define S_ME_SET (BV_INITIALIZATION | BV_STEPPING)
#define S_ME_NOMINALS (BV_INSTANTIATED | S_GET)

#define ME_ENTRY(c, function, mask)                                                          \
    Fmu2 *f = (Fmu2 *)(c);                                                                   \
    if (!me_entry(f, function))                                                              \
        return fmi2Error;                                                                      \
    if (!BV_STATE_IS(f->core, mask) && !bv_allowed(f->core, function, mask))                \
        return fmi2Error

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    ME_ENTRY(c, "fmi2EnterEventMode", S_ME_MODES);
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    ME_ENTRY(c, "fmi2NewDiscreteStates", S_ME_MODES);
    if (eventInfo == NULL)
        return fmi2Error;
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    ME_ENTRY(c, "fmi2EnterContinuousTimeMode", S_ME_MODES);
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode,
                                       fmi2Boolean *terminateSimulation)
{
    ME_ENTRY(c, "fmi2CompletedIntegratorStep", S_ME_MODES);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode != NULL)
        *enterEventMode = fmi2False;
    if (terminateSimulation != NULL)
        *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    ME_ENTRY(c, "fmi2SetTime", S_ME_SET);
    bv_me_set_time(f->core, time);
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    ME_ENTRY(c, "fmi2SetContinuousStates", S_ME_SET);
    if (x == NULL && nx > 0)
        return fmi2Error;
    return st(bv_me_set_states(f->core, x, nx));
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    ME_ENTRY(c, "fmi2GetDerivatives", S_GET);
    if (derivatives == NULL && nx > 0)
        return fmi2Error;
    return st(bv_me_derivatives(f->core, derivatives, nx));
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    ME_ENTRY(c, "fmi2GetEventIndicators", S_GET);
    (void)eventIndicators;
    if (ni != 0) {
        fmu_log(f, BV_ERROR, "fmi2GetEventIndicators: the model has no event indicators");
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    ME_ENTRY(c, "fmi2GetContinuousStates", S_GET);
    if (x == NULL && nx > 0)
        return fmi2Error;
    return st(bv_me_get_states(f->core, x, nx));
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    ME_ENTRY(c, "fmi2GetNominalsOfContinuousStates", S_ME_NOMINALS);
    if (x_nominal == NULL && nx > 0)
        return fmi2Error;
    return st(bv_me_nominals(f->core, x_nominal, nx));
}
