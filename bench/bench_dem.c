/* bench_dem.c - DEM contact throughput over the public sphdem_dem API (no engine).
 *
 * Scene: a dense column settling under gravity: grains of d = 5 mm, 2500 kg/m^3 on a simple cubic
 * lattice of spacing 0.9998 d (every grain touches its 6 lattice neighbours from the start), nx * nx
 * columns periodic in x and y, nz layers on a fixed floor plane (a core wall), random velocities of
 * about 0.01 m/s. Contacts: LAMMPS gran/hertz/history 2e7 NULL 5e3 NULL 0.5 1 (model hertz, or
 * --model liggghts: LIGGGHTS hertz with E 5e6, nu 0.45, e 0.7, mu 0.5), skin 1 mm, dt 2e-6 s.
 * The driver integrates (velocity Verlet, translation and rotation), as nve/sphere does.
 *
 * It runs `warmup` steps (not timed), resets the core timers, runs `steps` timed steps and prints
 * ONE line starting with "BENCH" (key=value): grains, steps, wall_s, psteps_per_s (grains * steps /
 * wall), contacts_per_s (touching pairs summed over the steps / wall), pairs (candidates) and
 * contacts at the end, builds, the core's split (t_upload t_check t_detect t_force t_download,
 * seconds), t_host (the driver's integration), t_call_min (the fastest sphdem_dem_compute call: a
 * measure that time slicing on a shared machine does not inflate) and the kinetic energy at the end.
 * A benchmark, not a test: it asserts nothing about speed.
 *
 *   bench_dem [--n 1e4] [--steps 1000] [--warmup 10] [--device cpu|gpu|auto] [--algo pair|particle]
 *             [--model hertz|liggghts] [--threads T] [--spacing S]
 * --spacing: lattice spacing in diameters (default 0.9998; 1.1 gives a loose packing in which the
 * candidate pairs within the skin do not touch at first, as in a falling cloud). --shuffle: the atom
 * tags are a random permutation of the grain order (as after an engine's spatial atom sort, the
 * order in which the engine hands the grains over is not the order of their tags). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "sphdem.h"


static uint64_t rng_state = 88172645463325252ULL;
static double urand(void) { /* xorshift64, uniform in (0, 1) */
  rng_state ^= rng_state << 13;
  rng_state ^= rng_state >> 7;
  rng_state ^= rng_state << 17;
  return ((rng_state >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}
static double grand(void) { return sqrt(-2.0 * log(urand())) * cos(6.283185307179586 * urand()); }

int main(int argc, char **argv) {
  double ntarget = 1e4, spacing = 0.9998;
  int shuffle = 0;
  int steps = 1000, warmup = 10, algo = SPHDEM_DEM_PARTICLE_PARALLEL, liggghts = 0, threads = 0;
  sphdem_device dev = SPHDEM_DEVICE_CPU;
  for (int k = 1; k < argc; k++) {
    const char *a = argv[k], *v = k + 1 < argc ? argv[k + 1] : "";
    if (!strcmp(a, "--n")) ntarget = atof(v), k++;
    else if (!strcmp(a, "--steps")) steps = atoi(v), k++;
    else if (!strcmp(a, "--warmup")) warmup = atoi(v), k++;
    else if (!strcmp(a, "--threads")) threads = atoi(v), k++;
    else if (!strcmp(a, "--spacing")) spacing = atof(v), k++;
    else if (!strcmp(a, "--shuffle")) shuffle = 1;
    else if (!strcmp(a, "--device")) bench_device(v, &dev), k++;
    else if (!strcmp(a, "--algo")) algo = !strcmp(v, "pair") ? SPHDEM_DEM_PAIR_PARALLEL : SPHDEM_DEM_PARTICLE_PARALLEL, k++;
    else if (!strcmp(a, "--model")) liggghts = !strcmp(v, "liggghts"), k++;
    else {
      fprintf(stderr, "usage: %s [--n N] [--steps S] [--warmup W] [--device cpu|gpu|auto] [--algo pair|particle] "
                      "[--model hertz|liggghts] [--threads T] [--spacing S] [--shuffle]\n", argv[0]);
      return 2;
    }
  }
  threads = bench_threads(threads);
  const double d = 0.005, r = 0.5 * d, a = spacing * d, rho = 2500.0, dt = 2e-6, g = 9.81;
  int nx = (int)floor(pow(ntarget, 1.0 / 3.0) + 0.5), nz = (int)floor(ntarget / ((double)nx * nx) + 0.5);
  if (nx < 2) nx = 2;
  if (nz < 1) nz = 1;
  const int n = nx * nx * nz;
  const double L = nx * a, m = rho * 4.0 / 3.0 * 3.141592653589793 * r * r * r, I = 0.4 * m * r * r;
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.algo = algo;
  if (liggghts) {
    p.model = SPHDEM_DEM_HERTZ_LIGGGHTS;
    p.E = 5e6; p.nu = 0.45; p.en = 0.7; p.mu = 0.5;
  } else {
    p.model = SPHDEM_DEM_HERTZ; /* gran/hertz/history 2e7 NULL 5e3 NULL 0.5 1 */
    p.kn = 2e7; p.kt = 2e7 * 2.0 / 7.0; p.gamman = 5e3; p.gammat = 2.5e3; p.mu = 0.5;
  }
  p.skin = 0.001;
  p.periodic[0] = p.periodic[1] = 1;
  p.boxlo[0] = p.boxlo[1] = 0.0;
  p.boxhi[0] = p.boxhi[1] = L;
  char msg[512];
  sphdem_dem dem;
  int rc = sphdem_dem_create(&dem, &p, dev, msg, sizeof msg);
  if (rc == SPHDEM_ERR_NO_GPU) { printf("BENCH status=skipped reason=\"%s\"\n", msg); return 77; }
  if (rc) { fprintf(stderr, "create: %s\n", msg); return 1; }
  sphdem_dem_wall floor_ = {{0, 0, 0}, {0, 0, 1}};
  sphdem_dem_set_walls(dem, 1, &floor_);
  int64_t *tag = malloc(sizeof(int64_t) * n);
  double *x = malloc(sizeof(double) * 3 * n), *v = malloc(sizeof(double) * 3 * n), *w = calloc(3 * (size_t)n, sizeof(double));
  double *rad = malloc(sizeof(double) * n), *mass = malloc(sizeof(double) * n);
  double *f = malloc(sizeof(double) * 3 * n), *tq = malloc(sizeof(double) * 3 * n);
  if (!tag || !x || !v || !w || !rad || !mass || !f || !tq) { fprintf(stderr, "out of memory\n"); return 1; }
  int q = 0;
  for (int k = 0; k < nz; k++)
    for (int j = 0; j < nx; j++)
      for (int i = 0; i < nx; i++, q++) {
        tag[q] = q + 1;
        x[3 * q] = (i + 0.5) * a;
        x[3 * q + 1] = (j + 0.5) * a;
        x[3 * q + 2] = (k + 0.5) * a;
        for (int c = 0; c < 3; c++) v[3 * q + c] = 0.01 * grand() / sqrt(3.0);
        rad[q] = r;
        mass[q] = m;
      }
  if (shuffle)
    for (int i = n - 1; i > 0; i--) { /* Fisher-Yates */
      int j = (int)(urand() * (i + 1));
      if (j > i) j = i;
      int64_t t = tag[i];
      tag[i] = tag[j];
      tag[j] = t;
    }
  rc = sphdem_dem_compute(dem, n, tag, x, v, w, rad, mass, NULL, dt, 0, f, tq, NULL);
  double t0 = 0, thost = 0, csum = 0, tcall_min = 1e30;
  for (int s = 0; !rc && s < warmup + steps; s++) {
    if (s == warmup) {
      sphdem_dem_timers_reset(dem);
      thost = csum = 0;
      t0 = wtime();
    }
    double h0 = wtime();
    for (int i = 0; i < n; i++) {
      for (int c = 0; c < 3; c++) {
        v[3 * i + c] += 0.5 * dt * (f[3 * i + c] / m - (c == 2 ? g : 0.0));
        w[3 * i + c] += 0.5 * dt * tq[3 * i + c] / I;
        x[3 * i + c] += dt * v[3 * i + c];
      }
      for (int c = 0; c < 2; c++) { /* wrap the periodic axes */
        if (x[3 * i + c] < 0.0) x[3 * i + c] += L;
        else if (x[3 * i + c] >= L) x[3 * i + c] -= L;
      }
    }
    thost += wtime() - h0;
    h0 = wtime();
    rc = sphdem_dem_compute(dem, n, tag, x, v, w, rad, mass, NULL, dt, 1, f, tq, NULL);
    double tc = wtime() - h0;
    if (s >= warmup && tc < tcall_min) tcall_min = tc;
    h0 = wtime();
    for (int i = 0; i < n; i++)
      for (int c = 0; c < 3; c++) {
        v[3 * i + c] += 0.5 * dt * (f[3 * i + c] / m - (c == 2 ? g : 0.0));
        w[3 * i + c] += 0.5 * dt * tq[3 * i + c] / I;
      }
    thost += wtime() - h0;
    sphdem_dem_stats st;
    sphdem_dem_stats_get(dem, &st);
    if (s >= warmup) csum += (double)st.ncontacts;
  }
  double wall = wtime() - t0;
  if (rc) { fprintf(stderr, "compute: %s\n", sphdem_dem_last_error(dem)); return 1; }
  double t[SPHDEM_DEM_NTIMERS], ke = 0;
  sphdem_dem_timers(dem, t);
  sphdem_dem_stats st;
  sphdem_dem_stats_get(dem, &st);
  for (int i = 0; i < n; i++)
    for (int c = 0; c < 3; c++) ke += 0.5 * m * v[3 * i + c] * v[3 * i + c] + 0.5 * I * w[3 * i + c] * w[3 * i + c];
  printf("BENCH code=sphdem_dem backend=%s model=%s algo=%s threads=%d spacing=%g shuffle=%d grains=%d steps=%d wall_s=%.6g "
         "psteps_per_s=%.6g contacts_per_s=%.6g pairs=%lld contacts=%lld builds=%lld t_upload=%.6g t_check=%.6g "
         "t_detect=%.6g t_force=%.6g t_download=%.6g t_host=%.6g t_call_min=%.6g ke=%.10g\n",
         sphdem_dem_backend(dem) == SPHDEM_DEVICE_GPU ? "gpu" : "cpu", liggghts ? "liggghts_hertz" : "hertz",
         algo == SPHDEM_DEM_PAIR_PARALLEL ? "pair" : "particle", threads, spacing, shuffle, n, steps, wall, (double)n * steps / wall,
         csum / wall, (long long)st.npairs, (long long)st.ncontacts, (long long)st.nbuilds, t[SPHDEM_DEM_T_UPLOAD],
         t[SPHDEM_DEM_T_CHECK], t[SPHDEM_DEM_T_DETECT], t[SPHDEM_DEM_T_FORCE], t[SPHDEM_DEM_T_DOWNLOAD], thost, tcall_min, ke);
  sphdem_dem_destroy(&dem);
  free(tag); free(x); free(v); free(w); free(rad); free(mass); free(f); free(tq);
  return 0;
}
