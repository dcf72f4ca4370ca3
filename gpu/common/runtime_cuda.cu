/* runtime_cuda.cu - CUDA memory of the shared runtime (cudaMalloc, cudaMemcpy, cudaMemset, synchronise) and
 * the GPU probe. */
#include <cuda_runtime.h>
#include <stdio.h>

#include "cuda_check.h"

static int cu_alloc(sphdem_rt *rt, void **ptr, size_t bytes) {
  cudaError_t e = cudaMalloc(ptr, bytes);
  if (e != cudaSuccess) {
    *ptr = NULL;
    return sphdem_rt_fail(rt, SPHDEM_ERR_ALLOC, "cannot allocate %zu bytes of GPU memory (%s)", bytes,
                          cudaGetErrorString(e));
  }
  return SPHDEM_OK;
}
static void cu_free(sphdem_rt *rt, void *ptr) { (void)rt; cudaFree(ptr); }
static int cu_h2d(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return rt_cuda_check(rt, cudaMemcpy(dst, src, bytes, cudaMemcpyHostToDevice), "host-to-device copy");
}
static int cu_d2h(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return rt_cuda_check(rt, cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToHost), "device-to-host copy");
}
static int cu_d2d(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return rt_cuda_check(rt, cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToDevice), "device copy");
}
static int cu_zero(sphdem_rt *rt, void *ptr, size_t bytes) {
  return rt_cuda_check(rt, cudaMemset(ptr, 0, bytes), "memset");
}
static int cu_sync(sphdem_rt *rt) { return rt_cuda_check(rt, cudaDeviceSynchronize(), "kernel execution"); }

extern "C" {

const sphdem_rt_mem sphdem_rt_cuda_mem = {"cuda", cu_alloc, cu_free, cu_h2d, cu_d2h, cu_d2d, cu_zero, cu_sync};

int sphdem_rt_gpu_probe(char *msg, size_t msglen) {
  int n = 0;
  cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    snprintf(msg, msglen, "cudaGetDeviceCount: %s", cudaGetErrorString(e));
    cudaGetLastError();
    return SPHDEM_ERR_NO_GPU;
  }
  if (n == 0) { snprintf(msg, msglen, "no CUDA device found"); return SPHDEM_ERR_NO_GPU; }
  cudaDeviceProp prop;
  if (cudaGetDeviceProperties(&prop, 0) != cudaSuccess) { snprintf(msg, msglen, "cannot query device 0"); return SPHDEM_ERR_NO_GPU; }
  snprintf(msg, msglen, "GPU 0: %s (sm_%d%d, %.1f GiB)", prop.name, prop.major, prop.minor,
           prop.totalGlobalMem / 1073741824.0);
  return SPHDEM_OK;
}

}
