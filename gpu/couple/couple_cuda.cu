/* couple_cuda.cu - CUDA backend of the SPH-DEM coupling: kernels over the bodies of couple_bodies.h. */
#include <cuda_runtime.h>

#include "couple_bodies.h"
#include "cuda_check.h"
#include "sph_internal.h"

#define SPHDEM_CBLOCK 128

static inline unsigned cblocks(int64_t n) { return (unsigned)((n + SPHDEM_CBLOCK - 1) / SPHDEM_CBLOCK); }

RT_KERNEL_EACH(k_couple_porosity, sphdem_dev, D.nf, couple_porosity_body)

RT_KERNEL_EACH(k_couple_grains, sphdem_dev, D.ng, couple_grain_body)

RT_KERNEL_EACH(k_couple_reaction, sphdem_dev, D.nf, couple_reaction_body)

extern "C" {

int sphdem_cuda_couple_porosity(struct sphdem_ctx_s *c) {
  if (c->D.nf == 0) return SPHDEM_OK;
  k_couple_porosity<<<cblocks(c->D.nf), SPHDEM_CBLOCK>>>(c->D);
  return rt_cuda_check(&c->rt, cudaGetLastError(), "coupling porosity kernel");
}

int sphdem_cuda_couple_grains(struct sphdem_ctx_s *c) {
  if (c->D.ng == 0) return SPHDEM_OK;
  k_couple_grains<<<cblocks(c->D.ng), SPHDEM_CBLOCK>>>(c->D);
  return rt_cuda_check(&c->rt, cudaGetLastError(), "coupling grain force kernel");
}

int sphdem_cuda_couple_reaction(struct sphdem_ctx_s *c) {
  if (c->D.nf == 0) return SPHDEM_OK;
  k_couple_reaction<<<cblocks(c->D.nf), SPHDEM_CBLOCK>>>(c->D);
  return rt_cuda_check(&c->rt, cudaGetLastError(), "coupling reaction kernel");
}

}
