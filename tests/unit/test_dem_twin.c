/* test_dem_twin.c - GPU DEM: the CUDA backend against the CPU backend on the same input, step by step
 * (both force algorithms; LAMMPS Hertz, Hertz-Mindlin, LIGGGHTS Hertz with friction and rolling friction, and
 * the granular model (two types, rolling sds, twisting marshall/sds);
 * periodic axes and walls). Exits 77
 * (skipped) where no GPU is usable. The trajectory is advanced with the CPU forces and fed to both. */
#include <math.h>
#define TEST_RNG_SEED 0x9E3779B97F4A7C15ull
#include "dem_granular_table.h"
#include "testlib.h"

int main(void) {
  if (!sphdem_gpu_available()) {
    return test_skip("no usable GPU (or built without CUDA)");
  }
  const int n = 2000;
  double L[3] = {2.0, 1.5, 2.0};
  int64_t *tag = malloc(sizeof(int64_t) * n);
  double *x = malloc(sizeof(double) * 3 * n), *v = malloc(sizeof(double) * 3 * n), *om = malloc(sizeof(double) * 3 * n);
  double *r = malloc(sizeof(double) * n), *m = malloc(sizeof(double) * n);
  double *fc = malloc(sizeof(double) * 3 * n), *tc = malloc(sizeof(double) * 3 * n);
  double *fg = malloc(sizeof(double) * 3 * n), *tg = malloc(sizeof(double) * 3 * n);
  for (int i = 0; i < n; i++) {
    tag[i] = 3 * i + 11;
    r[i] = 0.05 * (0.6 + 0.4 * urand());
    m[i] = 2500 * 4.0 / 3.0 * M_PI * r[i] * r[i] * r[i];
    for (int d = 0; d < 3; d++) {
      x[3 * i + d] = L[d] * urand();
      v[3 * i + d] = 0.5 * (urand() - 0.5);
      om[3 * i + d] = 10 * (urand() - 0.5);
    }
  }
  sphdem_dem_wall walls[2] = {{{0, 0.02, 0}, {0, 1, 0}}, {{0, 1.45, 0}, {0, -1, 0}}};
  /* the granular model: two grain types, every sub-model family (rolling and twisting history included) */
  int *fl = malloc(sizeof(int) * n);
  for (int i = 0; i < n; i++) fl[i] = (i % 2) << SPHDEM_DEM_MATERIAL_SHIFT;
  sphdem_dem_granular gt[4];
  dem_granular_test_table(gt, SPHDEM_GRAN_DAMP_VISCOELASTIC);
  for (int model = 1; model <= 4; model++)
    for (int algo = 0; algo < 2; algo++) {
      sphdem_dem_params p;
      sphdem_dem_params_default(&p);
      const int granular = model == 4; /* loop index 4: SPHDEM_DEM_GRANULAR */
      p.model = granular ? SPHDEM_DEM_GRANULAR : model;
      p.algo = algo;
      if (model == SPHDEM_DEM_HERTZ) { p.kn = 2e6; p.kt = 2.0 / 7.0 * 2e6; p.gamman = 50; p.gammat = 25; }
      else if (!granular) { p.E = 1e7; p.nu = 0.3; p.en = 0.7; } /* Hertz-Mindlin, LIGGGHTS Hertz */
      p.mu = 0.5; p.mu_r = granular ? 0.0 : 0.02; p.skin = 0.01;
      p.periodic[0] = p.periodic[2] = 1;
      for (int d = 0; d < 3; d++) { p.boxlo[d] = 0; p.boxhi[d] = L[d]; }
      char msg[256];
      sphdem_dem C, G;
      if (sphdem_dem_create(&C, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg) ||
          sphdem_dem_create(&G, &p, SPHDEM_DEVICE_GPU, msg, sizeof msg)) {
        printf("create: %s\n", msg);
        return 1;
      }
      sphdem_dem_set_walls(C, 2, walls);
      sphdem_dem_set_walls(G, 2, walls);
      if (granular && (sphdem_dem_set_granular(C, 2, gt) || sphdem_dem_set_granular(G, 2, gt))) {
        printf("set_granular: %s / %s\n", sphdem_dem_last_error(C), sphdem_dem_last_error(G));
        return 1;
      }
      const int *flags = granular ? fl : NULL;
      double dt = 2e-5, worst = 0, vc[6], vg[6], vworst = 0;
      int rc = 0;
      for (int s = 0; s < 200 && !rc; s++) {
        rc |= sphdem_dem_compute(C, n, tag, x, v, om, r, m, flags, dt, s > 0, fc, tc, vc);
        rc |= sphdem_dem_compute(G, n, tag, x, v, om, r, m, flags, dt, s > 0, fg, tg, vg);
        double fs = 0, ts = 0;
        for (int k = 0; k < 3 * n; k++) { fs = fmax(fs, fabs(fc[k])); ts = fmax(ts, fabs(tc[k])); }
        for (int k = 0; k < 3 * n; k++) {
          worst = fmax(worst, fabs(fc[k] - fg[k]) / fs);
          worst = fmax(worst, fabs(tc[k] - tg[k]) / ts);
        }
        double vs = 0;
        for (int k = 0; k < 6; k++) vs = fmax(vs, fabs(vc[k]));
        for (int k = 0; k < 6; k++) vworst = fmax(vworst, fabs(vc[k] - vg[k]) / vs);
        for (int i = 0; i < n; i++) {
          double I = 0.4 * m[i] * r[i] * r[i];
          for (int d = 0; d < 3; d++) {
            v[3 * i + d] += dt * fc[3 * i + d] / m[i];
            om[3 * i + d] += dt * tc[3 * i + d] / I;
            x[3 * i + d] += dt * v[3 * i + d];
          }
        }
      }
      sphdem_dem_stats sc, sg;
      sphdem_dem_stats_get(C, &sc);
      sphdem_dem_stats_get(G, &sg);
      printf("model %d algo %d: %lld pairs, %lld contacts (GPU %lld, %lld), %lld builds; max rel diff forces/torques %.3g, "
             "virial %.3g\n", model, algo, (long long)sc.npairs, (long long)sc.ncontacts, (long long)sg.npairs,
             (long long)sg.ncontacts, (long long)sc.nbuilds, worst, vworst);
      TEST_ASSERT(rc == SPHDEM_OK, "compute: %s / %s", sphdem_dem_last_error(C), sphdem_dem_last_error(G));
      TEST_ASSERT(sc.npairs == sg.npairs && sc.ncontacts == sg.ncontacts && sc.ncontacts > 100, "pair counts differ");
      TEST_ASSERT(worst < 1e-9 && vworst < 1e-9, "CPU vs GPU differ: %.3g %.3g", worst, vworst);
      sphdem_dem_destroy(&C);
      sphdem_dem_destroy(&G);
    }
  free(tag); free(x); free(v); free(om); free(r); free(m); free(fc); free(tc); free(fg); free(tg); free(fl);
  return test_summary("twin_dem");
}
