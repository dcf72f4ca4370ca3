/* couple_cpu.c - CPU backend of the SPH-DEM coupling: OpenMP loops over the bodies of couple_bodies.h. */
#include "couple_bodies.h"
#include "sphdem_internal.h"

int sphdem_cpu_couple_porosity(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t a = 0; a < D->nf; a++) couple_porosity_body(D, a);
  return SPHDEM_OK;
}

int sphdem_cpu_couple_grains(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
#pragma omp parallel for schedule(dynamic, 16)
  for (int64_t j = 0; j < D->ng; j++) couple_grain_body(D, j);
  return SPHDEM_OK;
}

int sphdem_cpu_couple_reaction(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t a = 0; a < D->nf; a++) couple_reaction_body(D, a);
  return SPHDEM_OK;
}
