/* couple_cuda.cu - CUDA backend of the SPH-DEM coupling: the kernels and launchers of its listed passes
 * (sph_passes.h) over the bodies of couple_bodies.h. */
#include <cuda_runtime.h>

#include "couple_bodies.h"
#include "cuda_check.h"
#include "sph_internal.h"

#define SPHDEM_CBLOCK 128

/* the kernels and launchers of the coupling's listed passes (sph_passes.h) */
#define SPHDEM_PASS_BLOCK SPHDEM_CBLOCK
SPHDEM_COUPLE_PASSES(SPHDEM_PASS_CUDA)
#undef SPHDEM_PASS_BLOCK
