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
  return sphdem_cfd_fail(m, SPHDEM_ERR_ARG, "internal: unknown gas-grid loop %d", kid);
}

static int c_reduce(struct sphdem_cfd_s *m, int rid, int64_t n, double *out) {
  const cfd_dev *D = &m->D;
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
    } else {                                                                                          \
      _Pragma("omp parallel for schedule(static) reduction(+ : acc) if (n > CFD_OMP_MIN)")            \
      for (int64_t i = 0; i < n; i++) acc += cfd_r_##name(D, i);                                      \
    }                                                                                                 \
    *out = acc;                                                                                       \
    return SPHDEM_OK;                                                                                 \
  }
    SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_RED_)
#undef SPHDEM_CFD_RED_
  }
  return sphdem_cfd_fail(m, SPHDEM_ERR_ARG, "internal: unknown gas-grid reduction %d", rid);
}

const cfd_ops sphdem_cfd_cpu_ops = {"cpu", c_run, c_reduce, NULL};
