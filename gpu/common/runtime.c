/* runtime.c - the device runtime shared by every context: CPU memory (malloc/memcpy/memset), reductions over
 * ranks, monotonic clock; the CUDA memory table is in runtime_cuda.cu, the error text in rt_error.c. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "runtime.h"

int sphdem_rt_allreduce(sphdem_rt *rt, double *buf, int n, int op) {
  if (!rt->comm.allreduce || n <= 0) return SPHDEM_OK;
  if (rt->comm.allreduce(rt->comm.user, buf, n, op) != 0)
    return sphdem_rt_fail(rt, SPHDEM_ERR_STATE, "the reduction of %d values over the MPI ranks failed", n);
  return SPHDEM_OK;
}

double sphdem_rt_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- CPU backend: device memory is host memory -------------------------------------------------- */

static int cpu_alloc(sphdem_rt *rt, void **ptr, size_t bytes) {
  *ptr = malloc(bytes);
  if (!*ptr) return sphdem_rt_fail(rt, SPHDEM_ERR_ALLOC, "cannot allocate %zu bytes of host memory", bytes);
  return SPHDEM_OK;
}
static void cpu_free(sphdem_rt *rt, void *ptr) { (void)rt; free(ptr); }
static int cpu_copy(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  (void)rt;
  memmove(dst, src, bytes);
  return SPHDEM_OK;
}
static int cpu_zero(sphdem_rt *rt, void *ptr, size_t bytes) {
  (void)rt;
  memset(ptr, 0, bytes);
  return SPHDEM_OK;
}
static int cpu_sync(sphdem_rt *rt) { (void)rt; return SPHDEM_OK; }
static int cpu_gather(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width) {
  (void)rt;
  for (int64_t k = 0; k < n; k++)
    for (int j = 0; j < width; j++) dst[k * width + j] = src[(int64_t)idx[k] * width + j];
  return SPHDEM_OK;
}
static int cpu_scatter(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width,
                       int add) {
  (void)rt;
  if (add)
    for (int64_t k = 0; k < n; k++)
      for (int j = 0; j < width; j++) dst[(int64_t)idx[k] * width + j] += src[k * width + j];
  else
    for (int64_t k = 0; k < n; k++)
      for (int j = 0; j < width; j++) dst[(int64_t)idx[k] * width + j] = src[k * width + j];
  return SPHDEM_OK;
}

const sphdem_rt_mem sphdem_rt_cpu_mem = {"cpu", cpu_alloc, cpu_free, cpu_copy, cpu_copy, cpu_copy, cpu_zero, cpu_sync,
                                         cpu_gather, cpu_scatter};

void sphdem_rt_init(sphdem_rt *rt, int dev) {
  rt->mem = &sphdem_rt_cpu_mem;
#ifdef SPHDEM_WITH_CUDA
  if (dev == SPHDEM_DEVICE_GPU) rt->mem = &sphdem_rt_cuda_mem;
#else
  (void)dev;
#endif
  rt->bytes = 0;
  rt->err[0] = 0;
}

#ifndef SPHDEM_WITH_CUDA
int sphdem_rt_gpu_probe(char *msg, size_t msglen) {
  if (msg && msglen) snprintf(msg, msglen, "built without CUDA");
  return SPHDEM_ERR_NO_GPU;
}
int sphdem_gpu_select(int local_rank, char *msg, size_t msglen) {
  (void)local_rank;
  return sphdem_rt_gpu_probe(msg, msglen);
}
#endif
