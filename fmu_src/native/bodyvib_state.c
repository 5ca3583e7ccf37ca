/*
 * bodyvib native core: the instance's serialized state (bv_state_size .. bv_state_read of
 * bodyvib_core.h; the head and checksum of bodyvib_fsm.h).
 */
#include "bodyvib_instance.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const unsigned char MAGIC[8] = {'B', 'V', 'S', 'T', 'A', 'T', 'E', '2'};

/* Payload: doubles time, initialized, init_failed, p[np], x[n], s[ni], then per fallback
 * pair x_prev, h_prev, has_prev, vel_set, slope_on, warned; a nonlinear model's regime last
 * (bv_rg_state_write). */
static size_t payload_doubles(const bv_instance *c)
{
    return 3 + (size_t)c->np + (size_t)c->n + (size_t)c->ni + 6 * (size_t)c->bc.md->npairs +
           (c->rg != NULL ? bv_rg_state_doubles(c) : 0);
}

size_t bv_state_size(const bv_instance *c)
{
    return BV_SNAPSHOT_HEAD + 8 * payload_doubles(c) + 8;
}

static unsigned char *put(unsigned char *q, const double *v, size_t k)
{
    memcpy(q, v, k * sizeof *v);
    return q + k * sizeof *v;
}

void bv_state_write(const bv_instance *c, unsigned char *buf)
{
    int k;
    size_t size = bv_state_size(c);
    double head[3], pair[6];
    unsigned char *q = bv_common_snapshot_head(&c->bc, buf, MAGIC, size);
    head[0] = c->bc.time;
    head[1] = c->bc.initialized;
    head[2] = c->bc.init_failed;
    q = put(q, head, 3);
    q = put(q, c->p, (size_t)c->np);
    q = put(q, c->x, (size_t)c->n);
    q = put(q, c->s, (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        pair[0] = c->x_prev[k];
        pair[1] = c->h_prev[k];
        pair[2] = c->has_prev[k];
        pair[3] = c->vel_set[k];
        pair[4] = c->slope_on[k];
        pair[5] = c->warned[k];
        q = put(q, pair, 6);
    }
    if (c->rg != NULL)
        q = bv_rg_state_write(c, q);
    bv_common_snapshot_seal(buf, size);
}

static int flag_ok(double v) { return v == 0.0 || v == 1.0; }

bv_status bv_state_check(const bv_instance *c, const unsigned char *buf, size_t size)
{
    size_t off, i;
    int k;
    double head[3], pair[6], *p, v;
    if (bv_common_snapshot_check(&c->bc, buf, size, MAGIC, bv_state_size(c)) != BV_OK)
        return BV_ERROR;
    memcpy(head, buf + BV_SNAPSHOT_HEAD, sizeof head);
    off = BV_SNAPSHOT_HEAD + sizeof head;
    if (!(isfinite(head[0]) && flag_ok(head[1]) && flag_ok(head[2]))) {
        say(c, BV_ERROR, "%s: the FMU state is invalid (time or flags); refused", c->bc.name);
        return BV_ERROR;
    }
    p = malloc((size_t)c->np * sizeof *p + 1);
    if (p == NULL)
        return BV_ERROR;
    memcpy(p, buf + off, (size_t)c->np * sizeof *p);
    if (head[1] != 0.0 && !bv_params_valid(c, p, 1)) {
        free(p);
        say(c, BV_ERROR, "%s: the FMU state holds invalid parameters; refused", c->bc.name);
        return BV_ERROR;
    }
    free(p);
    off += (size_t)c->np * 8;
    for (i = 0; i < (size_t)c->n; i++) {
        memcpy(&v, buf + off + 8 * i, 8);
        if (!isfinite(v)) {
            say(c, BV_ERROR, "%s: the FMU state holds a non-finite model state; refused",
                c->bc.name);
            return BV_ERROR;
        }
    }
    off += 8 * ((size_t)c->n + (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        memcpy(pair, buf + off + sizeof pair * (size_t)k, sizeof pair);
        /* consistent as only stepping makes it: a slope in use was seen (a previous
         * displacement and a normal positive step to divide by), never with the velocity
         * set, and warned about; no previous value, no step */
        int has_prev = pair[2] != 0.0, vel_set = pair[3] != 0.0, slope_on = pair[4] != 0.0;
        if (!(flag_ok(pair[2]) && flag_ok(pair[3]) && flag_ok(pair[4]) && flag_ok(pair[5]) &&
              isfinite(pair[0]) && isfinite(pair[1]) &&
              (has_prev ? isnormal(pair[1]) && pair[1] > 0.0
                        : pair[0] == 0.0 && pair[1] == 0.0) &&
              (!slope_on || (has_prev && !vel_set && pair[5] != 0.0)))) {
            say(c, BV_ERROR, "%s: the FMU state is invalid (fallback bookkeeping); refused",
                c->bc.name);
            return BV_ERROR;
        }
    }
    if (c->rg != NULL) {
        if (!bv_rg_state_check(c, buf + off + 48 * (size_t)c->bc.md->npairs)) {
            say(c, BV_ERROR, "%s: the FMU state is invalid (regime of the nonlinear elements); "
                             "refused", c->bc.name);
            return BV_ERROR;
        }
    }
    return BV_OK;
}

static const unsigned char *get(const unsigned char *q, double *v, size_t k)
{
    memcpy(v, q, k * sizeof *v);
    return q + k * sizeof *v;
}

bv_status bv_state_read(bv_instance *c, const unsigned char *buf, size_t size)
{
    int k;
    double head[3], pair[6];
    const unsigned char *regime;
    const unsigned char *q;
    if (bv_state_check(c, buf, size) != BV_OK)
        return BV_ERROR;
    q = get(buf + BV_SNAPSHOT_HEAD, head, 3);
    q = get(q, c->p, (size_t)c->np);
    q = get(q, c->x, (size_t)c->n);
    q = get(q, c->s, (size_t)c->ni);
    for (k = 0; k < c->bc.md->npairs; k++) {
        q = get(q, pair, 6);
        c->x_prev[k] = pair[0];
        c->h_prev[k] = pair[1];
        c->has_prev[k] = (unsigned char)(pair[2] != 0.0);
        c->vel_set[k] = (unsigned char)(pair[3] != 0.0);
        c->slope_on[k] = (unsigned char)(pair[4] != 0.0);
        c->warned[k] = (unsigned char)(pair[5] != 0.0);
    }
    regime = c->rg != NULL ? q : NULL;
    /* the state machine follows the snapshot */
    bv_common_restored(&c->bc, head[0], head[1] != 0.0, head[2] != 0.0, "valid parameters");
    if (memcmp(c->p, c->p_built, (size_t)c->np * sizeof(double)) != 0 && bv_params_valid(c, c->p, 1))
        if (!bv_build(c, c->p) && c->bc.initialized) {
            c->bc.initialized = 0;
            say(c, BV_ERROR, "%s: the restored parameters give a singular model", c->bc.name);
            return BV_ERROR;
        }
    if (regime != NULL) { /* after the model: the regime in force, its step matrices */
        if (!bv_rg_state_read(c, regime)) {
            say(c, BV_ERROR, "%s: the restored regime cannot be assembled", c->bc.name);
            return BV_ERROR;
        }
    }
    return BV_OK;
}
