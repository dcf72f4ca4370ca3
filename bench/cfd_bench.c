/* cfd_bench.c - CFD-DEM throughput benchmark: a gas-fluidized bed on the coarse gas grid
 * (sphdem_cfd_*) with the sphdem DEM contacts (sphdem_dem_*), integrated here (velocity Verlet).
 *
 * Scene: Yu 2024 §5.2 scaled. At 1e6 grains the column is 0.5 x 0.5 x 1.2 m (Yu: 1e6 grains, 3e5 cells,
 * U = 0.9 m/s; the paper gives no grain size). Here d = 4 mm, rho_p 2500 (a packed bed of 1e6 such grains
 * is ~ 0.27 m deep in that column), cells of 12.5 mm = 3.1 d (40 x 40 x 96 = 153,600 cells); for other N the
 * box scales by (N / 1e6)^(1/3) at the same d and cell size (1e5: 19 x 19 x 45 cells). Grains start on a
 * touching simple cubic lattice (spacing d) in the lower part of the box with small random velocities;
 * gas inlet zlo at --u (default 2.5 m/s, ~1.5 U_mf of Ergun at eps 0.45), outlet zhi, no-slip side walls;
 * DEM: Hooke, kn 1e4 N/m, kt 2/7 kn, e 0.9, friction 0.3, six fixed planes on the box faces, dt 1e-5 s
 * (t_c / 20); the gas advances every --every DEM steps (default 10, dt_gas = 1e-4 s, forces held).
 *
 * It runs --warmup coupled steps (not timed; the first builds the pair list), resets the timers, runs --steps
 * timed DEM steps and prints the split per DEM step: gas (predict + pressure solve + correct/grain forces),
 * coupling (voidage + drag coefficients), host<->device transfers of the gas context, DEM contacts
 * (sphdem_dem_compute wall time) and the driver's integration; PCG iterations of the last gas step;
 * grain-steps per second (N * DEM steps / wall). One line starting with BENCH carries the same values.
 * This is a benchmark, not a test: it asserts nothing about speed. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "sphdem.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif


/* half a velocity-Verlet kick: contact, drag and pressure-gradient forces, gravity -g along z; then, with move,
 * the drift x += dt v */
static void kick(int n, double *x, double *v, double *om, const double *f, const double *fd, const double *fp,
                 const double *tq, double m, double I, double g, double dt, int move) {
#pragma omp parallel for
  for (int i = 0; i < n; i++)
    for (int a = 0; a < 3; a++) {
      double acc = (f[3 * i + a] + fd[3 * i + a] + fp[3 * i + a]) / m - (a == 2 ? g : 0.0);
      v[3 * i + a] += 0.5 * dt * acc;
      om[3 * i + a] += 0.5 * dt * tq[3 * i + a] / I;
      if (move) x[3 * i + a] += dt * v[3 * i + a];
    }
}

static void usage(const char *prog) {
  fprintf(stderr,
          "usage: %s [--n N] [--steps S] [--warmup W] [--every E] [--device cpu|gpu|auto] [--threads T] [--u U]\n"
          "  --n       grains (default 1e5); box 0.5 x 0.5 x 1.2 m scaled by (N/1e6)^(1/3)\n"
          "  --steps   timed DEM steps (default 20); --warmup untimed DEM steps before (default 10)\n"
          "  --every   DEM steps per gas step (default 10)\n",
          prog);
}

int main(int argc, char **argv) {
  double ntarget = 1e5, U = 2.5;
  int steps = 20, warmup = 10, every = 10, threads = 0;
  const char *devname = "cpu";
  const bench_opt opts[] = {{"--n", 'd', &ntarget}, {"--steps", 'i', &steps}, {"--warmup", 'i', &warmup},
                            {"--every", 'i', &every}, {"--device", 's', &devname}, {"--threads", 'i', &threads},
                            {"--u", 'd', &U}};
  int parsed = bench_parse(argc, argv, opts, (int)(sizeof opts / sizeof opts[0]));
  if (parsed) { usage(argv[0]); return parsed == 1 ? 0 : 2; }
  sphdem_device dev;
  if (bench_device(devname, &dev)) { usage(argv[0]); return 2; }
  if (steps < 1 || warmup < 1 || every < 1 || ntarget < 8) { usage(argv[0]); return 2; }
  threads = bench_threads(threads);
  const double d = 4e-3, r = 0.5 * d, rhop = 2500.0, g = 9.81, hcell = 12.5e-3;
  const double scale = cbrt(ntarget / 1e6);
  double box[3] = {0.5 * scale, 0.5 * scale, 1.2 * scale};
  int nc[3];
  for (int a = 0; a < 3; a++) {
    nc[a] = (int)lround(box[a] / hcell);
    if (nc[a] < 1) nc[a] = 1;
    box[a] = nc[a] * hcell;
  }
  /* lattice: per x per y per layer, as many layers as needed */
  int px = (int)(box[0] / d), py = (int)(box[1] / d);
  int n = (int)ntarget;
  int layers = (n + px * py - 1) / (px * py);
  if ((layers + 1) * d > 0.8 * box[2]) { fprintf(stderr, "bench: %d grains do not fit\n", n); return 1; }
  double *x = malloc(sizeof(double) * 3 * n), *v = calloc(3 * n, sizeof(double)), *om = calloc(3 * n, sizeof(double));
  double *f = calloc(3 * n, sizeof(double)), *tq = calloc(3 * n, sizeof(double)), *fd = calloc(3 * n, sizeof(double));
  double *fp = calloc(3 * n, sizeof(double)), *rad = malloc(sizeof(double) * n), *mass = malloc(sizeof(double) * n);
  int64_t *tag = malloc(sizeof(int64_t) * n);
  if (!x || !v || !om || !f || !tq || !fd || !fp || !rad || !mass || !tag) { fprintf(stderr, "bench: no memory\n"); return 1; }
  const double m = rhop * M_PI / 6 * d * d * d, I = 0.4 * m * r * r;
  unsigned seed = 2024;
  for (int i = 0; i < n; i++) {
    int ix = i % px, iy = (i / px) % py, iz = i / (px * py);
    x[3 * i] = (ix + 0.5) * d;
    x[3 * i + 1] = (iy + 0.5) * d;
    x[3 * i + 2] = (iz + 0.5) * d;
    for (int a = 0; a < 3; a++) {
      seed = seed * 1103515245u + 12345u;
      v[3 * i + a] = 0.01 * (((seed >> 8) & 0xffff) / 65535.0 - 0.5);
    }
    rad[i] = r; mass[i] = m; tag[i] = i + 1;
  }
  /* DEM */
  sphdem_dem_params dp;
  sphdem_dem_params_default(&dp);
  dp.model = SPHDEM_DEM_HOOKE; dp.kn = 1e4; dp.kt = 2.0 / 7.0 * 1e4; dp.en = 0.9; dp.mu = 0.3; dp.skin = 0.2 * d;
  for (int a = 0; a < 3; a++) { dp.boxlo[a] = 0; dp.boxhi[a] = box[a]; }
  char msg[256];
  sphdem_dem dem;
  if (sphdem_dem_create(&dem, &dp, dev, msg, sizeof msg)) { fprintf(stderr, "dem: %s\n", msg); return 1; }
  sphdem_dem_wall w[6];
  for (int a = 0; a < 3; a++)
    for (int s = 0; s < 2; s++) {
      sphdem_dem_wall *q = &w[2 * a + s];
      memset(q, 0, sizeof *q);
      q->point[a] = s ? box[a] : 0.0;
      q->normal[a] = s ? -1.0 : 1.0;
    }
  sphdem_dem_set_walls(dem, 6, w);
  /* gas */
  sphdem_cfd_params cp;
  sphdem_cfd_params_default(&cp);
  for (int a = 0; a < 3; a++) { cp.nc[a] = nc[a]; cp.boxlo[a] = 0; cp.boxhi[a] = box[a]; }
  cp.gravity[2] = -g;
  for (int s = 0; s < 4; s++) cp.bc[s] = SPHDEM_CFD_NOSLIP;
  cp.bc[4] = SPHDEM_CFD_INLET; cp.inlet_u[4] = U;
  cp.bc[5] = SPHDEM_CFD_OUTLET;
  sphdem_cfd c;
  if (sphdem_cfd_create(&c, &cp, dev, msg, sizeof msg)) { fprintf(stderr, "cfd: %s\n", msg); return 1; }
  const double dt = 1e-5, dtg = every * dt;
  double t_dem = 0, t_int = 0, t_gas_call = 0;
  int rc = sphdem_dem_compute(dem, n, tag, x, v, om, rad, mass, NULL, dt, 0, f, tq, NULL);
  if (rc) { fprintf(stderr, "dem: %s\n", sphdem_dem_last_error(dem)); return 1; }
  double wall0 = 0;
  for (int it = 0; it < warmup + steps && !rc; it++) {
    if (it == warmup) {
      sphdem_cfd_timers_reset(c);
      t_dem = t_int = t_gas_call = 0;
      wall0 = wtime();
    }
    if (it % every == 0) {
      double t0 = wtime();
      rc = sphdem_cfd_step(c, dtg, n, x, v, rad, fd, fp);
      t_gas_call += wtime() - t0;
      if (rc) { fprintf(stderr, "gas: %s\n", sphdem_cfd_last_error(c)); break; }
    }
    double t1 = wtime();
    kick(n, x, v, om, f, fd, fp, tq, m, I, g, dt, 1);
    double t2 = wtime();
    rc = sphdem_dem_compute(dem, n, tag, x, v, om, rad, mass, NULL, dt, 1, f, tq, NULL);
    double t3 = wtime();
    if (rc) { fprintf(stderr, "dem: %s\n", sphdem_dem_last_error(dem)); break; }
    kick(n, x, v, om, f, fd, fp, tq, m, I, g, dt, 0);
    double t4 = wtime();
    t_dem += t3 - t2;
    t_int += (t2 - t1) + (t4 - t3);
  }
  if (rc) return 1;
  double wall = wtime() - wall0;
  double tm[SPHDEM_CFD_NTIMERS];
  sphdem_cfd_timers(c, tm);
  sphdem_cfd_stats st;
  sphdem_cfd_stats_get(c, &st);
  sphdem_dem_stats ds;
  sphdem_dem_stats_get(dem, &ds);
  int ngas = (steps + every - 1) / every; /* gas steps inside the timed loop (warmup is a multiple of every) */
  if (warmup % every) ngas = -1;
  double gas = tm[SPHDEM_CFD_T_PREDICT] + tm[SPHDEM_CFD_T_SOLVE] + tm[SPHDEM_CFD_T_CORRECT];
  long ncell = (long)nc[0] * nc[1] * nc[2];
  const char *be = sphdem_cfd_backend(c) == SPHDEM_DEVICE_GPU ? "gpu" : "cpu";
  printf("cfd_bench: backend %s (dem %s), %d threads, %d grains (d %.1f mm), box %.3f x %.3f x %.3f m, cells %d x %d x %d = "
         "%ld (%.1f mm = %.2f d), U %.2f m/s\n",
         be, sphdem_dem_backend(dem) == SPHDEM_DEVICE_GPU ? "gpu" : "cpu", threads, n, 1e3 * d, box[0], box[1], box[2],
         nc[0], nc[1], nc[2], ncell, 1e3 * hcell, hcell / d, U);
  printf("  %d timed DEM steps (dt %.1e s), gas every %d (%d gas steps): wall %.3f s = %.4f s per DEM step, %.3e "
         "grain-steps/s\n", steps, dt, every, ngas, wall, wall / steps, (double)n * steps / wall);
  printf("  per DEM step: gas %.4f s (predict %.4f, pressure solve %.4f, correct + grain forces %.4f), coupling "
         "(voidage + drag coefficients) %.4f s, gas transfers %.4f s, DEM contacts %.4f s, integration %.4f s\n",
         gas / steps, tm[SPHDEM_CFD_T_PREDICT] / steps, tm[SPHDEM_CFD_T_SOLVE] / steps, tm[SPHDEM_CFD_T_CORRECT] / steps,
         tm[SPHDEM_CFD_T_COUPLE] / steps, tm[SPHDEM_CFD_T_TRANSFER] / steps, t_dem / steps, t_int / steps);
  if (ngas > 0)
    printf("  per gas step: %.4f s (sphdem_cfd_step wall %.4f s incl. statistics), PCG iterations of the last %d "
           "(residual %.2e), mass error %.1e; DEM: %lld candidate pairs, %lld contacts, %lld list builds\n",
           (gas + tm[SPHDEM_CFD_T_COUPLE]) / ngas, t_gas_call / ngas, st.iters, st.residual, st.mass_err,
           (long long)ds.npairs, (long long)ds.ncontacts, (long long)ds.nbuilds);
  printf("BENCH code=sphdem_cfd backend=%s threads=%d ngrains=%d ncells=%ld steps=%d every=%d wall_s=%.4f "
         "s_per_step=%.5f gsteps_per_s=%.4e t_gas=%.5f t_predict=%.5f t_solve=%.5f t_correct=%.5f t_couple=%.5f "
         "t_transfer=%.5f t_dem=%.5f t_integrate=%.5f pcg_iters=%d\n",
         be, threads, n, ncell, steps, every, wall, wall / steps, (double)n * steps / wall, gas / steps,
         tm[SPHDEM_CFD_T_PREDICT] / steps, tm[SPHDEM_CFD_T_SOLVE] / steps, tm[SPHDEM_CFD_T_CORRECT] / steps,
         tm[SPHDEM_CFD_T_COUPLE] / steps, tm[SPHDEM_CFD_T_TRANSFER] / steps, t_dem / steps, t_int / steps, st.iters);
  sphdem_cfd_destroy(&c);
  sphdem_dem_destroy(&dem);
  free(x); free(v); free(om); free(f); free(tq); free(fd); free(fp); free(rad); free(mass); free(tag);
  return 0;
}
