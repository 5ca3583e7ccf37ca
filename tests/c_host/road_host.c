/*
 * A C host for the native Road.fmu (FMI 2.0), linked with the FMU's own sources/
 * (tests/test_native_road_interface.py runs it under valgrind).
 *
 *   road_host GUID DISPLACEMENT_VR VELOCITY_VR SPEED_VR
 *
 * It walks one co-simulation instance through the state machine (GetReal before
 * initialization, a start time of 2.5 s, 100 steps, output derivatives, refused input and
 * directional derivatives, FMU state get / serialize / deserialize / set, DoStep after
 * Terminate, Reset, a refused zero speed) and one model-exchange instance (no states, outputs
 * at the time set), checking each call's status. stdout: the log, then "checks failed N";
 * exit status 0 when every status was the expected one, else 4 (each failure named on stderr).
 */
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static int failed;

static void expect(const char *what, fmi2Status got, fmi2Status want)
{
    if (got != want) {
        fprintf(stderr, "%s: status %d, expected %d\n", what, (int)got, (int)want);
        failed++;
    }
}

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env, (void)name, (void)category;
    printf("[%d] %s\n", (int)status, message);
}

int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {logger, NULL, NULL, NULL, NULL};
    fmi2ValueReference out[2], sp, vr4[4];
    fmi2Integer order[4] = {1, 1, 2, 2};
    fmi2Real y[4], x[1], one = 1.0, zero = 0.0;
    fmi2FMUstate st = NULL, st2 = NULL;
    fmi2Byte *buf;
    fmi2Component c;
    size_t size = 0;
    int k;
    if (argc != 5) {
        fprintf(stderr, "usage: road_host GUID DISPLACEMENT_VR VELOCITY_VR SPEED_VR\n");
        return 1;
    }
    out[0] = (fmi2ValueReference)atoi(argv[2]);
    out[1] = (fmi2ValueReference)atoi(argv[3]);
    sp = (fmi2ValueReference)atoi(argv[4]);
    vr4[0] = vr4[2] = out[0];
    vr4[1] = vr4[3] = out[1];
    c = fmi2Instantiate("road", fmi2CoSimulation, argv[1], "", &cb, fmi2False, fmi2False);
    if (c == NULL)
        return 2;
    expect("GetReal instantiated", fmi2GetReal(c, out, 2, y), fmi2Error);
    expect("SetupExperiment", fmi2SetupExperiment(c, 0, 0, 2.5, 0, 0), fmi2OK);
    expect("EnterInitializationMode", fmi2EnterInitializationMode(c), fmi2OK);
    expect("GetReal initialization", fmi2GetReal(c, out, 2, y), fmi2OK);
    expect("ExitInitializationMode", fmi2ExitInitializationMode(c), fmi2OK);
    for (k = 0; k < 100; k++)
        expect("DoStep", fmi2DoStep(c, 2.5 + k * 1e-3, 1e-3, fmi2True), fmi2OK);
    expect("DoStep from 0", fmi2DoStep(c, 0.0, 1e-3, fmi2True), fmi2Error);
    expect("GetRealOutputDerivatives", fmi2GetRealOutputDerivatives(c, vr4, 4, order, y), fmi2OK);
    printf("derivatives %.17g %.17g %.17g %.17g\n", y[0], y[1], y[2], y[3]);
    expect("SetRealInputDerivatives", fmi2SetRealInputDerivatives(c, &sp, 1, order, &one),
           fmi2Error);
    expect("GetDirectionalDerivative",
           fmi2GetDirectionalDerivative(c, out, 1, &sp, 1, &one, y), fmi2Error);
    expect("GetFMUstate", fmi2GetFMUstate(c, &st), fmi2OK);
    expect("SerializedFMUstateSize", fmi2SerializedFMUstateSize(c, st, &size), fmi2OK);
    buf = malloc(size ? size : 1);
    if (buf == NULL)
        return 2;
    expect("SerializeFMUstate", fmi2SerializeFMUstate(c, st, buf, size), fmi2OK);
    expect("DeSerializeFMUstate", fmi2DeSerializeFMUstate(c, buf, size, &st2), fmi2OK);
    expect("SetFMUstate", fmi2SetFMUstate(c, st2), fmi2OK);
    expect("Terminate", fmi2Terminate(c), fmi2OK);
    expect("DoStep terminated", fmi2DoStep(c, 2.6, 1e-3, fmi2True), fmi2Error);
    expect("Reset", fmi2Reset(c), fmi2OK);
    expect("SetReal speed 0", fmi2SetReal(c, &sp, 1, &zero), fmi2OK);
    expect("EnterInitializationMode", fmi2EnterInitializationMode(c), fmi2OK);
    expect("ExitInitializationMode speed 0", fmi2ExitInitializationMode(c), fmi2Error);
    expect("DoStep failed", fmi2DoStep(c, 0.0, 1e-3, fmi2True), fmi2Error);
    expect("FreeFMUstate", fmi2FreeFMUstate(c, &st), fmi2OK);
    expect("FreeFMUstate", fmi2FreeFMUstate(c, &st2), fmi2OK);
    free(buf);
    fmi2FreeInstance(c);

    c = fmi2Instantiate("me", fmi2ModelExchange, argv[1], "", &cb, fmi2False, fmi2False);
    if (c == NULL)
        return 2;
    expect("ME SetupExperiment", fmi2SetupExperiment(c, 0, 0, 1.0, 0, 0), fmi2OK);
    expect("ME EnterInitializationMode", fmi2EnterInitializationMode(c), fmi2OK);
    expect("ME ExitInitializationMode", fmi2ExitInitializationMode(c), fmi2OK);
    expect("ME GetContinuousStates 0", fmi2GetContinuousStates(c, x, 0), fmi2OK);
    expect("ME GetDerivatives 0", fmi2GetDerivatives(c, x, 0), fmi2OK);
    expect("ME GetContinuousStates 1", fmi2GetContinuousStates(c, x, 1), fmi2Error);
    expect("ME SetTime", fmi2SetTime(c, 1.7), fmi2OK);
    expect("ME GetReal", fmi2GetReal(c, out, 2, y), fmi2OK);
    fmi2FreeInstance(c);
    printf("checks failed %d\n", failed);
    return failed ? 4 : 0;
}
