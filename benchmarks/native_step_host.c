/*
 * The C host of benchmarks/bench_native_step.py: one native FMU's step (set the inputs,
 * doStep, get the outputs, up to 16 each) against a plain C loop of the same step on the same matrices.
 *
 *     native_step_host MODE FMI BINARY TOKEN SET_VRS GET_VRS H STEPS REPEATS DATA
 *
 * MODE     time      REPEATS rounds, each one loop of STEPS FMU steps and one of STEPS
 *                    plain steps (interleaved, so both see the same load); then STEPS FMU
 *                    steps each followed by a plain step, both timed one by one
 *                    (percentiles), and the number of malloc/calloc/realloc/free calls made
 *                    in the FMU's steps.
 *          fmu       STEPS FMU steps only, untimed (fmu_loop)    } for instruction counts
 *          plain     STEPS plain steps only, untimed (plain_loop) } (valgrind --tool=callgrind)
 * FMI      2 or 3
 * SET_VRS  comma-separated value references of the inputs set at every step ("-": none)
 * GET_VRS  comma-separated value references of the outputs read at every step
 * DATA     what the plain loop multiplies (written by bench_native_step.py from the model):
 *              n ni nset nget
 *              set positions (nset ints: index of each set input among the ni inputs)
 *              Sc  n x (n + ni)   state at the step's end from [x | s]
 *              Ms  ni x ni        inputs at the step's end from s
 *              Y   nget x (n + ni) the outputs read, from [x | s]
 *              nsw                the switching functions (0: a linear model)
 *              negated (nsw ints) 1: the function's row is the previous one's negated
 *              P   nsw x (n + ni) the functions at the step's end from [x | s] at its start,
 *                                 each times its sign in the regime in force
 *              q   nsw            their constants, times the same signs
 *          or "road:SPEED" for a source FMU, whose plain loop evaluates the table compiled
 *          into this host (-DBV_ROAD_TABLE with the FMU's own sources/bodyvib_model.c).
 *
 * Output lines: "round fmu_ns plain_ns fmu_cpu_ns plain_cpu_ns calls_ns" per round (ns per
 * step; calls: the same calls into functions that do nothing, after the plain loop);
 * "latency p50 p99 p99.9 p99.99 max outliers" and "latency_plain ..." (ns, single FMU and
 * plain steps timed with the time-stamp counter after a warm-up, the counter's own cost
 * subtracted; outliers: steps above 3x their median), "latency_empty ..." (the same of a
 * region of no work timed in the same loop after each plain step; outliers: above 3x the
 * FMU step's median), "latency_clock COST RESOLUTION" (ns:
 * two reads, the smallest step the counter makes), "interrupts ALL TIMER" (taken by this
 * core during those steps), "switches VOLUNTARY INVOLUNTARY" (of this thread, then),
 * "stolen MS" (this core's time the virtual machine's host took then, ms; -1 unknown),
 * "locked 0|1" (mlockall), "allocations N" (calls in the timed FMU steps), "check D" (a
 * pass of STEPS steps of both side by side after the rounds: the largest difference of an
 * output over its largest magnitude). The inputs are precomputed (a 1.7 Hz sine's
 * displacement and velocity, a pair per road point), so a step costs only the FMU.
 */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <dlfcn.h>
#include <sched.h>
#include <stdint.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#endif

#ifdef BV_ROAD_TABLE
#include "bodyvib_table.h"
#endif

/* ------------------------------------------------------------------ counting allocations */

/* The host defines malloc & co. (the FMU binary's calls bind to these: symbols of the
 * executable come first) and forwards them to glibc's own entry points. */
extern void *__libc_malloc(size_t);
extern void *__libc_calloc(size_t, size_t);
extern void *__libc_realloc(void *, size_t);
extern void __libc_free(void *);
static int counting;
static long allocations;

void *malloc(size_t n)
{
    allocations += counting;
    return __libc_malloc(n);
}
void *calloc(size_t k, size_t n)
{
    allocations += counting;
    return __libc_calloc(k, n);
}
void *realloc(void *p, size_t n)
{
    allocations += counting;
    return __libc_realloc(p, n);
}
void free(void *p)
{
    allocations += counting && p != NULL;
    __libc_free(p);
}

/* ------------------------------------------------------------------ FMI, both versions */

typedef void *(*inst2_fn)(const char *, int, const char *, const char *, const void *, int, int);
typedef int (*setup2_fn)(void *, int, double, double, int, double);
typedef int (*mode_fn)(void *);
typedef int (*real2_fn)(void *, const unsigned int *, size_t, double *);
typedef int (*step2_fn)(void *, double, double, int);
typedef void *(*inst3_fn)(const char *, const char *, const char *, int, int, int, int,
                          const unsigned int *, size_t, void *, void *, void *);
typedef int (*enter3_fn)(void *, int, double, double, int, double);
typedef int (*real3_fn)(void *, const unsigned int *, size_t, double *, size_t);
typedef int (*step3_fn)(void *, double, double, int, int *, int *, int *, double *);

typedef struct {
    int fmi;
    void *c;
    real2_fn set2, get2;
    step2_fn step2;
    real3_fn set3, get3;
    step3_fn step3;
} Fmu;

static void die(const char *what)
{
    fprintf(stderr, "native_step_host: %s\n", what);
    exit(2);
}

static void *sym(void *lib, const char *name)
{
    void *f = dlsym(lib, name);
    if (f == NULL)
        die(name);
    return f;
}

static void fmi2_log(void *env, const char *name, int status, const char *cat, const char *msg,
                     ...)
{
    (void)env, (void)cat;
    fprintf(stderr, "[%s %d] %s\n", name, status, msg);
}

static void fmi3_log(void *env, int status, const char *cat, const char *msg)
{
    (void)env, (void)cat;
    fprintf(stderr, "[%d] %s\n", status, msg);
}

static void open_fmu(Fmu *f, int fmi, const char *path, const char *token)
{
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (lib == NULL)
        die(dlerror());
    f->fmi = fmi;
    if (fmi == 2) {
        /* fmi2CallbackFunctions: logger, allocate, free, stepFinished, environment */
        static void *callbacks[5];
        callbacks[0] = (void *)fmi2_log;
        callbacks[1] = (void *)calloc;
        callbacks[2] = (void *)free;
        f->c = ((inst2_fn)sym(lib, "fmi2Instantiate"))("bench", 1, token, "", callbacks, 0, 0);
        if (f->c == NULL)
            die("fmi2Instantiate failed");
        if (((setup2_fn)sym(lib, "fmi2SetupExperiment"))(f->c, 0, 0.0, 0.0, 0, 0.0) ||
            ((mode_fn)sym(lib, "fmi2EnterInitializationMode"))(f->c) ||
            ((mode_fn)sym(lib, "fmi2ExitInitializationMode"))(f->c))
            die("FMI 2.0 initialization failed");
        f->set2 = (real2_fn)sym(lib, "fmi2SetReal");
        f->get2 = (real2_fn)sym(lib, "fmi2GetReal");
        f->step2 = (step2_fn)sym(lib, "fmi2DoStep");
    } else {
        f->c = ((inst3_fn)sym(lib, "fmi3InstantiateCoSimulation"))(
            "bench", token, NULL, 0, 0, 0, 0, NULL, 0, NULL, (void *)fmi3_log, NULL);
        if (f->c == NULL)
            die("fmi3InstantiateCoSimulation failed");
        if (((enter3_fn)sym(lib, "fmi3EnterInitializationMode"))(f->c, 0, 0.0, 0.0, 0, 0.0) ||
            ((mode_fn)sym(lib, "fmi3ExitInitializationMode"))(f->c))
            die("FMI 3.0 initialization failed");
        f->set3 = (real3_fn)sym(lib, "fmi3SetFloat64");
        f->get3 = (real3_fn)sym(lib, "fmi3GetFloat64");
        f->step3 = (step3_fn)sym(lib, "fmi3DoStep");
    }
}

/* An FMU whose functions do nothing but what the calls' contract needs (get writes its
 * values, FMI 3.0's doStep its flags): the same calls through pointers, from the same host
 * code, with no check or work behind them. What a step of it costs is what the calls alone
 * cost, the least any FMU can add to its arithmetic. */
__attribute__((noipa)) static int empty_set2(void *c, const unsigned *vr, size_t n, double *v)
{
    (void)c, (void)vr, (void)n, (void)v;
    return 0;
}
__attribute__((noipa)) static int empty_get2(void *c, const unsigned *vr, size_t n, double *v)
{
    size_t i;
    (void)c, (void)vr;
    for (i = 0; i < n; i++)
        v[i] = 0.0;
    return 0;
}
__attribute__((noipa)) static int empty_step2(void *c, double t, double h, int last)
{
    (void)c, (void)t, (void)h, (void)last;
    return 0;
}
__attribute__((noipa)) static int empty_set3(void *c, const unsigned *vr, size_t n, double *v,
                                             size_t nv)
{
    (void)nv;
    return empty_set2(c, vr, n, v);
}
__attribute__((noipa)) static int empty_get3(void *c, const unsigned *vr, size_t n, double *v,
                                             size_t nv)
{
    (void)nv;
    return empty_get2(c, vr, n, v);
}
__attribute__((noipa)) static int empty_step3(void *c, double t, double h, int last, int *event,
                                              int *terminate, int *early, double *reached)
{
    (void)c, (void)last;
    *event = *terminate = *early = 0;
    *reached = t + h;
    return 0;
}

/* p, the compiler no longer knowing what it points to (the calls stay indirect, as a host's
 * calls into a loaded binary are). */
static void *opaque(void *p)
{
    __asm__("" : "+r"(p));
    return p;
}

static void open_empty(Fmu *e, int fmi)
{
    memset(e, 0, sizeof *e);
    e->fmi = fmi;
    e->c = e;
    e->set2 = (real2_fn)opaque((void *)empty_set2);
    e->get2 = (real2_fn)opaque((void *)empty_get2);
    e->step2 = (step2_fn)opaque((void *)empty_step2);
    e->set3 = (real3_fn)opaque((void *)empty_set3);
    e->get3 = (real3_fn)opaque((void *)empty_get3);
    e->step3 = (step3_fn)opaque((void *)empty_step3);
}

/* One FMU step: set, doStep, get; a refused call ends the run. */
static inline void fmu_step(const Fmu *f, const unsigned *sv, int ns, const double *in,
                            double t, double h, const unsigned *gv, int ng, double *out)
{
    int bad;
    if (f->fmi == 2) {
        bad = (ns && f->set2(f->c, sv, (size_t)ns, (double *)in)) || f->step2(f->c, t, h, 1) ||
              f->get2(f->c, gv, (size_t)ng, out);
    } else {
        int event, terminate, early;
        double last;
        bad = (ns && f->set3(f->c, sv, (size_t)ns, (double *)in, (size_t)ns)) ||
              f->step3(f->c, t, h, 1, &event, &terminate, &early, &last) ||
              f->get3(f->c, gv, (size_t)ng, out, (size_t)ng);
    }
    if (bad)
        die("the FMU refused a step");
}

/* ------------------------------------------------------------------ the plain loop */

/* The model's sizes, when the benchmark compiles the host for one model (-DPLAIN_N=..,
 * PLAIN_NI, PLAIN_NSET, PLAIN_NGET): constants, as they are in the FMU (built for its model
 * with link-time optimization); otherwise read from DATA. */
#ifdef PLAIN_N
#define P_N PLAIN_N
#define P_NI PLAIN_NI
#define P_NSET PLAIN_NSET
#define P_NGET PLAIN_NGET
#define P_NSW PLAIN_NSW
#else
#define P_N p->n
#define P_NI p->ni
#define P_NSET p->nset
#define P_NGET p->nget
#define P_NSW p->nsw
#endif

/* The FMU's loops over the model's sizes are unrolled; so are the plain loop's. */
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 8
#define UNROLL _Pragma("GCC unroll 16")
#else
#define UNROLL
#endif

#ifdef PLAIN_MS_PATTERN
/* Where Ms can be non-zero, when the host is compiled for one model: the FMU knows this
 * pattern where its step is compiled (from its model's constant R), so the floor does too. */
static const unsigned char ms_pattern[] = {PLAIN_MS_PATTERN};
#endif

#ifdef PLAIN_NEGATED
/* Which switching functions' rows are the previous one's negated (a stop's rebound side):
 * the FMU knows them where its step is compiled, so the floor does too. */
static const unsigned char negated[] = {PLAIN_NEGATED};
#define NEGATED(i) negated[i]
#else
#define NEGATED(i) p->negated[i]
#endif

typedef struct {
    int n, ni, nset, nget, road, nsw;
    int *setpos;
    unsigned char *negated;
    double *Sc, *Ms, *Y, *z, *zn, speed, t, periods;
    double *P, *q, *gm, *g0, *g1; /* switching functions; their last three values */
    long unclear;                 /* steps whose sign test did not pass */
} Plain;

static void read_plain(Plain *p, const char *path)
{
    int i, k;
    FILE *fp;
    memset(p, 0, sizeof *p);
    if (strncmp(path, "road:", 5) == 0) {
        p->road = 1;
        p->speed = atof(path + 5);
        return;
    }
    fp = fopen(path, "r");
    if (fp == NULL || fscanf(fp, "%d %d %d %d", &p->n, &p->ni, &p->nset, &p->nget) != 4)
        die("cannot read the plain loop's matrices");
#ifdef PLAIN_N
    if (p->n != PLAIN_N || p->ni != PLAIN_NI || p->nset != PLAIN_NSET || p->nget != PLAIN_NGET)
        die("the plain loop was compiled for other sizes than DATA's");
#endif
    k = p->n + p->ni;
    p->setpos = __libc_calloc((size_t)p->nset + 1, sizeof(int));
    p->Sc = __libc_calloc((size_t)(p->n + p->ni + p->nget) * k + 1, sizeof(double));
    p->Ms = p->Sc + (size_t)p->n * k;
    p->Y = p->Ms + (size_t)p->ni * p->ni;
    p->z = __libc_calloc(2 * (size_t)k + 1, sizeof(double));
    p->zn = p->z + k;
    for (i = 0; i < p->nset; i++)
        if (fscanf(fp, "%d", &p->setpos[i]) != 1)
            die("bad set positions");
    for (i = 0; i < p->n * k + p->ni * p->ni + p->nget * k; i++)
        if (fscanf(fp, "%lf", &p->Sc[i]) != 1)
            die("bad matrices");
    if (fscanf(fp, "%d", &p->nsw) != 1 || p->nsw < 0)
        die("bad number of switching functions");
#ifdef PLAIN_N
    if (p->nsw != PLAIN_NSW)
        die("the plain loop was compiled for another number of switching functions");
#endif
    p->negated = __libc_calloc((size_t)p->nsw + 1, 1);
    p->P = __libc_calloc((size_t)p->nsw * (k + 4) + 1, sizeof(double));
    p->q = p->P + (size_t)p->nsw * k;
    p->gm = p->q + p->nsw, p->g0 = p->gm + p->nsw, p->g1 = p->g0 + p->nsw;
    for (i = 0; i < p->nsw; i++) {
        if (fscanf(fp, "%d", &k) != 1)
            die("bad negated rows");
        p->negated[i] = (unsigned char)k;
#ifdef PLAIN_NEGATED
        if (p->negated[i] != negated[i])
            die("the plain loop was compiled for other negated rows");
#endif
    }
    k = p->n + p->ni;
    for (i = 0; i < p->nsw * (k + 1); i++)
        if (fscanf(fp, "%lf", &p->P[i]) != 1)
            die("bad switching functions");
    for (i = 0; i < p->nsw; i++) /* at rest, as the FMU starts: the constants */
        p->gm[i] = p->g0[i] = p->q[i];
    fclose(fp);
}

/* out = M v (rows x cols, row-major), each row with two accumulators (even and odd
 * columns) added at the end: the FMU's sums, in its order. */
static inline void mv(double *restrict out, const double *restrict M, const double *restrict v,
                      int rows, int cols)
{
    int i, j;
    UNROLL
    for (i = 0; i < rows; i++) {
        double a = 0.0, b = 0.0;
        UNROLL
        for (j = 0; j + 1 < cols; j += 2) {
            a += M[i * cols + j] * v[j];
            b += M[i * cols + j + 1] * v[j + 1];
        }
        if (j < cols)
            a += M[i * cols + j] * v[j];
        out[i] = a + b;
    }
}

#ifdef BV_ROAD_TABLE
/* The table's cubic Hermite interpolant at p (periodic or held), values and rates: the
 * arithmetic of the FMU's own evaluation, without its state machine and calls. A periodic
 * table's position is reduced as the FMU does, from the whole periods of the last step
 * (u - q k, exact), with fmod only when that guess fails. */
static inline void road_at(Plain *p, double pos, double *out)
{
    const bv_source *t = &bv_source_data;
    int k = t->rows - 1, i;
    double u = (pos - t->p0) / t->dp, s, s2, s3, z0, z1, m0, m1;
    if (t->periodic) {
        double r = u - p->periods * k;
        if (fabs(u) < 0x1p52 && r >= 0.0 && r < k) {
            u = r;
        } else { /* a remainder with the divisor's sign */
            p->periods = floor(u / k);
            u = fmod(u, (double)k);
            if (u < 0.0)
                u += k;
        }
    }
    u = u < 0.0 ? 0.0 : (u > k ? k : u);
    i = (int)u;
    if (i > k - 1)
        i = k - 1;
    s = u - i, s2 = s * s, s3 = s2 * s;
    z0 = t->value[i * t->signals], z1 = t->value[(i + 1) * t->signals];
    m0 = t->slope[i * t->signals] * t->dp, m1 = t->slope[(i + 1) * t->signals] * t->dp;
    out[0] = (2 * s3 - 3 * s2 + 1) * z0 + (s3 - 2 * s2 + s) * m0 + (3 * s2 - 2 * s3) * z1 +
             (s3 - s2) * m1;
    out[1] = p->speed * (((6 * s2 - 6 * s) * (z0 - z1) + (3 * s2 - 4 * s + 1) * m0 +
                          (3 * s2 - 2 * s) * m1) / t->dp);
}
#endif

/* The switching functions at the step's end from z = [x | s] at its start, times their
 * signs, and the sign test of the FMU's step: each stays >= 0 and no parabola through its
 * last three values dips below zero inside the step, sufficient where 4 min(g0, g1) >=
 * max(gm, g1) (bodyvib_regimes_hot.h); a step that fails it is counted (the FMU would test
 * it in full, and locate an event if one is there). */
static inline void plain_switching(Plain *p, const double *z, int k)
{
    double *t = p->gm, last = 0.0;
    int i, ok = 1;
    UNROLL
    for (i = 0; i < P_NSW; i++) {
        double v = NEGATED(i) ? -last : 0.0, g0 = p->g0[i], gm = p->gm[i], g1, lo, hi;
        if (!NEGATED(i)) {
            double a = 0.0, b = 0.0;
            int j;
            UNROLL
            for (j = 0; j + 1 < k; j += 2) {
                a += p->P[i * k + j] * z[j];
                b += p->P[i * k + j + 1] * z[j + 1];
            }
            if (j < k)
                a += p->P[i * k + j] * z[j];
            v = a + b;
        }
        g1 = p->g1[i] = v + p->q[i];
        lo = g0 < g1 ? g0 : g1, hi = gm > g1 ? gm : g1;
        ok &= 4.0 * lo >= hi;
        last = v;
    }
    if (!ok)
        p->unclear++;
    p->gm = p->g0, p->g0 = p->g1, p->g1 = t; /* g moves on a step */
}

static inline void plain_step(Plain *p, const double *in, double h, double *out)
{
    int i, j, n = P_N, k = P_N + P_NI;
    if (p->road) {
#ifdef BV_ROAD_TABLE
        p->t += h;
        road_at(p, p->speed * p->t, out);
#else
        (void)h, (void)out, (void)j;
        die("a road's plain loop needs the table: compile with -DBV_ROAD_TABLE");
#endif
        return;
    }
    UNROLL
    for (i = 0; i < P_NSET; i++)
        p->z[n + p->setpos[i]] = in[i];
    if (P_NSW)
        plain_switching(p, p->z, k);
    mv(p->zn, p->Sc, p->z, n, k);
    UNROLL
    for (i = 0; i < P_NI; i++) { /* s <- Ms s, over Ms's non-zero entries (as the FMU) */
        double a = 0.0, b = 0.0;
        UNROLL
        for (j = 0; j < P_NI; j++) {
            double v = p->Ms[i * P_NI + j];
#ifdef PLAIN_MS_PATTERN
            if (!ms_pattern[i * P_NI + j])
                continue;
#else
            if (v == 0.0)
                continue;
#endif
            if (j & 1)
                b += v * p->z[n + j];
            else
                a += v * p->z[n + j];
        }
        p->zn[n + i] = a + b;
    }
    UNROLL
    for (i = 0; i < k; i++)
        p->z[i] = p->zn[i];
    mv(out, p->Y, p->z, P_NGET, k);
}

/* ------------------------------------------------------------------ untimed loops */

/* STEPS steps of each kind, apart (callgrind counts the instructions inside with
 * --toggle-collect=fmu_loop or =plain_loop). */
__attribute__((noinline)) static double fmu_loop(const Fmu *f, const unsigned *sv, int ns,
                                                 const double *in, double h, const unsigned *gv,
                                                 int ng, long steps)
{
    double out[16], t = 0.0, sink = 0.0;
    long k;
    for (k = 0; k < steps; k++) {
        fmu_step(f, sv, ns, in + k * ns, t, h, gv, ng, out);
        t += h;
        sink += out[0];
    }
    return sink;
}

__attribute__((noinline)) static double plain_loop(Plain *p, int ns, const double *in, double h,
                                                   long steps)
{
    double out[16], sink = 0.0;
    long k;
    for (k = 0; k < steps; k++) {
        plain_step(p, in + k * ns, h, out);
        sink += out[0];
    }
    return sink;
}

/* ------------------------------------------------------------------ timing */

static double now(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return ts.tv_sec * 1e9 + ts.tv_nsec;
}

/* The clock of single steps: the time-stamp counter where there is one (x86: rdtsc between
 * fences, a few ns to read; constant-rate on current processors), else CLOCK_MONOTONIC in ns.
 * Converted to ns by the ratio of both over the timed loop. */
static inline uint64_t ticks(void)
{
#if defined(__x86_64__) || defined(__i386__)
    uint64_t t;
    _mm_lfence();
    t = __rdtsc();
    _mm_lfence();
    return t;
#else
    return (uint64_t)now(CLOCK_MONOTONIC);
#endif
}

/* Interrupts delivered to `cpu` so far (/proc/interrupts): all of them, and the local
 * timer's (LOC); -1 where the file cannot be read. */
static void interrupts(int cpu, long *all, long *timer)
{
    char line[4096];
    FILE *fp = fopen("/proc/interrupts", "r");
    *all = *timer = -1;
    if (fp == NULL || cpu < 0 || fgets(line, sizeof line, fp) == NULL) {
        if (fp)
            fclose(fp);
        return;
    }
    *all = *timer = 0;
    while (fgets(line, sizeof line, fp) != NULL) {
        char *q = strchr(line, ':'), *end;
        long v = 0;
        int c;
        if (q == NULL)
            continue;
        q++;
        for (c = 0; c <= cpu; c++) {
            v = strtol(q, &end, 10);
            if (end == q)
                break;
            q = end;
        }
        if (c <= cpu) /* fewer columns (ERR, MIS): not per core */
            continue;
        *all += v;
        if (strncmp(line + strspn(line, " "), "LOC:", 4) == 0)
            *timer = v;
    }
    fclose(fp);
}

/* Time stolen from `cpu` so far by the virtual machine's host (/proc/stat, the eighth
 * figure of its line, in clock ticks of sysconf(_SC_CLK_TCK)); -1 where not known. */
static long stolen(int cpu)
{
    char line[512], name[16];
    long v[8], found = -1;
    FILE *fp = fopen("/proc/stat", "r");
    if (fp == NULL)
        return -1;
    snprintf(name, sizeof name, "cpu%d ", cpu);
    while (fgets(line, sizeof line, fp) != NULL)
        if (strncmp(line, name, strlen(name)) == 0 &&
            sscanf(line + strlen(name), "%ld %ld %ld %ld %ld %ld %ld %ld", &v[0], &v[1], &v[2],
                   &v[3], &v[4], &v[5], &v[6], &v[7]) == 8) {
            found = v[7];
            break;
        }
    fclose(fp);
    return found;
}

/* Durations of single steps in counter ticks, counted per tick (the last bin: that many
 * or more), and the longest: a few cache lines touched, where an array of 1e6 durations
 * would take the timed steps through a new page every 512 steps. */
#define HIST_BINS 65536
typedef struct {
    unsigned bin[HIST_BINS];
    uint64_t top;
} Hist;
static Hist hist[3]; /* the FMU's steps, the plain loop's, nothing's (two reads) */

static inline void count(Hist *hs, uint64_t d)
{
    hs->bin[d < HIST_BINS ? d : HIST_BINS - 1]++;
    hs->top = d > hs->top ? d : hs->top;
}

/* The q-quantile of the `total` durations counted in hs (ticks). */
static double percentile(const Hist *hs, long total, double q)
{
    long k, seen = 0, rank = (long)(q * (double)total);
    for (k = 0; k < HIST_BINS; k++) {
        seen += hs->bin[k];
        if (seen > rank)
            return (double)k;
    }
    return (double)(HIST_BINS - 1);
}

/* "KEY p50 p99 p99.9 p99.99 max outliers": ns, the clock's own cost subtracted; outliers:
 * the durations above `above` ns (0: above 3 times their own median). Returns the median. */
static double report(const char *key, const Hist *hs, long total, double clock_ticks,
                     double tick_ns, double above)
{
    double q[4] = {0.5, 0.99, 0.999, 0.9999}, v[4];
    long k, outliers = 0;
    int j;
    for (j = 0; j < 4; j++)
        v[j] = (percentile(hs, total, q[j]) - clock_ticks) * tick_ns;
    if (above <= 0.0)
        above = 3 * v[0];
    for (k = 0; k < HIST_BINS; k++)
        if (((double)k - clock_ticks) * tick_ns > above)
            outliers += hs->bin[k];
    printf("%s %.1f %.1f %.1f %.1f %.0f %ld\n", key, v[0], v[1], v[2], v[3],
           ((double)hs->top - clock_ticks) * tick_ns, outliers);
    return v[0];
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int parse_vrs(const char *text, unsigned *vr)
{
    int k = 0;
    if (strcmp(text, "-") == 0)
        return 0;
    while (*text && k < 16) {
        vr[k++] = (unsigned)strtoul(text, (char **)&text, 10);
        if (*text == ',')
            text++;
    }
    return k;
}

int main(int argc, char **argv)
{
    Fmu f, e;
    Plain p;
    unsigned sv[16], gv[16];
    int ns, ng, r, fmi;
    long steps, repeats, cap, k;
    double h, *in, *lat, sink = 0.0, diff = 0.0;
    const char *mode;
    if (argc != 11)
        die("usage: MODE FMI BINARY TOKEN SET_VRS GET_VRS H STEPS REPEATS DATA");
    mode = argv[1];
    fmi = atoi(argv[2]);
    ns = parse_vrs(argv[5], sv);
    ng = parse_vrs(argv[6], gv);
    h = atof(argv[7]);
    steps = atol(argv[8]);
    repeats = atol(argv[9]);
    read_plain(&p, argv[10]);
    /* no page faults while stepping (needs the right to lock memory: root or a limit) */
    printf("locked %d\n", mlockall(MCL_CURRENT | MCL_FUTURE) == 0);
    open_fmu(&f, fmi, argv[3], argv[4]);
    open_empty(&e, fmi);
    /* inputs: pairs of a 1.7 Hz, 10 mm sine's displacement and velocity, each pair (a road
     * point: a full car's four corners) 0.4 rad behind the one before */
    /* buffers of one size for any STEPS up to 1e6: runs of different lengths make the same
     * system calls but for the steps' own (strace -c compares them) */
    cap = steps > 1000000 ? steps : 1000000;
    in = __libc_calloc((size_t)cap * (ns ? ns : 1), sizeof(double));
    lat = __libc_calloc((size_t)cap, sizeof(double));
    for (k = 0; k < steps; k++) {
        double w = 2 * M_PI * 1.7, t = k * h;
        for (r = 0; r < ns; r++)
            in[k * ns + r] = 0.01 * pow(w, r % 2) * sin(w * t + (r % 2) * M_PI / 2 + (r / 2) * 0.4);
    }
    if (strcmp(mode, "fmu") == 0)
        sink = fmu_loop(&f, sv, ns, in, h, gv, ng, steps);
    else if (strcmp(mode, "plain") == 0)
        sink = plain_loop(&p, ns, in, h, steps);
    else if (strcmp(mode, "time") == 0) {
        double t_fmu = 0.0;
        for (r = 0; r < repeats; r++) {
            double out[16], ref[16], w0, w1, w2, w3, c0, c1, c2;
            w0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_THREAD_CPUTIME_ID);
            for (k = 0; k < steps; k++) {
                fmu_step(&f, sv, ns, in + k * ns, t_fmu, h, gv, ng, out);
                t_fmu += h;
                sink += out[0];
            }
            w1 = now(CLOCK_MONOTONIC), c1 = now(CLOCK_THREAD_CPUTIME_ID);
            for (k = 0; k < steps; k++) {
                plain_step(&p, in + k * ns, h, ref);
                sink += ref[0];
            }
            w2 = now(CLOCK_MONOTONIC), c2 = now(CLOCK_THREAD_CPUTIME_ID);
            for (k = 0; k < steps; k++) {
                fmu_step(&e, sv, ns, in + k * ns, t_fmu, h, gv, ng, out);
                sink += out[0];
            }
            w3 = now(CLOCK_MONOTONIC);
            printf("round %.2f %.2f %.2f %.2f %.2f\n", (w1 - w0) / steps, (w2 - w1) / steps,
                   (c1 - c0) / steps, (c2 - c1) / steps, (w3 - w2) / steps);
        }
        { /* both have run the same steps: one more pass side by side, the largest
           * difference of each output over its largest magnitude */
            double out[16], ref[16], big[16] = {0}, off[16] = {0};
            int j;
            for (k = 0; k < steps; k++) {
                fmu_step(&f, sv, ns, in + k * ns, t_fmu, h, gv, ng, out);
                t_fmu += h;
                plain_step(&p, in + k * ns, h, ref);
                for (j = 0; j < ng; j++) {
                    big[j] = fmax(big[j], fabs(ref[j]));
                    off[j] = fmax(off[j], fabs(out[j] - ref[j]));
                }
            }
            for (j = 0; j < ng; j++)
                diff = fmax(diff, off[j] / fmax(big[j], 1e-300));
        }
        { /* single FMU steps, timed one by one: after a warm-up (caches, branch
           * predictors), the counter's own cost (two reads with nothing between, median)
           * subtracted; the interrupts this core took and the thread's context switches
           * during the loop, to name what the slowest steps waited for */
            long irq0, irq1, loc0, loc1, st0, st1;
            int cpu = sched_getcpu();
            struct rusage r0, r1;
            double w0, w1, tick_ns, clock_ticks, step = 1e300, fmu_p50;
            uint64_t k0, k1;
            for (k = 0; k < steps; k++) {
                uint64_t a = ticks();
                lat[k] = (double)(ticks() - a);
            }
            qsort(lat, (size_t)steps, sizeof *lat, cmp);
            clock_ticks = lat[steps / 2];
            /* the counter's resolution: the smallest difference between two of these
             * durations (or the smallest non-zero one) */
            for (k = 0; k < steps; k++) {
                double d = k ? lat[k] - lat[k - 1] : lat[k];
                if (d > 0 && d < step)
                    step = d;
            }
            /* a new second of the kernel's real-time budget (0.95 s of every 1 s, which the
             * rounds may have spent): a real-time run is not stopped inside the timed steps */
            usleep(1100000);
            for (k = 0; k < 10000; k++) {
                double out[16];
                fmu_step(&f, sv, ns, in + (k % steps) * ns, t_fmu, h, gv, ng, out);
                t_fmu += h;
            }
            memset(hist, 0, sizeof hist);
            interrupts(cpu, &irq0, &loc0);
            st0 = stolen(cpu);
            getrusage(RUSAGE_THREAD, &r0);
            w0 = now(CLOCK_MONOTONIC), k0 = ticks();
            for (k = 0; k < steps; k++) {
                double out[16], u[16];
                uint64_t a, d;
                for (r = 0; r < ns; r++) /* the step's inputs at hand, as a host has them */
                    u[r] = in[k * ns + r];
                counting = 1;
                a = ticks();
                fmu_step(&f, sv, ns, u, t_fmu, h, gv, ng, out);
                d = ticks() - a;
                counting = 0;
                count(&hist[0], d);
                t_fmu += h;
                sink += out[0];
                a = ticks();
                plain_step(&p, u, h, out);
                d = ticks() - a;
                count(&hist[1], d);
                sink += out[0];
                a = ticks(); /* nothing: what the machine adds to a region of no work */
                d = ticks() - a;
                count(&hist[2], d);
            }
            k1 = ticks(), w1 = now(CLOCK_MONOTONIC);
            getrusage(RUSAGE_THREAD, &r1);
            st1 = stolen(cpu);
            interrupts(cpu, &irq1, &loc1);
            tick_ns = (w1 - w0) / (double)(k1 - k0);
            fmu_p50 = report("latency", &hist[0], steps, clock_ticks, tick_ns, 0.0);
            report("latency_plain", &hist[1], steps, clock_ticks, tick_ns, 0.0);
            /* nothing's outliers: the regions of no work as slow as an FMU step's outlier */
            report("latency_empty", &hist[2], steps, clock_ticks, tick_ns, 3 * fmu_p50);
            printf("latency_clock %.1f %.1f\n", clock_ticks * tick_ns, step * tick_ns);
            printf("interrupts %ld %ld\n", irq0 < 0 ? -1 : irq1 - irq0, loc0 < 0 ? -1 : loc1 - loc0);
            printf("switches %ld %ld\n", r1.ru_nvcsw - r0.ru_nvcsw, r1.ru_nivcsw - r0.ru_nivcsw);
            printf("stolen %.0f\n", st0 < 0 || st1 < 0 ? -1.0 : (st1 - st0) * 1e3 / sysconf(_SC_CLK_TCK));
        }
        printf("allocations %ld\n", allocations);
        printf("check %.3g\n", diff);
        printf("unclear %ld\n", p.unclear);
    }
    fprintf(stderr, "sink %g\n", sink);
    return 0;
}
