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
__global__ void k_gather_rows(double *dst, const double *src, const int32_t *idx, int64_t n, int width) {
  const int64_t t = RT_THREAD_INDEX();
  if (t < n * width) dst[t] = src[(int64_t)idx[t / width] * width + t % width];
}
static int cu_gather(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width) {
  const int64_t m = n * width;
  k_gather_rows<<<(unsigned)((m + 255) / 256), 256>>>(dst, src, idx, n, width);
  RT_LAUNCHED(rt, "grain gather");
  return SPHDEM_OK;
}
__global__ void k_scatter_rows(double *dst, const double *src, const int32_t *idx, int64_t n, int width, int add) {
  const int64_t t = RT_THREAD_INDEX();
  if (t >= n * width) return;
  double *d = dst + (int64_t)idx[t / width] * width + t % width;
  *d = add ? *d + src[t] : src[t];
}
static int cu_scatter(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width,
                      int add) {
  const int64_t m = n * width;
  k_scatter_rows<<<(unsigned)((m + 255) / 256), 256>>>(dst, src, idx, n, width, add);
  RT_LAUNCHED(rt, "row scatter");
  return SPHDEM_OK;
}

extern "C" {

const sphdem_rt_mem sphdem_rt_cuda_mem = {"cuda", cu_alloc, cu_free, cu_h2d, cu_d2h, cu_d2d, cu_zero, cu_sync,
                                          cu_gather, cu_scatter};

int sphdem_rt_gpu_probe(char *msg, size_t msglen) {
  int n = 0;
  cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    snprintf(msg, msglen, "cudaGetDeviceCount: %s", cudaGetErrorString(e));
    cudaGetLastError();
    return SPHDEM_ERR_NO_GPU;
  }
  if (n == 0) { snprintf(msg, msglen, "no CUDA device found"); return SPHDEM_ERR_NO_GPU; }
  int dev = 0;
  if (cudaGetDevice(&dev) != cudaSuccess) { cudaGetLastError(); dev = 0; }
  cudaDeviceProp prop;
  if (cudaGetDeviceProperties(&prop, dev) != cudaSuccess) {
    snprintf(msg, msglen, "cannot query device %d", dev);
    return SPHDEM_ERR_NO_GPU;
  }
  snprintf(msg, msglen, "GPU %d: %s (sm_%d%d, %.1f GiB)", dev, prop.name, prop.major, prop.minor,
           prop.totalGlobalMem / 1073741824.0);
  return SPHDEM_OK;
}

int sphdem_gpu_select(int local_rank, char *msg, size_t msglen) {
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess || n == 0) {
    cudaGetLastError();
    if (msg && msglen) snprintf(msg, msglen, "no CUDA device found");
    return SPHDEM_ERR_NO_GPU;
  }
  const int dev = (local_rank < 0 ? 0 : local_rank) % n;
  cudaError_t e = cudaSetDevice(dev);
  if (e != cudaSuccess) {
    if (msg && msglen) snprintf(msg, msglen, "cudaSetDevice(%d): %s", dev, cudaGetErrorString(e));
    cudaGetLastError();
    return SPHDEM_ERR_NO_GPU;
  }
  char m[256];
  const int rc = sphdem_rt_gpu_probe(m, sizeof m);
  if (msg && msglen) snprintf(msg, msglen, "%s (of %d on this node)", m, n);
  return rc;
}

}
