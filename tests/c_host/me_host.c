/*
 * An FMI 2.0 model-exchange host in C for the bodyvib native FMUs (tests/test_native_me.py).
 *
 * It loads the FMU binary (dlopen on POSIX, LoadLibrary on Windows: cross-compiled with
 * mingw-w64 and run under wine), instantiates it for model exchange and integrates it with
 * the classical fixed-step Runge-Kutta method (RK4), the inputs evaluated at every stage:
 * a sine displacement d(t) = A sin(w t) on value reference 0 and its exact derivative
 * v(t) = A w cos(w t) on value reference 1 (the FMU's displacement and velocity inputs);
 * the other inputs stay 0. Then it prints the exact Jacobian of the derivatives from
 * fmi2GetDirectionalDerivative, one unit seed per known (the states, then the inputs).
 *
 *   me_host [--modes] BINARY GUID N_STATES N_INPUTS STATE_VR0 DER_VR0 STEP N_STEPS AMPLITUDE
 *           FREQ_HZ
 *
 * stdout: one line per step "k t x_1 ... x_n" (%.17g), then one line per known
 * "jac j d_1 ... d_n" (the column of d(der)/d(known j)), then "ok". Exit status: 0 success,
 * 1 usage, 2 cannot load the binary or a function, 3 an FMI call did not return fmi2OK.
 *
 * --modes: instead, the model-exchange state machine after initialization: calls in Event
 * Mode and in Continuous-Time Mode, those of the other mode among them (each must return
 * fmi2Error, logged, and change nothing); stdout "name status" per call, then "ok".
 *
 * Build: gcc -std=c99 -O2 -I<fmpy>/c-code me_host.c -o me_host -ldl -lm
 *        x86_64-w64-mingw32-gcc -std=c99 -O2 -static -I<fmpy>/c-code me_host.c -o me_host.exe
 */
#define _XOPEN_SOURCE 700

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "host_load.h"

#define MAX_N 64

static void *lib;

/* A function of the binary, or exit 2. */
static void *fn(const char *name) { return host_symbol(lib, name, "me_host", exit); }

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    fprintf(stderr, "[%s %d %s] %s\n", name, (int)status, category, message);
}

#define CHECK(call)                                                                          \
    do {                                                                                     \
        if ((call) != fmi2OK) {                                                              \
            fprintf(stderr, "%s failed\n", #call);                                           \
            return 3;                                                                        \
        }                                                                                    \
    } while (0)

static fmi2SetTimeTYPE *set_time;
static fmi2SetRealTYPE *set_real;
static fmi2SetContinuousStatesTYPE *set_states;
static fmi2GetDerivativesTYPE *get_derivatives;
static double amplitude, omega;

/* dx = f(t, x): inputs at t, states x */
static int rhs(fmi2Component c, double t, const double *x, double *dx, size_t n)
{
    const fmi2ValueReference vr[2] = {0, 1};
    double u[2];
    u[0] = amplitude * sin(omega * t);
    u[1] = amplitude * omega * cos(omega * t);
    if (set_time(c, t) != fmi2OK || set_real(c, vr, 2, u) != fmi2OK ||
        set_states(c, x, n) != fmi2OK || get_derivatives(c, dx, n) != fmi2OK)
        return 0;
    return 1;
}

/* --modes (see the head of this file): the instance has just left initialization. */
static void modes(fmi2Component c, size_t n)
{
    fmi2EnterEventModeTYPE *event = (fmi2EnterEventModeTYPE *)fn("fmi2EnterEventMode");
    fmi2NewDiscreteStatesTYPE *discrete = (fmi2NewDiscreteStatesTYPE *)fn("fmi2NewDiscreteStates");
    fmi2EnterContinuousTimeModeTYPE *continuous =
        (fmi2EnterContinuousTimeModeTYPE *)fn("fmi2EnterContinuousTimeMode");
    fmi2CompletedIntegratorStepTYPE *completed =
        (fmi2CompletedIntegratorStepTYPE *)fn("fmi2CompletedIntegratorStep");
    fmi2GetContinuousStatesTYPE *get_states =
        (fmi2GetContinuousStatesTYPE *)fn("fmi2GetContinuousStates");
    fmi2EventInfo info;
    fmi2Boolean enter, stop;
    double x[MAX_N], before[MAX_N], after[MAX_N];
    size_t i;
    int same = 1;
    for (i = 0; i < n; i++)
        x[i] = 1e-3 * (double)(i + 1);
    printf("states_event %d\n", (int)get_states(c, before, n)); /* Event Mode */
    printf("setstates_event %d\n", (int)set_states(c, x, n));
    printf("completed_event %d\n", (int)completed(c, fmi2True, &enter, &stop));
    printf("settime_event %d\n", (int)set_time(c, 1e-3));
    printf("derivatives_event %d\n", (int)get_derivatives(c, after, n));
    printf("discrete_event %d\n", (int)discrete(c, &info));
    get_states(c, after, n);
    for (i = 0; i < n; i++)
        same = same && after[i] == before[i];
    printf("refusals_left_states %d\n", same);
    printf("continuous_event %d\n", (int)continuous(c)); /* into Continuous-Time Mode */
    printf("discrete_continuous %d\n", (int)discrete(c, &info));
    printf("continuous_continuous %d\n", (int)continuous(c));
    printf("setstates_continuous %d\n", (int)set_states(c, x, n));
    printf("completed_continuous %d\n", (int)completed(c, fmi2True, &enter, &stop));
    printf("event_continuous %d\n", (int)event(c)); /* back into Event Mode */
    printf("event_event %d\n", (int)event(c));      /* FMI 2.0 allows it there too */
    printf("setstates_event_again %d\n", (int)set_states(c, x, n));
    printf("terminate_event %d\n", (int)((fmi2TerminateTYPE *)fn("fmi2Terminate"))(c));
}

int main(int argc, char **argv)
{
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2InstantiateTYPE *instantiate;
    fmi2GetDirectionalDerivativeTYPE *directional;
    fmi2GetContinuousStatesTYPE *get_states;
    fmi2EventInfo info;
    fmi2Component c;
    fmi2ValueReference unknowns[MAX_N], known;
    double x[MAX_N], k1[MAX_N], k2[MAX_N], k3[MAX_N], k4[MAX_N], xs[MAX_N], h, t;
    size_t n, ni, i, j;
    long k, steps;
    unsigned state_vr0, der_vr0;
    int check_modes = argc > 1 && strcmp(argv[1], "--modes") == 0;
    argv += check_modes;
    argc -= check_modes;
    if (argc != 11) {
        fprintf(stderr, "usage: me_host [--modes] BINARY GUID N_STATES N_INPUTS STATE_VR0 DER_VR0 "
                        "STEP N_STEPS AMPLITUDE FREQ_HZ\n");
        return 1;
    }
    n = (size_t)atoi(argv[3]);
    ni = (size_t)atoi(argv[4]);
    state_vr0 = (unsigned)atoi(argv[5]);
    der_vr0 = (unsigned)atoi(argv[6]);
    h = atof(argv[7]);
    steps = atol(argv[8]);
    amplitude = atof(argv[9]);
    omega = 2.0 * 3.14159265358979323846 * atof(argv[10]);
    if (n == 0 || n > MAX_N || ni < 2 || !(h > 0.0) || steps < 1)
        return 1;
    lib = host_open(argv[1]);
    if (lib == NULL) {
        fprintf(stderr, "cannot load %s\n", argv[1]);
        return 2;
    }
    instantiate = (fmi2InstantiateTYPE *)fn("fmi2Instantiate");
    set_time = (fmi2SetTimeTYPE *)fn("fmi2SetTime");
    set_real = (fmi2SetRealTYPE *)fn("fmi2SetReal");
    set_states = (fmi2SetContinuousStatesTYPE *)fn("fmi2SetContinuousStates");
    get_states = (fmi2GetContinuousStatesTYPE *)fn("fmi2GetContinuousStates");
    get_derivatives = (fmi2GetDerivativesTYPE *)fn("fmi2GetDerivatives");
    directional = (fmi2GetDirectionalDerivativeTYPE *)fn("fmi2GetDirectionalDerivative");
    c = instantiate("me", fmi2ModelExchange, argv[2], "", &cb, fmi2False, fmi2False);
    if (c == NULL) {
        fprintf(stderr, "fmi2Instantiate(fmi2ModelExchange) returned NULL\n");
        return 3;
    }
    CHECK(((fmi2SetupExperimentTYPE *)fn("fmi2SetupExperiment"))(c, fmi2False, 0.0, 0.0,
                                                                   fmi2False, 0.0));
    CHECK(((fmi2EnterInitializationModeTYPE *)fn("fmi2EnterInitializationMode"))(c));
    CHECK(((fmi2ExitInitializationModeTYPE *)fn("fmi2ExitInitializationMode"))(c));
    if (check_modes) {
        modes(c, n);
        ((fmi2FreeInstanceTYPE *)fn("fmi2FreeInstance"))(c);
        printf("ok\n");
        return 0;
    }
    CHECK(((fmi2NewDiscreteStatesTYPE *)fn("fmi2NewDiscreteStates"))(c, &info));
    CHECK(((fmi2EnterContinuousTimeModeTYPE *)fn("fmi2EnterContinuousTimeMode"))(c));
    CHECK(get_states(c, x, n));
    printf("0 0");
    for (i = 0; i < n; i++)
        printf(" %.17g", x[i]);
    printf("\n");
    for (k = 0; k < steps; k++) {
        t = k * h;
        if (!rhs(c, t, x, k1, n))
            return 3;
        for (i = 0; i < n; i++)
            xs[i] = x[i] + 0.5 * h * k1[i];
        if (!rhs(c, t + 0.5 * h, xs, k2, n))
            return 3;
        for (i = 0; i < n; i++)
            xs[i] = x[i] + 0.5 * h * k2[i];
        if (!rhs(c, t + 0.5 * h, xs, k3, n))
            return 3;
        for (i = 0; i < n; i++)
            xs[i] = x[i] + h * k3[i];
        if (!rhs(c, t + h, xs, k4, n))
            return 3;
        for (i = 0; i < n; i++)
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        printf("%ld %.17g", k + 1, (k + 1) * h);
        for (i = 0; i < n; i++)
            printf(" %.17g", x[i]);
        printf("\n");
    }
    CHECK(set_states(c, x, n));
    CHECK(get_states(c, xs, n));
    for (i = 0; i < n; i++)
        if (xs[i] != x[i]) {
            fprintf(stderr, "GetContinuousStates does not return the states set\n");
            return 3;
        }
    for (i = 0; i < n; i++)
        unknowns[i] = der_vr0 + (fmi2ValueReference)i;
    for (j = 0; j < n + ni; j++) {
        double seed = 1.0;
        known = j < n ? state_vr0 + (fmi2ValueReference)j : (fmi2ValueReference)(j - n);
        CHECK(directional(c, unknowns, n, &known, 1, &seed, k1));
        printf("jac %lu", (unsigned long)j);
        for (i = 0; i < n; i++)
            printf(" %.17g", k1[i]);
        printf("\n");
    }
    ((fmi2TerminateTYPE *)fn("fmi2Terminate"))(c);
    ((fmi2FreeInstanceTYPE *)fn("fmi2FreeInstance"))(c);
    printf("ok\n");
    return 0;
}
