/* test_cfd_twin.c - gas grid: the CUDA backend against the CPU backend on the same input (a bed of moving
 * grains with a spout patch, smooth voidage, Gidaspow drag), step by step: fields and grain forces.
 * Exits 77 (skipped) where no GPU is usable. */
#include <math.h>
#define TEST_RNG_SEED 0x9E3779B97F4A7C15ull
#include "testlib.h"

static double reldiff(const double *a, const double *b, int64_t n) {
  double m = 0, s = 0;
  for (int64_t i = 0; i < n; i++) {
    m = fmax(m, fabs(a[i] - b[i]));
    s = fmax(s, fabs(a[i]));
  }
  return s > 0 ? m / s : m;
}

int main(void) {
  if (!sphdem_gpu_available()) {
    return test_skip("no usable GPU (or built without CUDA)");
  }
  sphdem_cfd_params p;
  sphdem_cfd_params_default(&p);
  int nc[3] = {10, 4, 30};
  for (int d = 0; d < 3; d++) {
    p.nc[d] = nc[d];
    p.boxhi[d] = 0.004 * nc[d];
  }
  p.bc[0] = p.bc[1] = SPHDEM_CFD_NOSLIP;
  p.bc[2] = p.bc[3] = SPHDEM_CFD_SLIP;
  p.bc[4] = SPHDEM_CFD_INLET;
  p.inlet_u[4] = 0.6;
  p.bc[5] = SPHDEM_CFD_OUTLET;
  p.npatch = 1;
  p.patch[0].side = 4;
  p.patch[0].lo[0] = 0.016; p.patch[0].hi[0] = 0.024;
  p.patch[0].lo[1] = 0; p.patch[0].hi[1] = 0.016;
  p.patch[0].u = 4.0;
  p.voidage = SPHDEM_CFD_VOID_SMOOTH;
  sphdem_cfd cc, cg;
  char msg[512];
  if (sphdem_cfd_create(&cc, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg) ||
      sphdem_cfd_create(&cg, &p, SPHDEM_DEVICE_GPU, msg, sizeof msg)) {
    printf("create: %s\n", msg);
    return 1;
  }
  int n = 3000;
  double *x = malloc(sizeof(double) * 3 * n), *v = malloc(sizeof(double) * 3 * n), *r = malloc(sizeof(double) * n);
  double *fdc = malloc(sizeof(double) * 3 * n), *fpc = malloc(sizeof(double) * 3 * n);
  double *fdg = malloc(sizeof(double) * 3 * n), *fpg = malloc(sizeof(double) * 3 * n);
  for (int i = 0; i < n; i++) {
    r[i] = 0.0006;
    for (int d = 0; d < 3; d++) {
      x[3 * i + d] = p.boxhi[d] * (d == 2 ? 0.4 : 1.0) * urand();
      v[3 * i + d] = 0.1 * (urand() - 0.5);
    }
  }
  int64_t nce = (int64_t)nc[0] * nc[1] * nc[2];
  double *ec = malloc(8 * nce), *eg = malloc(8 * nce), *pc = malloc(8 * nce), *pg = malloc(8 * nce);
  double *uc = malloc(24 * nce), *ug = malloc(24 * nce);
  double worst = 0;
  for (int s = 0; s < 50; s++) {
    for (int i = 0; i < 3 * n; i++) x[i] += 1e-4 * v[i];
    int rc1 = sphdem_cfd_step(cc, 1e-4, n, x, v, r, fdc, fpc), rc2 = sphdem_cfd_step(cg, 1e-4, n, x, v, r, fdg, fpg);
    TEST_ASSERT(rc1 == 0 && rc2 == 0, "step %d: %s / %s", s, sphdem_cfd_last_error(cc), sphdem_cfd_last_error(cg));
    if (rc1 || rc2) break;
    sphdem_cfd_get_fields(cc, ec, pc, uc);
    sphdem_cfd_get_fields(cg, eg, pg, ug);
    double d = fmax(fmax(reldiff(ec, eg, nce), reldiff(pc, pg, nce)), reldiff(uc, ug, 3 * nce));
    d = fmax(d, fmax(reldiff(fdc, fdg, 3 * n), reldiff(fpc, fpg, 3 * n)));
    worst = fmax(worst, d);
  }
  printf("twin_cfd: max relative CPU-CUDA difference over 50 steps %.3g\n", worst);
  /* atomics change the summation order of the voidage and drag scatters; the solver tolerance is 1e-10 */
  TEST_ASSERT(worst < 1e-8, "CPU and CUDA agree (%.3g)", worst);
  sphdem_cfd_destroy(&cc);
  sphdem_cfd_destroy(&cg);
  return test_summary("twin_cfd");
}
