/* Identity and sizes of SignTrackingLogic for the shared FMI 2/3 glue (see ../common/model.h). */
#ifndef FMIONNX_CONFIG_H
#define FMIONNX_CONFIG_H

#define MODEL_GUID "{a3c9d0e4-7b12-4f5a-8e3d-6c1b2a9f4d02}"
#define MODEL_HAS_MODEL_EXCHANGE 0

/* Real value references (modelDescription.xml lists the same numbers). */
enum {
    /* inputs; colour index 0 red = stop, 1 green = turn right, 2 blue = turn left */
    VR_BLOBSIZE0, VR_BLOBSIZE1, VR_BLOBSIZE2,
    VR_BLOBX0, VR_BLOBX1, VR_BLOBX2,
    VR_POSX, VR_POSY, VR_THETA,
    /* outputs */
    VR_V, VR_W,
    /* parameters */
    VR_CRUISE_SPEED, VR_APPROACH_SPEED, VR_APPROACH_GAIN, VR_HEADING_GAIN, VR_TURN_RATE,
    VR_TURN_GAIN, VR_TURN_TOLERANCE, VR_DETECT_SIZE, VR_ACTION_SIZE, VR_REARM_DISTANCE,
    /* locals: the discrete state, visible for debugging and plots */
    VR_HEADING_REF, VR_TURN_TARGET, VR_REARM_X, VR_REARM_Y,
    N_REALS
};

/* Integer value references are INTEGER_VR_BASE + index. */
enum { I_STATE, I_IMAGE_WIDTH, I_SIGN, N_INTEGERS };

/* Boolean value references are BOOLEAN_VR_BASE + index. */
enum { B_STOP_ROBOT, B_SNAP_HEADING, B_STARTED, N_BOOLEANS };

#endif
