/*
 * bodyvib native FMUs: the FMI calls, once for both versions (bodyvib_calls.c).
 *
 * fmi2Functions.c and fmi3Functions.c keep only what differs between the versions: the
 * names and argument lists, the states only one version allows a function in, the host's
 * logger and the status enum (fmi2Status and fmi3Status have the values of bv_status). An
 * instance of either version is a bv_fmu; every function of either version begins with
 * bv_fmu_enter (the instance, its interface, its state against the function's BV_ON_* mask
 * below), and what the call then does beyond one core function (argument checks, FMU
 * states, serialization, directional derivatives, the model-exchange vectors) is a
 * bv_fmu_* function here.
 */
#ifndef BODYVIB_CALLS_H
#define BODYVIB_CALLS_H

#include <stddef.h>

#include "bodyvib_core.h"

/* The host's logger, stored as a generic function pointer (the wrapper casts it back to
 * fmi2CallbackLogger / fmi3LogMessageCallback). */
typedef void (*bv_host_fn)(void);

/* One FMU instance, FMI 2.0 or 3.0. */
typedef struct {
    bv_instance *core;
    bv_host_fn logger;  /* the host's logger, or NULL */
    void *env;          /* its componentEnvironment / instanceEnvironment */
    char *name;         /* the instance name the host gave ("" if none; NULL for FMI 3.0's NULL) */
    int me;             /* instantiated for model exchange */
    int categories;     /* the log categories switched on (BV_LOG_* bits) */
    bv_log_fn log;      /* the wrapper's message function: env is this bv_fmu */
} bv_fmu;

/* The log categories of the model description (bodyvib.fmu.native.LOG_CATEGORIES): one per
 * message status. Both are on from instantiation, whatever loggingOn says: the FMU has no
 * debug messages, only these status reports, and hosts that instantiate with loggingOn false
 * still show warnings and errors. SetDebugLogging switches them (bv_fmu_set_logging). */
enum { BV_LOG_WARNING = 1, BV_LOG_ERROR = 2, BV_LOG_ALL = 3 };

/* Flags of a function's mask besides its states (BV_INSTANTIATED .. BV_EVENT): the
 * interface the function belongs to when it is not both. */
enum { BV_CS_ONLY = 64, BV_ME_ONLY = 128 };

/* The states the FMI functions are allowed in, from the standard's state tables (the same in
 * FMI 2.0 and 3.0 for these; a version's own are in its file), with the interface flags.
 * Single states: BV_INSTANTIATED (SetupExperiment, EnterInitializationMode),
 * BV_INITIALIZATION (ExitInitializationMode). Model exchange: Event Mode is BV_EVENT,
 * Continuous-Time Mode BV_STEPPING (a co-simulation instance is never in BV_EVENT). */
#define BV_ON_GET (BV_INITIALIZATION | BV_EVENT | BV_STEPPING | BV_TERMINATED | BV_FAILED)
#define BV_ON_SET (BV_INSTANTIATED | BV_INITIALIZATION | BV_EVENT | BV_STEPPING) /* values */
#define BV_ON_TERMINATE (BV_EVENT | BV_STEPPING)
#define BV_ON_STEP (BV_STEPPING | BV_CS_ONLY) /* DoStep */
#define BV_ON_EVENT_MODE (BV_EVENT | BV_ME_ONLY) /* discrete states, EnterContinuousTimeMode */
#define BV_ON_CT_MODE (BV_STEPPING | BV_ME_ONLY) /* CompletedIntegratorStep */
#define BV_ON_TIME (BV_INITIALIZATION | BV_EVENT | BV_STEPPING | BV_ME_ONLY) /* SetTime */
#define BV_ON_ME_SET (BV_INITIALIZATION | BV_STEPPING | BV_ME_ONLY) /* SetContinuousStates */
#define BV_ON_ME_GET (BV_ON_GET | BV_ME_ONLY) /* states, derivatives, event indicators */
#define BV_ON_NOMINALS (BV_INSTANTIATED | BV_ON_ME_GET)

/* A new instance and its core (NULL when out of memory or the model cannot be assembled:
 * that reason logged). `log` is the wrapper's message function (called with this bv_fmu);
 * logger and env are the host's, set before the core is made so that it can log. */
bv_fmu *bv_fmu_new(const char *name, int me, bv_host_fn logger, void *env, bv_log_fn log);
void bv_fmu_free(bv_fmu *f);

/* Log a message as the instance (printf-like). */
void bv_fmu_say(bv_fmu *f, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* SetDebugLogging: loggingOn true switches on the named categories (all when n is 0), false
 * switches them off (all when n is 0). An unknown or NULL category refuses the call (logged,
 * nothing changed). */
bv_status bv_fmu_set_logging(bv_fmu *f, const char *function, int on, size_t n,
                             const char *const categories[]);

/* Whether a message of this status is in a category switched on: logStatusError for
 * BV_ERROR, logStatusWarning for the others (the labels the wrappers give them). */
int bv_fmu_logs(const bv_fmu *f, int status);

/* A NULL pointer argument `name` of `function`: the refusal logged. */
void bv_fmu_null_arg(bv_fmu *f, const char *function, const char *name) BV_COLD;

/* A pointer argument of `function` that must not be NULL when the call reads or writes n > 0
 * entries through it (n = 1 for a single output): 1, or 0 with the refusal logged. */
static inline int bv_fmu_arg(bv_fmu *f, const char *function, const char *name, const void *p,
                             size_t n)
{
    if (BV_LIKELY(p != NULL || n == 0))
        return 1;
    bv_fmu_null_arg(f, function, name);
    return 0;
}

/* Values that must be finite (a time, continuous states): 1, or 0 with the refusal logged
 * naming the first that is not. */
int bv_fmu_finite(bv_fmu *f, const char *function, const char *name, const double v[],
                  size_t n);

/* A function this FMU does not provide (`why`): logged, BV_ERROR. */
bv_status bv_fmu_unsupported(bv_fmu *f, const char *function, const char *why);

/* A function called on an instance of the other interface: logged, 0. */
int bv_fmu_wrong_interface(bv_fmu *f, const char *function) BV_COLD;

/* The entry of every FMI function: 1 when the instance exists, `function` belongs to its
 * interface and its state is in `mask`; otherwise 0, the reason logged (the wrapper returns
 * Error, nothing changed). Inline: the state test is on the hot path; bv_allowed (which
 * logs) runs only when it fails, and then the call is refused whatever it returns (it
 * returns 0: the state is not in the mask), so that the hot path keeps nothing for it. */
static inline int bv_fmu_enter(bv_fmu *f, const char *function, int mask)
{
    if (BV_UNLIKELY(f == NULL))
        return 0;
    if (BV_UNLIKELY((mask & BV_ME_ONLY && !f->me) || (mask & BV_CS_ONLY && f->me))) {
        bv_fmu_wrong_interface(f, function);
        return 0;
    }
    if (BV_LIKELY(BV_STATE_IS(f->core, mask)))
        return 1;
    bv_allowed(f->core, function, mask & BV_ANY_STATE);
    return 0;
}

/* Values (real / Float64), input and output derivatives: the arrays the counts need. */
bv_status bv_fmu_get(bv_fmu *f, const unsigned int vr[], size_t nvr, double value[]);
bv_status bv_fmu_set(bv_fmu *f, const unsigned int vr[], size_t nvr, const double value[]);
bv_status bv_fmu_set_input_derivatives(bv_fmu *f, const unsigned int vr[], size_t nvr,
                                       const int order[], const double value[]);
bv_status bv_fmu_get_output_derivatives(bv_fmu *f, const unsigned int vr[], size_t nvr,
                                        const int order[], double value[]);

/* FMU states: a snapshot of the core (bv_state_write) in a buffer the host holds. Get
 * reuses *state when it has the size, Deserialize makes a new one the host frees. */
bv_status bv_fmu_get_state(bv_fmu *f, const char *function, void **state);
bv_status bv_fmu_set_state(bv_fmu *f, const char *function, void *state);
bv_status bv_fmu_free_state(void **state);
bv_status bv_fmu_state_size(bv_fmu *f, const char *function, void *state, size_t *size);
bv_status bv_fmu_serialize(bv_fmu *f, const char *function, void *state,
                           unsigned char serialized[], size_t size);
bv_status bv_fmu_deserialize(bv_fmu *f, const char *function, const unsigned char serialized[],
                             size_t size, void **state);

/* Exact directional derivatives (bv_directional), the arrays checked. */
bv_status bv_fmu_directional(bv_fmu *f, const unsigned int unknowns[], size_t nu,
                             const unsigned int knowns[], size_t nk, const double seed[],
                             double sensitivity[]);

/* Model exchange: the vectors of the continuous states, in (set: finite) or out (the
 * others), nx checked against the model's count, refusals logged as `function`'s. */
typedef enum { BV_SET_STATES, BV_GET_STATES, BV_DERIVATIVES, BV_NOMINALS } bv_vector;
bv_status bv_fmu_vector(bv_fmu *f, const char *function, bv_vector which, const double in[],
                        double out[], size_t nx);
/* The wrapper of bv_fmu_vector in a version: fn(instance, x, nx) of the version's Status and
 * Instance types, x of type T (const for BV_SET_STATES, passed as `in`; else as `out`),
 * entered through the version's CHECKED (the instance, its state in mask). */
#define BV_VECTOR_FUNCTION(Status, Instance, fn, mask, which, T, in, out)                   \
    Status fn(Instance instance, T x[], size_t nx)                                          \
    {                                                                                       \
        CHECKED(instance, fn, mask);                                                        \
        return (Status)bv_fmu_vector(f, #fn, which, in, out, nx);                           \
    }
/* The four of a version (named set, get, der, nom there), Real its floating-point type. */
#define BV_VECTOR_FUNCTIONS(Status, Instance, Real, set, get, der, nom)                     \
    BV_VECTOR_FUNCTION(Status, Instance, set, BV_ON_ME_SET, BV_SET_STATES, const Real, x, NULL) \
    BV_VECTOR_FUNCTION(Status, Instance, get, BV_ON_ME_GET, BV_GET_STATES, Real, NULL, x)   \
    BV_VECTOR_FUNCTION(Status, Instance, der, BV_ON_ME_GET, BV_DERIVATIVES, Real, NULL, x)  \
    BV_VECTOR_FUNCTION(Status, Instance, nom, BV_ON_NOMINALS, BV_NOMINALS, Real, NULL, x)

/* The event indicators into z: ni must be the model's number (else logged as `function`'s
 * refusal). */
bv_status bv_fmu_event_indicators(bv_fmu *f, const char *function, double z[], size_t ni);

#endif
