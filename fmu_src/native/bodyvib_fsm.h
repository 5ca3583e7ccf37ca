/*
 * bodyvib native FMUs: the FMI state machine both cores share (bodyvib_fsm.c).
 *
 * Every core's instance struct (struct bv_instance of bodyvib_core.c, of bodyvib_table.c)
 * begins with a bv_common: the FMI state (its first member, so BV_STATE_IS of
 * bodyvib_core.h reads it), the model, the instance's name and logger, the model's time
 * and start time, the initialization flags and the reason a failed initialization gave.
 * bodyvib_fsm.c implements on it the functions that are the same for every core
 * (bv_allowed, bv_setup, bv_enter_initialization, bv_terminate, bv_time, bv_name,
 * bv_me_nstates, bv_me_set_time), the snapshots' head and checksum, and
 * the transitions the cores' bv_initialize, bv_step, bv_reset and bv_state_read make, so
 * that one implementation decides the states, the allowed calls and their messages.
 * Internal to the cores: the FMI wrappers see only bodyvib_core.h.
 */
#ifndef BODYVIB_FSM_H
#define BODYVIB_FSM_H

#include <math.h>
#include <stdint.h>

#include "bodyvib_core.h"

#define BV_MESSAGE 640


typedef struct {
    int mode;           /* first (BV_STATE_IS): BV_INSTANTIATED .. BV_EVENT, the FMI state */
    int me;             /* a model-exchange instance: Event and Continuous-Time Mode */
    int64_t time_vr;    /* the value reference of the independent variable time, which reads
                         * as the model's time and cannot be set (FMI 3.0:
                         * bv_set_time_variable); -1: none (FMI 2.0) */
    const bv_model *md;
    char name[128];
    bv_log_fn log;
    void *env;
    double time;        /* the model's time (s) */
    double start_time;  /* fmi2SetupExperiment / fmi3EnterInitializationMode */
    int initialized;
    int init_failed;
    char init_error[BV_MESSAGE];
} bv_common;

/* The bv_common of an instance (its first member). */
#define BV_COMMON(c) ((bv_common *)(void *)(c))

/* Log a message through the instance's logger (printf-like). */
void bv_say(const bv_common *b, int status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The shortest %g text that reads back as v (as Python's repr), into buf[32]. */
const char *bv_shortest(double v, char *buf);

/* At bv_new: the model, the name (the model's if NULL), the logger; then bv_common_clear. */
void bv_common_init(bv_common *b, const bv_model *md, const char *name, bv_log_fn log,
                    void *env);
/* Instantiated, time and start time 0, not initialized (bv_new, bv_reset). */
void bv_common_clear(bv_common *b);
/* ExitInitializationMode begins: not initialized, time = start time, state Error until
 * bv_common_initialized. */
void bv_common_begin_initialize(bv_common *b);
/* ExitInitializationMode failed: b->init_error holds the reason (logged here); the
 * instance stays in the error state and refuses to step until Reset. */
bv_status bv_common_failed(bv_common *b);
/* ExitInitializationMode succeeded: Step Mode (co-simulation) or Event Mode (model exchange). */
void bv_common_initialized(bv_common *b);
/* The checks every DoStep(t, h) makes before it changes anything: h positive and finite,
 * the instance initialized, t the model's time (up to rounding). BV_OK or BV_ERROR
 * (logged). */
bv_status bv_common_step_check(bv_common *b, double t, double h);
/* A step from t starts where the model is: t equals the model's time up to rounding (a host
 * whose clock differs by more is out of step with the model). The last of
 * bv_common_step_check's tests, which a core's step whose other tests are known to pass
 * makes inline. */
static inline int bv_common_on_time(const bv_common *b, double t)
{
    double at = fabs(b->time);
    return fabs(t - b->time) <= 1e-9 * (at > 1.0 ? at : 1.0);
}
/* A snapshot restored with these flags: initialized ones step, a failed one is in error
 * (`fix` ends the message: what to set), one from before initialization keeps
 * Instantiated / InitializationMode. */
void bv_common_restored(bv_common *b, double time, int initialized, int init_failed,
                        const char *fix);
/* Whether vr is the independent variable time (b->time_vr). */
static inline int bv_common_is_time(const bv_common *b, unsigned int vr)
{
    return (int64_t)vr == b->time_vr;
}
/* Set of the independent variable time: refused, logged (BV_ERROR). */
bv_status bv_common_time_not_settable(const bv_common *b);
/* A value that is not finite for the variable vr: refused, logged (BV_ERROR). Model
 * exchange refuses it at SetReal (the derivatives would not be finite); co-simulation at
 * the step, whose state it would make not finite. */
bv_status bv_common_not_finite(const bv_common *b, unsigned int vr, double value);
/* A value reference the model has (logged and 0 if not). */
int bv_common_check_vr(const bv_common *b, unsigned int vr);
/* A value may be set for the model's variable vr now: an input, or a parameter before
 * initialization (else the reason logged, 0). */
int bv_common_settable(const bv_common *b, unsigned int vr);
/* A request for output derivatives: every reference an output, every order 1 ..
 * BV_MAX_OUTPUT_ORDER. BV_OK, or BV_ERROR (logged) before anything is computed. */
bv_status bv_common_check_output_orders(const bv_common *b, const unsigned int vr[],
                                        size_t nvr, const int order[]);

/* Snapshots (bv_state_write .. bv_state_read of either core): 8 bytes of the core's magic,
 * the snapshot's size and the hash of the model's token (uint64 each), the core's payload,
 * then a checksum (uint64, FNV-1a of every byte before it). */
#define BV_SNAPSHOT_HEAD 24
/* Write the head of a snapshot of `size` bytes; returns where the payload begins. */
unsigned char *bv_common_snapshot_head(const bv_common *b, unsigned char *buf,
                                       const unsigned char magic[8], uint64_t size);
/* Write the checksum into the last 8 bytes of a snapshot of `size` bytes. */
void bv_common_snapshot_seal(unsigned char *buf, size_t size);
/* A snapshot of this core and model: the magic, the size `want` (of the buffer too), the
 * token and the checksum. BV_OK, or BV_ERROR with the reason logged. */
bv_status bv_common_snapshot_check(const bv_common *b, const unsigned char *buf, size_t size,
                                   const unsigned char magic[8], uint64_t want);

#endif
