/* runtime.h - the device runtime shared by the fluid, coupling, DEM and gas-grid contexts: memory operations
 * of the backend, the device byte count, the error text, a monotonic clock, the GPU probe (not public). */
#ifndef SPHDEM_RUNTIME_H
#define SPHDEM_RUNTIME_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include "sphdem.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sphdem_rt sphdem_rt;

/* Memory operations of one backend; each returns SPHDEM_OK or a code with the message set in rt. */
typedef struct {
  const char *name;
  int (*alloc)(sphdem_rt *rt, void **ptr, size_t bytes);
  void (*free)(sphdem_rt *rt, void *ptr);
  int (*h2d)(sphdem_rt *rt, void *dst, const void *src, size_t bytes);
  int (*d2h)(sphdem_rt *rt, void *dst, const void *src, size_t bytes);
  int (*d2d)(sphdem_rt *rt, void *dst, const void *src, size_t bytes);
  int (*zero)(sphdem_rt *rt, void *ptr, size_t bytes);
  int (*sync)(sphdem_rt *rt);
  /* dst[k width + j] = src[idx[k] width + j] for k < n, j < width (idx on the device) */
  int (*gather)(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width);
  /* dst[idx[k] width + j] = src[k width + j] (add: +=) for k < n, j < width (idx on the device, no index twice) */
  int (*scatter)(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width, int add);
} sphdem_rt_mem;

/* One per context (embedded): which memory the context's arrays live in, how much of it they hold, and the
 * message of the last error. */
struct sphdem_rt {
  const sphdem_rt_mem *mem;
  size_t bytes;  /* device bytes held: counted by rt_alloc, given back by rt_free */
  char err[1024];
  sphdem_comm comm; /* the engine's reductions over ranks (zero: one rank); sphdem_rt_init leaves it */
};

extern const sphdem_rt_mem sphdem_rt_cpu_mem;
#ifdef SPHDEM_WITH_CUDA
extern const sphdem_rt_mem sphdem_rt_cuda_mem;
#endif

/* The runtime of a context on backend dev (SPHDEM_DEVICE_CPU or _GPU; GPU needs the CUDA backend). */
void sphdem_rt_init(sphdem_rt *rt, int dev);
/* Set rt->err (printf-style; rt may be NULL); returns code. */
int sphdem_rt_fail(sphdem_rt *rt, int code, const char *fmt, ...)
#ifdef __GNUC__
    __attribute__((format(printf, 3, 4)))
#endif
    ;
int sphdem_rt_vfail(sphdem_rt *rt, int code, const char *fmt, va_list ap);
/* Seconds of a monotonic clock (for the timers of each context). */
double sphdem_rt_now(void);
/* SPHDEM_OK if a CUDA device is usable; msg gets its name or the reason it is not (runtime_cuda.cu). */
int sphdem_rt_gpu_probe(char *msg, size_t msglen);

/* buf[0..n) combined over every rank (op: sphdem_red_op); nothing to do on one rank. */
int sphdem_rt_allreduce(sphdem_rt *rt, double *buf, int n, int op);
static inline int rt_nranks(const sphdem_rt *rt) { return rt->comm.allreduce && rt->comm.nranks > 1 ? rt->comm.nranks : 1; }

#define rt_fail sphdem_rt_fail
#define rt_now sphdem_rt_now

/* Device memory, counted in rt->bytes; 0 bytes allocate (and count) 8. */
static inline int rt_alloc(sphdem_rt *rt, void **ptr, size_t bytes) {
  if (bytes == 0) bytes = 8;
  int rc = rt->mem->alloc(rt, ptr, bytes);
  if (rc == SPHDEM_OK) rt->bytes += bytes;
  return rc;
}
/* Free *ptr (no-op when NULL) and clear it; bytes as counted when it was allocated, 0 where the context keeps
 * no count. */
static inline void rt_free(sphdem_rt *rt, void **ptr, size_t bytes) {
  if (!*ptr) return;
  rt->mem->free(rt, *ptr);
  rt->bytes -= bytes;
  *ptr = NULL;
}
/* Copies and zeroing; nothing happens for 0 bytes. */
static inline int rt_h2d(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return bytes ? rt->mem->h2d(rt, dst, src, bytes) : SPHDEM_OK;
}
static inline int rt_d2h(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return bytes ? rt->mem->d2h(rt, dst, src, bytes) : SPHDEM_OK;
}
static inline int rt_d2d(sphdem_rt *rt, void *dst, const void *src, size_t bytes) {
  return bytes ? rt->mem->d2d(rt, dst, src, bytes) : SPHDEM_OK;
}
static inline int rt_zero(sphdem_rt *rt, void *ptr, size_t bytes) {
  return bytes ? rt->mem->zero(rt, ptr, bytes) : SPHDEM_OK;
}
/* Rows of src picked by the device index list idx (width doubles a row); nothing for n = 0. */
static inline int rt_gather(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width) {
  return n > 0 ? rt->mem->gather(rt, dst, src, idx, n, width) : SPHDEM_OK;
}
/* Rows of src written to the rows of dst named by the device index list idx (the inverse of rt_gather). */
static inline int rt_scatter(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n, int width) {
  return n > 0 ? rt->mem->scatter(rt, dst, src, idx, n, width, 0) : SPHDEM_OK;
}
/* The same, added to the rows of dst. */
static inline int rt_scatter_add(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx, int64_t n,
                                 int width) {
  return n > 0 ? rt->mem->scatter(rt, dst, src, idx, n, width, 1) : SPHDEM_OK;
}
/* Wait for the device's queued work (a kernel's error surfaces here). */
static inline int rt_sync(sphdem_rt *rt) { return rt->mem->sync(rt); }

/* The error-text function of a context type: int name(struct T *c, int code, const char *fmt, ...) writing
 * into c->rt. */
#define SPHDEM_RT_FAIL_FN(name, T)                                                                    \
  int name(T *c, int code, const char *fmt, ...) {                                                   \
    va_list ap;                                                                                       \
    va_start(ap, fmt);                                                                                \
    code = sphdem_rt_vfail(c ? &c->rt : NULL, code, fmt, ap);                                         \
    va_end(ap);                                                                                       \
    return code;                                                                                      \
  }

#ifdef __cplusplus
}
#endif

#endif
