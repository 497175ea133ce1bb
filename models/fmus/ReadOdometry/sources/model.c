/* ReadOdometry: planar pose (posX, posY, theta) from a 3-D position and orientation quaternion.
 *
 * theta is the yaw (rotation about +z) of the quaternion q = (w, x, y, z), i.e. the heading of
 * the body's x axis projected on the ground plane:
 *
 *     theta = atan2(2 (w z + x y), w^2 + x^2 - y^2 - z^2)
 *
 * Both arguments are homogeneous of degree 2 in q, so the angle is the same for q and s*q
 * (s > 0): non-unit quaternions need no normalisation, and atan2 keeps full precision on the
 * whole circle, including near +-pi where the sign of the first argument flips. For a unit
 * quaternion the second argument equals the textbook 1 - 2 (y^2 + z^2). The zero quaternion
 * (no orientation) gives theta = 0.
 */
#include <math.h>

#include "model.h"

void model_set_start_values(ModelData *m) {
    for (int k = 0; k < N_REALS; k++) m->reals[k] = 0.0;
    m->reals[VR_QW] = 1.0;
}

void model_evaluate(ModelData *m) {
    const double *r = m->reals;
    const double w = r[VR_QW], x = r[VR_QX], y = r[VR_QY], z = r[VR_QZ];
    m->reals[VR_POSX] = r[VR_X];
    m->reals[VR_POSY] = r[VR_Y];
    m->reals[VR_THETA] = atan2(2.0 * (w * z + x * y), (w * w + x * x) - (y * y + z * z));
}

void model_do_step(ModelData *m, double h) {
    (void)h; /* algebraic model: nothing to advance */
    model_evaluate(m);
}

void model_initialize(ModelData *m) { model_evaluate(m); }
