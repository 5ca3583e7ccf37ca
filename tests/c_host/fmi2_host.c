/*
 * A minimal FMI 2.0 co-simulation host in C: a non-Python host for the bodyvib body FMUs.
 *
 * Used by tests/test_fmu_c_host.py. It loads binaries/linux64/<modelIdentifier>.so from an
 * extracted FMU folder with dlopen, drives one instance through a seat bump and prints the
 * outputs, so the test can check that a C program (no Python of its own) runs the pythonfmu
 * FMUs and exits cleanly.
 *
 *   fmi2_host [--nan-step K] [--null-get K] [--skip-finalize]
 *             FMU_DIR MODEL_IDENTIFIER GUID IN_VRS OUT_VRS STEP_SIZE N_STEPS
 *
 *   FMU_DIR           extracted FMU folder (modelDescription.xml, binaries/, resources/)
 *   IN_VRS            value references of seat_displacement and seat_velocity, e.g. "0,1"
 *   OUT_VRS           value references of the outputs to print, e.g. "2,3,4,5"
 *   STEP_SIZE         communication step h, s
 *   N_STEPS           number of doStep calls; communication points t_k = k h, k = 0..N_STEPS
 *   --nan-step K      before the normal step from t_K, set seat_displacement = NaN and call
 *                     fmi2DoStep once, printing the status it returns; then go on as usual.
 *   --null-get K      before the step from t_K, call fmi2GetReal(c, NULL, 3, NULL) (a host
 *                     bug: three values asked for with no arrays), printing
 *                     "nullget K status" if it returns.
 *   --skip-finalize   do not call finalizePythonInterpreter before exiting (see "Exit" below).
 *
 * Seat motion (computed here, in C): a triangular bump of height BUMP_HEIGHT that rises from
 * BUMP_START over BUMP_LENGTH/2 and falls back over BUMP_LENGTH/2:
 *     x(t) = BUMP_HEIGHT * max(0, 1 - |2 (t - BUMP_START) / BUMP_LENGTH - 1|)   [m]
 * and at each communication point the velocity input is the slope over the coming step,
 *     v_k = (x(t_{k+1}) - x(t_k)) / h                                             [m/s]
 * (the FMUs extrapolate seat_displacement at seat_velocity over a step).
 *
 * stdout, one line per communication point k = 0..N_STEPS (inputs set, outputs read, then
 * the step from t_k taken; the final point takes no step and prints status -1):
 *     k t_k x_k v_k y_1 ... y_m status_of_fmi2DoStep
 * with %.17g values; "refused K status" for the NaN step; "terminate status", "done" after
 * fmi2FreeInstance, "finalized" after finalizePythonInterpreter and "closed" after dlclose. The FMU's log messages go to stderr as
 *     [log] <instance> <status> <category>: <message>
 *
 * Exit. pythonfmu 0.7.0's linux64 binary cannot be unloaded (dlclose leaves it loaded: it
 * has STB_GNU_UNIQUE symbols), so its teardown runs at process exit, in the wrong order: the
 * exit handlers first destroy its static std::shared_ptr<PyState>, then its
 * __attribute__((destructor)) assigns nullptr to that destroyed pointer, touching freed
 * memory (valgrind: invalid read in finalizePythonInterpreter); whether that aborts the
 * process depends on the heap's history. The binary exports that function, and calling it
 * once every instance is freed releases the state (finalizing the Python it started) and
 * empties the pointer, after which the exit-time teardown has nothing to do. So this host
 * calls finalizePythonInterpreter after fmi2FreeInstance and then returns from main
 * normally; --skip-finalize leaves the call out, to show the difference.
 *
 * Exit status: 0 success, 1 usage, 2 cannot load the FMU binary or a function, 3 an FMI call
 * returned an unexpected status (named on stderr). The error exits after the binary is
 * loaded go through _exit (an instance may still be alive; nothing is released).
 *
 * Build: gcc -std=c99 -O2 -ffp-contract=off -I<fmpy>/c-code fmi2_host.c -o fmi2_host -ldl -lm
 * (the FMI 2.0 headers are the ones shipped with fmpy, in its c-code folder).
 */
#define _XOPEN_SOURCE 700 /* realpath */

#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "host_load.h"

#define BUMP_HEIGHT 0.02 /* m */
#define BUMP_START 0.1   /* s */
#define BUMP_LENGTH 0.1  /* s */
#define MAX_VRS 64

static double seat_displacement(double t)
{
    double r = 1.0 - fabs(2.0 * (t - BUMP_START) / BUMP_LENGTH - 1.0);
    return BUMP_HEIGHT * (r > 0.0 ? r : 0.0);
}

static const char *status_name(fmi2Status s)
{
    switch (s) {
    case fmi2OK: return "fmi2OK";
    case fmi2Warning: return "fmi2Warning";
    case fmi2Discard: return "fmi2Discard";
    case fmi2Error: return "fmi2Error";
    case fmi2Fatal: return "fmi2Fatal";
    case fmi2Pending: return "fmi2Pending";
    }
    return "unknown";
}

/* The message is printed as it is, not used as a format: pythonfmu passes plain text,
 * which may contain '%'. */
static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    fprintf(stderr, "[log] %s %s %s: %s\n", instance ? instance : "?", status_name(status),
            category ? category : "", message ? message : "");
    fflush(stderr);
}

/* Leave on an error, without pythonfmu's exit-time teardown (see "Exit" above). */
static void finish(int code)
{
    fflush(stdout);
    fflush(stderr);
    _exit(code);
}

static size_t parse_vrs(const char *text, fmi2ValueReference *vrs, const char *what)
{
    size_t n = 0;
    const char *p = text;
    while (*p) {
        char *end;
        unsigned long v = strtoul(p, &end, 10);
        if (end == p || n == MAX_VRS || v > UINT_MAX) {
            fprintf(stderr, "fmi2_host: %s must be comma-separated value references, got '%s'\n",
                    what, text);
            exit(1);
        }
        vrs[n++] = (fmi2ValueReference)v;
        p = *end == ',' ? end + 1 : end;
        if (*end && *end != ',') {
            fprintf(stderr, "fmi2_host: bad character in %s '%s'\n", what, text);
            exit(1);
        }
    }
    return n;
}

/* file:// URI of an absolute path, percent-encoding all but unreserved characters and '/'. */
static char *file_uri(const char *path)
{
    char *uri = malloc(7 + 3 * strlen(path) + 1), *q;
    const unsigned char *p;
    strcpy(uri, "file://");
    q = uri + 7;
    for (p = (const unsigned char *)path; *p; p++) {
        if (isalnum(*p) || strchr("-._~/", *p))
            *q++ = (char)*p;
        else
            q += sprintf(q, "%%%02X", *p);
    }
    *q = '\0';
    return uri;
}

static void check(fmi2Status s, const char *call)
{
    if (s != fmi2OK) {
        fprintf(stderr, "fmi2_host: %s returned %s (%d)\n", call, status_name(s), (int)s);
        finish(3);
    }
}

int main(int argc, char **argv)
{
    fmi2ValueReference in_vrs[MAX_VRS], out_vrs[MAX_VRS];
    fmi2Real inputs[2], outputs[MAX_VRS];
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    char path[PATH_MAX], dir[PATH_MAX];
    size_t n_in, n_out, i;
    long k, n_steps, nan_step = -1, null_step = -1;
    double h;
    char *uri, *end;
    void *lib;
    fmi2Component c;
    HostCs cs;
    void (*finalize)(void);
    int skip_finalize = 0;

    while (argc > 1 && strncmp(argv[1], "--", 2) == 0) {
        /* --nan-step K, --null-get K: the step index K into the option's variable */
        long *step = strcmp(argv[1], "--nan-step") == 0   ? &nan_step
                     : strcmp(argv[1], "--null-get") == 0 ? &null_step
                                                          : NULL;
        if (step != NULL && argc > 2) {
            *step = strtol(argv[2], &end, 10);
            if (*end || *step < 0) {
                fprintf(stderr, "fmi2_host: %s needs a step index >= 0\n", argv[1]);
                return 1;
            }
            argv += 2;
            argc -= 2;
        } else if (strcmp(argv[1], "--skip-finalize") == 0) {
            skip_finalize = 1;
            argv++;
            argc--;
        } else {
            fprintf(stderr, "fmi2_host: unknown option %s\n", argv[1]);
            return 1;
        }
    }
    if (argc != 8) {
        fprintf(stderr, "usage: fmi2_host [--nan-step K] [--null-get K] [--skip-finalize] FMU_DIR "
                        "MODEL_IDENTIFIER GUID IN_VRS OUT_VRS STEP_SIZE N_STEPS\n");
        return 1;
    }
    if (realpath(argv[1], dir) == NULL) {
        fprintf(stderr, "fmi2_host: FMU folder %s not found\n", argv[1]);
        return 1;
    }
    n_in = parse_vrs(argv[4], in_vrs, "IN_VRS");
    n_out = parse_vrs(argv[5], out_vrs, "OUT_VRS");
    h = strtod(argv[6], &end);
    if (*end || !(h > 0.0)) {
        fprintf(stderr, "fmi2_host: STEP_SIZE must be a positive number, got '%s'\n", argv[6]);
        return 1;
    }
    n_steps = strtol(argv[7], &end, 10);
    if (n_in != 2 || n_out == 0 || *end || n_steps < 1) {
        fprintf(stderr, "fmi2_host: need 2 input value references (displacement, velocity), "
                        "at least one output and N_STEPS >= 1\n");
        return 1;
    }

    if (snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, argv[2]) >= (int)sizeof path) {
        fprintf(stderr, "fmi2_host: path too long\n");
        return 1;
    }
    lib = host_open(path);
    if (lib == NULL) {
        fprintf(stderr, "fmi2_host: dlopen failed: %s\n", host_error());
        return 2;
    }
    host_load_cs(&cs, lib, "fmi2_host", finish);
    /* pythonfmu's, see "Exit" */
    *(void **)&finalize = host_symbol(lib, "finalizePythonInterpreter", "fmi2_host", finish);

    if (snprintf(path, sizeof path, "%s/resources", dir) >= (int)sizeof path) {
        fprintf(stderr, "fmi2_host: path too long\n");
        return 1;
    }
    uri = file_uri(path);
    c = cs.instantiate("c_host", fmi2CoSimulation, argv[3], uri, &callbacks, fmi2False, fmi2True);
    free(uri);
    if (c == NULL) {
        fprintf(stderr, "fmi2_host: fmi2Instantiate returned NULL\n");
        finish(3);
    }
    check(cs.setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
    check(cs.enter_init(c), "fmi2EnterInitializationMode");
    check(cs.exit_init(c), "fmi2ExitInitializationMode");

    for (k = 0; k <= n_steps; k++) {
        double t = k * h;
        int step_status = -1; /* no step from the final point */
        if (k == nan_step) {
            inputs[0] = NAN;
            inputs[1] = 0.0;
            check(cs.set_real(c, in_vrs, 2, inputs), "fmi2SetReal (NaN)");
            printf("refused %ld %d\n", k, (int)cs.do_step(c, t, h, fmi2True));
        }
        if (k == null_step) {
            fflush(stdout);
            printf("nullget %ld %d\n", k, (int)cs.get_real(c, NULL, 3, NULL));
        }
        inputs[0] = seat_displacement(t);
        inputs[1] = (seat_displacement((k + 1) * h) - inputs[0]) / h;
        check(cs.set_real(c, in_vrs, 2, inputs), "fmi2SetReal");
        check(cs.get_real(c, out_vrs, n_out, outputs), "fmi2GetReal");
        if (k < n_steps) {
            fmi2Status status = cs.do_step(c, t, h, fmi2True);
            if (status != fmi2OK) {
                fprintf(stderr, "fmi2_host: fmi2DoStep at t = %.17g returned %s (%d)\n", t,
                        status_name(status), (int)status);
                finish(3);
            }
            step_status = (int)status;
        }
        printf("%ld %.17g %.17g %.17g", k, t, inputs[0], inputs[1]);
        for (i = 0; i < n_out; i++)
            printf(" %.17g", outputs[i]);
        printf(" %d\n", step_status);
    }

    printf("terminate %d\n", (int)cs.terminate(c));
    cs.free_instance(c);
    printf("done\n");
    if (!skip_finalize) {
        finalize(); /* release pythonfmu's interpreter state now, not at exit */
        printf("finalized\n");
    }
    fflush(stdout);
    if (dlclose(lib) != 0) {
        fprintf(stderr, "fmi2_host: dlclose failed: %s\n", dlerror());
        finish(2);
    }
    printf("closed\n");
    return 0; /* the exit handlers run pythonfmu's teardown */
}
