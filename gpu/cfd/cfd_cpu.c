/* cfd_cpu.c - CPU (OpenMP) backend of the gas grid: one parallel loop per body of cfd_bodies.h. */
#include <stdlib.h>
#include <string.h>

#include "cfd_bodies.h"

/* below this many elements a loop runs on one thread (fork/join costs more than the work) */
#define CFD_OMP_MIN 4096

static int c_run(struct sphdem_cfd_s *m, int kid, int64_t n) {
  const cfd_dev *D = &m->D;
  switch (kid) {
#define SPHDEM_CFD_LOOP_(name)                                                                        \
  case CFD_K_##name: {                                                                                \
    _Pragma("omp parallel for schedule(static) if (n > CFD_OMP_MIN)")                                 \
    for (int64_t i = 0; i < n; i++) cfd_k_##name(D, i);                                               \
    return SPHDEM_OK;                                                                                 \
  }
    SPHDEM_CFD_KERNELS(SPHDEM_CFD_LOOP_)
#undef SPHDEM_CFD_LOOP_
  }
  return rt_fail(&m->rt, SPHDEM_ERR_ARG, "internal: unknown gas-grid loop %d", kid);
}

/* Sums in a fixed order, whatever the thread count: partial sums of fixed chunks of CFD_RED_CHUNK elements,
 * then the partials added in chunk order. The same arrays give the same bits on every run and every rank
 * (the replicated grid of many ranks relies on it: a stopping test or a CFL check must not differ between
 * ranks). Maxima are exact in any order. */
#define CFD_RED_CHUNK 4096

typedef struct {
  double *part;
  int64_t cap;
} cfd_cpu_data;

static int c_reduce(struct sphdem_cfd_s *m, int rid, int64_t n, double *out) {
  const cfd_dev *D = &m->D;
  int64_t nch = (n + CFD_RED_CHUNK - 1) / CFD_RED_CHUNK;
  double *part = NULL;
  if (nch > 1) {
    cfd_cpu_data *cd = (cfd_cpu_data *)m->backend_data;
    if (!cd) {
      cd = (cfd_cpu_data *)calloc(1, sizeof *cd);
      if (!cd) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the reduction buffers");
      m->backend_data = cd;
    }
    if (cd->cap < nch) {
      double *q = (double *)realloc(cd->part, sizeof(double) * (size_t)nch);
      if (!q) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate %lld reduction partials", (long long)nch);
      cd->part = q;
      cd->cap = nch;
    }
    part = cd->part;
  }
  switch (rid) {
#define SPHDEM_CFD_RED_(name, op)                                                                     \
  case CFD_R_##name: {                                                                                \
    double acc = (op) ? -HUGE_VAL : 0.0;                                                              \
    if (op) {                                                                                         \
      _Pragma("omp parallel for schedule(static) reduction(max : acc) if (n > CFD_OMP_MIN)")          \
      for (int64_t i = 0; i < n; i++) {                                                               \
        double t = cfd_r_##name(D, i);                                                                \
        if (t > acc) acc = t;                                                                         \
      }                                                                                               \
    } else if (nch <= 1) {                                                                            \
      for (int64_t i = 0; i < n; i++) acc += cfd_r_##name(D, i);                                      \
    } else {                                                                                          \
      _Pragma("omp parallel for schedule(static) if (n > CFD_OMP_MIN)")                               \
      for (int64_t k = 0; k < nch; k++) {                                                             \
        int64_t e = (k + 1) * CFD_RED_CHUNK < n ? (k + 1) * CFD_RED_CHUNK : n;                        \
        double s = 0.0;                                                                               \
        for (int64_t i = k * CFD_RED_CHUNK; i < e; i++) s += cfd_r_##name(D, i);                      \
        part[k] = s;                                                                                  \
      }                                                                                               \
      for (int64_t k = 0; k < nch; k++) acc += part[k];                                               \
    }                                                                                                 \
    *out = acc;                                                                                       \
    return SPHDEM_OK;                                                                                 \
  }
    SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_RED_)
#undef SPHDEM_CFD_RED_
  }
  return rt_fail(&m->rt, SPHDEM_ERR_ARG, "internal: unknown gas-grid reduction %d", rid);
}

static void c_release(struct sphdem_cfd_s *m) {
  cfd_cpu_data *cd = (cfd_cpu_data *)m->backend_data;
  if (!cd) return;
  free(cd->part);
  free(cd);
  m->backend_data = NULL;
}

const cfd_ops sphdem_cfd_cpu_ops = {"cpu", c_run, c_reduce, c_release};
