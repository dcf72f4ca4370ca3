/* sph_cuda.cu - CUDA backend of the fluid: the kernels and launchers of the listed passes (sph_passes.h), the
 * sorts and the reduction. */
#include <cuda_runtime.h>
#include <thrust/device_ptr.h>
#include <thrust/execution_policy.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <stdio.h>

#include "cuda_check.h"
#include "fluid_rates.h"
#include "sph_internal.h"

#define SPHDEM_BLOCK 256
#define SPHDEM_RED_BLOCKS 512

static inline unsigned nblocks(int64_t n) { return (unsigned)((n + SPHDEM_BLOCK - 1) / SPHDEM_BLOCK); }

/* ---- sort and reduction kernels; the passes' kernels come from the list ------------------------------ */

__global__ void k_cell(sphdem_dev D, int set, uint64_t *key, int32_t *perm) {
  int64_t i = RT_THREAD_INDEX();
  if (i >= set_count(&D, set)) return;
  int32_t c = set_cell_of(&D, set, set_x(&D, set) + 3 * i);
  key[i] = sort_key(c, set_tag(&D, set)[i]);
  perm[i] = (int32_t)i;
}

__global__ void k_cell_from_key(const uint64_t *key, int32_t *cell, int64_t n) {
  int64_t i = RT_THREAD_INDEX();
  if (i < n) cell[i] = (int32_t)(key[i] >> 36);
}

__global__ void k_gather(uint32_t *dst, const uint32_t *src, const int32_t *perm, int ew, int64_t n) {
  int64_t i = RT_THREAD_INDEX();
  if (i < n) gather_words_body(dst, src, perm, ew, i);
}

__global__ void k_cell_ranges(const int32_t *cell, int64_t n, int32_t *cs, int32_t *ce) {
  int64_t i = RT_THREAD_INDEX();
  if (i < n) cell_range_body(cell, n, i, cs, ce);
}

/* the kernels and launchers of the listed passes (sph_passes.h) */
#define SPHDEM_PASS_BLOCK SPHDEM_BLOCK
SPHDEM_FLUID_PASSES(SPHDEM_PASS_CUDA)
#undef SPHDEM_PASS_BLOCK

/* Block-wise reduction with the shared red_combine; the host combines the block results. */
__global__ void k_reduce(sphdem_dev D, int set, sphdem_red *out) {
  __shared__ sphdem_red sh[SPHDEM_BLOCK];
  int64_t n = set == SPHDEM_SET_FLUID ? D.nf : D.nw;
  sphdem_red r;
  red_init(&r);
  for (int64_t i = RT_THREAD_INDEX(); i < n; i += (int64_t)gridDim.x * blockDim.x)
    red_body(&D, set, i, &r);
  sh[threadIdx.x] = r;
  __syncthreads();
  for (int s = blockDim.x / 2; s > 0; s >>= 1) {
    if (threadIdx.x < s) red_combine(&sh[threadIdx.x], &sh[threadIdx.x + s]);
    __syncthreads();
  }
  if (threadIdx.x == 0) out[blockIdx.x] = sh[0];
}

/* ---- operations ------------------------------------------------------------------------------------- */

typedef struct {
  sphdem_red *dred;
  sphdem_red hred[SPHDEM_RED_BLOCKS];
} cuda_data;

static int cu_sort_perm(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = set_count(D, set);
  uint64_t *key = (uint64_t *)c->scratch_i;
  k_cell<<<nblocks(n), SPHDEM_BLOCK>>>(*D, set, key, c->perm);
  RT_LAUNCHED(&c->rt, "cell index kernel");
  thrust::sort_by_key(thrust::device, thrust::device_ptr<uint64_t>(key), thrust::device_ptr<uint64_t>(key + n),
                      thrust::device_ptr<int32_t>(c->perm));
  RT_LAUNCHED(&c->rt, "radix sort");
  k_cell_from_key<<<nblocks(n), SPHDEM_BLOCK>>>(key, set_cell(D, set), n);
  RT_LAUNCHED(&c->rt, "cell extraction kernel");
  return SPHDEM_OK;
}

static int cu_gather(struct sphdem_ctx_s *c, void *arr, int elem_bytes, int64_t n) {
  k_gather<<<nblocks(n), SPHDEM_BLOCK>>>((uint32_t *)c->scratch_d, (const uint32_t *)arr, c->perm, elem_bytes / 4, n);
  RT_LAUNCHED(&c->rt, "gather kernel");
  return rt_d2d(&c->rt, arr, c->scratch_d, (size_t)elem_bytes * (size_t)n);
}

static int cu_cell_ranges(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = set_count(D, set);
  int32_t *cs = set_cstart(D, set), *ce = set_cend(D, set);
  RT_CK(&c->rt, cudaMemset(cs, 0, sizeof(int32_t) * (size_t)set_ncells(D, set)), "memset");
  RT_CK(&c->rt, cudaMemset(ce, 0, sizeof(int32_t) * (size_t)set_ncells(D, set)), "memset");
  k_cell_ranges<<<nblocks(n), SPHDEM_BLOCK>>>(set_cell(D, set), n, cs, ce);
  RT_LAUNCHED(&c->rt, "cell range kernel");
  return SPHDEM_OK;
}

static int cu_reduce(struct sphdem_ctx_s *c, int set, sphdem_red *out) {
  cuda_data *cd = (cuda_data *)c->backend_data;
  int64_t n = set == SPHDEM_SET_FLUID ? c->D.nf : c->D.nw;
  red_init(out);
  if (n == 0) return SPHDEM_OK;
  unsigned nb = nblocks(n);
  if (nb > SPHDEM_RED_BLOCKS) nb = SPHDEM_RED_BLOCKS;
  k_reduce<<<nb, SPHDEM_BLOCK>>>(c->D, set, cd->dred);
  RT_LAUNCHED(&c->rt, "reduction kernel");
  RT_CK(&c->rt, cudaMemcpy(cd->hred, cd->dred, nb * sizeof(sphdem_red), cudaMemcpyDeviceToHost), "reduction copy");
  for (unsigned b = 0; b < nb; b++) red_combine(out, &cd->hred[b]);
  return SPHDEM_OK;
}

extern "C" {

const sphdem_ops sphdem_cuda_ops = {
  "cuda", cu_sort_perm, cu_gather, cu_cell_ranges, cu_reduce,
  SPHDEM_FLUID_PASSES(SPHDEM_PASS_CUDA_ENTRY)
  SPHDEM_COUPLE_PASSES(SPHDEM_PASS_CUDA_ENTRY)
};

int sphdem_cuda_init(struct sphdem_ctx_s *c) {
  cuda_data *cd = (cuda_data *)calloc(1, sizeof(cuda_data));
  if (!cd) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate CUDA backend data");
  if (cudaMalloc((void **)&cd->dred, SPHDEM_RED_BLOCKS * sizeof(sphdem_red)) != cudaSuccess) {
    free(cd);
    return sphdem_fail(c, SPHDEM_ERR_CUDA, "cannot allocate the reduction buffer on the GPU");
  }
  c->backend_data = cd;
  return SPHDEM_OK;
}

void sphdem_cuda_fini(struct sphdem_ctx_s *c) {
  cuda_data *cd = (cuda_data *)c->backend_data;
  if (!cd) return;
  cudaFree(cd->dred);
  free(cd);
  c->backend_data = NULL;
}

}
