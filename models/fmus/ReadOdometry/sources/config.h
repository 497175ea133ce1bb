/* Identity and sizes of ReadOdometry for the shared FMI 2/3 glue (see ../common/model.h). */
#ifndef FMIONNX_CONFIG_H
#define FMIONNX_CONFIG_H

#define MODEL_GUID "{5f0e7a52-3c1d-4b8e-9a61-0d2f4c7b9e01}"
#define MODEL_HAS_MODEL_EXCHANGE 1

/* Value references of the Real variables (modelDescription.xml lists the same numbers). */
enum { VR_QW, VR_QX, VR_QY, VR_QZ, VR_X, VR_Y, VR_POSX, VR_POSY, VR_THETA, N_REALS };

#define N_INTEGERS 0
#define N_BOOLEANS 0

#endif
