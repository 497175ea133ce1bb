/* Heater: a room heated by an electric heater, one thermal capacity C losing heat through a
 * wall of thermal resistance R to the outside air:
 *
 *     C dT/dt = power - (T - ambient) / R
 *
 * A first-order plant with time constant tau = R C and steady state ambient + R power.
 * Co-simulation steps use the exact solution for inputs held over the step,
 *
 *     T(t + h) = Tss + (T(t) - Tss) exp(-h / tau),   Tss = ambient + R power,
 *
 * so the result does not depend on the communication step (no integration error to tune),
 * which is what a master holding inputs constant between steps assumes anyway.
 */
#include <math.h>

#include "model.h"

void model_set_start_values(ModelData *m) {
    double *r = m->reals;
    r[VR_POWER] = 0.0;
    r[VR_AMBIENT] = 10.0;
    r[VR_R] = 0.01;     /* K/W: 1 kW keeps the room 10 K above the outside */
    r[VR_C] = 20000.0;  /* J/K: with R, a time constant of 200 s */
    r[VR_T0] = 15.0;
    r[VR_T] = r[VR_T0];
}

/* T is the state: nothing to compute from the inputs (no direct feedthrough). */
void model_evaluate(ModelData *m) { (void)m; }

void model_do_step(ModelData *m, double h) {
    double *r = m->reals;
    const double tau = r[VR_R] * r[VR_C];
    if (!(tau > 0.0)) return; /* a non-physical parameter set: hold the temperature */
    const double steady = r[VR_AMBIENT] + r[VR_R] * r[VR_POWER];
    r[VR_T] = steady + (r[VR_T] - steady) * exp(-h / tau);
}

void model_initialize(ModelData *m) { m->reals[VR_T] = m->reals[VR_T0]; }
