/* SignTrackingLogic: drive a differential robot by coloured traffic signs.
 *
 * Inputs per sign colour c (0 red = stop, 1 green = turn right, 2 blue = turn left): blobSize[c]
 * (sqrt(2 * pixel count), 0 when unseen) and blobX[c] (mean image column, -1 when unseen);
 * the odometry pose posX, posY, theta. Outputs the velocity command v (m/s), w (rad/s,
 * counter-clockwise positive) and stopRobot.
 *
 * State machine, advanced once per co-simulation step (outputs hold until the next step):
 *
 *   SEARCH     drive at cruiseSpeed holding headingRef (P control on theta);
 *              -> APPROACH when the largest blob >= detectSize and the robot moved at least
 *                 rearmDistance since the last turn (so the sign just obeyed cannot re-trigger).
 *   APPROACH   drive at approachSpeed steering to centre the largest blob in the image;
 *              -> SEARCH when no blob >= detectSize remains;
 *              -> STOP / TURN_RIGHT / TURN_LEFT when the largest blob >= actionSize and it is
 *                 red / green / blue.
 *   TURN_LEFT  turn on the spot to turnTarget = headingRef + pi/2 (closed on theta, error
 *   TURN_RIGHT wrapped to (-pi, pi]; -pi/2 for the right turn); -> SEARCH within turnTolerance,
 *              with headingRef = turnTarget.
 *   STOP       v = w = 0, stopRobot = true; final.
 *
 * With snapHeading the headings are rounded to the nearest multiple of pi/2 (a grid course):
 * the small heading error left by steering on a sign is then not carried into the next leg.
 */
#include <math.h>

#include "model.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { SEARCH = 0, APPROACH = 1, TURN_LEFT = 2, TURN_RIGHT = 3, STOP = 4 };
enum { RED = 0, GREEN = 1, BLUE = 2 };

static double wrap(double angle) {
    /* to (-pi, pi] */
    double a = fmod(angle + M_PI, 2.0 * M_PI);
    if (a <= 0.0) a += 2.0 * M_PI;
    return a - M_PI;
}

static double clamp(double value, double limit) {
    return value > limit ? limit : (value < -limit ? -limit : value);
}

static double snap(const ModelData *m, double heading) {
    if (!m->booleans[B_SNAP_HEADING]) return wrap(heading);
    return wrap(M_PI / 2.0 * nearbyint(heading / (M_PI / 2.0)));
}

void model_set_start_values(ModelData *m) {
    double *r = m->reals;
    for (int k = 0; k < N_REALS; k++) r[k] = 0.0;
    for (int c = 0; c < 3; c++) r[VR_BLOBX0 + c] = -1.0;
    r[VR_CRUISE_SPEED] = 0.5;
    r[VR_APPROACH_SPEED] = 0.4;
    r[VR_APPROACH_GAIN] = 0.6;
    r[VR_HEADING_GAIN] = 2.0;
    r[VR_TURN_RATE] = 0.8;
    r[VR_TURN_GAIN] = 3.0;
    r[VR_TURN_TOLERANCE] = 0.01;
    r[VR_DETECT_SIZE] = 60.0;
    r[VR_ACTION_SIZE] = 300.0;
    r[VR_REARM_DISTANCE] = 0.5;
    m->integers[I_STATE] = SEARCH;
    m->integers[I_IMAGE_WIDTH] = 640;
    m->integers[I_SIGN] = -1;
    m->booleans[B_STOP_ROBOT] = 0;
    m->booleans[B_SNAP_HEADING] = 1;
    m->booleans[B_STARTED] = 0;
}

/* Index of the largest blob at least detectSize, or -1. Ties go to the lower index. */
static int dominant_sign(const ModelData *m) {
    int best = -1;
    for (int c = 0; c < 3; c++) {
        const double size = m->reals[VR_BLOBSIZE0 + c];
        if (size >= m->reals[VR_DETECT_SIZE] && (best < 0 || size > m->reals[VR_BLOBSIZE0 + best])) {
            best = c;
        }
    }
    return best;
}

static void start_turn(ModelData *m, int state, double quarter) {
    m->integers[I_STATE] = state;
    m->reals[VR_TURN_TARGET] = snap(m, m->reals[VR_HEADING_REF] + quarter);
}

static void transition(ModelData *m) {
    double *r = m->reals;
    const int sign = dominant_sign(m);
    m->integers[I_SIGN] = sign;
    switch (m->integers[I_STATE]) {
    case SEARCH: {
        const double moved = hypot(r[VR_POSX] - r[VR_REARM_X], r[VR_POSY] - r[VR_REARM_Y]);
        if (sign >= 0 && moved >= r[VR_REARM_DISTANCE]) m->integers[I_STATE] = APPROACH;
        break;
    }
    case APPROACH:
        if (sign < 0) {
            m->integers[I_STATE] = SEARCH;
        } else if (r[VR_BLOBSIZE0 + sign] >= r[VR_ACTION_SIZE]) {
            if (sign == RED) m->integers[I_STATE] = STOP;
            else if (sign == GREEN) start_turn(m, TURN_RIGHT, -M_PI / 2.0);
            else start_turn(m, TURN_LEFT, M_PI / 2.0);
        }
        break;
    case TURN_LEFT:
    case TURN_RIGHT:
        if (fabs(wrap(r[VR_TURN_TARGET] - r[VR_THETA])) < r[VR_TURN_TOLERANCE]) {
            m->integers[I_STATE] = SEARCH;
            r[VR_HEADING_REF] = r[VR_TURN_TARGET];
            r[VR_REARM_X] = r[VR_POSX];
            r[VR_REARM_Y] = r[VR_POSY];
        }
        break;
    default: /* STOP is final */
        break;
    }
}

static void command(ModelData *m) {
    double *r = m->reals;
    const double limit = r[VR_TURN_RATE];
    double v = 0.0, w = 0.0;
    switch (m->integers[I_STATE]) {
    case SEARCH:
        v = r[VR_CRUISE_SPEED];
        w = clamp(r[VR_HEADING_GAIN] * wrap(r[VR_HEADING_REF] - r[VR_THETA]), limit);
        break;
    case APPROACH: {
        const int sign = m->integers[I_SIGN];
        const double half = 0.5 * (double)m->integers[I_IMAGE_WIDTH];
        /* image column grows to the right; a sign right of centre needs a clockwise turn */
        const double offset = (r[VR_BLOBX0 + sign] - (half - 0.5)) / half;
        v = r[VR_APPROACH_SPEED];
        w = clamp(-r[VR_APPROACH_GAIN] * offset, limit);
        break;
    }
    case TURN_LEFT:
    case TURN_RIGHT:
        w = clamp(r[VR_TURN_GAIN] * wrap(r[VR_TURN_TARGET] - r[VR_THETA]), limit);
        break;
    default:
        break;
    }
    r[VR_V] = v;
    r[VR_W] = w;
    m->booleans[B_STOP_ROBOT] = m->integers[I_STATE] == STOP;
}

void model_initialize(ModelData *m) {
    m->integers[I_STATE] = SEARCH;
    m->booleans[B_STARTED] = 0;
    m->reals[VR_V] = 0.0;
    m->reals[VR_W] = 0.0;
    m->booleans[B_STOP_ROBOT] = 0;
}

/* Outputs are held between steps (no direct feedthrough): nothing to evaluate. */
void model_evaluate(ModelData *m) { (void)m; }

void model_do_step(ModelData *m, double h) {
    (void)h;
    if (!m->booleans[B_STARTED]) {
        /* the first pose seen defines the initial heading and the rearm point */
        m->booleans[B_STARTED] = 1;
        m->reals[VR_HEADING_REF] = snap(m, m->reals[VR_THETA]);
        m->reals[VR_REARM_X] = m->reals[VR_POSX] - 1e9; /* armed from the start */
        m->reals[VR_REARM_Y] = m->reals[VR_POSY];
    }
    transition(m);
    command(m);
}
