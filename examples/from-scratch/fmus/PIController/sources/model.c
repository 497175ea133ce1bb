/* PIController: a PI controller with feed-forward, output limits and anti-windup.
 *
 *     u = clamp(feedforward + kp (e + integral / Ti), uMin, uMax),   e = setpoint - measurement
 *
 * The integral advances by e h per communication step (forward Euler: the value used for u
 * during a step is the one known at its start, as a sampled controller does). Anti-windup by
 * conditional integration: while u sits at a limit, the error that pushes it further into the
 * limit is not integrated, so the controller leaves saturation as soon as the error turns
 * instead of first unwinding an integral that grew while nothing could happen.
 */
#include "model.h"

static double unclamped(const double *r) {
    const double e = r[VR_SETPOINT] - r[VR_MEASUREMENT];
    const double ti = r[VR_TI] > 0.0 ? r[VR_TI] : 1.0;
    return r[VR_FEEDFORWARD] + r[VR_KP] * (e + r[VR_INTEGRAL] / ti);
}

void model_set_start_values(ModelData *m) {
    double *r = m->reals;
    for (int k = 0; k < N_REALS; k++) r[k] = 0.0;
    r[VR_KP] = 500.0;   /* W/K */
    r[VR_TI] = 200.0;   /* s */
    r[VR_UMIN] = 0.0;   /* W: a heater cannot cool */
    r[VR_UMAX] = 3000.0;
}

void model_evaluate(ModelData *m) {
    double *r = m->reals;
    const double u = unclamped(r);
    r[VR_U] = u < r[VR_UMIN] ? r[VR_UMIN] : (u > r[VR_UMAX] ? r[VR_UMAX] : u);
}

void model_do_step(ModelData *m, double h) {
    double *r = m->reals;
    const double e = r[VR_SETPOINT] - r[VR_MEASUREMENT];
    const double u = unclamped(r);
    const int pushes_up = u >= r[VR_UMAX] && e > 0.0;
    const int pushes_down = u <= r[VR_UMIN] && e < 0.0;
    if (!pushes_up && !pushes_down) r[VR_INTEGRAL] += e * h;
    model_evaluate(m);
}

void model_initialize(ModelData *m) {
    m->reals[VR_INTEGRAL] = 0.0;
    model_evaluate(m);
}
