/* Identity and sizes of Heater for the shared FMI 2 glue (models/fmus/common/model.h). */
#ifndef FMIONNX_CONFIG_H
#define FMIONNX_CONFIG_H

#define MODEL_GUID "{7c1e2f40-5a9b-4d3e-8f16-2b0c9a4e6d11}"
/* Co-simulation only: the glue's model exchange has no continuous states to integrate. */
#define MODEL_HAS_MODEL_EXCHANGE 0

/* Real value references (modelDescription.xml lists the same numbers). */
enum { VR_POWER, VR_AMBIENT, VR_T, VR_R, VR_C, VR_T0, N_REALS };

#define N_INTEGERS 0
#define N_BOOLEANS 0

#endif
