/* test_dem_twin.c - GPU DEM: the CUDA backend against the CPU backend on the same input, step by step
 * (both force algorithms; LAMMPS Hertz, Hertz-Mindlin, LIGGGHTS Hertz with friction and rolling friction, and
 * the granular model (two types, rolling sds, twisting marshall/sds);
 * periodic axes and walls; the grain flags of several ranks: another rank's grains, periodic images, skipped copies,
 * split pairs on both ranks and once). Exits 77
 * (skipped) where no GPU is usable. The trajectory is advanced with the CPU forces and fed to both. */
#include <math.h>
#include <string.h>
#define TEST_RNG_SEED 0x9E3779B97F4A7C15ull
#include "dem_granular_table.h"
#include "testlib.h"

/* Grain k: radius 0.03-0.05, density 2500, at a uniform random place in 0..L, random velocity and spin. */
static void random_grain(int k, const double *L, double *x, double *v, double *om, double *r, double *m) {
  r[k] = 0.05 * (0.6 + 0.4 * urand());
  m[k] = 2500 * 4.0 / 3.0 * M_PI * r[k] * r[k] * r[k];
  for (int d = 0; d < 3; d++) {
    x[3 * k + d] = L[d] * urand();
    v[3 * k + d] = 0.5 * (urand() - 0.5);
    om[3 * k + d] = 10 * (urand() - 0.5);
  }
}

/* Several ranks' grain flags on both backends: a rank's own grains in a box periodic in x (the core's minimum image)
 * and cut along z; copies of them shifted by L along x (SPHDEM_DEM_SKIP: the engine's images along an axis the
 * ranks do not cut), shifted by L along z (SPHDEM_DEM_IMAGE: periodic images across a cut axis) and another
 * rank's grains above the cut (SPHDEM_DEM_GHOST), with split pairs evaluated on both ranks and once
 * (sphdem_dem_set_ghost_once). Forces, torques (every row: the ghost rows hold the other grain's share) and the
 * virial compared step by step, the trajectory advanced with the CPU forces. */
static void twin_ranks(sphdem_device gdev) {
  const int n0 = 1500;
  const double L[3] = {1.5, 1.5, 1.5};
  int cap = 3 * n0 + 400, n = 0;
  int64_t *tag = malloc(sizeof(int64_t) * cap);
  int *fl = malloc(sizeof(int) * cap);
  double *x = malloc(sizeof(double) * 3 * cap), *v = malloc(sizeof(double) * 3 * cap), *om = malloc(sizeof(double) * 3 * cap);
  double *r = malloc(sizeof(double) * cap), *m = malloc(sizeof(double) * cap);
  double *fc = malloc(sizeof(double) * 3 * cap), *tc = malloc(sizeof(double) * 3 * cap);
  double *fg = malloc(sizeof(double) * 3 * cap), *tg = malloc(sizeof(double) * 3 * cap);
  for (int i = 0; i < n0; i++, n++) {
    tag[n] = 2 * i + 1;
    fl[n] = 0;
    random_grain(n, L, x, v, om, r, m);
  }
  /* another rank's grains just above the cut at z = L: new (even) tags */
  for (int i = 0; i < 300; i++, n++) {
    tag[n] = 2 * i + 2;
    fl[n] = SPHDEM_DEM_GHOST;
    r[n] = 0.05 * (0.6 + 0.4 * urand());
    m[n] = 2500 * 4.0 / 3.0 * M_PI * r[n] * r[n] * r[n];
    x[3 * n] = L[0] * urand(), x[3 * n + 1] = L[1] * urand(), x[3 * n + 2] = L[2] + 0.12 * urand();
    for (int d = 0; d < 3; d++) v[3 * n + d] = 0.5 * (urand() - 0.5), om[3 * n + d] = 10 * (urand() - 0.5);
  }
  /* copies of the own grains: near x = 0 shifted by +L along x (skipped), near z = 0 by +L along z (images) */
  const int nown = n0;
  for (int i = 0; i < nown; i++)
    for (int axis = 0; axis < 3; axis += 2) {
      if (x[3 * i + axis] > 0.12) continue;
      tag[n] = tag[i];
      fl[n] = axis == 0 ? SPHDEM_DEM_SKIP : SPHDEM_DEM_IMAGE;
      r[n] = r[i], m[n] = m[i];
      for (int d = 0; d < 3; d++) x[3 * n + d] = x[3 * i + d] + (d == axis ? L[d] : 0.0), v[3 * n + d] = v[3 * i + d], om[3 * n + d] = om[3 * i + d];
      n++;
    }
  for (int once = 0; once < 2; once++)
    for (int algo = 0; algo < 2; algo++) {
      sphdem_dem_params p;
      sphdem_dem_params_default(&p);
      p.model = SPHDEM_DEM_HERTZ;
      p.kn = 2e6; p.kt = 2.0 / 7.0 * 2e6; p.gamman = 50; p.gammat = 25; p.mu = 0.5; p.skin = 0.01;
      p.algo = algo;
      p.periodic[0] = 1;
      for (int d = 0; d < 3; d++) { p.boxlo[d] = 0; p.boxhi[d] = L[d]; }
      char msg[256];
      sphdem_dem C, G;
      if (sphdem_dem_create(&C, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg) || sphdem_dem_create(&G, &p, gdev, msg, sizeof msg)) {
        TEST_ASSERT(0, "create: %s", msg);
        return;
      }
      sphdem_dem_set_ghost_once(C, once);
      sphdem_dem_set_ghost_once(G, once);
      /* the positions of the copies follow their grains (the trajectory of the own grains only) */
      double *xs = malloc(sizeof(double) * 3 * n), *vs = malloc(sizeof(double) * 3 * n), *ws = malloc(sizeof(double) * 3 * n);
      memcpy(xs, x, sizeof(double) * 3 * n), memcpy(vs, v, sizeof(double) * 3 * n), memcpy(ws, om, sizeof(double) * 3 * n);
      double dt = 2e-5, worst = 0, vc[6], vg[6], vworst = 0;
      int rc = 0;
      for (int s = 0; s < 100 && !rc; s++) {
        rc |= sphdem_dem_compute(C, n, tag, xs, vs, ws, r, m, fl, dt, s > 0, fc, tc, vc);
        rc |= sphdem_dem_compute(G, n, tag, xs, vs, ws, r, m, fl, dt, s > 0, fg, tg, vg);
        double fmx = 0, tmx = 0, vmx = 0;
        for (int k = 0; k < 3 * n; k++) fmx = fmax(fmx, fabs(fc[k])), tmx = fmax(tmx, fabs(tc[k]));
        for (int k = 0; k < 3 * n; k++)
          worst = fmax(worst, fmax(fabs(fc[k] - fg[k]) / fmx, fabs(tc[k] - tg[k]) / tmx));
        for (int k = 0; k < 6; k++) vmx = fmax(vmx, fabs(vc[k]));
        for (int k = 0; k < 6; k++) vworst = fmax(vworst, fabs(vc[k] - vg[k]) / vmx);
        for (int i = 0; i < nown; i++) {
          const double I = 0.4 * m[i] * r[i] * r[i];
          for (int d = 0; d < 3; d++) {
            vs[3 * i + d] += dt * fc[3 * i + d] / m[i];
            ws[3 * i + d] += dt * tc[3 * i + d] / I;
            xs[3 * i + d] += dt * vs[3 * i + d];
          }
        }
        for (int k = nown + 300, i = 0; k < n; k++) { /* each copy follows its grain (same tag, in order) */
          while (tag[i] != tag[k]) i++;
          for (int d = 0; d < 3; d++)
            xs[3 * k + d] = xs[3 * i + d] + (x[3 * k + d] - x[3 * i + d]), vs[3 * k + d] = vs[3 * i + d], ws[3 * k + d] = ws[3 * i + d];
        }
      }
      sphdem_dem_stats sc, sg;
      sphdem_dem_stats_get(C, &sc);
      sphdem_dem_stats_get(G, &sg);
      printf("several ranks' flags (%d own, 300 another rank's, %d copies), ghost_once %d, algo %d: %lld pairs, %lld "
             "contacts (other backend %lld, %lld); max rel diff forces/torques %.3g, virial %.3g\n", nown, n - nown - 300,
             once, algo, (long long)sc.npairs, (long long)sc.ncontacts, (long long)sg.npairs, (long long)sg.ncontacts,
             worst, vworst);
      TEST_ASSERT(rc == SPHDEM_OK, "compute: %s / %s", sphdem_dem_last_error(C), sphdem_dem_last_error(G));
      TEST_ASSERT(sc.npairs == sg.npairs && sc.ncontacts == sg.ncontacts && sc.ncontacts > 100, "pair counts differ");
      TEST_ASSERT(worst < 1e-9 && vworst < 1e-9, "the backends differ: %.3g %.3g", worst, vworst);
      sphdem_dem_destroy(&C);
      sphdem_dem_destroy(&G);
      free(xs); free(vs); free(ws);
    }
  free(tag); free(fl); free(x); free(v); free(om); free(r); free(m); free(fc); free(tc); free(fg); free(tg);
}

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
    random_grain(i, L, x, v, om, r, m);
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
  twin_ranks(SPHDEM_DEVICE_GPU);
  return test_summary("twin_dem");
}
