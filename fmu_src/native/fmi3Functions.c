/*
 * FMI 3.0 co-simulation and model-exchange interface of the bodyvib native FMUs: a thin
 * wrapper of the model-independent core (bodyvib_core.c), the same core as fmi2Functions.c.
 * Float64 variables only, plus the independent variable "time" (value reference
 * bv_model_data.nvars, after the contract's variables); the other types accept empty
 * requests and refuse any value reference. Co-simulation and model exchange (the functions
 * at the end); scheduled execution is not provided (its instantiate function returns NULL).
 *
 * Status as in FMI 2.0 (fmi2Functions.c): calls out of order, non-finite inputs, bad steps
 * return fmi3Error, a step whose state would not be finite fmi3Discard, nothing changed;
 * an invalid parameter makes fmi3ExitInitializationMode return fmi3Error; a foreign or
 * corrupt FMU state is refused.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "bodyvib_core.h"

typedef struct {
    bv_instance *core;
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment env;
    int logging_on;
    int me; /* instantiated for model exchange */
} Fmu3;

typedef struct {
    size_t size;
    unsigned char bytes[1];
} State3;

static void fmu_log(void *env, int status, const char *message)
{
    Fmu3 *f = env;
    if (f->logger != NULL)
        f->logger(f->env, (fmi3Status)status,
                  status == BV_ERROR ? "logStatusError" : "logStatusWarning", message);
}

static fmi3Status st(bv_status s) { return (fmi3Status)s; }

#define INSTANCE(c)                                                                          \
    Fmu3 *f = (Fmu3 *)(c);                                                                   \
    if (f == NULL)                                                                           \
        return fmi3Error

/* The FMI 3.0 co-simulation state machine (no event mode: Step Mode follows
 * fmi3ExitInitializationMode), checked by the core: a call out of order returns fmi3Error
 * with the reason logged, and changes nothing. */
#define S_ANY BV_ANY_STATE
#define S_GET (BV_INITIALIZATION | BV_STEPPING | BV_TERMINATED | BV_FAILED)
#define S_SET (BV_INSTANTIATED | BV_INITIALIZATION | BV_STEPPING)
#define S_OUTPUT_DERIVATIVES (BV_STEPPING | BV_TERMINATED)

#define CHECKED(c, function, mask)                                                          \
    INSTANCE(c);                                                                             \
    if (!BV_STATE_IS(f->core, mask) && !bv_allowed(f->core, function, mask))                \
        return fmi3Error

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    INSTANCE(instance);
    (void)nCategories, (void)categories;
    f->logging_on = loggingOn;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    Fmu3 *f;
    (void)resourcePath, (void)visible;
    if (instantiationToken == NULL || strcmp(instantiationToken, bv_model_data.token) != 0) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "the instantiation token does not match this FMU's");
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (f == NULL)
        return NULL;
    f->logger = logMessage;
    f->env = instanceEnvironment;
    f->logging_on = loggingOn;
    f->me = 1;
    f->core = bv_new(&bv_model_data, instanceName, fmu_log, f);
    if (f->core == NULL) {
        free(f);
        return NULL;
    }
    return f;
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    Fmu3 *f;
    (void)resourcePath, (void)visible, (void)earlyReturnAllowed,
        (void)requiredIntermediateVariables, (void)nRequiredIntermediateVariables,
        (void)intermediateUpdate;
    if (instantiationToken == NULL || strcmp(instantiationToken, bv_model_data.token) != 0) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "the instantiation token does not match this FMU's");
        return NULL;
    }
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "this FMU has no event mode");
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (f == NULL)
        return NULL;
    f->logger = logMessage;
    f->env = instanceEnvironment;
    f->logging_on = loggingOn;
    f->core = bv_new(&bv_model_data, instanceName, fmu_log, f);
    if (f->core == NULL) {
        free(f);
        return NULL;
    }
    return f;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible,
        (void)loggingOn, (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU supports co-simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    Fmu3 *f = (Fmu3 *)instance;
    if (f == NULL)
        return;
    bv_free(f->core);
    free(f);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    bv_status s;
    CHECKED(instance, "fmi3EnterInitializationMode", BV_INSTANTIATED);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    s = bv_setup(f->core, startTime); /* the model's time starts there */
    if (s == BV_OK)
        bv_enter_initialization(f->core);
    return st(s);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    CHECKED(instance, "fmi3ExitInitializationMode", BV_INITIALIZATION);
    return st(bv_initialize(f->core));
}


fmi3Status fmi3Terminate(fmi3Instance instance)
{
    CHECKED(instance, "fmi3Terminate", BV_STEPPING);
    bv_terminate(f->core);
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    INSTANCE(instance);
    bv_reset(f->core);
    return fmi3OK;
}

#define TIME_VR ((fmi3ValueReference)bv_model_data.nvars)

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          fmi3Float64 values[], size_t nValues)
{
    size_t i;
    CHECKED(instance, "fmi3GetFloat64", S_GET);
    if (nValues != nvr || (nvr > 0 && (vr == NULL || values == NULL)))
        return fmi3Error;
    for (i = 0; i < nvr; i++)
        if (vr[i] == TIME_VR)
            break;
    if (i == nvr)
        return st(bv_get(f->core, vr, nvr, values));
    for (i = 0; i < nvr; i++) {
        if (vr[i] == TIME_VR)
            values[i] = bv_time(f->core);
        else if (bv_get(f->core, &vr[i], 1, &values[i]) != BV_OK)
            return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues)
{
    size_t i;
    CHECKED(instance, "fmi3SetFloat64", S_SET);
    if (nValues != nvr || (nvr > 0 && (vr == NULL || values == NULL)))
        return fmi3Error;
    for (i = 0; i < nvr; i++)
        if (vr[i] == TIME_VR) {
            fmu_log(f, BV_ERROR, "time is the independent variable and cannot be set");
            return fmi3Error;
        }
    return st(bv_set(f->core, vr, nvr, values));
}

/* No variables of the other types. */
#define NO_GET(fn, T)                                                                        \
    fmi3Status fn(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,          \
                  T values[], size_t nValues)                                                \
    {                                                                                        \
        CHECKED(instance, #fn, S_GET);                                                       \
        (void)vr, (void)values, (void)nValues;                                               \
        return nvr == 0 ? fmi3OK : fmi3Error;                                                \
    }
#define NO_SET(fn, T)                                                                        \
    fmi3Status fn(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,          \
                  const T values[], size_t nValues)                                          \
    {                                                                                        \
        CHECKED(instance, #fn, S_SET);                                                       \
        (void)vr, (void)values, (void)nValues;                                               \
        return nvr == 0 ? fmi3OK : fmi3Error;                                                \
    }
NO_GET(fmi3GetFloat32, fmi3Float32)
NO_GET(fmi3GetInt8, fmi3Int8)
NO_GET(fmi3GetUInt8, fmi3UInt8)
NO_GET(fmi3GetInt16, fmi3Int16)
NO_GET(fmi3GetUInt16, fmi3UInt16)
NO_GET(fmi3GetInt32, fmi3Int32)
NO_GET(fmi3GetUInt32, fmi3UInt32)
NO_GET(fmi3GetInt64, fmi3Int64)
NO_GET(fmi3GetUInt64, fmi3UInt64)
NO_GET(fmi3GetBoolean, fmi3Boolean)
NO_GET(fmi3GetString, fmi3String)
NO_SET(fmi3SetFloat32, fmi3Float32)
NO_SET(fmi3SetInt8, fmi3Int8)
NO_SET(fmi3SetUInt8, fmi3UInt8)
NO_SET(fmi3SetInt16, fmi3Int16)
NO_SET(fmi3SetUInt16, fmi3UInt16)
NO_SET(fmi3SetInt32, fmi3Int32)
NO_SET(fmi3SetUInt32, fmi3UInt32)
NO_SET(fmi3SetInt64, fmi3Int64)
NO_SET(fmi3SetUInt64, fmi3UInt64)
NO_SET(fmi3SetBoolean, fmi3Boolean)
NO_SET(fmi3SetString, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    INSTANCE(instance);
    (void)vr, (void)valueSizes, (void)values, (void)nValues;
    return nvr == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    INSTANCE(instance);
    (void)vr, (void)valueSizes, (void)values, (void)nValues;
    return nvr == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Clock values[])
{
    INSTANCE(instance);
    (void)vr, (void)values;
    return nvr == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Clock values[])
{
    INSTANCE(instance);
    (void)vr, (void)values;
    return nvr == 0 ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    INSTANCE(instance);
    (void)valueReference, (void)nDependencies;
    return fmi3Error;
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies)
{
    INSTANCE(instance);
    (void)dependent, (void)elementIndicesOfDependent, (void)independents,
        (void)elementIndicesOfIndependents, (void)dependencyKinds, (void)nDependencies;
    return fmi3Error;
}

/* ------------------------------------------------------------------ FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    size_t size;
    State3 *s;
    INSTANCE(instance);
    if (FMUState == NULL)
        return fmi3Error;
    size = bv_state_size(f->core);
    s = *FMUState;
    if (s == NULL || s->size != size) {
        free(s);
        *FMUState = NULL;
        s = malloc(sizeof *s + size);
        if (s == NULL)
            return fmi3Error;
        s->size = size;
    }
    bv_state_write(f->core, s->bytes);
    *FMUState = s;
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    State3 *s = FMUState;
    INSTANCE(instance);
    if (s == NULL)
        return fmi3Error;
    return st(bv_state_read(f->core, s->bytes, s->size));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    INSTANCE(instance);
    if (FMUState != NULL) {
        free(*FMUState);
        *FMUState = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    State3 *s = FMUState;
    INSTANCE(instance);
    if (s == NULL || size == NULL)
        return fmi3Error;
    *size = s->size;
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    State3 *s = FMUState;
    INSTANCE(instance);
    if (s == NULL || serializedState == NULL || size < s->size)
        return fmi3Error;
    memcpy(serializedState, s->bytes, s->size);
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    State3 *s;
    INSTANCE(instance);
    if (FMUState == NULL ||
        bv_state_check(f->core, (const unsigned char *)serializedState, size) != BV_OK)
        return fmi3Error;
    s = malloc(sizeof *s + size);
    if (s == NULL)
        return fmi3Error;
    s->size = size;
    memcpy(s->bytes, serializedState, size);
    *FMUState = s;
    return fmi3OK;
}

/* Exact: the rows of A, B U (state derivatives) and of the output matrices on the columns
 * of the knowns (continuous states, inputs); both interfaces. All variables are scalars. */
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity)
{
    INSTANCE(instance);
    if (nSeed != nKnowns || nSensitivity != nUnknowns ||
        (nUnknowns > 0 && (unknowns == NULL || sensitivity == NULL)) ||
        (nKnowns > 0 && (knowns == NULL || seed == NULL))) {
        fmu_log(f, BV_ERROR, "fmi3GetDirectionalDerivative: nSeed must equal nKnowns and "
                             "nSensitivity nUnknowns (scalar variables)");
        return fmi3Error;
    }
    return st(bv_directional(f->core, unknowns, nUnknowns, knowns, nKnowns, seed, sensitivity));
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    INSTANCE(instance);
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed,
        (void)sensitivity, (void)nSensitivity;
    return fmi3Error;
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    INSTANCE(instance);
    return fmi3Error;
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    INSTANCE(instance);
    return fmi3Error;
}

/* No clocks. */
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)intervals, (void)qualifiers;
    return fmi3Error;
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    return fmi3Error;
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)shifts;
    return fmi3Error;
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return fmi3Error;
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)intervals;
    return fmi3Error;
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return fmi3Error;
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)shifts;
    return fmi3Error;
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    return fmi3Error;
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    INSTANCE(instance);
    return fmi3Error;
}

/* ------------------------------------------------------------------ co-simulation */

/* Step Mode is entered from Event Mode, which this FMU does not have (hasEventMode false:
 * fmi3ExitInitializationMode leads to Step Mode). */
fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    CHECKED(instance, "fmi3EnterStepMode", 0);
    return fmi3Error;
}

/* Output derivatives (maxOutputDerivativeOrder 2): exact, from the state equations. */
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    CHECKED(instance, "fmi3GetOutputDerivatives", S_OUTPUT_DERIVATIVES);
    if (nValues != nvr || (nvr > 0 && (vr == NULL || orders == NULL || values == NULL)))
        return fmi3Error;
    return st(bv_get_output_derivatives(f->core, vr, nvr, (const int *)orders, values));
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    bv_status s;
    CHECKED(instance, "fmi3DoStep", BV_STEPPING);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (f->me) {
        fmu_log(f, BV_ERROR, "fmi3DoStep: the instance was instantiated for model exchange");
        return fmi3Error;
    }
    s = bv_step(f->core, currentCommunicationPoint, communicationStepSize);
    if (eventHandlingNeeded)
        *eventHandlingNeeded = fmi3False;
    if (terminateSimulation)
        *terminateSimulation = fmi3False;
    if (earlyReturn)
        *earlyReturn = fmi3False;
    if (lastSuccessfulTime)
        *lastSuccessfulTime = bv_time(f->core);
    return st(s);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    INSTANCE(instance);
    (void)clockReference, (void)activationTime;
    return fmi3Error;
}

/* ------------------------------------------------------------------ model exchange
 *
 * x' = A x + B U s with the inputs s the host set for the current time (see
 * fmi2Functions.c): no events, no event indicators, no discrete states. */

/* Entry of every model-exchange function (the place for the state machine's checks). */
static int me_entry(Fmu3 *f, const char *function)
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
    Fmu3 *f = (Fmu3 *)(c);                                                                   \
    if (!me_entry(f, function))                                                              \
        return fmi3Error;                                                                      \
    if (!BV_STATE_IS(f->core, mask) && !bv_allowed(f->core, function, mask))                \
        return fmi3Error

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    ME_ENTRY(instance, "fmi3EnterEventMode", S_ME_MODES); /* co-simulation: no event mode */
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime)
{
    ME_ENTRY(instance, "fmi3UpdateDiscreteStates", S_ME_MODES);
    if (discreteStatesNeedUpdate)
        *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation)
        *terminateSimulation = fmi3False;
    if (nominalsOfContinuousStatesChanged)
        *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged)
        *valuesOfContinuousStatesChanged = fmi3False;
    if (nextEventTimeDefined)
        *nextEventTimeDefined = fmi3False;
    if (nextEventTime)
        *nextEventTime = 0.0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    ME_ENTRY(instance, "fmi3EnterContinuousTimeMode", S_ME_MODES);
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation)
{
    ME_ENTRY(instance, "fmi3CompletedIntegratorStep", S_ME_MODES);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (enterEventMode)
        *enterEventMode = fmi3False;
    if (terminateSimulation)
        *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    ME_ENTRY(instance, "fmi3SetTime", S_ME_SET);
    bv_me_set_time(f->core, time);
    return fmi3OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    ME_ENTRY(instance, "fmi3SetContinuousStates", S_ME_SET);
    if (continuousStates == NULL && nContinuousStates > 0)
        return fmi3Error;
    return st(bv_me_set_states(f->core, continuousStates, nContinuousStates));
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    ME_ENTRY(instance, "fmi3GetContinuousStateDerivatives", S_GET);
    if (derivatives == NULL && nContinuousStates > 0)
        return fmi3Error;
    return st(bv_me_derivatives(f->core, derivatives, nContinuousStates));
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators)
{
    ME_ENTRY(instance, "fmi3GetEventIndicators", S_GET);
    (void)eventIndicators;
    if (nEventIndicators != 0) {
        fmu_log(f, BV_ERROR, "fmi3GetEventIndicators: the model has no event indicators");
        return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    ME_ENTRY(instance, "fmi3GetContinuousStates", S_GET);
    if (continuousStates == NULL && nContinuousStates > 0)
        return fmi3Error;
    return st(bv_me_get_states(f->core, continuousStates, nContinuousStates));
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    ME_ENTRY(instance, "fmi3GetNominalsOfContinuousStates", S_ME_NOMINALS);
    if (nominals == NULL && nContinuousStates > 0)
        return fmi3Error;
    return st(bv_me_nominals(f->core, nominals, nContinuousStates));
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    INSTANCE(instance);
    if (nEventIndicators)
        *nEventIndicators = 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    INSTANCE(instance);
    if (nContinuousStates)
        *nContinuousStates = (size_t)bv_me_nstates(f->core);
    return fmi3OK;
}
