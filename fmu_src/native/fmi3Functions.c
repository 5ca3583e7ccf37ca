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
 * corrupt FMU state is refused. Arguments are checked before anything changes (NULL
 * pointers the call needs, a non-finite time or continuous state, a function of the other
 * interface); a function this FMU does not provide returns fmi3Error; every refusal is
 * logged, under the categories fmi3SetDebugLogging switches (both on from instantiation).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "bodyvib_calls.h"

static void fmu_log(void *env, int status, const char *message)
{
    bv_fmu *f = env;
    if (f->logger != NULL && bv_fmu_logs(f, status))
        ((fmi3LogMessageCallback)f->logger)(
            f->env, (fmi3Status)status, status == BV_ERROR ? "logStatusError" : "logStatusWarning",
            message);
}

static fmi3Status st(bv_status s) { return (fmi3Status)s; }

/* The states of the FMI 3.0 functions not in bodyvib_calls.h's shared table (co-simulation
 * has no event mode: Step Mode follows fmi3ExitInitializationMode). */
#define S_OUTPUT_DERIVATIVES (BV_STEPPING | BV_TERMINATED | BV_CS_ONLY)
#define S_STEP_MODE BV_CS_ONLY /* Step Mode is entered from Event Mode, which it has not */

/* The instance f of a function allowed in every state. */
#define INSTANCE(c)                                                                          \
    bv_fmu *f = (bv_fmu *)(c);                                                               \
    if (f == NULL)                                                                           \
        return fmi3Error
/* The instance f of a function allowed in the states of `mask` (bodyvib_calls.h). */
#define CHECKED(c, function, mask)                                                           \
    INSTANCE(c);                                                                             \
    if (!bv_fmu_enter(f, #function, mask))                                                   \
        return fmi3Error
/* A pointer argument of the current function through which it reads or writes n entries. */
#define NEED(p, n)                                                                           \
    if (!bv_fmu_arg(f, __func__, #p, p, n))                                                  \
        return fmi3Error
/* A function this FMU does not provide, and why (logged). */
#define UNSUPPORTED(why) return st(bv_fmu_unsupported(f, __func__, why))
/* nValues must equal nvr: every variable is a scalar. */
#define SCALARS(nValues, nvr)                                                                \
    if ((nValues) != (nvr))                                                                  \
    UNSUPPORTED("nValues must equal nValueReferences (every variable is a scalar)")

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    INSTANCE(instance);
    return st(bv_fmu_set_logging(f, __func__, loggingOn, nCategories, categories));
}

/* The independent variable time: the value reference after the contract's variables. */
#define TIME_VR ((fmi3ValueReference)bv_model_data.nvars)

/* A new instance (or NULL) whose core knows the independent variable time: bv_get reads it
 * as the model's time, bv_set refuses it. */
static bv_fmu *with_time(bv_fmu *f)
{
    if (f != NULL)
        bv_set_time_variable(f->core, TIME_VR);
    return f;
}

/* The instantiation token is this FMU's (else logged, 0). */
static int token_ok(fmi3String token, fmi3InstanceEnvironment env, fmi3LogMessageCallback log)
{
    if (token != NULL && strcmp(token, bv_model_data.token) == 0)
        return 1;
    if (log)
        log(env, fmi3Error, "logStatusError", "the instantiation token does not match this FMU's");
    return 0;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)resourcePath, (void)visible, (void)loggingOn;
    if (!token_ok(instantiationToken, instanceEnvironment, logMessage))
        return NULL;
    return with_time(
        bv_fmu_new(instanceName, 1, (bv_host_fn)logMessage, instanceEnvironment, fmu_log));
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath, (void)visible, (void)loggingOn, (void)earlyReturnAllowed,
        (void)requiredIntermediateVariables, (void)nRequiredIntermediateVariables,
        (void)intermediateUpdate;
    if (!token_ok(instantiationToken, instanceEnvironment, logMessage))
        return NULL;
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "this FMU has no event mode");
        return NULL;
    }
    return with_time(
        bv_fmu_new(instanceName, 0, (bv_host_fn)logMessage, instanceEnvironment, fmu_log));
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

void fmi3FreeInstance(fmi3Instance instance) { bv_fmu_free((bv_fmu *)instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    bv_status s;
    CHECKED(instance, fmi3EnterInitializationMode, BV_INSTANTIATED);
    (void)toleranceDefined, (void)tolerance, (void)stopTimeDefined, (void)stopTime;
    s = bv_setup(f->core, startTime); /* the model's time starts there */
    if (s == BV_OK)
        bv_enter_initialization(f->core);
    return st(s);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    CHECKED(instance, fmi3ExitInitializationMode, BV_INITIALIZATION);
    return st(bv_initialize(f->core));
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    CHECKED(instance, fmi3Terminate, BV_ON_TERMINATE);
    bv_terminate(f->core);
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    INSTANCE(instance);
    bv_reset(f->core);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          fmi3Float64 values[], size_t nValues)
{
    CHECKED(instance, fmi3GetFloat64, BV_ON_GET);
    NEED(vr, nvr);
    NEED(values, nvr);
    SCALARS(nValues, nvr);
    return st(bv_get(f->core, vr, nvr, values));
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues)
{
    CHECKED(instance, fmi3SetFloat64, BV_ON_SET);
    NEED(vr, nvr);
    NEED(values, nvr);
    SCALARS(nValues, nvr);
    return st(bv_set(f->core, vr, nvr, values));
}

/* No variables of the other types. */
#define NO_GET(fn, T)                                                                        \
    fmi3Status fn(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,          \
                  T values[], size_t nValues)                                                \
    {                                                                                        \
        CHECKED(instance, fn, BV_ON_GET);                                                    \
        NEED(vr, nvr);                                                                       \
        NEED(values, nvr);                                                                   \
        (void)nValues;                                                                       \
        if (nvr > 0)                                                                         \
            UNSUPPORTED("the FMU has Float64 variables only");                               \
        return fmi3OK;                                                                       \
    }
#define NO_SET(fn, T)                                                                        \
    fmi3Status fn(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,          \
                  const T values[], size_t nValues)                                          \
    {                                                                                        \
        CHECKED(instance, fn, BV_ON_SET);                                                    \
        NEED(vr, nvr);                                                                       \
        NEED(values, nvr);                                                                   \
        (void)nValues;                                                                       \
        if (nvr > 0)                                                                         \
            UNSUPPORTED("the FMU has Float64 variables only");                               \
        return fmi3OK;                                                                       \
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
    if (nvr > 0)
        UNSUPPORTED("the FMU has no Binary variables");
    return fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    INSTANCE(instance);
    (void)vr, (void)valueSizes, (void)values, (void)nValues;
    if (nvr > 0)
        UNSUPPORTED("the FMU has no Binary variables");
    return fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        fmi3Clock values[])
{
    INSTANCE(instance);
    (void)vr, (void)values;
    if (nvr > 0)
        UNSUPPORTED("the FMU has no clocks");
    return fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                        const fmi3Clock values[])
{
    INSTANCE(instance);
    (void)vr, (void)values;
    if (nvr > 0)
        UNSUPPORTED("the FMU has no clocks");
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    INSTANCE(instance);
    (void)valueReference, (void)nDependencies;
    UNSUPPORTED("the dependencies are in the model description's ModelStructure only");
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
    UNSUPPORTED("the dependencies are in the model description's ModelStructure only");
}

/* ------------------------------------------------------------------ FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    INSTANCE(instance);
    return st(bv_fmu_get_state(f, __func__, FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    INSTANCE(instance);
    return st(bv_fmu_set_state(f, __func__, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    INSTANCE(instance);
    return st(bv_fmu_free_state(FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    INSTANCE(instance);
    return st(bv_fmu_state_size(f, __func__, FMUState, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    INSTANCE(instance);
    return st(bv_fmu_serialize(f, __func__, FMUState, serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    INSTANCE(instance);
    return st(bv_fmu_deserialize(f, __func__, serializedState, size, FMUState));
}

/* Exact: the rows of A, B U (state derivatives) and of the output matrices on the columns
 * of the knowns (continuous states, inputs); both interfaces. All variables are scalars. */
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity)
{
    INSTANCE(instance);
    NEED(unknowns, nUnknowns);
    NEED(sensitivity, nUnknowns);
    NEED(knowns, nKnowns);
    NEED(seed, nKnowns);
    if (!bv_fmu_finite(f, __func__, "seed", seed, nKnowns))
        return fmi3Error;
    if (nSeed != nKnowns || nSensitivity != nUnknowns) {
        fmu_log(f, BV_ERROR, "fmi3GetDirectionalDerivative: nSeed must equal nKnowns and "
                             "nSensitivity nUnknowns (scalar variables)");
        return fmi3Error;
    }
    return st(bv_fmu_directional(f, unknowns, nUnknowns, knowns, nKnowns, seed, sensitivity));
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    INSTANCE(instance);
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed,
        (void)sensitivity, (void)nSensitivity;
    UNSUPPORTED("no adjoint derivatives (providesAdjointDerivatives is false)");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    INSTANCE(instance);
    UNSUPPORTED("the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    INSTANCE(instance);
    UNSUPPORTED("the FMU has no structural parameters");
}

/* No clocks. */
fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)intervals, (void)qualifiers;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)shifts;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)intervals;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[],
                                   size_t nvr, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)shifts;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    INSTANCE(instance);
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED("the FMU has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    INSTANCE(instance);
    UNSUPPORTED("the FMU has no discrete states (providesEvaluateDiscreteStates is false)");
}

/* ------------------------------------------------------------------ co-simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    CHECKED(instance, fmi3EnterStepMode, S_STEP_MODE);
    UNSUPPORTED("co-simulation without event mode is in Step Mode after initialization");
}

/* Output derivatives (maxOutputDerivativeOrder 2): exact, from the state equations. */
fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[],
                                    size_t nvr, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    CHECKED(instance, fmi3GetOutputDerivatives, S_OUTPUT_DERIVATIVES);
    NEED(vr, nvr);
    NEED(orders, nvr);
    NEED(values, nvr);
    SCALARS(nValues, nvr);
    return st(bv_fmu_get_output_derivatives(f, vr, nvr, (const int *)orders, values));
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    bv_status s;
    CHECKED(instance, fmi3DoStep, BV_ON_STEP);
    NEED(eventHandlingNeeded, 1);
    NEED(terminateSimulation, 1);
    NEED(earlyReturn, 1);
    NEED(lastSuccessfulTime, 1);
    (void)noSetFMUStatePriorToCurrentPoint;
    /* the flags first: after the step only the time is left to write, so that little is kept
     * across the call */
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    s = bv_step(f->core, currentCommunicationPoint, communicationStepSize);
    *lastSuccessfulTime = bv_time(f->core);
    return st(s);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    INSTANCE(instance);
    (void)clockReference, (void)activationTime;
    UNSUPPORTED("scheduled execution is not provided");
}

/* ------------------------------------------------------------------ model exchange
 *
 * x' = A x + B U s with the inputs s the host set for the current time (see
 * fmi2Functions.c): a nonlinear model's switching functions as event indicators, the regime
 * taken in fmi3UpdateDiscreteStates, no time events; Event Mode after
 * fmi3ExitInitializationMode, and each call checked against the mode the host put it in. */

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    CHECKED(instance, fmi3EnterEventMode, BV_ON_CT_MODE); /* co-simulation: no event mode */
    bv_me_enter(f->core, BV_EVENT);
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime)
{
    CHECKED(instance, fmi3UpdateDiscreteStates, BV_ON_EVENT_MODE);
    NEED(discreteStatesNeedUpdate, 1);
    NEED(terminateSimulation, 1);
    NEED(nominalsOfContinuousStatesChanged, 1);
    NEED(valuesOfContinuousStatesChanged, 1);
    NEED(nextEventTimeDefined, 1);
    NEED(nextEventTime, 1);
    /* The regime of the switching functions' signs. Where it changes the states keep their
     * values but the right-hand side switches: the importer must restart its integrator (a
     * multistep method's history spans the switch), which this flag asks of it. */
    const int switched = bv_me_update_regime(f->core);
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = switched ? fmi3True : fmi3False;
    *nextEventTimeDefined = fmi3False;
    *nextEventTime = 0.0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    CHECKED(instance, fmi3EnterContinuousTimeMode, BV_ON_EVENT_MODE);
    bv_me_enter(f->core, BV_STEPPING);
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation)
{
    CHECKED(instance, fmi3CompletedIntegratorStep, BV_ON_CT_MODE);
    NEED(enterEventMode, 1);
    NEED(terminateSimulation, 1);
    (void)noSetFMUStatePriorToCurrentPoint;
    *enterEventMode = fmi3False;
    *terminateSimulation = fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    CHECKED(instance, fmi3SetTime, BV_ON_TIME);
    if (!bv_fmu_finite(f, __func__, "time", &time, 1))
        return fmi3Error;
    bv_me_set_time(f->core, time);
    return fmi3OK;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators)
{
    CHECKED(instance, fmi3GetEventIndicators, BV_ON_ME_GET);
    NEED(eventIndicators, nEventIndicators);
    return st(bv_fmu_event_indicators(f, "fmi3GetEventIndicators", eventIndicators,
                                      nEventIndicators));
}

/* The continuous-state vectors: set, get, derivatives, nominals (bv_fmu_vector). */
BV_VECTOR_FUNCTIONS(fmi3Status, fmi3Instance, fmi3Float64, fmi3SetContinuousStates,
                    fmi3GetContinuousStates, fmi3GetContinuousStateDerivatives,
                    fmi3GetNominalsOfContinuousStates)

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    INSTANCE(instance);
    NEED(nEventIndicators, 1);
    *nEventIndicators = (size_t)bv_me_nevents(f->core);
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    INSTANCE(instance);
    NEED(nContinuousStates, 1);
    *nContinuousStates = (size_t)bv_me_nstates(f->core);
    return fmi3OK;
}
