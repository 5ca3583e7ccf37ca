/*
 * An FMI 2.0 co-simulation host in C for the bodyvib native FMUs (tests/test_native_host.py).
 *
 * It loads the FMU binary (dlopen on POSIX, LoadLibrary on Windows: the same source is
 * cross-compiled with mingw-w64 and run under wine), drives instances through a seat
 * chirp computed here and prints what it sees. No Python, no environment needed.
 *
 *   native_host [--resources URI] MODE BINARY GUID IN_VRS OUT_VRS STEP N_STEPS [MASS_VR]
 *
 *   MODE      run      one instance through the chirp, fixed step STEP
 *             vary     the same with varying steps h_k = STEP (1 + 0.5 frac(0.6180339887 k))
 *             threads  (POSIX) two instances of different amplitude on two threads, each
 *                      checked bit for bit against the same run done before on this thread
 *             checks   status codes, FMU state get/set/serialize, reset (needs MASS_VR: the
 *                      value reference of a mass parameter)
 *             fsm      the FMI state machine: calls out of order (each must return fmi2Error
 *                      and change nothing), fmi2SetupExperiment's start time (needs MASS_VR)
 *             overflow finite inputs that overflow, a huge step with the velocity never set,
 *                      crafted FMU states, a denormal mass then Reset (needs MASS_VR)
 *             misuse   fmi2SetReal and fmi2GetReal with n = SIZE_MAX and one-element arrays
 *                      (malloc'd, so memcheck sees a read past them) whose reference is
 *                      unknown: each must be refused without reading past the arrays;
 *                      prints "setreal STATUS", "getreal STATUS"
 *             bench    N_STEPS of set input + doStep + get output, 7 times; prints wall-clock
 *                      and thread CPU time per step of each and the best
 *             bench-vary  the same with a new step size at every step (each step
 *                      rediscretizes: the cost of a step-size change)
 *   --resources  the fmuResourceLocation passed to fmi2Instantiate (default ""; the native
 *                FMUs need none, a pythonfmu FMU benchmarked here needs its file:// URI)
 *   BINARY    path of binaries/<platform>/<id>.so or .dll
 *   IN_VRS    value references of seat_displacement and seat_velocity ("0,1")
 *   OUT_VRS   value references of the outputs to print ("2,3,4,5")
 *
 * Chirp: x(t) = A sin(2 pi (F0 t + (F1 - F0) t^2 / (2 T))), v = dx/dt exactly, T the run's
 * length; the inputs at each communication point are x(t_k), v(t_k).
 *
 * stdout (run, vary): "libpython absent|present" (POSIX: from /proc/self/maps), then one
 * line per communication point "k t_k x_k v_k y_1 ... y_m" (%.17g), then "ok".
 * checks: one "name value" line per check, then "ok". Exit status: 0 success, 1 usage,
 * 2 cannot load the binary or a function, 3 an FMI call returned an unexpected status,
 * 4 a check failed (named on stderr).
 *
 * Build: gcc -std=c99 -O2 -I<fmpy>/c-code native_host.c -o native_host -ldl -lm -lpthread
 *        x86_64-w64-mingw32-gcc -std=c99 -O2 -static -I<fmpy>/c-code native_host.c -o host.exe
 */
#define _XOPEN_SOURCE 700

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#ifndef _WIN32
#include <pthread.h>
#include <unistd.h>
#endif

#include "fmi2Functions.h"
#include "host_load.h"

#define AMPLITUDE 0.01 /* m */
#define F0 0.5         /* Hz */
#define F1 20.0        /* Hz */
#define MAX_VRS 16

/* The functions beyond the state machine's (cs, host_load.h). */
typedef struct {
    fmi2ResetTYPE *reset;
    fmi2GetFMUstateTYPE *get_state;
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
    fmi2SerializedFMUstateSizeTYPE *state_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    fmi2GetRealStatusTYPE *real_status;
} Api;

static HostCs cs;
static Api api;
static const char *guid;
static fmi2ValueReference in_vrs[2], out_vrs[MAX_VRS];
static size_t n_out;
static int quiet_log;
static const char *resources = "";
static double t_offset; /* the run's start time (fmi2SetupExperiment) */

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    (void)message;
    if (quiet_log)
        return;
    /* the bodyvib FMUs pass the text as the one "%s" argument */
    {
        va_list ap;
        va_start(ap, message);
        fprintf(stderr, "[log] %s %d %s: ", instance ? instance : "?", (int)status,
                category ? category : "");
        vfprintf(stderr, message, ap);
        fprintf(stderr, "\n");
        va_end(ap);
    }
}

/* A function of the binary, or exit 2. */
static void *symbol(void *lib, const char *name)
{
    return host_symbol(lib, name, "native_host", exit);
}

static void load(const char *path)
{
    void *lib = host_open(path);
    if (lib == NULL) {
        fprintf(stderr, "native_host: cannot load %s\n", path);
        exit(2);
    }
    host_load_cs(&cs, lib, "native_host", exit);
    *(void **)&api.reset = symbol(lib, "fmi2Reset");
    *(void **)&api.get_state = symbol(lib, "fmi2GetFMUstate");
    *(void **)&api.set_state = symbol(lib, "fmi2SetFMUstate");
    *(void **)&api.free_state = symbol(lib, "fmi2FreeFMUstate");
    *(void **)&api.state_size = symbol(lib, "fmi2SerializedFMUstateSize");
    *(void **)&api.serialize = symbol(lib, "fmi2SerializeFMUstate");
    *(void **)&api.deserialize = symbol(lib, "fmi2DeSerializeFMUstate");
    *(void **)&api.real_status = symbol(lib, "fmi2GetRealStatus");
}

static void expect(fmi2Status got, fmi2Status want, const char *call)
{
    if (got != want) {
        fprintf(stderr, "native_host: %s returned %d, expected %d\n", call, (int)got, (int)want);
        exit(3);
    }
}

#ifndef _WIN32
static void fail(const char *what)
{
    fprintf(stderr, "native_host: check failed: %s\n", what);
    exit(4);
}
#endif

static size_t parse_vrs(const char *text, fmi2ValueReference *vrs, size_t max)
{
    size_t n = 0;
    char *end;
    while (*text && n < max) {
        vrs[n++] = (fmi2ValueReference)strtoul(text, &end, 10);
        if (end == text)
            break;
        text = *end == ',' ? end + 1 : end;
    }
    return n;
}

static fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static fmi2Component start(const char *name)
{
    fmi2Component c = cs.instantiate(name, fmi2CoSimulation, guid, resources, &callbacks, fmi2False,
                                      fmi2False);
    if (c == NULL) {
        fprintf(stderr, "native_host: fmi2Instantiate returned NULL\n");
        exit(3);
    }
    expect(cs.setup(c, fmi2False, 0.0, t_offset, fmi2False, 0.0), fmi2OK, "fmi2SetupExperiment");
    expect(cs.enter_init(c), fmi2OK, "fmi2EnterInitializationMode");
    expect(cs.exit_init(c), fmi2OK, "fmi2ExitInitializationMode");
    return c;
}

static void chirp(double t, double T, double amp, double *x, double *v)
{
    double phase = 2.0 * M_PI * (F0 * t + (F1 - F0) * t * t / (2.0 * T));
    *x = amp * sin(phase);
    *v = amp * 2.0 * M_PI * (F0 + (F1 - F0) * t / T) * cos(phase);
}

static double step_size(double h, long k, int vary)
{
    double f;
    if (!vary)
        return h;
    f = 0.6180339887 * (double)k;
    return h * (1.0 + 0.5 * (f - floor(f)));
}

/* Run one instance from its current state through the chirp; outputs into y (n_steps+1 rows). */
static void run(fmi2Component c, double h, long n_steps, int vary, double amp, double *y,
                double *tx, long from, long to)
{
    long k;
    double t = 0.0, T = 0.0, in[2];
    for (k = 0; k < n_steps; k++)
        T += step_size(h, k, vary);
    for (k = 0; k < from; k++)
        t += step_size(h, k, vary);
    for (k = from; k <= to; k++) {
        double hk = step_size(h, k, vary);
        chirp(t, T, amp, &in[0], &in[1]);
        expect(cs.set_real(c, in_vrs, 2, in), fmi2OK, "fmi2SetReal");
        expect(cs.get_real(c, out_vrs, n_out, y + (size_t)k * n_out), fmi2OK, "fmi2GetReal");
        if (tx) {
            tx[3 * k] = t;
            tx[3 * k + 1] = in[0];
            tx[3 * k + 2] = in[1];
        }
        if (k < to) {
            expect(cs.do_step(c, t_offset + t, hk, fmi2True), fmi2OK, "fmi2DoStep");
            t += hk;
        }
    }
}

static void libpython_line(void)
{
#ifdef _WIN32
    printf("libpython unknown\n");
#else
    char line[4096];
    int found = 0;
    FILE *maps = fopen("/proc/self/maps", "r");
    if (maps == NULL) {
        printf("libpython unknown\n");
        return;
    }
    while (fgets(line, sizeof line, maps))
        if (strstr(line, "libpython"))
            found = 1;
    fclose(maps);
    printf("libpython %s\n", found ? "present" : "absent");
#endif
}

#ifndef _WIN32
typedef struct {
    double h, amp;
    long n;
    double *y;
} Job;

static void *worker(void *arg)
{
    Job *j = arg;
    long r;
    for (r = 0; r < 20; r++) { /* repeat, so the two threads overlap */
        fmi2Component c = start("thread");
        run(c, j->h, j->n, 0, j->amp, j->y + (size_t)r * (j->n + 1) * n_out, NULL, 0, j->n);
        cs.terminate(c);
        cs.free_instance(c);
    }
    return NULL;
}
#endif

/* A pythonfmu FMU (benchmarked for comparison) must release its interpreter before exit,
 * and its exit-time teardown is skipped (see fmi2_host.c, "Exit"); a native FMU has no
 * finalizePythonInterpreter. */
#ifndef _WIN32
static void finish_python(const char *path)
{
    void *lib = dlopen(path, RTLD_NOW | RTLD_NOLOAD);
    void (*finalize)(void) = NULL;
    if (lib != NULL)
        *(void **)&finalize = dlsym(lib, "finalizePythonInterpreter");
    if (finalize != NULL) {
        finalize();
        printf("ok\n");
        fflush(stdout);
        _exit(0);
    }
}
#endif

static int same(const double *a, const double *b, size_t n)
{
    return memcmp(a, b, n * sizeof *a) == 0;
}

int main(int argc, char **argv)
{
    const char *mode;
    double h;
    long n_steps, k;
    size_t rows, i;
    double *y, *tx;
    fmi2Component c;

    if (argc > 2 && strcmp(argv[1], "--resources") == 0) {
        resources = argv[2];
        argv += 2;
        argc -= 2;
    }
    if (argc < 8) {
        fprintf(stderr, "usage: native_host MODE BINARY GUID IN_VRS OUT_VRS STEP N_STEPS "
                        "[MASS_VR]\n");
        return 1;
    }
    mode = argv[1];
    guid = argv[3];
    if (parse_vrs(argv[4], in_vrs, 2) != 2 || (n_out = parse_vrs(argv[5], out_vrs, MAX_VRS)) == 0)
        return 1;
    h = strtod(argv[6], NULL);
    n_steps = strtol(argv[7], NULL, 10);
    if (!(h > 0.0) || n_steps < 2)
        return 1;
    load(argv[2]);
    rows = (size_t)n_steps + 1;
    y = calloc(rows * n_out * 3, sizeof *y);
    tx = calloc(rows * 3, sizeof *tx);

    if (strcmp(mode, "run") == 0 || strcmp(mode, "vary") == 0) {
        libpython_line();
        c = start("run");
        run(c, h, n_steps, strcmp(mode, "vary") == 0, AMPLITUDE, y, tx, 0, n_steps);
        expect(cs.terminate(c), fmi2OK, "fmi2Terminate");
        cs.free_instance(c);
        for (k = 0; k <= n_steps; k++) {
            printf("%ld %.17g %.17g %.17g", k, tx[3 * k], tx[3 * k + 1], tx[3 * k + 2]);
            for (i = 0; i < n_out; i++)
                printf(" %.17g", y[(size_t)k * n_out + i]);
            printf("\n");
        }
    } else if (strcmp(mode, "threads") == 0) {
#ifdef _WIN32
        printf("threads skipped\n");
#else
        Job jobs[2];
        pthread_t th[2];
        double *ref[2];
        int j;
        long r;
        for (j = 0; j < 2; j++) {
            jobs[j].h = h;
            jobs[j].n = n_steps;
            jobs[j].amp = AMPLITUDE * (j + 1);
            jobs[j].y = calloc(rows * n_out * 20, sizeof(double));
            ref[j] = calloc(rows * n_out, sizeof(double));
            c = start("sequential");
            run(c, h, n_steps, 0, jobs[j].amp, ref[j], NULL, 0, n_steps);
            cs.free_instance(c);
        }
        for (j = 0; j < 2; j++)
            pthread_create(&th[j], NULL, worker, &jobs[j]);
        for (j = 0; j < 2; j++)
            pthread_join(th[j], NULL);
        for (j = 0; j < 2; j++)
            for (r = 0; r < 20; r++)
                if (!same(jobs[j].y + (size_t)r * rows * n_out, ref[j], rows * n_out))
                    fail("a thread's run differs from the sequential run");
        if (same(ref[0], ref[1], rows * n_out))
            fail("the two amplitudes gave the same outputs");
        for (j = 0; j < 2; j++) {
            free(jobs[j].y);
            free(ref[j]);
        }
        printf("threads identical\n");
#endif
    } else if (strcmp(mode, "checks") == 0) {
        fmi2ValueReference mass_vr;
        fmi2FMUstate s = NULL, s2 = NULL;
        size_t size;
        fmi2Byte *bytes;
        double *y2 = y + rows * n_out, *y3 = y2 + rows * n_out, in[2], v;
        long half = n_steps / 2;
        if (argc < 9)
            return 1;
        mass_vr = (fmi2ValueReference)strtoul(argv[8], NULL, 10);
        quiet_log = 0;
        /* non-finite input and non-positive step: fmi2Error, and the state is unchanged */
        c = start("checks");
        in[0] = NAN;
        in[1] = 0.0;
        expect(cs.set_real(c, in_vrs, 2, in), fmi2OK, "fmi2SetReal NaN");
        printf("nan_step %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        in[0] = 0.0;
        in[1] = INFINITY;
        expect(cs.set_real(c, in_vrs, 2, in), fmi2OK, "fmi2SetReal inf");
        printf("inf_step %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        in[1] = 0.0;
        expect(cs.set_real(c, in_vrs, 2, in), fmi2OK, "fmi2SetReal 0");
        printf("negative_step %d\n", (int)cs.do_step(c, 0.0, -h, fmi2True));
        printf("zero_step %d\n", (int)cs.do_step(c, 0.0, 0.0, fmi2True));
        /* after the refusals the run equals a fresh one */
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, n_steps);
        cs.free_instance(c);
        c = start("fresh");
        run(c, h, n_steps, 0, AMPLITUDE, y2, NULL, 0, n_steps);
        printf("refusals_leave_state %d\n", same(y, y2, rows * n_out));
        cs.free_instance(c);
        /* an invalid parameter: fmi2ExitInitializationMode returns fmi2Error; steps refused */
        c = cs.instantiate("mass", fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
        v = -1.0;
        expect(cs.set_real(c, &mass_vr, 1, &v), fmi2OK, "fmi2SetReal mass");
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        printf("negative_mass_init %d\n", (int)cs.exit_init(c));
        printf("negative_mass_step %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        /* reset: back to the defaults; the run equals a fresh one */
        expect(api.reset(c), fmi2OK, "fmi2Reset");
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        expect(cs.exit_init(c), fmi2OK, "fmi2ExitInitializationMode after reset");
        run(c, h, n_steps, 0, AMPLITUDE, y3, NULL, 0, n_steps);
        printf("reset_equals_fresh %d\n", same(y3, y2, rows * n_out));
        cs.free_instance(c);
        /* FMU state: get at half-way, run on, restore, run again: bit-identical */
        c = start("state");
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, half); /* steps 0..half-1 */
        expect(api.get_state(c, &s), fmi2OK, "fmi2GetFMUstate");
        expect(api.state_size(c, s, &size), fmi2OK, "fmi2SerializedFMUstateSize");
        bytes = malloc(size);
        expect(api.serialize(c, s, bytes, size), fmi2OK, "fmi2SerializeFMUstate");
        memset(y3, 0, rows * n_out * sizeof *y3);
        /* on to the end from the half-way point; compare with the uninterrupted run y2 */
        {
            double *yy = calloc(rows * n_out, sizeof *yy);
            run(c, h, n_steps, 0, AMPLITUDE, yy, NULL, half, n_steps);
            printf("state_continue_equals_fresh %d\n",
                   same(yy + half * n_out, y2 + half * n_out, (rows - half) * n_out));
            expect(api.set_state(c, s), fmi2OK, "fmi2SetFMUstate");
            memset(yy, 0, rows * n_out * sizeof *yy);
            run(c, h, n_steps, 0, AMPLITUDE, yy, NULL, half, n_steps);
            printf("state_restore_equals_fresh %d\n",
                   same(yy + half * n_out, y2 + half * n_out, (rows - half) * n_out));
            expect(api.deserialize(c, bytes, size, &s2), fmi2OK, "fmi2DeSerializeFMUstate");
            expect(api.set_state(c, s2), fmi2OK, "fmi2SetFMUstate (deserialized)");
            memset(yy, 0, rows * n_out * sizeof *yy);
            run(c, h, n_steps, 0, AMPLITUDE, yy, NULL, half, n_steps);
            printf("deserialized_equals_fresh %d\n",
                   same(yy + half * n_out, y2 + half * n_out, (rows - half) * n_out));
            free(yy);
        }
        quiet_log = 1;
        bytes[size / 2] ^= 0x01;
        printf("corrupt_state %d\n", (int)api.deserialize(c, bytes, size, &s2));
        bytes[size / 2] ^= 0x01;
        printf("short_state %d\n", (int)api.deserialize(c, bytes, size - 8, &s2));
        bytes[0] = 'X';
        printf("foreign_state %d\n", (int)api.deserialize(c, bytes, size, &s2));
        quiet_log = 0;
        api.free_state(c, &s);
        api.free_state(c, &s2);
        free(bytes);
        cs.free_instance(c);
    } else if (strcmp(mode, "fsm") == 0) {
        /* every call out of order returns fmi2Error (3) and changes nothing */
        fmi2ValueReference mass_vr;
        double v, m0, in[2] = {0.0, 0.0}, out[MAX_VRS], last = -1.0;
        double *y2 = y + rows * n_out;
        if (argc < 9)
            return 1;
        mass_vr = (fmi2ValueReference)strtoul(argv[8], NULL, 10);
        c = cs.instantiate("fsm", fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
        printf("getreal_instantiated %d\n", (int)cs.get_real(c, out_vrs, n_out, out));
        printf("dostep_instantiated %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        printf("exit_instantiated %d\n", (int)cs.exit_init(c));
        printf("terminate_instantiated %d\n", (int)cs.terminate(c));
        printf("setreal_instantiated %d\n", (int)cs.set_real(c, in_vrs, 2, in));
        printf("setup_instantiated %d\n", (int)cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        printf("enter %d\n", (int)cs.enter_init(c));
        printf("setup_initialization %d\n",
               (int)cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        printf("enter_initialization %d\n", (int)cs.enter_init(c));
        printf("dostep_initialization %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        printf("terminate_initialization %d\n", (int)cs.terminate(c));
        printf("getreal_initialization %d\n", (int)cs.get_real(c, &mass_vr, 1, &m0));
        printf("exit %d\n", (int)cs.exit_init(c));
        printf("exit_stepping %d\n", (int)cs.exit_init(c));
        printf("enter_stepping %d\n", (int)cs.enter_init(c));
        v = 2.0 * m0;
        printf("set_parameter_stepping %d\n", (int)cs.set_real(c, &mass_vr, 1, &v));
        printf("dostep_wrong_time %d\n", (int)cs.do_step(c, 1.0, h, fmi2True));
        printf("dostep %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        {
            /* an unknown value reference after a valid one: Error, and nothing set */
            fmi2ValueReference bad[2];
            double two[2] = {0.5, 0.5}, x0 = -1.0, x1 = -2.0;
            bad[0] = in_vrs[0];
            bad[1] = 99999;
            cs.get_real(c, in_vrs, 1, &x0);
            printf("unknown_vr_set %d\n", (int)cs.set_real(c, bad, 2, two));
            cs.get_real(c, in_vrs, 1, &x1);
            printf("unknown_vr_nothing_set %d\n", x0 == x1);
        }
        printf("terminate %d\n", (int)cs.terminate(c));
        printf("dostep_terminated %d\n", (int)cs.do_step(c, h, h, fmi2True));
        printf("setreal_terminated %d\n", (int)cs.set_real(c, in_vrs, 2, in));
        printf("terminate_terminated %d\n", (int)cs.terminate(c));
        printf("getreal_terminated %d\n", (int)cs.get_real(c, &mass_vr, 1, &v));
        printf("parameter_unchanged %d\n", v == m0);
        printf("reset %d\n", (int)api.reset(c));
        printf("getreal_after_reset %d\n", (int)cs.get_real(c, out_vrs, n_out, out));
        cs.free_instance(c);
        /* a failed initialization is the error state: no step, no terminate; Reset recovers */
        c = cs.instantiate("failed", fmi2CoSimulation, guid, "", &callbacks, fmi2False,
                            fmi2False);
        v = -1.0;
        cs.set_real(c, &mass_vr, 1, &v);
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        printf("exit_invalid %d\n", (int)cs.exit_init(c));
        printf("dostep_failed %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        printf("terminate_failed %d\n", (int)cs.terminate(c));
        printf("getreal_failed %d\n", (int)cs.get_real(c, &mass_vr, 1, &v));
        printf("reset_failed %d\n", (int)api.reset(c));
        cs.free_instance(c);
        /* the start time: the model's time starts there, steps must start there, and a run
         * from 2.5 s equals the run from 0 (the model does not depend on the time) */
        c = start("from0");
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, n_steps);
        cs.free_instance(c);
        t_offset = 2.5;
        c = start("from2.5");
        api.real_status(c, fmi2LastSuccessfulTime, &last);
        printf("time_at_start %d\n", last == 2.5);
        printf("dostep_from_zero %d\n", (int)cs.do_step(c, 0.0, h, fmi2True));
        run(c, h, n_steps, 0, AMPLITUDE, y2, NULL, 0, n_steps);
        printf("start_time_run_equals %d\n", same(y, y2, rows * n_out));
        api.real_status(c, fmi2LastSuccessfulTime, &last);
        printf("last_time_ok %d\n", fabs(last - (2.5 + h * (double)n_steps)) < 1e-9);
        cs.free_instance(c);
        t_offset = 0.0;
    } else if (strcmp(mode, "overflow") == 0) {
        fmi2ValueReference mass_vr;
        double *y2 = y + rows * n_out, *y3 = y2 + rows * n_out, in[2], v, m0, out[MAX_VRS];
        double last = -1.0;
        long at = n_steps / 2, j;
        fmi2FMUstate s = NULL, s2 = NULL;
        size_t size;
        fmi2Byte *bytes;
        if (argc < 9)
            return 1;
        mass_vr = (fmi2ValueReference)strtoul(argv[8], NULL, 10);
        c = start("fresh");
        run(c, h, n_steps, 0, AMPLITUDE, y2, tx, 0, n_steps);
        cs.free_instance(c);
        /* finite inputs that overflow the step: discarded (2), nothing changed */
        c = start("overflow");
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, at);
        in[0] = in[1] = 1e308;
        expect(cs.set_real(c, in_vrs, 2, in), fmi2OK, "fmi2SetReal 1e308");
        printf("overflow_getreal %d\n", (int)cs.get_real(c, out_vrs, n_out, out));
        printf("overflow_step %d\n", (int)cs.do_step(c, tx[3 * at], h, fmi2True));
        api.real_status(c, fmi2LastSuccessfulTime, &last);
        printf("overflow_last_time %d\n", last == tx[3 * at]);
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, at, n_steps);
        printf("overflow_leaves_state %d\n", same(y + at * n_out, y2 + at * n_out,
                                                  (rows - at) * n_out));
        cs.free_instance(c);
        /* the velocity never set (its slope stands in): a huge step, then displacements
         * +-1e300, are refused and leave the slope bookkeeping as it was */
        for (j = 0; j < 2; j++) {
            double *yy = j ? y3 : y;
            long k;
            c = start("slope");
            for (k = 0; k <= n_steps; k++) {
                double x = tx[3 * k + 1];
                if (k == at) {
                    if (j == 0) {
                        printf("huge_step %d\n", (int)cs.do_step(c, tx[3 * k], 1e300, fmi2True));
                    } else {
                        v = 1e300;
                        cs.set_real(c, &in_vrs[0], 1, &v);
                        printf("huge_displacement %d\n",
                               (int)cs.do_step(c, tx[3 * k], h, fmi2True));
                        v = -1e300;
                        cs.set_real(c, &in_vrs[0], 1, &v);
                        printf("huge_displacement_back %d\n",
                               (int)cs.do_step(c, tx[3 * k], h, fmi2True));
                    }
                }
                expect(cs.set_real(c, &in_vrs[0], 1, &x), fmi2OK, "fmi2SetReal x");
                expect(cs.get_real(c, out_vrs, n_out, yy + (size_t)k * n_out), fmi2OK,
                       "fmi2GetReal");
                if (k < n_steps)
                    expect(cs.do_step(c, tx[3 * k], tx[3 * k + 3] - tx[3 * k], fmi2True),
                           fmi2OK, "fmi2DoStep");
            }
            cs.free_instance(c);
        }
        /* the undisturbed slope run */
        {
            long k;
            c = start("slope0");
            quiet_log = 1;
            for (k = 0; k <= n_steps; k++) {
                double x = tx[3 * k + 1];
                cs.set_real(c, &in_vrs[0], 1, &x);
                cs.get_real(c, out_vrs, n_out, y2 + (size_t)k * n_out);
                if (k < n_steps)
                    cs.do_step(c, tx[3 * k], tx[3 * k + 3] - tx[3 * k], fmi2True);
            }
            quiet_log = 0;
            /* a crafted state, checksum valid, bookkeeping inconsistent: refused */
            expect(api.get_state(c, &s), fmi2OK, "fmi2GetFMUstate");
            expect(api.state_size(c, s, &size), fmi2OK, "fmi2SerializedFMUstateSize");
            bytes = malloc(size);
            expect(api.serialize(c, s, bytes, size), fmi2OK, "fmi2SerializeFMUstate");
            cs.free_instance(c);
        }
        printf("huge_step_leaves_slope %d\n", same(y, y2, rows * n_out));
        printf("huge_displacement_leaves_slope %d\n", same(y3, y2, rows * n_out));
        {
            /* the pair's doubles (x_prev, h_prev, has_prev, vel_set, slope_on, warned) end
             * 8 bytes before the end (the checksum: FNV-1a of everything before it) */
            double pair[6], zero = 0.0;
            unsigned char *u = (unsigned char *)bytes, *q = u + size - 8 - sizeof pair;
            unsigned long long sum;
            int variant;
            c = start("crafted");
            for (variant = 0; variant < 3; variant++) {
                size_t b;
                expect(api.serialize(c, s, bytes, size), fmi2OK, "fmi2SerializeFMUstate");
                memcpy(pair, q, sizeof pair);
                if (variant == 0) {
                    pair[1] = zero; /* the slope in use, divided by a zero step */
                } else if (variant == 1) {
                    pair[2] = 0.0; /* the slope in use without a previous displacement */
                } else {
                    pair[3] = 1.0; /* the slope in use with the velocity set */
                }
                memcpy(q, pair, sizeof pair);
                sum = 1469598103934665603ULL;
                for (b = 0; b < size - 8; b++) {
                    sum ^= u[b];
                    sum *= 1099511628211ULL;
                }
                memcpy(bytes + size - 8, &sum, 8);
                printf("crafted_state_%d %d\n", variant,
                       (int)api.deserialize(c, bytes, size, &s2));
                api.free_state(c, &s2);
            }
            cs.free_instance(c);
        }
        api.free_state(c, &s);
        free(bytes);
        /* a denormal mass: initialization refused; Reset and valid parameters recover */
        c = start("fresh2");
        run(c, h, n_steps, 0, AMPLITUDE, y2, NULL, 0, n_steps);
        cs.free_instance(c);
        c = cs.instantiate("denormal", fmi2CoSimulation, guid, "", &callbacks, fmi2False,
                            fmi2False);
        v = 1e-310;
        cs.set_real(c, &mass_vr, 1, &v);
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        printf("denormal_init %d\n", (int)cs.exit_init(c));
        expect(api.reset(c), fmi2OK, "fmi2Reset");
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        printf("reset_init %d\n", (int)cs.exit_init(c));
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, n_steps);
        printf("denormal_reset_recovers %d\n", same(y, y2, rows * n_out));
        cs.free_instance(c);
        /* the same with the outputs read while the denormal mass was set, then the mass set
         * back (no Reset) */
        c = cs.instantiate("denormal2", fmi2CoSimulation, guid, "", &callbacks, fmi2False,
                            fmi2False);
        cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        cs.enter_init(c);
        cs.get_real(c, &mass_vr, 1, &m0);
        v = 1e-310;
        cs.set_real(c, &mass_vr, 1, &v);
        printf("denormal_getreal %d\n", (int)cs.get_real(c, out_vrs, n_out, out));
        cs.set_real(c, &mass_vr, 1, &m0);
        printf("mass_back_init %d\n", (int)cs.exit_init(c));
        run(c, h, n_steps, 0, AMPLITUDE, y, NULL, 0, n_steps);
        printf("denormal_mass_back_recovers %d\n", same(y, y2, rows * n_out));
        cs.free_instance(c);
#ifndef _WIN32
    } else if (strcmp(mode, "misuse") == 0) {
        /* a host that lies about n: the FMU cannot guard against it fully, but it refuses at
         * the first unknown reference and reads nothing after it */
        fmi2ValueReference *refs = malloc(sizeof *refs);
        double *values = malloc(sizeof *values);
        c = start("misuse");
        refs[0] = 0x7fffffffu;
        values[0] = 0.0;
        quiet_log = 1;
        printf("setreal %d\n", (int)cs.set_real(c, refs, (size_t)-1, values));
        printf("getreal %d\n", (int)cs.get_real(c, refs, (size_t)-1, values));
        quiet_log = 0;
        cs.free_instance(c);
        free(refs);
        free(values);
    } else if (strcmp(mode, "bench") == 0 || strcmp(mode, "bench-vary") == 0) {
        int vary = strcmp(mode, "bench-vary") == 0;
        double in[2] = {0.0, 0.0}, out[MAX_VRS], best = 1e300, best_cpu = 1e300, t0, t1, cpu;
        struct timespec a, b, ca, cb;
        int rep;
        double table[2 * 1024];
        for (k = 0; k < 1024; k++) { /* inputs computed before the clock starts */
            table[2 * k] = 1e-3 * sin(k * h * 30.0);
            table[2 * k + 1] = 3e-2 * cos(k * h * 30.0);
        }
        double tb = 0.0; /* the model's time runs on through the repetitions */
        c = start("bench");
        for (rep = 0; rep < 7; rep++) {
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ca);
            clock_gettime(CLOCK_MONOTONIC, &a);
            for (k = 0; k < n_steps; k++) {
                double hk = vary ? step_size(h, k, 1) : h;
                in[0] = table[2 * (k & 1023)];
                in[1] = table[2 * (k & 1023) + 1];
                cs.set_real(c, in_vrs, 2, in);
                if (cs.do_step(c, tb, hk, fmi2True) != fmi2OK) {
                    fprintf(stderr, "native_host: fmi2DoStep refused a benchmark step\n");
                    exit(3);
                }
                tb += hk;
                cs.get_real(c, out_vrs, n_out, out);
            }
            clock_gettime(CLOCK_MONOTONIC, &b);
            clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cb);
            t0 = (double)a.tv_sec * 1e9 + (double)a.tv_nsec;
            t1 = (double)b.tv_sec * 1e9 + (double)b.tv_nsec;
            cpu = ((double)cb.tv_sec * 1e9 + (double)cb.tv_nsec) -
                  ((double)ca.tv_sec * 1e9 + (double)ca.tv_nsec);
            printf("ns_per_step %.3f cpu_ns_per_step %.3f\n", (t1 - t0) / (double)n_steps,
                   cpu / (double)n_steps);
            if (t1 - t0 < best)
                best = t1 - t0;
            if (cpu < best_cpu)
                best_cpu = cpu;
        }
        cs.free_instance(c);
        printf("best_ns_per_step %.3f\n", best / (double)n_steps);
        printf("best_cpu_ns_per_step %.3f\n", best_cpu / (double)n_steps);
        finish_python(argv[2]);
#endif
    } else {
        fprintf(stderr, "native_host: unknown mode %s\n", mode);
        return 1;
    }
    free(y);
    free(tx);
    printf("ok\n");
    return 0;
}
