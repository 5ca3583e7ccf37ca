/*
 * bodyvib native source FMUs (Road.fmu): a tabulated profile driven through at a speed.
 *
 * The same API as the linear core (bodyvib_core.h: bv_new .. bv_directional), implemented
 * by bodyvib_table.c instead of bodyvib_core.c, with the same state machine
 * (bodyvib_fsm.c), so the FMI 2.0 and 3.0 function files wrap either unchanged. The generated model file (bodyvib_model.c) defines, besides
 * bv_model_data (names, value references, the speed parameter), the table:
 *
 *     rows p_i = p0 + i dp (i = 0 .. rows - 1) of the profiles z_c(p_i) and slopes
 *     dz_c/dp(p_i), c = 0 .. signals - 1.
 *
 * Outputs 2c and 2c + 1 (value references in bv_model_data) are z_c(p) and
 * speed * dz_c/dp at p = speed * time, from one piecewise cubic Hermite interpolant
 * (the rate output is the exact derivative of the value output); periodic tables repeat,
 * others hold their end values with zero slope: bodyvib.runtime.tabulated.HermiteTable,
 * operation for operation, so the native and the pythonfmu Road.fmu agree to rounding.
 */
#ifndef BODYVIB_SOURCE_H
#define BODYVIB_SOURCE_H

#include "bodyvib_core.h"

typedef struct {
    int signals;          /* profiles */
    int rows;             /* table rows, >= 2 */
    double p0, dp;        /* first position, uniform spacing (> 0) */
    int periodic;         /* 1: period (rows - 1) dp; 0: hold the end values */
    const double *value;  /* [rows * signals] row-major */
    const double *slope;  /* [rows * signals] row-major, d value / d position */
    int loop;             /* periodic: the repeating part's first row (the rows before it
                             are a lead-in, driven once); 0: the whole table repeats */
} bv_source;

/* The generated table (bodyvib_model.c of a source FMU). */
extern const bv_source bv_source_data;

/* Values z[signals] and slopes dz[signals] (per unit of the coordinate) at position p. */
void bv_source_evaluate(const bv_source *t, double p, double *z, double *dz);
/* Second and third derivatives d2z[signals], d3z[signals] (per unit of the coordinate) at
 * position p: those of the segment's cubic (the next segment's at a table row); 0 off a
 * non-periodic table. */
void bv_source_curvature(const bv_source *t, double p, double *d2z, double *d3z);

#endif
