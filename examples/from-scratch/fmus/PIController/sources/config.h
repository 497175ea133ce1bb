/* Identity and sizes of PIController for the shared FMI 2 glue (models/fmus/common/model.h). */
#ifndef FMIONNX_CONFIG_H
#define FMIONNX_CONFIG_H

#define MODEL_GUID "{e4b8a6d2-1f37-4c95-a0d8-93c5f7b2e640}"
/* Co-simulation only: the integral is a discrete state advanced by fmi2DoStep. */
#define MODEL_HAS_MODEL_EXCHANGE 0

/* Real value references (modelDescription.xml lists the same numbers). */
enum {
    VR_SETPOINT, VR_MEASUREMENT, VR_FEEDFORWARD, /* inputs */
    VR_U,                                        /* output */
    VR_KP, VR_TI, VR_UMIN, VR_UMAX,              /* parameters */
    VR_INTEGRAL,                                 /* local: the integral of the error */
    N_REALS
};

#define N_INTEGERS 0
#define N_BOOLEANS 0

#endif
