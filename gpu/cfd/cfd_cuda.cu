/* cfd_cuda.cu - CUDA backend of the gas grid: one kernel per body of cfd_bodies.h, block reductions. */
#include <cuda_runtime.h>
#include <stdlib.h>

#include "cfd_bodies.h"
#include "cuda_check.h"

#define CFD_BLOCK 256
#define CFD_RED_BLOCKS 1024

static inline unsigned nblk(int64_t n) { return (unsigned)((n + CFD_BLOCK - 1) / CFD_BLOCK); }

#define SPHDEM_CFD_KERNEL_(name)                                                                      \
  __global__ void k_cfd_##name(cfd_dev D, int64_t n) {                                                \
    int64_t i = RT_THREAD_INDEX();                                                                    \
    if (i < n) cfd_k_##name(&D, i);                                                                   \
  }
SPHDEM_CFD_KERNELS(SPHDEM_CFD_KERNEL_)
#undef SPHDEM_CFD_KERNEL_

/* grid-stride partial sums (op 0) or maxima (op 1), one value per block, in a fixed order */
#define SPHDEM_CFD_RKERNEL_(name, op)                                                                 \
  __global__ void r_cfd_##name(cfd_dev D, int64_t n, double *part) {                                  \
    __shared__ double sh[CFD_BLOCK];                                                                  \
    double acc = (op) ? -HUGE_VAL : 0.0;                                                              \
    for (int64_t i = blockIdx.x * (int64_t)blockDim.x + threadIdx.x; i < n;                           \
         i += (int64_t)blockDim.x * gridDim.x) {                                                      \
      double t = cfd_r_##name(&D, i);                                                                 \
      acc = (op) ? (t > acc ? t : acc) : acc + t;                                                     \
    }                                                                                                 \
    sh[threadIdx.x] = acc;                                                                            \
    __syncthreads();                                                                                  \
    for (int s = blockDim.x / 2; s > 0; s >>= 1) {                                                    \
      if (threadIdx.x < s) {                                                                          \
        double o = sh[threadIdx.x + s];                                                               \
        sh[threadIdx.x] = (op) ? (o > sh[threadIdx.x] ? o : sh[threadIdx.x]) : sh[threadIdx.x] + o;   \
      }                                                                                               \
      __syncthreads();                                                                                \
    }                                                                                                 \
    if (threadIdx.x == 0) part[blockIdx.x] = sh[0];                                                   \
  }
SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_RKERNEL_)
#undef SPHDEM_CFD_RKERNEL_

typedef struct {
  double *dpart; /* CFD_RED_BLOCKS partials on the device */
  double *hpart; /* pinned host copy */
} cfd_cuda_data;

static int g_run(struct sphdem_cfd_s *m, int kid, int64_t n) {
  if (n <= 0) return SPHDEM_OK;
  switch (kid) {
#define SPHDEM_CFD_LAUNCH_(name)                                                                      \
  case CFD_K_##name:                                                                                  \
    k_cfd_##name<<<nblk(n), CFD_BLOCK>>>(m->D, n);                                                    \
    return rt_cuda_check(&m->rt, cudaGetLastError(), "kernel " #name);
    SPHDEM_CFD_KERNELS(SPHDEM_CFD_LAUNCH_)
#undef SPHDEM_CFD_LAUNCH_
  }
  return rt_fail(&m->rt, SPHDEM_ERR_ARG, "internal: unknown gas-grid loop %d", kid);
}

static const int g_red_op[] = {
#define SPHDEM_CFD_ROP_(name, op) op,
    SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_ROP_)
#undef SPHDEM_CFD_ROP_
};

static int g_reduce(struct sphdem_cfd_s *m, int rid, int64_t n, double *out) {
  cfd_cuda_data *cd = (cfd_cuda_data *)m->backend_data;
  int rc;
  if (!cd) {
    cd = (cfd_cuda_data *)calloc(1, sizeof *cd);
    if (!cd) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the reduction buffers");
    m->backend_data = cd;
    if ((rc = rt_cuda_check(&m->rt, cudaMalloc((void **)&cd->dpart, sizeof(double) * CFD_RED_BLOCKS), "reduction buffer")) ||
        (rc = rt_cuda_check(&m->rt, cudaMallocHost((void **)&cd->hpart, sizeof(double) * CFD_RED_BLOCKS), "pinned buffer")))
      return rc;
  }
  int op = g_red_op[rid];
  if (n <= 0) {
    *out = op ? -HUGE_VAL : 0.0;
    return SPHDEM_OK;
  }
  unsigned nb = nblk(n);
  if (nb > CFD_RED_BLOCKS) nb = CFD_RED_BLOCKS;
  switch (rid) {
#define SPHDEM_CFD_RLAUNCH_(name, op_)                                                                \
  case CFD_R_##name:                                                                                  \
    r_cfd_##name<<<nb, CFD_BLOCK>>>(m->D, n, cd->dpart);                                              \
    break;
    SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_RLAUNCH_)
#undef SPHDEM_CFD_RLAUNCH_
    default:
      return rt_fail(&m->rt, SPHDEM_ERR_ARG, "internal: unknown gas-grid reduction %d", rid);
  }
  if ((rc = rt_cuda_check(&m->rt, cudaGetLastError(), "reduction kernel"))) return rc;
  if ((rc = rt_cuda_check(&m->rt, cudaMemcpy(cd->hpart, cd->dpart, sizeof(double) * nb, cudaMemcpyDeviceToHost),
                   "reduction copy")))
    return rc;
  double acc = op ? -HUGE_VAL : 0.0;
  for (unsigned b = 0; b < nb; b++) acc = op ? (cd->hpart[b] > acc ? cd->hpart[b] : acc) : acc + cd->hpart[b];
  *out = acc;
  return SPHDEM_OK;
}

static void g_release(struct sphdem_cfd_s *m) {
  cfd_cuda_data *cd = (cfd_cuda_data *)m->backend_data;
  if (!cd) return;
  if (cd->dpart) cudaFree(cd->dpart);
  if (cd->hpart) cudaFreeHost(cd->hpart);
  free(cd);
  m->backend_data = NULL;
}

extern "C" const cfd_ops sphdem_cfd_cuda_ops = {"cuda", g_run, g_reduce, g_release};
