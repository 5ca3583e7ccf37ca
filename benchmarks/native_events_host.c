/*
 * The C host of benchmarks/bench_native_events.py: the native QuarterCar with its tire
 * contact and stops against the same car built linearized, in one process.
 *
 *     native_events_host NL_BINARY NL_TOKEN LIN_BINARY LIN_TOKEN STEPS ROUNDS BUMP_STEPS
 *
 * Every step sets road_displacement and road_velocity (value references 0 and 1), does the
 * step of 1 ms and reads seat_displacement and tire_force (4 and 8 in both: the contract's
 * order). Output lines:
 *   "round NL_NS LIN_NS" per round: thread-CPU ns per step of STEPS steps of each FMU,
 *       interleaved, on a 1 mm sine road where nothing switches (a first untimed round of
 *       each: the step matrices made);
 *   "event EVENT_NS PLAIN_NS EVENTS": over an 80 mm full-cosine bump 1 m long at 20 m/s
 *       (BUMP_STEPS steps, repeated ROUNDS times), each nonlinear step timed alone: the
 *       median of the steps in which a switching function changed sign (the located
 *       events' steps, found from the flags read after it) and of the others, and how many
 *       event steps one pass has.
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *(*inst_fn)(const char *, int, const char *, const char *, const void *, int, int);
typedef int (*setup_fn)(void *, int, double, double, int, double);
typedef int (*mode_fn)(void *);
typedef int (*real_fn)(void *, const unsigned int *, size_t, double *);
typedef int (*step_fn)(void *, double, double, int);

typedef struct {
    void *c;
    real_fn set, get;
    step_fn step;
} fmu;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...)
{
    (void)env, (void)cat;
    fprintf(stderr, "[%s %d] %s\n", name, status, msg);
}

static void *sym(void *lib, const char *name)
{
    void *p = dlsym(lib, name);
    if (p == NULL) {
        fprintf(stderr, "missing %s\n", name);
        exit(2);
    }
    return p;
}

static fmu load(const char *path, const char *token)
{
    static void *callbacks[5];
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    fmu f;
    if (lib == NULL) {
        fprintf(stderr, "%s\n", dlerror());
        exit(2);
    }
    callbacks[0] = (void *)logger, callbacks[1] = (void *)calloc, callbacks[2] = (void *)free;
    f.c = ((inst_fn)sym(lib, "fmi2Instantiate"))("bench", 1, token, "", callbacks, 0, 0);
    if (f.c == NULL)
        exit(3);
    ((setup_fn)sym(lib, "fmi2SetupExperiment"))(f.c, 0, 0.0, 0.0, 0, 0.0);
    ((mode_fn)sym(lib, "fmi2EnterInitializationMode"))(f.c);
    ((mode_fn)sym(lib, "fmi2ExitInitializationMode"))(f.c);
    f.set = (real_fn)sym(lib, "fmi2SetReal");
    f.get = (real_fn)sym(lib, "fmi2GetReal");
    f.step = (step_fn)sym(lib, "fmi2DoStep");
    return f;
}

static const unsigned int SET[2] = {0, 1}, GET[2] = {4, 8}, FLAGS[2] = {9, 10};
static const double H = 1e-3;

/* This thread's CPU time, ns: what the step costs, not the time other processes took. */
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec;
}

/* n steps from step k0 with the inputs in (2 per step); returns ns per step. */
static double run(fmu *f, const double *in, long k0, long n, double *sink)
{
    double y[2], t0 = now();
    long k;
    for (k = 0; k < n; k++) {
        f->set(f->c, SET, 2, (double *)in + 2 * k);
        if (f->step(f->c, (k0 + k) * H, H, 1) != 0)
            exit(4);
        f->get(f->c, GET, 2, y);
        *sink += y[0];
    }
    return (now() - t0) / n;
}

/* The two FMUs' loops apart (for an instruction count: valgrind --tool=callgrind). */
static __attribute__((noinline)) double run_nl(fmu *f, const double *in, long k0, long n, double *s)
{
    return run(f, in, k0, n, s);
}

static __attribute__((noinline)) double run_lin(fmu *f, const double *in, long k0, long n,
                                                double *s)
{
    return run(f, in, k0, n, s);
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, long n)
{
    qsort(v, (size_t)n, sizeof *v, cmp);
    return n ? v[n / 2] : NAN;
}

/* The bump, each step timed; event steps are those after which a flag changed. */
static void bump(fmu *f, long n, int rounds, double *sink)
{ /* f: a fresh instance at t = 0 */
    double *ev = calloc((size_t)n * rounds, sizeof *ev), *pl = calloc((size_t)n * rounds, sizeof *pl);
    double u[2], y[2], flag[2], last[2] = {1.0, 0.0}, pi = 3.141592653589793;
    long k, ne = 0, np = 0, per = 0;
    int r;
    for (r = 0; r < rounds; r++) {
        for (k = 0; k < n; k++) {
            double t = (r * n + k) * H, s = fmod(20.0 * t, 20.0 * n * H) - 10.0, t0;
            int on = s >= 0 && s <= 1.0;
            u[0] = on ? 0.04 * (1 - cos(2 * pi * s)) : 0.0;
            u[1] = on ? 0.04 * 2 * pi * sin(2 * pi * s) * 20.0 : 0.0;
            t0 = now();
            f->set(f->c, SET, 2, u);
            if (f->step(f->c, t, H, 1) != 0)
                exit(4);
            f->get(f->c, GET, 2, y);
            t0 = now() - t0;
            f->get(f->c, FLAGS, 2, flag);
            *sink += y[0];
            if (flag[0] != last[0] || (flag[1] != 0.0) != (last[1] != 0.0)) {
                ev[ne++] = t0;
                per += r == 0;
            } else {
                pl[np++] = t0;
            }
            last[0] = flag[0], last[1] = flag[1];
        }
    }
    printf("event %.1f %.1f %ld\n", median(ev, ne), median(pl, np), per);
    free(ev), free(pl);
}

int main(int argc, char **argv)
{
    fmu nl, lin, fresh;
    long steps, k, nb;
    int rounds, r;
    double *in, sink = 0.0;
    if (argc != 8) {
        fprintf(stderr, "usage: native_events_host NL TOKEN LIN TOKEN STEPS ROUNDS BUMP_STEPS\n");
        return 1;
    }
    nl = load(argv[1], argv[2]);
    lin = load(argv[3], argv[4]);
    steps = atol(argv[5]), rounds = atoi(argv[6]), nb = atol(argv[7]);
    in = malloc(2 * (size_t)steps * rounds * sizeof *in);
    for (k = 0; k < steps * rounds; k++) { /* a 1 mm, 1.7 Hz sine: nothing switches */
        double w = 2 * 3.141592653589793 * 1.7;
        in[2 * k] = 1e-3 * sin(w * k * H), in[2 * k + 1] = 1e-3 * w * cos(w * k * H);
    }
    run(&nl, in, 0, steps, &sink); /* warm-up: the first step's discretization, caches */
    run(&lin, in, 0, steps, &sink);
    for (r = 1; r < rounds; r++) {
        double a = run_nl(&nl, in + 2 * steps * r, steps * r, steps, &sink);
        double b = run_lin(&lin, in + 2 * steps * r, steps * r, steps, &sink);
        printf("round %.2f %.2f\n", a, b);
    }
    fresh = load(argv[1], argv[2]);
    bump(&fresh, nb, rounds, &sink);
    fprintf(stderr, "(checksum %g)\n", sink);
    return 0;
}
