/* The contract between the shared FMI glue (fmi2Functions.c, fmi3Functions.c) and one model (model.c).
 *
 * Why a split: every FMU in models/ needs the same ~40 FMI 2 entry points, mode checks and
 * state copying; only the equations differ. The glue owns the FMI side, a model fills in the
 * four functions below. Each model's config.h sets the sizes and identity used here.
 *
 * Values live in one flat array per FMI base type. Value references are unique over all types
 * (Real: 0.., Integer: INTEGER_VR_BASE.., Boolean: BOOLEAN_VR_BASE..) so that tools keying
 * variables by value reference alone still work.
 */
#ifndef FMIONNX_MODEL_H
#define FMIONNX_MODEL_H

#include "config.h"

#define INTEGER_VR_BASE 100u
#define BOOLEAN_VR_BASE 200u

#define ARRAY_SIZE(n) ((n) > 0 ? (n) : 1)

typedef struct {
    double reals[ARRAY_SIZE(N_REALS)];
    int integers[ARRAY_SIZE(N_INTEGERS)];
    int booleans[ARRAY_SIZE(N_BOOLEANS)];
    double time;
    /* Set when an input changed since the outputs were last evaluated (lazy evaluation). */
    int dirty;
} ModelData;

/* Start values of every variable (called by fmi2Instantiate and fmi2Reset). */
void model_set_start_values(ModelData *m);

/* Outputs from inputs and discrete state, without advancing anything (direct feedthrough). */
void model_evaluate(ModelData *m);

/* Advance the discrete state over one communication step of length h (co-simulation). */
void model_do_step(ModelData *m, double h);

/* Called once by fmi2ExitInitializationMode, after parameters and inputs are set. */
void model_initialize(ModelData *m);

#endif
