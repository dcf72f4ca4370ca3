/* couple_cuda.cu - CUDA backend of the SPH-DEM coupling: kernels over the bodies of couple_bodies.h. */
#include <cuda_runtime.h>

#include "couple_bodies.h"
#include "cuda_check.h"
#include "sph_internal.h"

#define SPHDEM_CBLOCK 128

static inline unsigned cblocks(int64_t n) { return (unsigned)((n + SPHDEM_CBLOCK - 1) / SPHDEM_CBLOCK); }

__global__ void k_couple_porosity(sphdem_dev D) {
  int64_t i = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (i < D.nf) couple_porosity_body(&D, i);
}

__global__ void k_couple_grains(sphdem_dev D) {
  int64_t j = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (j < D.ng) couple_grain_body(&D, j);
}

__global__ void k_couple_reaction(sphdem_dev D) {
  int64_t i = blockIdx.x * (int64_t)blockDim.x + threadIdx.x;
  if (i < D.nf) couple_reaction_body(&D, i);
}

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
