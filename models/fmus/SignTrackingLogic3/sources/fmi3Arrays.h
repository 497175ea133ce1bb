/* FMI 3 arrays of SignTrackingLogic3 for the shared FMI 3 glue (see ../common/fmi3Functions.c).
 *
 * Why: the FMI 2 build has no arrays and names blobSize[1..3], blobX[1..3] as six scalars
 * (value references 0..5). The FMI 3 build declares them as two Float64 arrays of three elements,
 * each with one value reference (that of its first element), over the same reals of config.h.
 * Colour index 0 red = stop, 1 green = turn right, 2 blue = turn left.
 */
#ifndef FMIONNX_FMI3_ARRAYS_H
#define FMIONNX_FMI3_ARRAYS_H

/* {value reference, first index in ModelData.reals, element count} */
#define MODEL_FMI3_ARRAYS                    \
    {                                        \
        {VR_BLOBSIZE0, VR_BLOBSIZE0, 3},     \
        {VR_BLOBX0, VR_BLOBX0, 3},           \
    }

#endif
