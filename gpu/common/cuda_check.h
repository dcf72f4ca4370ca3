/* cuda_check.h - the one CUDA error check of the backends (a failed call or launch sets the context's error
 * text "CUDA error in <what>: <reason>" and returns SPHDEM_ERR_CUDA) and the one-thread-per-element kernel
 * shape (not public). */
#ifndef SPHDEM_CUDA_CHECK_H
#define SPHDEM_CUDA_CHECK_H

#include <cuda_runtime.h>

#include "runtime.h"

static inline int rt_cuda_check(sphdem_rt *rt, cudaError_t e, const char *what) {
  if (e == cudaSuccess) return SPHDEM_OK;
  return sphdem_rt_fail(rt, SPHDEM_ERR_CUDA, "CUDA error in %s: %s", what, cudaGetErrorString(e));
}
/* return from the calling function on a failed call / kernel launch */
#define RT_CK(rt, call, what) do { int rc_ = rt_cuda_check((rt), (call), (what)); if (rc_) return rc_; } while (0)
#define RT_LAUNCHED(rt, what) RT_CK(rt, cudaGetLastError(), what)

/* index of this thread in a one-dimensional launch */
#define RT_THREAD_INDEX() (blockIdx.x * (int64_t)blockDim.x + threadIdx.x)
/* the kernel name(T D) of one thread per element: body(&D, i) for each i < count (an expression in D) */
#define RT_KERNEL_EACH(name, T, count, body)                                                          \
  __global__ void name(T D) {                                                                         \
    const int64_t i = RT_THREAD_INDEX();                                                              \
    if (i < (count)) body(&D, i);                                                                     \
  }

#endif
