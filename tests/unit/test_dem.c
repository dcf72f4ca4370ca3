/* test_dem.c - GPU DEM core: parameter errors name the field, contact detection against brute force
 * (periodic, clamped and tiny grids), pair- vs particle-parallel forces, Newton's third law, history
 * carried through rebuilds and arbitrary reordering, closed-form single contacts. */
#include <math.h>
#define TEST_RNG_SEED 88172645463325252ull
#include "dem_granular_table.h"
#include "testlib.h"
#include "dem_internal.h" /* (which pass the CPU backend takes, for test_serial_pass) */

static sphdem_dem make(const sphdem_dem_params *p) {
  char msg[256];
  sphdem_dem d = NULL;
  int rc = sphdem_dem_create(&d, p, test_device(), msg, sizeof msg);
  if (rc) { printf("create: %s\n", msg); exit(rc == SPHDEM_ERR_NO_GPU ? test_skip("no usable GPU") : 1); }
  return d;
}

/* The Hertz grains of most tests below: kn 2e5, kt 5e4, gamma_n 50, gamma_t 25, mu 0.5, the given skin and algorithm
 * (< 0: the default), in the box lo..hi, periodic along every axis where periodic != 0. */
static sphdem_dem_params hertz_params(double skin, int algo, const double *lo, const double *hi, int periodic) {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_HERTZ; p.kn = 2e5; p.kt = 5e4; p.gamman = 50; p.gammat = 25; p.mu = 0.5;
  p.skin = skin;
  if (algo >= 0) p.algo = algo;
  for (int d = 0; d < 3; d++) {
    p.periodic[d] = periodic != 0;
    p.boxlo[d] = lo[d];
    p.boxhi[d] = hi[d];
  }
  return p;
}

static void expect_arg(sphdem_dem_params p, const char *field) {
  char msg[256] = "";
  int rc = sphdem_dem_params_check(&p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, field) == msg, "bad %s: rc %d msg '%s'", field, rc, msg);
  sphdem_dem d = NULL;
  rc = sphdem_dem_create(&d, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && d == NULL && strstr(msg, field) == msg, "create with bad %s: '%s'", field, msg);
}

static void test_bad_params(void) {
  sphdem_dem_params p, q;
  sphdem_dem_params_default(&p);
  p.kn = 1e5; p.kt = 2e4;
  char msg[256];
  TEST_ASSERT(sphdem_dem_params_check(&p, msg, sizeof msg) == SPHDEM_OK, "good params rejected: %s", msg);
  q = p; q.kn = 0; expect_arg(q, "kn");
  q = p; q.kt = -1; expect_arg(q, "kt");
  q = p; q.gamman = -1; expect_arg(q, "gamman");
  q = p; q.en = 1.5; expect_arg(q, "en");
  q = p; q.model = 7; expect_arg(q, "model");
  q = p; q.algo = 3; expect_arg(q, "algo");
  q = p; q.mu = -0.1; expect_arg(q, "mu");
  q = p; q.mu_r = -0.1; expect_arg(q, "mu_r");
  q = p; q.first_contact = 1; q.model = SPHDEM_DEM_HERTZ_MINDLIN; q.E = 1e7; q.en = 0.5; expect_arg(q, "first_contact");
  q = p; q.skin = -1; expect_arg(q, "skin");
  q = p; q.periodic[1] = 1; expect_arg(q, "boxhi[1]");
  q = p; q.model = SPHDEM_DEM_HERTZ; q.en = 0.5; expect_arg(q, "en");
  q = p; q.model = SPHDEM_DEM_HERTZ_MINDLIN; q.en = 0.5; q.E = 0; expect_arg(q, "E");
  q = p; q.model = SPHDEM_DEM_HERTZ_MINDLIN; q.en = 0.5; q.E = 1e7; q.nu = 0.7; expect_arg(q, "nu");
  q = p; q.model = SPHDEM_DEM_HERTZ_LIGGGHTS; q.en = 0.02; q.E = 1e7; expect_arg(q, "en");
  /* call arguments */
  sphdem_dem d = make(&p);
  sphdem_dem_wall w = {{0, 0, 0}, {0, 2, 0}};
  TEST_ASSERT(sphdem_dem_set_walls(d, 1, &w) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(d), "walls[0].normal"),
              "non-unit wall normal: %s", sphdem_dem_last_error(d));
  int64_t tag[2] = {1, 0};
  double x[6] = {0}, v[6] = {0}, om[6] = {0}, r[2] = {1, 1}, m[2] = {1, 1}, f[6], t[6];
  TEST_ASSERT(sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-3, 1, f, t, NULL) == SPHDEM_ERR_ARG &&
                  strstr(sphdem_dem_last_error(d), "tag[1]"), "tag 0: %s", sphdem_dem_last_error(d));
  tag[1] = 2; r[0] = -1;
  TEST_ASSERT(sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-3, 1, f, t, NULL) == SPHDEM_ERR_ARG &&
                  strstr(sphdem_dem_last_error(d), "radius[0]"), "radius: %s", sphdem_dem_last_error(d));
  sphdem_dem_destroy(&d);
}

/* ---- random packings ---------------------------------------------------------------------------------- */
typedef struct { int n; int64_t *tag; double *x, *v, *om, *r, *m, *f, *t; } grains;

static grains make_grains(int n, const double *lo, const double *hi, double r0, double vscale) {
  grains g;
  g.n = n;
  g.tag = malloc(sizeof(int64_t) * n);
  g.x = malloc(sizeof(double) * 3 * n); g.v = malloc(sizeof(double) * 3 * n); g.om = malloc(sizeof(double) * 3 * n);
  g.f = malloc(sizeof(double) * 3 * n); g.t = malloc(sizeof(double) * 3 * n);
  g.r = malloc(sizeof(double) * n); g.m = malloc(sizeof(double) * n);
  for (int i = 0; i < n; i++) {
    g.tag[i] = 1000 + 7 * i; /* not contiguous, not ordered like anything else */
    g.r[i] = r0 * (0.6 + 0.4 * urand());
    g.m[i] = 2500 * 4.0 / 3.0 * M_PI * pow(g.r[i], 3);
    for (int d = 0; d < 3; d++) {
      g.x[3 * i + d] = lo[d] + (hi[d] - lo[d]) * urand();
      g.v[3 * i + d] = vscale * (urand() - 0.5);
      g.om[3 * i + d] = vscale / r0 * (urand() - 0.5);
    }
  }
  return g;
}
/* n grains of make_grains (radius 0.06..0.1) filling the cube lo..hi (set here, from 0) to a volume fraction of
 * about phi (counted with radius 0.1), velocities up to vscale */
static grains packing(int n, double phi, double vscale, double *lo, double *hi) {
  const double L = 0.1 * cbrt((double)n / phi * 4.0 / 3.0 * M_PI / 8.0);
  for (int d = 0; d < 3; d++) lo[d] = 0.0, hi[d] = L;
  return make_grains(n, lo, hi, 0.1, vscale);
}
static void free_grains(grains *g) {
  free(g->tag); free(g->x); free(g->v); free(g->om); free(g->f); free(g->t); free(g->r); free(g->m);
}

static int cmp_pair(const void *a, const void *b) {
  const int64_t *p = a, *q = b;
  if (p[0] != q[0]) return p[0] < q[0] ? -1 : 1;
  return p[1] < q[1] ? -1 : p[1] > q[1];
}

/* candidate pairs of the core vs all pairs closer than r_a + r_b + skin by brute force (minimum image) */
static void check_detection(const char *what, sphdem_dem_params p, grains *g, int nw, const sphdem_dem_wall *w) {
  sphdem_dem d = make(&p);
  sphdem_dem_set_walls(d, nw, w);
  int rc = sphdem_dem_compute(d, g->n, g->tag, g->x, g->v, g->om, g->r, g->m, NULL, 1e-4, 0, g->f, g->t, NULL);
  TEST_ASSERT(rc == SPHDEM_OK, "%s: %s", what, sphdem_dem_last_error(d));
  int64_t cap = (int64_t)g->n * 64 + 64;
  int64_t *core = malloc(sizeof(int64_t) * 2 * cap), *brute = malloc(sizeof(int64_t) * 2 * cap);
  int64_t nc = sphdem_dem_debug_pairs(d, core, cap), nb = 0;
  for (int i = 0; i < g->n; i++) {
    for (int j = i + 1; j < g->n; j++) {
      double r2 = 0;
      for (int k = 0; k < 3; k++) {
        double s = g->x[3 * i + k] - g->x[3 * j + k];
        if (p.periodic[k]) { double L = p.boxhi[k] - p.boxlo[k]; s -= L * rint(s / L); }
        r2 += s * s;
      }
      double cut = g->r[i] + g->r[j] + p.skin;
      if (r2 < cut * cut) {
        int lo = g->tag[i] < g->tag[j];
        brute[2 * nb] = lo ? i : j;
        brute[2 * nb + 1] = lo ? j : i;
        nb++;
      }
    }
    for (int k = 0; k < nw; k++) {
      double dist = 0;
      for (int q = 0; q < 3; q++) dist += (g->x[3 * i + q] - w[k].point[q]) * w[k].normal[q];
      if (dist < g->r[i] + p.skin) { brute[2 * nb] = i; brute[2 * nb + 1] = -1 - k; nb++; }
    }
  }
  int same = nc == nb;
  if (same) {
    qsort(core, nc, 2 * sizeof(int64_t), cmp_pair);
    qsort(brute, nb, 2 * sizeof(int64_t), cmp_pair);
    same = memcmp(core, brute, sizeof(int64_t) * 2 * nb) == 0;
  }
  TEST_ASSERT(same && nb > 0, "%s: core %lld pairs, brute force %lld", what, (long long)nc, (long long)nb);
  printf("  detection %s: %lld candidate pairs, identical to brute force: %s\n", what, (long long)nb, same ? "yes" : "NO");
  free(core);
  free(brute);
  sphdem_dem_destroy(&d);
}

static void test_detection(void) {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.kn = 1e5; p.kt = 2e4;
  p.skin = 0.05;
  double lo[3] = {0, 0, 0}, hi[3] = {3, 2, 2.5};
  grains g = make_grains(600, lo, hi, 0.1, 0);
  /* periodic in x and z, a floor and a tilted plane */
  p.periodic[0] = p.periodic[2] = 1;
  for (int d = 0; d < 3; d++) { p.boxlo[d] = lo[d]; p.boxhi[d] = hi[d]; }
  double s = 1 / sqrt(2.0);
  sphdem_dem_wall w[2] = {{{0, 0.05, 0}, {0, 1, 0}}, {{0, 2, 0}, {s, -s, 0}}};
  check_detection("periodic x,z + 2 walls", p, &g, 2, w);
  /* no periodic axis: the grid spans the grains' bounding box; some grains far outside */
  p.periodic[0] = p.periodic[2] = 0;
  for (int i = 0; i < 20; i++) g.x[3 * i] += 50.0 + 0.01 * i;
  check_detection("open, spread", p, &g, 0, NULL);
  p.algo = SPHDEM_DEM_PARTICLE_PARALLEL;
  check_detection("open, particle-parallel", p, &g, 0, NULL);
  free_grains(&g);
  /* periodic box only 2.2 cells wide on x and y: the adjacent-cell set must not repeat cells */
  double lo2[3] = {0, 0, 0}, hi2[3] = {0.55, 0.55, 2};
  grains h = make_grains(60, lo2, hi2, 0.1, 0);
  p.algo = SPHDEM_DEM_PAIR_PARALLEL;
  p.periodic[0] = p.periodic[1] = 1;
  for (int d = 0; d < 3; d++) { p.boxlo[d] = lo2[d]; p.boxhi[d] = hi2[d]; }
  check_detection("periodic, 2 cells across", p, &h, 0, NULL);
  free_grains(&h);
}

/* ---- dynamics: algorithms agree, Newton's third law, history through reordering ----------------------- */

static double maxabs(const double *a, int n) {
  double m = 0;
  for (int i = 0; i < n; i++) m = fmax(m, fabs(a[i]));
  return m;
}

static void test_dynamics(void) {
  double lo[3] = {0, 0, 0}, hi[3] = {1.2, 1.2, 1.2};
  grains g = make_grains(300, lo, hi, 0.1, 0.5);
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_HERTZ; p.kn = 2e5; p.kt = 2.0 / 7.0 * 2e5; p.gamman = 50; p.gammat = 25; p.mu = 0.5;
  p.mu_r = 0.01;
  p.skin = 0.02;
  p.periodic[0] = p.periodic[1] = p.periodic[2] = 1;
  for (int d = 0; d < 3; d++) { p.boxlo[d] = lo[d]; p.boxhi[d] = hi[d]; }
  sphdem_dem A = make(&p);        /* pair-parallel, grains in a fixed order */
  p.algo = SPHDEM_DEM_PARTICLE_PARALLEL;
  sphdem_dem B = make(&p);        /* particle-parallel, fixed order */
  sphdem_dem C = make(&p);        /* particle-parallel, reshuffled every step */
  sphdem_dem Dn = make(&p);       /* control: reshuffled and recreated every step (history lost) */
  int n = g.n;
  int *perm = malloc(sizeof(int) * n);
  int64_t *ptag = malloc(sizeof(int64_t) * n);
  double *px = malloc(sizeof(double) * 3 * n), *pv = malloc(sizeof(double) * 3 * n), *pom = malloc(sizeof(double) * 3 * n);
  double *pr = malloc(sizeof(double) * n), *pm = malloc(sizeof(double) * n);
  double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
  double *fC = malloc(sizeof(double) * 3 * n), *tC = malloc(sizeof(double) * 3 * n);
  double *fD = malloc(sizeof(double) * 3 * n), *tD = malloc(sizeof(double) * 3 * n);
  double dt = 2e-5, worst_ab = 0, worst_bc = 0, worst_newton = 0, lost = 0, vir[6];
  int rc = 0;
  for (int step = 0; step < 400 && !rc; step++) {
    for (int i = 0; i < n; i++) perm[i] = i;
    for (int i = n - 1; i > 0; i--) { int j = (int)(urand() * (i + 1)); int t = perm[i]; perm[i] = perm[j]; perm[j] = t; }
    for (int k = 0; k < n; k++) {
      int i = perm[k];
      ptag[k] = g.tag[i]; pr[k] = g.r[i]; pm[k] = g.m[i];
      for (int d = 0; d < 3; d++) { px[3 * k + d] = g.x[3 * i + d]; pv[3 * k + d] = g.v[3 * i + d]; pom[3 * k + d] = g.om[3 * i + d]; }
    }
    rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, dt, 1, g.f, g.t, vir);
    rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, dt, 1, fB, tB, NULL);
    rc |= sphdem_dem_compute(C, n, ptag, px, pv, pom, pr, pm, NULL, dt, 1, fC, tC, NULL);
    sphdem_dem_destroy(&Dn);
    Dn = make(&p);
    rc |= sphdem_dem_compute(Dn, n, ptag, px, pv, pom, pr, pm, NULL, dt, 1, fD, tD, NULL);
    double fscale = fmax(maxabs(g.f, 3 * n), 1e-300), tscale = fmax(maxabs(g.t, 3 * n), 1e-300), sum[3] = {0, 0, 0};
    for (int i = 0; i < n; i++)
      for (int d = 0; d < 3; d++) {
        worst_ab = fmax(worst_ab, fabs(g.f[3 * i + d] - fB[3 * i + d]) / fscale);
        worst_ab = fmax(worst_ab, fabs(g.t[3 * i + d] - tB[3 * i + d]) / tscale);
        sum[d] += g.f[3 * i + d];
      }
    for (int k = 0; k < n; k++)
      for (int d = 0; d < 3; d++) {
        int i = perm[k];
        worst_bc = fmax(worst_bc, fabs(fB[3 * i + d] - fC[3 * k + d]) / fscale);
        worst_bc = fmax(worst_bc, fabs(tB[3 * i + d] - tC[3 * k + d]) / tscale);
        lost = fmax(lost, fabs(fB[3 * i + d] - fD[3 * k + d]) / fscale);
      }
    for (int d = 0; d < 3; d++) worst_newton = fmax(worst_newton, fabs(sum[d]) / fscale);
    /* advance with A's forces (symplectic Euler), no gravity: a shaken periodic packing */
    for (int i = 0; i < n; i++) {
      double I = 0.4 * g.m[i] * g.r[i] * g.r[i];
      for (int d = 0; d < 3; d++) {
        g.v[3 * i + d] += dt * g.f[3 * i + d] / g.m[i];
        g.om[3 * i + d] += dt * g.t[3 * i + d] / I;
        g.x[3 * i + d] += dt * g.v[3 * i + d];
      }
    }
  }
  TEST_ASSERT(rc == SPHDEM_OK, "compute failed: %s", sphdem_dem_last_error(A));
  sphdem_dem_stats sa, sc;
  sphdem_dem_stats_get(A, &sa);
  sphdem_dem_stats_get(C, &sc);
  /* a sliding, touching pair with history */
  int64_t pairs[2 * 4096];
  int64_t np = sphdem_dem_debug_pairs(B, pairs, 4096);
  double hB[4] = {0}, hC[4] = {0}, hmax = 0;
  int found = 0;
  for (int64_t q = 0; q < np && q < 4096; q++) {
    if (pairs[2 * q + 1] < 0) continue;
    int64_t ta = g.tag[pairs[2 * q]], tb = g.tag[pairs[2 * q + 1]];
    if (sphdem_dem_debug_history(B, ta, tb, hB) == SPHDEM_OK && hB[3] != 0.0 &&
        sphdem_dem_debug_history(C, ta, tb, hC) == SPHDEM_OK) {
      double s = sqrt(hB[0] * hB[0] + hB[1] * hB[1] + hB[2] * hB[2]);
      if (s > hmax) { hmax = s; found = memcmp(hB, hC, sizeof hB) == 0; }
    }
  }
  printf("  dynamics: 300 grains, 400 steps, %lld builds (reshuffled copy: %lld), %lld contacts at the end\n",
         (long long)sa.nbuilds, (long long)sc.nbuilds, (long long)sa.ncontacts);
  printf("  pair- vs particle-parallel max rel diff %.3g; particle-parallel fixed vs reshuffled every step %.3g; "
         "history lost each step %.3g; |sum F| / max|F| %.3g; largest tangential displacement %.3g m\n",
         worst_ab, worst_bc, lost, worst_newton, hmax);
  TEST_ASSERT(sa.nbuilds > 2 && sa.ncontacts > 50, "the test needs rebuilds and contacts (%lld, %lld)",
              (long long)sa.nbuilds, (long long)sa.ncontacts);
  TEST_ASSERT(worst_ab < 1e-10, "pair- vs particle-parallel differ by %.3g", worst_ab);
  TEST_ASSERT(worst_bc == 0.0, "reordering changed particle-parallel forces by %.3g (history not carried?)", worst_bc);
  TEST_ASSERT(lost > 1e-3, "losing the history changes nothing (%.3g): the test would not see a lost history", lost);
  TEST_ASSERT(worst_newton < 1e-10, "Newton's third law: |sum F| / max|F| = %.3g", worst_newton);
  TEST_ASSERT(hmax > 0 && found, "no tangential history, or it differs after reordering (%.3g)", hmax);
  sphdem_dem_destroy(&A); sphdem_dem_destroy(&B); sphdem_dem_destroy(&C); sphdem_dem_destroy(&Dn);
  free(perm); free(ptag); free(px); free(pv); free(pom); free(pr); free(pm);
  free(fB); free(tB); free(fC); free(tC); free(fD); free(tD);
  free_grains(&g);
}

/* ---- closed-form single contacts ----------------------------------------------------------------------- */

static void test_single_contacts(void) {
  int64_t tag[2] = {5, 3};
  double ra = 0.01, rb = 0.02, delta = 1e-4, reff = ra * rb / (ra + rb);
  double x[6] = {0, 0, 0, ra + rb - delta, 0, 0}, v[6] = {0}, om[6] = {0}, r[2] = {ra, rb}, m[2] = {1e-2, 8e-2};
  double f[6], t[6];
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.kn = 1e5; p.kt = 1e4; p.mu = 0.3;
  const char *names[4] = {"hooke", "hertz", "hertz_mindlin", "hertz_liggghts"};
  for (int model = 0; model < 4; model++) {
    p.model = model;
    if (model >= SPHDEM_DEM_HERTZ_MINDLIN) { p.E = 1e8; p.nu = 0.25; p.en = 0.5; }
    sphdem_dem d = make(&p);
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    /* He eqs 18, 21 and LIGGGHTS' k_n = 4/3 Y* sqrt(R* delta) are the same Hertz law at rest */
    double expect = model == 0 ? p.kn * delta
                  : model == 1 ? p.kn * delta * sqrt(delta * reff)
                               : 4.0 / 3.0 * p.E / (2 * (1 - p.nu * p.nu)) * sqrt(reff) * pow(delta, 1.5);
    /* grain 1 (tag 3) is at +x: it is pushed to +x */
    TEST_ASSERT(rc == 0 && fabs(f[3] / expect - 1) < 1e-12 && f[0] == -f[3], "%s normal force %.15g vs %.15g",
                names[model], f[3], expect);
    sphdem_dem_destroy(&d);
  }
  /* rolling friction (He eq 25): constant torque mu_r R |F_n| against the relative rotation */
  p.model = SPHDEM_DEM_HOOKE; p.mu_r = 0.1; p.mu = 0;
  om[2] = 3.0;
  sphdem_dem d = make(&p);
  sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
  double fn = p.kn * delta;
  TEST_ASSERT(fabs(t[2] + p.mu_r * ra * fn) < 1e-15 && fabs(t[5] - p.mu_r * rb * fn) < 1e-15,
              "rolling torque %.6g %.6g vs -/+ %.6g %.6g", t[2], t[5], p.mu_r * ra * fn, p.mu_r * rb * fn);
  sphdem_dem_destroy(&d);
  /* Mindlin: grain 1 (tag 3, the pair's a) slides along +y; once the tangential displacement exceeds
   * delta_t,max (eq 22, 3.5e-5 m here) the force on it is -mu |F_n| along y, the torques r x F on both */
  p.model = SPHDEM_DEM_HERTZ_MINDLIN; p.mu_r = 0; p.mu = 0.3; p.en = 0.5;
  om[2] = 0;
  v[4] = 0.01;
  d = make(&p);
  for (int s = 0; s < 1000; s++) sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-5, 1, f, t, NULL);
  double Fn = 4.0 / 3.0 * p.E / (2 * (1 - p.nu * p.nu)) * sqrt(reff) * pow(delta, 1.5);
  TEST_ASSERT(fabs(-f[4] / (p.mu * Fn) - 1) < 1e-12 && f[1] == -f[4], "sliding force %.12g vs -mu Fn %.12g", f[4], -p.mu * Fn);
  /* grain 1 (radius r[1]) gets f_y < 0 at -r[1] x from its centre: torque_z = -r[1] f_y; grain 0 (radius
   * r[0]) gets -f_y at +r[0] x: torque_z = -r[0] f_y, the same sign */
  TEST_ASSERT(fabs(t[5] / (-r[1] * f[4]) - 1) < 1e-12 && fabs(t[2] / (-r[0] * f[4]) - 1) < 1e-12,
              "tangential torques %.6g %.6g", t[2], t[5]);
  sphdem_dem_destroy(&d);
}

/* Above 2048 grains the CPU loops run on OpenMP threads (ctest runs unit_dem with OMP_NUM_THREADS=2): the atomic
 * pair-parallel sums and the particle-parallel pass must still agree, and detection stay exact. */
static void test_threaded(void) {
  double lo[3] = {0, 0, 0}, hi[3] = {3, 3, 3};
  grains g = make_grains(6000, lo, hi, 0.1, 0.5);
  sphdem_dem_params p = hertz_params(0.02, -1, lo, hi, 1);
  p.mu_r = 0.01;
  check_detection("6000 grains, threaded", p, &g, 0, NULL);
  sphdem_dem A = make(&p);
  p.algo = SPHDEM_DEM_PARTICLE_PARALLEL;
  sphdem_dem B = make(&p);
  double *fB = malloc(sizeof(double) * 3 * g.n), *tB = malloc(sizeof(double) * 3 * g.n), worst = 0;
  int rc = 0;
  for (int s = 0; s < 5; s++) {
    rc |= sphdem_dem_compute(A, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
    rc |= sphdem_dem_compute(B, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, fB, tB, NULL);
    double fs = fmax(maxabs(g.f, 3 * g.n), 1e-300), ts = fmax(maxabs(g.t, 3 * g.n), 1e-300);
    for (int k = 0; k < 3 * g.n; k++)
      worst = fmax(worst, fmax(fabs(g.f[k] - fB[k]) / fs, fabs(g.t[k] - tB[k]) / ts));
    for (int k = 0; k < 3 * g.n; k++) g.x[k] += 1e-5 * g.v[k];
  }
  sphdem_dem_stats st;
  sphdem_dem_stats_get(A, &st);
  printf("  threaded: %lld contacts, pair- vs particle-parallel max rel diff %.3g\n", (long long)st.ncontacts, worst);
  TEST_ASSERT(rc == 0 && st.ncontacts > 1000 && worst < 1e-10, "threaded pair vs particle: %.3g", worst);
  sphdem_dem_destroy(&A);
  sphdem_dem_destroy(&B);
  free(fB); free(tB);
  free_grains(&g);
}

/* Yu eq 12: a new contact's tangential displacement starts at v_t min(delta/|v_n|, dt), not v_t dt */
static void test_first_contact(void) {
  int64_t tag[2] = {1, 2};
  double ra = 0.01, rb = 0.01, delta = 2e-6, vn = 1.0, vt = 0.3, dt = 1e-5; /* delta/vn = 2e-6 < dt */
  double x[6] = {0, 0, 0, ra + rb - delta, 0, 0}, v[6] = {vn, vt, 0, 0, 0, 0}, om[6] = {0}, r[2] = {ra, rb};
  double m[2] = {1e-3, 1e-3}, f[6], t[6], h[4];
  for (int fc = 0; fc <= 1; fc++) {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    p.kn = 1e5; p.kt = 2e4; p.mu = 0.5; p.first_contact = fc;
    sphdem_dem d = make(&p);
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    rc |= sphdem_dem_debug_history(d, 1, 2, h);
    double expect = vt * (fc ? delta / vn : dt);
    TEST_ASSERT(rc == 0 && fabs(h[1] / expect - 1) < 1e-9 && h[3] == 1.0, "first_contact %d: shear %.6g vs %.6g", fc,
                h[1], expect);
    sphdem_dem_destroy(&d);
  }
}

/* Grains the core cannot bin or pair stop with an error naming them by tag: coincident centres (both
 * algorithms, hooke and the LIGGGHTS hertz law), a non-finite position, grains spread too far for any
 * cell grid; a step with no grain left (NULL arrays) after grains existed; the LAMMPS-syntax models
 * (E = 0) run with finite forces. */
static void test_bad_grains(void) {
  double r0 = 0.001;
  for (int variant = 0; variant < 3; variant++) {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    if (variant < 2) { p.kn = 1e5; p.kt = 2e4; p.algo = variant ? SPHDEM_DEM_PARTICLE_PARALLEL : SPHDEM_DEM_PAIR_PARALLEL; }
    else { p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 1e7; p.nu = 0.3; p.en = 0.5; }
    p.skin = 0.2 * r0;
    sphdem_dem d = make(&p);
    /* five grains in a row, the fourth (tag 12) put on the second (tag 7) */
    int64_t tag[5] = {3, 7, 9, 12, 20};
    double x[15], v[15] = {0}, om[15] = {0}, r[5], m[5], f[15], t[15];
    for (int i = 0; i < 5; i++) {
      x[3 * i] = 3.0 * r0 * i; x[3 * i + 1] = 0.001; x[3 * i + 2] = -0.002;
      r[i] = r0; m[i] = 1e-6;
    }
    int rc = sphdem_dem_compute(d, 5, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    TEST_ASSERT(rc == SPHDEM_OK, "variant %d: separated grains: %s", variant, sphdem_dem_last_error(d));
    x[9] = x[3]; x[10] = x[4]; x[11] = x[5];
    rc = sphdem_dem_compute(d, 5, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    const char *e = sphdem_dem_last_error(d);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(e, "grains 7 and 12 are at the same position"),
                "variant %d: coincident grains: rc %d '%s'", variant, rc, e);
    /* the same context runs on once the grain is moved away (the flag does not stick) */
    x[9] = 9.0 * r0, x[10] = 0.001, x[11] = -0.002;
    rc = sphdem_dem_compute(d, 5, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    int finite = 1;
    for (int k = 0; k < 15; k++) finite &= isfinite(f[k]) && isfinite(t[k]);
    TEST_ASSERT(rc == SPHDEM_OK && finite, "variant %d: after moving the grain away: %s", variant, sphdem_dem_last_error(d));
    x[7] = NAN;
    rc = sphdem_dem_compute(d, 5, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    e = sphdem_dem_last_error(d);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(e, "grain 9: position") && strstr(e, "not finite"),
                "variant %d: NaN position: rc %d '%s'", variant, rc, e);
    x[7] = 0.001;
    x[14] = 1e300; /* finite, but no grid of at most 2^24 cells spans it */
    x[12] = -1e300;
    rc = sphdem_dem_compute(d, 5, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    e = sphdem_dem_last_error(d);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(e, "no cell grid"), "variant %d: grains 1e300 apart: rc %d '%s'",
                variant, rc, e);
    /* every grain lost: no arrays at all */
    rc = sphdem_dem_compute(d, 0, NULL, NULL, NULL, NULL, NULL, NULL, NULL, 1e-6, 1, NULL, NULL, NULL);
    TEST_ASSERT(rc == SPHDEM_OK, "variant %d: no grains left: %s", variant, sphdem_dem_last_error(d));
    sphdem_dem_destroy(&d);
  }
  /* LAMMPS syntax (E = 0): two overlapping grains, finite and opposite forces */
  for (int model = SPHDEM_DEM_HOOKE; model <= SPHDEM_DEM_HERTZ; model++) {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    p.model = model; p.kn = 1e5; p.kt = 2e4; p.gamman = 10; p.gammat = 5;
    TEST_ASSERT(p.E == 0.0, "default E is %g", p.E);
    sphdem_dem d = make(&p);
    int64_t tag[2] = {1, 2};
    double x[6] = {0, 0, 0, 1.9 * r0, 0, 0}, v[6] = {0.1, 0, 0, 0, 0, 0}, om[6] = {0}, r[2] = {r0, r0};
    double m[2] = {1e-6, 1e-6}, f[6], t[6];
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, 1e-6, 1, f, t, NULL);
    TEST_ASSERT(rc == SPHDEM_OK && isfinite(f[0]) && f[0] < 0.0 && f[3] == -f[0],
                "model %d, E = 0: rc %d f %g %g", model, rc, f[0], f[3]);
    sphdem_dem_destroy(&d);
  }
}

/* A grain slides along a frozen one, leaves it and touches it again within one pair-list lifetime (no
 * rebuild: skin 1 mm, displacements 0.03 mm). LAMMPS models (keep_history 0): the history is zeroed when
 * the pair separates, so the second contact starts from zero: its history after the first step equals
 * that of a fresh context given the same state. LIGGGHTS (keep_history 1): the separated pair keeps its
 * history until a build the engine asks for (sphdem_dem_request_build), which keeps it only for touching pairs. */
static void bounce_phase(sphdem_dem d, double *x, double *v, double gap, int steps, double dt, double h[4]) {
  int64_t tag[2] = {1, 2};
  double om[6] = {0, 0, 0, 0, 0, 30.0}, r[2] = {0.001, 0.001}, m[2] = {1e-5, 1e-5}, f[6], t[6];
  int fl[2] = {SPHDEM_DEM_FROZEN, 0};
  for (int s = 0; s < steps; s++) {
    x[3] = 0.002 + gap; /* grain 2 beside grain 1 along x, sliding along y */
    x[4] += v[4] * dt;
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, fl, dt, 1, f, t, NULL);
    TEST_ASSERT(rc == SPHDEM_OK, "bounce: %s", sphdem_dem_last_error(d));
  }
  TEST_ASSERT(sphdem_dem_debug_history(d, 1, 2, h) == SPHDEM_OK, "bounce history: %s", sphdem_dem_last_error(d));
}

static void test_recontact_history(void) {
  const double dt = 1e-5;
  for (int keep = 0; keep <= 1; keep++)
    for (int algo = 0; algo <= 1; algo++) {
      sphdem_dem_params p;
      sphdem_dem_params_default(&p);
      if (keep) { p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 5e6; p.nu = 0.45; p.en = 0.7; }
      else { p.model = SPHDEM_DEM_HERTZ; p.kn = 2e7; p.kt = 2e7 * 2.0 / 7.0; p.gamman = 5e3; p.gammat = 2.5e3; }
      p.mu = 0.5; p.skin = 0.001; p.algo = algo; p.keep_history = keep;
      for (int engine_build = 0; engine_build <= keep; engine_build++) {
        sphdem_dem d = make(&p);
        double x[6] = {0, 0, 0, 0, 0, 0}, v[6] = {0, 0, 0, 0, 0.1, 0}, h1[4], h2[4], h3[4], hf[4];
        bounce_phase(d, x, v, -1e-5, 20, dt, h1);  /* first contact */
        bounce_phase(d, x, v, +1e-5, 10, dt, h2);  /* apart, still in the pair list */
        if (engine_build) { /* the engine rebuilds its lists while the grains are apart */
          sphdem_dem_request_build(d);
          bounce_phase(d, x, v, +1e-5, 1, dt, h2);
        }
        double xs[6], vs[6];
        memcpy(xs, x, sizeof x); memcpy(vs, v, sizeof v);
        bounce_phase(d, x, v, -1e-5, 1, dt, h3);   /* the first step of the second contact */
        sphdem_dem_stats st;
        sphdem_dem_stats_get(d, &st);
        sphdem_dem fresh = make(&p);
        bounce_phase(fresh, xs, vs, -1e-5, 1, dt, hf);
        const double s1 = sqrt(h1[0] * h1[0] + h1[1] * h1[1] + h1[2] * h1[2]);
        const int same_as_fresh = h3[0] == hf[0] && h3[1] == hf[1] && h3[2] == hf[2];
        TEST_ASSERT(s1 > 1e-7 && h1[3] > 0.0, "keep %d algo %d: the first contact built no history (|s| %g)", keep, algo, s1);
        TEST_ASSERT(st.nbuilds == 1 + engine_build, "keep %d algo %d: %lld pair-list builds", keep, algo, (long long)st.nbuilds);
        if (!keep || engine_build) {
          TEST_ASSERT(same_as_fresh && h3[3] > 0.0, "keep %d algo %d build %d: second contact history (%g %g %g) is not a "
                      "fresh contact's (%g %g %g)", keep, algo, engine_build, h3[0], h3[1], h3[2], hf[0], hf[1], hf[2]);
          TEST_ASSERT(h2[0] == 0.0 && h2[1] == 0.0 && h2[2] == 0.0 && h2[3] == 0.0,
                      "keep %d algo %d: separated pair keeps history %g %g %g %g", keep, algo, h2[0], h2[1], h2[2], h2[3]);
        } else {
          TEST_ASSERT(h2[0] == h1[0] && h2[1] == h1[1] && h2[2] == h1[2] && h2[3] < 0.0,
                      "algo %d: LIGGGHTS rule: the separated pair's history (%g %g %g, flag %g) is not the one it left with",
                      algo, h2[0], h2[1], h2[2], h2[3]);
          TEST_ASSERT(!same_as_fresh && h3[3] > 0.0, "algo %d: LIGGGHTS rule: the second contact started from zero", algo);
        }
        sphdem_dem_destroy(&fresh);
        sphdem_dem_destroy(&d);
      }
    }
  /* keep_history is LIGGGHTS' rule: refused for the LAMMPS models */
  sphdem_dem_params q;
  sphdem_dem_params_default(&q);
  q.kn = 1e5; q.kt = 2e4; q.keep_history = 1;
  expect_arg(q, "keep_history");
}

/* Several materials (LIGGGHTS model hertz): the normal force of each material pair at rest is LIGGGHTS'
 * 4/3 Y* sqrt(R* delta) delta with Y* = 1/((1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j); a sliding pair is held at
 * mu_ij |F_n|; with tangential_damping off the first step's tangential force is the spring's
 * -8 G* sqrt(R* delta) v_t dt alone; a table of one material repeated gives the bits of the params' one
 * material; bad tables and material indices are refused. */
static void test_materials(void) {
  const double E[2] = {5e6, 2e7}, nu[2] = {0.45, 0.3};
  const double en[4] = {0.7, 0.55, 0.55, 0.4}, mu[4] = {0.5, 0.3, 0.3, 0.2};
  const double ra = 0.001, rb = 0.0008, delta = 2e-5, reff = ra * rb / (ra + rb), V = 0.05, dt = 1e-6;
  int64_t tag[2] = {1, 2};
  double x[6] = {0, 0, 0, ra + rb - delta, 0, 0}, v[6] = {0, V, 0, 0, 0, 0}, om[6] = {0}, r[2] = {ra, rb};
  double m[2] = {1e-5, 6e-6}, f[6], t[6];
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = E[0]; p.nu = nu[0]; p.en = 0.7; p.mu = 10.0; p.algo = SPHDEM_DEM_PARTICLE_PARALLEL;
  for (int tdoff = 0; tdoff < 2; tdoff++)
    for (int ia = 0; ia < 2; ia++)
      for (int ib = 0; ib < 2; ib++) {
        p.no_tangential_damping = tdoff;
        sphdem_dem d = make(&p);
        const double big[4] = {10, 10, 10, 10};
        sphdem_dem_materials mt = {2, E, nu, en, big, NULL};
        int flags[2] = {ia << SPHDEM_DEM_MATERIAL_SHIFT, ib << SPHDEM_DEM_MATERIAL_SHIFT};
        int rc = sphdem_dem_set_materials(d, &mt);
        if (!rc) rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, flags, dt, 1, f, t, NULL);
        const double Y = 1. / ((1. - nu[ia] * nu[ia]) / E[ia] + (1. - nu[ib] * nu[ib]) / E[ib]);
        const double G = 1. / (2. * (2. - nu[ia]) * (1. + nu[ia]) / E[ia] + 2. * (2. - nu[ib]) * (1. + nu[ib]) / E[ib]);
        const double fn = 4. / 3. * Y * sqrt(reff * delta) * delta, kt = 8. * G * sqrt(reff * delta);
        /* grain 0 (the pair's a) is at -x of grain 1: pushed to -x */
        TEST_ASSERT(rc == 0 && fabs(-f[0] / fn - 1) < 1e-12 && f[3] == -f[0],
                    "materials %d %d: normal force %.15g vs %.15g (rc %d %s)", ia, ib, -f[0], fn, rc, sphdem_dem_last_error(d));
        if (tdoff)
          TEST_ASSERT(fabs(f[1] / (-kt * V * dt) - 1) < 1e-12, "tangential_damping off, materials %d %d: F_t %.15g vs "
                      "the spring's %.15g", ia, ib, f[1], -kt * V * dt);
        else /* the dashpot -gamma_t v_t (gamma_t < 0 in LIGGGHTS' sign: it adds to the spring's force) */
          TEST_ASSERT(f[1] < -kt * V * dt * (1 + 1e-6), "tangential damping on, materials %d %d: F_t %.15g, spring %.15g",
                      ia, ib, f[1], -kt * V * dt);
        sphdem_dem_destroy(&d);
      }
  /* sliding: the friction of the material pair caps the tangential force at mu_ij |F_n| */
  p.no_tangential_damping = 0;
  {
    sphdem_dem d = make(&p);
    sphdem_dem_materials mt = {2, E, nu, en, mu, NULL};
    int flags[2] = {0, 1 << SPHDEM_DEM_MATERIAL_SHIFT};
    int rc = sphdem_dem_set_materials(d, &mt);
    double vs[6] = {0, 1.0, 0, 0, 0, 0};
    for (int s = 0; s < 200 && !rc; s++) rc = sphdem_dem_compute(d, 2, tag, x, vs, om, r, m, flags, dt, 1, f, t, NULL);
    const double Y = 1. / ((1. - nu[0] * nu[0]) / E[0] + (1. - nu[1] * nu[1]) / E[1]);
    const double fn = 4. / 3. * Y * sqrt(reff * delta) * delta;
    TEST_ASSERT(rc == 0 && fabs(-f[1] / (mu[1] * fn) - 1) < 1e-12, "sliding between materials 0 and 1: F_t %.15g vs "
                "-mu_01 F_n %.15g", f[1], -mu[1] * fn);
    sphdem_dem_destroy(&d);
  }
  /* a table of the params' one material, repeated: the same bits as without a table, over 300 steps of a
   * sliding, rolling, spinning pair with rolling friction (cdt) */
  {
    p.mu = 0.4; p.mu_r = 0.03;
    const double E1[2] = {p.E, p.E}, nu1[2] = {p.nu, p.nu}, en1[4] = {p.en, p.en, p.en, p.en};
    const double mu1[4] = {p.mu, p.mu, p.mu, p.mu}, mr1[4] = {p.mu_r, p.mu_r, p.mu_r, p.mu_r};
    double fa[6], ta[6], fb[6], tb[6];
    double x1[6], v1[6] = {0.01, 0.3, -0.02, 0, -0.1, 0.01}, w1[6] = {5, -3, 2, 1, 4, -6};
    sphdem_dem d0 = make(&p), d1 = make(&p);
    sphdem_dem_materials mt = {2, E1, nu1, en1, mu1, mr1};
    int flags[2] = {1 << SPHDEM_DEM_MATERIAL_SHIFT, 0}, rc = sphdem_dem_set_materials(d1, &mt), same = 1;
    memcpy(x1, x, sizeof x1);
    for (int s = 0; s < 300 && !rc; s++) {
      rc = sphdem_dem_compute(d0, 2, tag, x1, v1, w1, r, m, NULL, dt, 1, fa, ta, NULL);
      if (!rc) rc = sphdem_dem_compute(d1, 2, tag, x1, v1, w1, r, m, flags, dt, 1, fb, tb, NULL);
      same &= memcmp(fa, fb, sizeof fa) == 0 && memcmp(ta, tb, sizeof ta) == 0;
      for (int k = 0; k < 6; k++) x1[k] += v1[k] * dt * 1e-2;
    }
    TEST_ASSERT(rc == 0 && same && fa[1] != 0.0 && ta[2] != 0.0, "a table of one material: the bits of the params' "
                "material (rc %d, same %d)", rc, same);
    /* bad tables and indices */
    const double asym[4] = {0.5, 0.3, 0.2, 0.2};
    sphdem_dem_materials bad = {2, E, nu, en, asym, NULL};
    rc = sphdem_dem_set_materials(d0, &bad);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(d0), "symmetric"), "a non-symmetric table: rc %d '%s'",
                rc, sphdem_dem_last_error(d0));
    int flags3[2] = {0, 2 << SPHDEM_DEM_MATERIAL_SHIFT};
    rc = sphdem_dem_compute(d1, 2, tag, x1, v1, w1, r, m, flags3, dt, 1, fb, tb, NULL);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(d1), "grain 2: material 2"), "material index 2 of "
                "2: rc %d '%s'", rc, sphdem_dem_last_error(d1));
    sphdem_dem_destroy(&d0);
    sphdem_dem_destroy(&d1);
    sphdem_dem_params q;
    sphdem_dem_params_default(&q);
    q.kn = 1e5; q.kt = 2e4;
    sphdem_dem dh = make(&q);
    rc = sphdem_dem_set_materials(dh, &mt);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG, "a table of materials with the LAMMPS hooke model: rc %d", rc);
    sphdem_dem_destroy(&dh);
    q.no_tangential_damping = 1;
    expect_arg(q, "no_tangential_damping");
  }
}

/* Rolling friction epsd2 (LIGGGHTS): two grains rolling on each other without slip (no tangential force) get
 * the spring torque k_t R*^2 (w_a - w_b) dt per step, accumulated in the pair's history, until it reaches
 * mu_r R* |F_n|; the engine's list build keeps it only for touching pairs. */
static void test_epsd2(void) {
  const double ra = 0.001, rb = 0.0008, delta = 2e-5, reff = ra * rb / (ra + rb), dt = 1e-6, W = 2.0;
  const double cri = ra - 0.5 * delta, crj = rb - 0.5 * delta;
  int64_t tag[2] = {1, 2};
  double x[6] = {0, 0, 0, ra + rb - delta, 0, 0}, v[6] = {0}, om[6] = {0, 0, W, 0, 0, -W * cri / crj}, r[2] = {ra, rb};
  double m[2] = {1e-5, 6e-6}, f[6], t[6];
  for (int algo = 0; algo < 2; algo++) {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 5e6; p.nu = 0.45; p.en = 0.7; p.mu = 0.5; p.mu_r = 0.05;
    p.rolling_model = SPHDEM_DEM_ROLL_EPSD2; p.keep_history = 1; p.algo = algo; p.skin = 1e-4;
    sphdem_dem d = make(&p);
    const double G = 1. / (2. * (2. - p.nu) * (1. + p.nu) / p.E + 2. * (2. - p.nu) * (1. + p.nu) / p.E);
    const double Y = 1. / ((1. - p.nu * p.nu) / p.E + (1. - p.nu * p.nu) / p.E);
    const double kt = 8. * G * sqrt(reff * delta), fn = 4. / 3. * Y * sqrt(reff * delta) * delta;
    const double step = kt * reff * reff * (om[2] - om[5]) * dt, cap = p.mu_r * reff * fn;
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 0, f, t, NULL); /* setup: no history */
    double t_setup = t[2];
    for (int s = 0; s < 3 && !rc; s++) rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    TEST_ASSERT(rc == 0 && fabs(t_setup / -step - 1) < 1e-12 && fabs(t[2] / (-3 * step) - 1) < 1e-12 && t[5] == -t[2] &&
                fabs(f[1]) < 1e-12 * fn, "epsd2 (algo %d): rolling torque %.15g after 3 steps vs %.15g (setup %.15g vs %.15g), "
                "F_t %.3g", algo, t[2], -3 * step, t_setup, -step, f[1]);
    for (int s = 0; s < 200000 && !rc && fabs(t[2]) < cap * (1 - 1e-9); s++)
      rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    TEST_ASSERT(rc == 0 && fabs(-t[2] / cap - 1) < 1e-12, "epsd2 (algo %d): capped torque %.15g vs mu_r R* F_n %.15g", algo,
                -t[2], cap);
    /* apart for one step (kept), back: the torque continues from the cap; apart at a requested build: zeroed */
    x[3] += 2 * delta;
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    x[3] -= 2 * delta;
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    TEST_ASSERT(rc == 0 && fabs(-t[2] / cap - 1) < 1e-12, "epsd2 (algo %d): torque kept while apart %.15g", algo, -t[2]);
    x[3] += 2 * delta;
    sphdem_dem_request_build(d);
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    x[3] -= 2 * delta;
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    TEST_ASSERT(rc == 0 && fabs(t[2] / -step - 1) < 1e-12, "epsd2 (algo %d): after a build while apart the torque restarts: "
                "%.15g vs %.15g", algo, t[2], -step);
    sphdem_dem_destroy(&d);
  }
  /* epsd: spring k_r = 2.25 k_n mu_r^2 R*^2 and, below the cap, the dashpot rvd 2 sqrt(I_r k_r) w_rel (not kept) */
  {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 5e6; p.nu = 0.45; p.en = 0.7; p.mu = 0.5; p.mu_r = 0.3; p.rvd = 0.2;
    p.rolling_model = SPHDEM_DEM_ROLL_EPSD; p.keep_history = 1; p.skin = 1e-4;
    sphdem_dem d = make(&p);
    const double Y = 1. / ((1. - p.nu * p.nu) / p.E + (1. - p.nu * p.nu) / p.E);
    const double kn = 4. / 3. * Y * sqrt(reff * delta), kr = 2.25 * kn * p.mu_r * p.mu_r * reff * reff;
    const double ir = 1.4 * (m[0] * ra * ra) * (m[1] * rb * rb) / (m[0] * ra * ra + m[1] * rb * rb);
    const double wrel = om[2] - om[5], damp = p.rvd * 2 * sqrt(ir * kr) * wrel;
    int rc = sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    rc |= sphdem_dem_compute(d, 2, tag, x, v, om, r, m, NULL, dt, 1, f, t, NULL);
    const double want = -(2 * kr * wrel * dt + damp);
    TEST_ASSERT(rc == 0 && fabs(t[2] / want - 1) < 1e-12 && t[5] == -t[2] && fabs(kn * delta * reff * p.mu_r) > fabs(want),
                "epsd: torque %.15g after 2 steps vs spring + dashpot %.15g", t[2], want);
    sphdem_dem_destroy(&d);
  }
  sphdem_dem_params q;
  sphdem_dem_params_default(&q);
  q.kn = 1e5; q.kt = 2e4; q.rolling_model = SPHDEM_DEM_ROLL_EPSD2;
  expect_arg(q, "rolling_model");
}

/* Cohesion sjkr, sjkr2 (LIGGGHTS): at rest the normal force is the Hertz force minus k A, with the contact
 * area of each model and the cohesion energy density k of the material pair. */
static void test_cohesion(void) {
  const double E[2] = {5e6, 2e7}, nu[2] = {0.45, 0.3}, en[4] = {0.7, 0.55, 0.55, 0.4}, mu[4] = {0.5, 0.3, 0.3, 0.2};
  const double ced[4] = {3e5, 2e5, 2e5, 1e5};
  const double ra = 0.001, rb = 0.0008, delta = 2e-5, reff = ra * rb / (ra + rb), r = ra + rb - delta;
  int64_t tag[2] = {1, 2};
  double x[6] = {0, 0, 0, r, 0, 0}, v[6] = {0}, om[6] = {0}, rad[2] = {ra, rb}, m[2] = {1e-5, 6e-6}, f[6], t[6];
  for (int model = SPHDEM_DEM_COH_SJKR; model <= SPHDEM_DEM_COH_SJKR2; model++) {
    sphdem_dem_params p;
    sphdem_dem_params_default(&p);
    p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = E[0]; p.nu = nu[0]; p.en = 0.7; p.cohesion = model;
    sphdem_dem d = make(&p);
    sphdem_dem_materials mt = {2, E, nu, en, mu, NULL, ced};
    int flags[2] = {0, 1 << SPHDEM_DEM_MATERIAL_SHIFT};
    int rc = sphdem_dem_set_materials(d, &mt);
    if (!rc) rc = sphdem_dem_compute(d, 2, tag, x, v, om, rad, m, flags, 1e-6, 1, f, t, NULL);
    const double Y = 1. / ((1. - nu[0] * nu[0]) / E[0] + (1. - nu[1] * nu[1]) / E[1]);
    const double A = model == SPHDEM_DEM_COH_SJKR
                         ? M_PI / 4 * (-(r - ra - rb) * (r + ra - rb) * (r - ra + rb) * (r + ra + rb)) / (r * r)
                         : 2 * M_PI * (2 * ra * rb / (ra + rb)) * delta;
    const double fn = 4. / 3. * Y * sqrt(reff * delta) * delta - ced[1] * A;
    TEST_ASSERT(rc == 0 && fabs(-f[0] / fn - 1) < 1e-12 && f[3] == -f[0] && fn < 4. / 3. * Y * sqrt(reff * delta) * delta,
                "cohesion %s: normal force %.15g vs Hertz - k A %.15g", model == 1 ? "sjkr" : "sjkr2", -f[0], fn);
    sphdem_dem_destroy(&d);
  }
  sphdem_dem_params q;
  sphdem_dem_params_default(&q);
  q.kn = 1e5; q.kt = 2e4; q.cohesion = SPHDEM_DEM_COH_SJKR;
  expect_arg(q, "cohesion");
}

/* The granular model (LAMMPS pair_style granular): a two-type table with every sub-model family, pair- vs
 * particle-parallel forces equal, momentum conserved, the table required, bad tables refused, and the rolling /
 * twisting history negated by sphdem_dem_flip_history (the forces of a flipped pair change). */
static void fill_granular(sphdem_dem_granular *t) { dem_granular_test_table(t, SPHDEM_GRAN_DAMP_MASS_VELOCITY); }

static void test_granular(void) {
  double lo[3] = {0, 0, 0}, hi[3] = {1.5, 1.5, 1.5};
  grains g = make_grains(1500, lo, hi, 0.06, 0.5);
  int *fl = malloc(sizeof(int) * g.n);
  for (int i = 0; i < g.n; i++) fl[i] = (i % 2) << SPHDEM_DEM_MATERIAL_SHIFT;
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_GRANULAR;
  p.skin = 0.01;
  p.periodic[0] = p.periodic[1] = p.periodic[2] = 1;
  for (int d = 0; d < 3; d++) { p.boxlo[d] = lo[d]; p.boxhi[d] = hi[d]; }
  sphdem_dem A = make(&p);
  /* no table yet: refused; a table for another model: refused; an asymmetric table: refused */
  int rc = sphdem_dem_compute(A, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 1, g.f, g.t, NULL);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "type-pair table"), "no table: %s",
              sphdem_dem_last_error(A));
  sphdem_dem_granular t[4];
  fill_granular(t);
  t[1].mu = 0.3;
  TEST_ASSERT(sphdem_dem_set_granular(A, 2, t) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "symmetric"),
              "asymmetric table: %s", sphdem_dem_last_error(A));
  fill_granular(t);
  t[0].twisting = 7;
  TEST_ASSERT(sphdem_dem_set_granular(A, 2, t) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "twisting"),
              "bad twisting: %s", sphdem_dem_last_error(A));
  fill_granular(t);
  TEST_ASSERT(sphdem_dem_set_granular(A, 2, t) == SPHDEM_OK, "table: %s", sphdem_dem_last_error(A));
  p.algo = SPHDEM_DEM_PARTICLE_PARALLEL;
  sphdem_dem B = make(&p);
  TEST_ASSERT(sphdem_dem_set_granular(B, 2, t) == SPHDEM_OK, "table: %s", sphdem_dem_last_error(B));
  double *fB = malloc(sizeof(double) * 3 * g.n), *tB = malloc(sizeof(double) * 3 * g.n), worst = 0, mom = 0;
  rc = 0;
  for (int s = 0; s < 20; s++) {
    rc |= sphdem_dem_compute(A, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 1, g.f, g.t, NULL);
    rc |= sphdem_dem_compute(B, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 1, fB, tB, NULL);
    double fs = fmax(maxabs(g.f, 3 * g.n), 1e-300), ts = fmax(maxabs(g.t, 3 * g.n), 1e-300), sum[3] = {0, 0, 0};
    for (int k = 0; k < 3 * g.n; k++) {
      worst = fmax(worst, fmax(fabs(g.f[k] - fB[k]) / fs, fabs(g.t[k] - tB[k]) / ts));
      sum[k % 3] += g.f[k];
    }
    for (int d = 0; d < 3; d++) mom = fmax(mom, fabs(sum[d]) / fs);
    for (int k = 0; k < 3 * g.n; k++) g.x[k] += 1e-5 * g.v[k];
  }
  sphdem_dem_stats st;
  sphdem_dem_stats_get(A, &st);
  printf("  granular: %lld contacts, pair- vs particle-parallel max rel diff %.3g, net force / max force %.3g\n",
         (long long)st.ncontacts, worst, mom);
  TEST_ASSERT(rc == 0 && st.ncontacts > 100 && worst < 1e-10 && mom < 1e-10, "granular: rc %d (%s) diff %.3g mom %.3g",
              rc, sphdem_dem_last_error(A), worst, mom);
  /* flipping the rolling and twisting history of every pair changes the torques, not the forces (evaluated
   * without advancing the history) */
  int64_t np = sphdem_dem_get_history(B, NULL, NULL, 0);
  uint64_t *keys = malloc(sizeof(uint64_t) * (size_t)np);
  double *h = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * (size_t)np);
  TEST_ASSERT(sphdem_dem_get_history(B, keys, h, np) == np, "get_history");
  double *f0 = malloc(sizeof(double) * 3 * g.n), *t0 = malloc(sizeof(double) * 3 * g.n);
  rc = sphdem_dem_compute(B, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 0, f0, t0, NULL);
  rc |= sphdem_dem_flip_history(B, np, keys);
  rc |= sphdem_dem_compute(B, g.n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 0, fB, tB, NULL);
  double df = 0, dt = 0;
  for (int k = 0; k < 3 * g.n; k++) { df = fmax(df, fabs(f0[k] - fB[k])); dt = fmax(dt, fabs(t0[k] - tB[k])); }
  /* (an evaluation that does not advance the history still re-caps sliding contacts: round-off in F) */
  df /= fmax(maxabs(f0, 3 * g.n), 1e-300);
  dt /= fmax(maxabs(t0, 3 * g.n), 1e-300);
  printf("  granular flip: relative force change %.3g, relative torque change %.3g\n", df, dt);
  TEST_ASSERT(rc == 0 && df < 1e-12 && dt > 1e-3, "flip_history: rc %d df %.3g dt %.3g", rc, df, dt);
  free(keys); free(h); free(f0); free(t0);
  sphdem_dem_destroy(&A);
  sphdem_dem_destroy(&B);
  free(fB); free(tB); free(fl);
  free_grains(&g);
}

/* sphdem_dem_set_accumulate: the forces are added to what f and torque hold (an engine's arrays after its force
 * clear, and other styles' forces). Onto zeros the one-thread pass gives the same bits as overwriting; onto other
 * values the sum differs from values + overwritten forces only by rounding. Both passes (one thread under 2048
 * grains, the threaded particle-parallel pass above) and the pair-parallel algorithm. */
static void test_accumulate(void) {
  const int sizes[2] = {400, 6000};
  for (int si = 0; si < 2; si++)
    for (int algo = 0; algo < 2; algo++) {
      const int n = sizes[si];
      double lo[3], hi[3];
      grains g = packing(n, 0.2, 0.5, lo, hi);
      sphdem_dem_params p =
          hertz_params(0.02, algo ? SPHDEM_DEM_PAIR_PARALLEL : SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
      sphdem_dem A = make(&p), B = make(&p), C = make(&p);
      TEST_ASSERT(sphdem_dem_set_accumulate(B, 1) == SPHDEM_OK && sphdem_dem_set_accumulate(C, 1) == SPHDEM_OK &&
                  sphdem_dem_set_accumulate(NULL, 1) == SPHDEM_ERR_ARG, "set_accumulate");
      double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
      double *fC = malloc(sizeof(double) * 3 * n), *tC = malloc(sizeof(double) * 3 * n);
      double *c = malloc(sizeof(double) * 3 * n);
      double worst = 0.0, zero_same = 1.0;
      int rc = 0;
      for (int s = 0; s < 4; s++) {
        for (int k = 0; k < 3 * n; k++) {
          c[k] = 10.0 * (urand() - 0.5);
          fB[k] = tB[k] = 0.0;
          fC[k] = c[k];
          tC[k] = -c[k];
        }
        rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
        rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, fB, tB, NULL);
        rc |= sphdem_dem_compute(C, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, fC, tC, NULL);
        const double fs = fmax(maxabs(g.f, 3 * n), 1e-300), ts = fmax(maxabs(g.t, 3 * n), 1e-300);
        for (int k = 0; k < 3 * n; k++) {
          if (si == 0 && algo == 0 && (fB[k] != g.f[k] || tB[k] != g.t[k])) zero_same = 0.0;
          worst = fmax(worst, fabs(fC[k] - c[k] - g.f[k]) / (fs + fabs(c[k])));
          worst = fmax(worst, fabs(tC[k] + c[k] - g.t[k]) / (ts + fabs(c[k])));
        }
        for (int k = 0; k < 3 * n; k++) g.x[k] += 1e-5 * g.v[k];
      }
      sphdem_dem_stats st;
      sphdem_dem_stats_get(A, &st);
      printf("  accumulate, %d grains, %s: %lld contacts; added onto values: max rel diff %.3g%s\n", n,
             algo ? "pair-parallel" : "particle-parallel", (long long)st.ncontacts, worst,
             si == 0 && algo == 0 ? (zero_same == 1.0 ? "; onto zeros: the same bits" : "; onto zeros: DIFFERENT") : "");
      TEST_ASSERT(rc == 0 && st.ncontacts > 100, "accumulate: %s (%lld contacts)", sphdem_dem_last_error(A),
                  (long long)st.ncontacts);
      TEST_ASSERT(worst < 1e-12, "accumulate: forces added onto values differ by %.3g", worst);
      TEST_ASSERT(zero_same == 1.0, "accumulate onto zeros differs from overwriting");
      sphdem_dem_destroy(&A); sphdem_dem_destroy(&B); sphdem_dem_destroy(&C);
      free(fB); free(tB); free(fC); free(tC); free(c);
      free_grains(&g);
    }
}

/* Copies of another rank's grain (SPHDEM_DEM_GHOST, one tag) share one run of pairs; the run's force goes to the
 * copy of its first pair. Here the first pair (copy 1 with grain X) does not touch and the second (copy 2 with
 * grain Y) does: the force on Y must be the one a single copy gives, in both passes. */
static void test_ghost_copies(void) {
  for (int algo = 0; algo < 2; algo++) {
    const double blo[3] = {-1, -1, -1}, bhi[3] = {2, 2, 2};
    sphdem_dem_params p =
        hertz_params(0.05, algo ? SPHDEM_DEM_PAIR_PARALLEL : SPHDEM_DEM_PARTICLE_PARALLEL, blo, bhi, 0);
    /* X (tag 5), Y (tag 6), copy 1 of tag 1 within the skin of X, copy 2 of tag 1 overlapping Y by 0.01 */
    const int64_t tag[4] = {5, 6, 1, 1};
    const double x[12] = {0, 0, 0, 1, 0, 0, 0, 0.22, 0, 1, 0.19, 0};
    const double v[12] = {0, 0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.05, 0, 0}, om[12] = {0};
    const double r[4] = {0.1, 0.1, 0.1, 0.1}, m[4] = {1, 1, 1, 1};
    const int32_t fl[4] = {0, 0, SPHDEM_DEM_GHOST, SPHDEM_DEM_GHOST};
    double f[12], t[12], f1[9], t1[9];
    sphdem_dem A = make(&p), B = make(&p);
    int rc = 0;
    for (int s = 0; s < 3; s++) {
      rc |= sphdem_dem_compute(A, 4, tag, x, v, om, r, m, fl, 1e-5, 1, f, t, NULL);
      /* the single copy: grains X, Y and copy 2 only */
      const int64_t tag1[3] = {5, 6, 1};
      double x1[9], v1[9];
      const int32_t fl1[3] = {0, 0, SPHDEM_DEM_GHOST};
      for (int k = 0; k < 6; k++) x1[k] = x[k], v1[k] = v[k];
      for (int k = 0; k < 3; k++) x1[6 + k] = x[9 + k], v1[6 + k] = v[9 + k];
      rc |= sphdem_dem_compute(B, 3, tag1, x1, v1, om, r, m, fl1, 1e-5, 1, f1, t1, NULL);
    }
    printf("  ghost copies of one tag, %s: force on Y %.6g %.6g %.6g (one copy: %.6g %.6g %.6g)\n",
           algo ? "pair-parallel" : "particle-parallel", f[3], f[4], f[5], f1[3], f1[4], f1[5]);
    TEST_ASSERT(rc == 0, "ghost copies: %s", sphdem_dem_last_error(A));
    TEST_ASSERT(f[4] < 0.0, "ghost copies: no contact force on Y (%g)", f[4]);
    int same = 1;
    for (int k = 0; k < 6; k++) same &= f[k] == f1[k] && t[k] == t1[k];
    TEST_ASSERT(same, "ghost copies: the forces on X, Y differ from those of one copy");
    sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
  }
}

/* sphdem_dem_set_ghost_once: a pair of this rank's grain and another rank's is evaluated on the rank of its grain of
 * lower tag only, which writes the other grain's share (-F) to that grain's row; without it, on both ranks. */
static void test_ghost_once(void) {
  const double blo[3] = {-1, -1, -1}, bhi[3] = {2, 2, 2};
  sphdem_dem_params p = hertz_params(0.05, -1, blo, bhi, 0);
  const double x[6] = {0, 0, 0, 0.19, 0.01, 0}, v[6] = {0.1, 0, 0, 0, 0, 0}, om[6] = {0};
  const double r[2] = {0.1, 0.1}, m[2] = {1, 1};
  const int32_t fl[2] = {0, SPHDEM_DEM_GHOST}; /* grain 0 this rank's, grain 1 another rank's */
  double fref[6] = {0}, tref[6] = {0};
  int ok = 1, rc = 0;
  for (int once = 0; once < 2; once++)
    for (int low = 1; low >= 0; low--) { /* low: this rank's grain has the lower tag (1 first: the reference) */
      const int64_t tag[2] = {low ? 1 : 2, low ? 2 : 1};
      double f[6], t[6];
      sphdem_dem A = make(&p);
      rc |= sphdem_dem_set_ghost_once(A, once);
      rc |= sphdem_dem_compute(A, 2, tag, x, v, om, r, m, fl, 1e-5, 1, f, t, NULL);
      if (!once && low)
        for (int k = 0; k < 6; k++) fref[k] = f[k], tref[k] = t[k];
      const int kept = !once || low;
      for (int k = 0; k < 3; k++) {
        ok &= f[k] == (kept ? fref[k] : 0.0) && t[k] == (kept ? tref[k] : 0.0);
        if (once) ok &= f[3 + k] == (kept ? -fref[k] : 0.0); /* the other grain's share in its row */
      }
      sphdem_dem_stats st;
      sphdem_dem_stats_get(A, &st);
      printf("  ghost_once %d, this rank's grain has the %s tag: force on it %.6g %.6g %.6g, on the other's row "
             "%.6g %.6g %.6g, %lld contacts\n", once, low ? "lower" : "higher", f[0], f[1], f[2], f[3], f[4], f[5],
             (long long)st.ncontacts);
      sphdem_dem_destroy(&A);
    }
  TEST_ASSERT(rc == 0 && fref[0] < 0.0, "ghost_once: no contact force (rc %d, %g)", rc, fref[0]);
  TEST_ASSERT(ok, "ghost_once: a pair with another rank's grain is not kept by the rule (see the lines above)");
  TEST_ASSERT(sphdem_dem_set_ghost_once(NULL, 1) == SPHDEM_ERR_ARG, "set_ghost_once(NULL)");
}

/* SPHDEM_DEM_SKIP: copies that take no part (periodic images along an axis the ranks do not cut, whose pairs the
 * core finds by the minimum image) change nothing: the grains interleaved with a shifted copy of each, flagged
 * SKIP, get the forces and torques of the grains alone, and the copies none. Both passes (one thread under 2048
 * grains, the threaded particle-parallel pass above), both algorithms, the history advanced over four steps. */
static void test_skipped_copies(void) {
  const int sizes[2] = {400, 6000};
  for (int si = 0; si < 2; si++)
    for (int algo = 0; algo < 2; algo++) {
      const int n = sizes[si];
      double lo[3], hi[3];
      grains g = packing(n, 0.2, 0.5, lo, hi);
      sphdem_dem_params p =
          hertz_params(0.02, algo ? SPHDEM_DEM_PAIR_PARALLEL : SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
      sphdem_dem A = make(&p), B = make(&p);
      const int n2 = 2 * n;
      int64_t *tag2 = malloc(sizeof(int64_t) * n2);
      int32_t *fl2 = malloc(sizeof(int32_t) * n2);
      double *x2 = malloc(sizeof(double) * 3 * n2), *v2 = malloc(sizeof(double) * 3 * n2);
      double *om2 = malloc(sizeof(double) * 3 * n2), *f2 = malloc(sizeof(double) * 3 * n2);
      double *t2 = malloc(sizeof(double) * 3 * n2), *r2 = malloc(sizeof(double) * n2), *m2 = malloc(sizeof(double) * n2);
      double worst = 0.0, skipped = 0.0;
      int rc = 0;
      for (int s = 0; s < 4; s++) {
        /* grain i at 2i, its copy (shifted by L along x, or -L along y for odd i) at 2i + 1 */
        for (int i = 0; i < n; i++)
          for (int c = 0; c < 2; c++) {
            const int k = 2 * i + c;
            tag2[k] = g.tag[i];
            fl2[k] = c ? SPHDEM_DEM_SKIP : 0;
            r2[k] = g.r[i];
            m2[k] = g.m[i];
            for (int d = 0; d < 3; d++) {
              x2[3 * k + d] = g.x[3 * i + d] + (c && d == (i & 1) ? (i & 1 ? -hi[d] : hi[d]) : 0.0);
              v2[3 * k + d] = g.v[3 * i + d];
              om2[3 * k + d] = g.om[3 * i + d];
            }
          }
        rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
        rc |= sphdem_dem_compute(B, n2, tag2, x2, v2, om2, r2, m2, fl2, 1e-5, 1, f2, t2, NULL);
        const double fs = fmax(maxabs(g.f, 3 * n), 1e-300), ts = fmax(maxabs(g.t, 3 * n), 1e-300);
        for (int i = 0; i < n; i++)
          for (int d = 0; d < 3; d++) {
            worst = fmax(worst, fabs(f2[6 * i + d] - g.f[3 * i + d]) / fs);
            worst = fmax(worst, fabs(t2[6 * i + d] - g.t[3 * i + d]) / ts);
            skipped = fmax(skipped, fmax(fabs(f2[6 * i + 3 + d]), fabs(t2[6 * i + 3 + d])));
          }
        for (int k = 0; k < 3 * n; k++) g.x[k] += 1e-5 * g.v[k];
      }
      sphdem_dem_stats sa, sb;
      sphdem_dem_stats_get(A, &sa);
      sphdem_dem_stats_get(B, &sb);
      printf("  skipped copies, %d grains, %s: %lld contacts (alone %lld); max rel diff %.3g, largest value on a copy %.3g\n",
             n, algo ? "pair-parallel" : "particle-parallel", (long long)sb.ncontacts, (long long)sa.ncontacts, worst,
             skipped);
      TEST_ASSERT(rc == 0 && sa.ncontacts > 100, "skip: %s / %s (%lld contacts)", sphdem_dem_last_error(A),
                  sphdem_dem_last_error(B), (long long)sa.ncontacts);
      TEST_ASSERT(sb.ncontacts == sa.ncontacts && sb.npairs == sa.npairs, "skip: %lld contacts, %lld pairs; alone %lld, %lld",
                  (long long)sb.ncontacts, (long long)sb.npairs, (long long)sa.ncontacts, (long long)sa.npairs);
      TEST_ASSERT(worst < 1e-12 && skipped == 0.0, "skip: forces differ by %.3g, a copy got %.3g", worst, skipped);
      sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
      free(tag2); free(fl2); free(x2); free(v2); free(om2); free(f2); free(t2); free(r2); free(m2);
      free_grains(&g);
    }
}

/* The hand-over between ranks: sphdem_dem_get_history_of gives exactly the pairs of the listed tags of the
 * whole history, in its order and with its bits; sphdem_dem_add_history gives a fresh context the history of the
 * pairs it is handed (the first values of a key given twice, nothing for a key the new list does not hold), and a
 * pair the carried history holds already keeps its own values. */
static void test_history_hand_over(void) {
  const int n = 400;
  double lo[3], hi[3];
  grains g = packing(n, 0.3, 0.5, lo, hi);
  sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
  sphdem_dem A = make(&p), B = make(&p);
  int rc = 0;
  for (int s = 0; s < 5; s++) {
    rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
    for (int k = 0; k < 3 * n; k++) g.x[k] += 1e-5 * g.v[k];
  }
  const int H = SPHDEM_DEM_HIST_DOUBLES;
  const int64_t np = sphdem_dem_get_history(A, NULL, NULL, 0);
  uint64_t *ka = malloc(sizeof(uint64_t) * (size_t)(np + 2)), *ko = malloc(sizeof(uint64_t) * (size_t)(np + 2));
  double *ha = malloc(sizeof(double) * H * (size_t)(np + 2)), *ho = malloc(sizeof(double) * H * (size_t)(np + 2));
  double *ro = malloc(sizeof(double) * 3 * (size_t)(np + 2));
  sphdem_dem_get_history(A, ka, ha, np);
  /* the tags of the first 40 grains and of every 7th (make_grains: tag 1000 + 7 i) */
#define LISTED(t) ((t) >= 1000 && (t) < 1000 + 7 * n && (((t) - 1000) / 7 < 40 || (((t) - 1000) / 7) % 7 == 0))
  int64_t tags[200];
  int nt = 0;
  for (int i = 0; i < n; i++)
    if (LISTED(g.tag[i])) tags[nt++] = g.tag[i];
  const int64_t c0 = sphdem_dem_get_history_of(A, nt, tags, NULL, NULL, NULL, 0);
  const int64_t c = sphdem_dem_get_history_of(A, nt, tags, ko, ho, ro, np);
  int64_t want = 0, mism = 0, touching = 0;
  for (int64_t q = 0; q < np; q++) {
    const int64_t ta = (int64_t)(ka[q] >> 32), tb = (int64_t)(uint32_t)ka[q];
    if (!(LISTED(ta) || LISTED(tb))) continue;
    if (want < c && (ko[want] != ka[q] || memcmp(ho + H * want, ha + H * q, sizeof(double) * H))) mism++;
    touching += ha[H * q + 3] != 0.0;
    want++;
  }
  for (int64_t q = 0; q < 3 * c; q++) mism += ro[q] != 0.0; /* (no rolling model: zeros) */
  printf("  history of %d tags: %lld of %lld pairs (%lld with a contact), %lld differ\n", nt, (long long)c,
         (long long)np, (long long)touching, (long long)mism);
  TEST_ASSERT(rc == 0 && c == want && c0 == c && mism == 0 && c > 50 && touching > 20 && c < np,
              "get_history_of: %lld pairs (count %lld), expected %lld, %lld differ", (long long)c, (long long)c0,
              (long long)want, (long long)mism);
  /* B: the pairs of the listed tags handed over before its first build, one key twice (second values other),
   * one key of no pair */
#undef LISTED
  ko[c] = ko[0];
  for (int k = 0; k < H; k++) ho[H * c + k] = ho[k] + 1.0;
  ko[c + 1] = ((uint64_t)1 << 32) | 2u; /* (tags 1 and 2: no grain) */
  for (int k = 0; k < H; k++) ho[H * (c + 1) + k] = 7.0;
  rc |= sphdem_dem_add_history(B, c + 2, ko, ho, NULL);
  rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 0, g.f, g.t, NULL);
  /* D: the same as B, for the reference of the pairs held (below) */
  sphdem_dem D = make(&p);
  rc |= sphdem_dem_add_history(D, c + 2, ko, ho, NULL);
  rc |= sphdem_dem_compute(D, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 0, g.f, g.t, NULL);
  /* C: the same pairs (each once, no unknown key) as the whole history to carry (sphdem_dem_set_history) */
  sphdem_dem C = make(&p);
  rc |= sphdem_dem_set_history(C, c, ko, ho);
  rc |= sphdem_dem_compute(C, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 0, g.f, g.t, NULL);
  uint64_t *kb = malloc(sizeof(uint64_t) * (size_t)(np + 2)), *kc = malloc(sizeof(uint64_t) * (size_t)(np + 2));
  double *hb = malloc(sizeof(double) * H * (size_t)(np + 2)), *hc = malloc(sizeof(double) * H * (size_t)(np + 2));
  const int64_t nb = sphdem_dem_get_history(B, kb, hb, np + 2), nc = sphdem_dem_get_history(C, kc, hc, np + 2);
  int64_t carried = 0; /* pairs of B's list with a tangential history (the handed ones that are in it) */
  for (int64_t q = 0; q < nb; q++) carried += hb[H * q] != 0.0 || hb[H * q + 1] != 0.0 || hb[H * q + 2] != 0.0;
  const int as_set = nb == nc && nb > 0 && !memcmp(kb, kc, sizeof(uint64_t) * (size_t)nb) &&
                     !memcmp(hb, hc, sizeof(double) * H * (size_t)nb);
  /* a pair held already keeps its own values: B handed the pairs again (other values) before a build is the same as
   * D built without (the same bits; against B's history before, a sliding contact's history would differ in its
   * last bits: each evaluation caps it again, as the stock style's set-up does) */
  for (int64_t q = 0; q < c; q++)
    for (int k = 0; k < H; k++) ho[H * q + k] *= 2.0;
  rc |= sphdem_dem_add_history(B, c, ko, ho, NULL);
  rc |= sphdem_dem_request_build(B);
  rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 0, g.f, g.t, NULL);
  rc |= sphdem_dem_request_build(D);
  rc |= sphdem_dem_compute(D, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 0, g.f, g.t, NULL);
  double *hb2 = malloc(sizeof(double) * H * (size_t)(np + 2)), *hd = malloc(sizeof(double) * H * (size_t)(np + 2));
  uint64_t *kb2 = malloc(sizeof(uint64_t) * (size_t)(np + 2)), *kd = malloc(sizeof(uint64_t) * (size_t)(np + 2));
  const int64_t nb2 = sphdem_dem_get_history(B, kb2, hb2, np + 2), nd = sphdem_dem_get_history(D, kd, hd, np + 2);
  const int same = nb2 == nd && nd > 0 && !memcmp(kb2, kd, sizeof(uint64_t) * (size_t)nd) &&
                   !memcmp(hb2, hd, sizeof(double) * H * (size_t)nd);
  printf("  handed over %lld pairs (one twice, one of no grains) before the first build: %lld of %lld pairs carry a "
         "tangential history, the same bits as the history set whole: %s; held pairs kept theirs: %s\n", (long long)c,
         (long long)carried, (long long)nb, as_set ? "yes" : "no", same ? "yes" : "no");
  TEST_ASSERT(rc == 0 && as_set && carried > 100 && same, "add_history: %s; as set_history %d (%lld vs %lld pairs), "
              "%lld carried, held kept %d", sphdem_dem_last_error(B), as_set, (long long)nb, (long long)nc,
              (long long)carried, same);
  TEST_ASSERT(sphdem_dem_add_history(B, 1, NULL, ho, NULL) == SPHDEM_ERR_ARG &&
                  strstr(sphdem_dem_last_error(B), "add_history") != NULL,
              "add_history without keys: '%s'", sphdem_dem_last_error(B));
  free(ka); free(ko); free(ha); free(ho); free(ro); free(kb); free(hb); free(kc); free(hc); free(kb2); free(hb2);
  free(kd); free(hd);
  sphdem_dem_destroy(&A); sphdem_dem_destroy(&B); sphdem_dem_destroy(&C); sphdem_dem_destroy(&D);
  free_grains(&g);
}

/* The one-thread pass (the overlap test without a branch on its outcome, the square roots of a block of touching
 * pairs taken ahead of the law) against the pair-parallel pass (the law takes its own roots, pair by pair): over
 * steps with contacts made and lost, the history of every pair the same bits (it depends on the positions,
 * velocities and the last history only, which both see alike), the forces, torques and virial the same to
 * rounding (the two sum in different orders); with and without the virial, with copies of grains sharing a tag
 * (SPHDEM_DEM_GHOST), for the Hooke law (no Hertz root), and in a box of six walls without periodic axes (the
 * walls' pairs and the pairs of the periodic box's two sides take the general overlap test). */
static void test_serial_pass(void) {
  for (int variant = 0; variant < 5; variant++) {
    const int n = 500;
    double lo[3], hi[3]; /* dense: most listed pairs touch */
    grains g = packing(n, 0.45, 2.0, lo, hi);
    /* (500 grains: the one-thread pass at any thread count) */
    sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, variant != 4);
    if (variant == 3) p.model = SPHDEM_DEM_HOOKE;
    sphdem_dem_params q = p;
    q.algo = SPHDEM_DEM_PAIR_PARALLEL;
    sphdem_dem A = make(&p), B = make(&q);
    if (variant == 4) {
      sphdem_dem_wall w[6];
      for (int k = 0; k < 6; k++) {
        const int d = k / 2, up = k % 2;
        for (int e = 0; e < 3; e++) w[k].point[e] = lo[e], w[k].normal[e] = 0.0;
        w[k].point[d] = up ? hi[d] : lo[d];
        w[k].normal[d] = up ? -1.0 : 1.0;
      }
      TEST_ASSERT(sphdem_dem_set_walls(A, 6, w) == SPHDEM_OK && sphdem_dem_set_walls(B, 6, w) == SPHDEM_OK,
                  "serial pass: walls: %s", sphdem_dem_last_error(A));
    }
    TEST_ASSERT(sphdem_dem_cpu_serial_pass(A) && !sphdem_dem_cpu_serial_pass(B), "serial pass: the passes compared");
    int32_t *fl = NULL;
    if (variant == 2) { /* the last 50 grains: copies of another rank's grains, two per tag */
      fl = calloc((size_t)n, sizeof(int32_t));
      for (int i = n - 50; i < n; i++) fl[i] = SPHDEM_DEM_GHOST, g.tag[i] = g.tag[n - 50 + (i - (n - 50)) / 2];
    }
    double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n), vA[6], vB[6];
    int same = 1, rc = 0;
    double dmax = 0.0, fbig = 0.0, vdmax = 0.0, vmax = 0.0;
    int64_t contacts_first = -1, contacts_last = -1;
    for (int s = 0; s < 30; s++) {
      const int vir = variant == 1 || variant == 2;
      rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-4, 1, g.f, g.t, vir ? vA : NULL);
      rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-4, 1, fB, tB, vir ? vB : NULL);
      for (int k = 0; k < 3 * n; k++) {
        if (fl && fl[k / 3]) continue; /* (the force on a copy is dropped) */
        dmax = fmax(dmax, fmax(fabs(g.f[k] - fB[k]), fabs(g.t[k] - tB[k])));
        fbig = fmax(fbig, fmax(fabs(fB[k]), fabs(tB[k])));
      }
      for (int k = 0; vir && k < 6; k++) vdmax = fmax(vdmax, fabs(vA[k] - vB[k])), vmax = fmax(vmax, fabs(vB[k]));
      sphdem_dem_stats st;
      sphdem_dem_stats_get(A, &st);
      if (s == 0) contacts_first = st.ncontacts;
      contacts_last = st.ncontacts;
      int64_t np = sphdem_dem_get_history(A, NULL, NULL, 0), nq = sphdem_dem_get_history(B, NULL, NULL, 0);
      uint64_t *ka = malloc(sizeof(uint64_t) * (size_t)(np + 1)), *kb = malloc(sizeof(uint64_t) * (size_t)(nq + 1));
      double *ha = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * (size_t)(np + 1));
      double *hb = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * (size_t)(nq + 1));
      same &= np == nq && sphdem_dem_get_history(A, ka, ha, np) == np && sphdem_dem_get_history(B, kb, hb, nq) == nq;
      for (int64_t k = 0; same && k < np; k++) {
        same &= ka[k] == kb[k];
        for (int c = 0; c < SPHDEM_DEM_HIST_DOUBLES; c++)
          same &= ha[SPHDEM_DEM_HIST_DOUBLES * k + c] == hb[SPHDEM_DEM_HIST_DOUBLES * k + c];
      }
      free(ka); free(kb); free(ha); free(hb);
      for (int k = 0; k < 3 * n; k++) g.x[k] += 1e-4 * g.v[k];
    }
    const double rel = dmax / fbig, vrel = vmax > 0.0 ? vdmax / vmax : 0.0;
    printf("  one-thread pass vs pair-parallel pass, %s: %lld then %lld contacts; history %s; forces and torques "
           "%.2e of the largest, virial %.2e\n",
           variant == 0 ? "hertz" : variant == 1 ? "hertz, virial" : variant == 2 ? "hertz, virial, copies sharing a tag"
                                    : variant == 3 ? "hooke" : "hertz, six walls",
           (long long)contacts_first, (long long)contacts_last, same ? "the same bits" : "DIFFERENT", rel, vrel);
    TEST_ASSERT(rc == 0 && contacts_first > 500 && contacts_last != contacts_first,
                "serial pass: rc %d (%s), %lld, %lld contacts", rc, sphdem_dem_last_error(A),
                (long long)contacts_first, (long long)contacts_last);
    TEST_ASSERT(same, "serial pass: the history differs from the pair-parallel pass");
    TEST_ASSERT(rel < 1e-13 && vrel < 1e-13, "serial pass: forces %.3e, virial %.3e of the largest apart", rel, vrel);
    sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
    free(fB); free(tB); free(fl);
    free_grains(&g);
  }
}

/* The pairs the one-thread pass visits between list builds: a pair that touched at the last step is visited (and
 * its history cleared) even where the moves of its grains since the build no longer reach its gap. Grains a and b
 * half a skin apart at the build come together (touching, a tangential history made), go back to where they were
 * built, and come together again; a second pair stays apart throughout (the visited set is one pair of two). The
 * history after each step is the same bits as the pair-parallel pass's, which looks at every pair. */
static void test_visited_set(void) {
  const int n = 4;
  const double lo[3] = {0, 0, 0}, hi[3] = {2, 2, 2}, skin = 0.02;
  grains g = make_grains(n, lo, hi, 0.1, 0.0);
  const double x0[4][3] = {{0.8, 1, 1}, {1.01, 1, 1}, {0.5, 0.5, 0.5}, {0.715, 0.5, 0.5}}; /* gaps 0.5 and 0.75 skin */
  for (int i = 0; i < n; i++) {
    g.r[i] = 0.1;
    g.m[i] = 2500 * 4.0 / 3.0 * M_PI * 1e-3;
    for (int d = 0; d < 3; d++) g.x[3 * i + d] = x0[i][d], g.v[3 * i + d] = g.om[3 * i + d] = 0.0;
  }
  g.v[1] = 0.5; /* a slides past b (y) while they touch */
  sphdem_dem_params p = hertz_params(skin, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 0), q = p;
  q.algo = SPHDEM_DEM_PAIR_PARALLEL;
  sphdem_dem A = make(&p), B = make(&q);
  TEST_ASSERT(sphdem_dem_cpu_serial_pass(A) && !sphdem_dem_cpu_serial_pass(B), "visited set: the passes compared");
  double fB[12], tB[12];
  int rc = 0, same = 1, touched = 0;
  for (int s = 0; s < 6; s++) {
    const double in = (s == 2 || s == 4) ? 0.3 * skin : 0.0; /* each of a and b moves 0.3 skin toward the other */
    g.x[0] = x0[0][0] + in;
    g.x[3] = x0[1][0] - in;
    rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-4, 1, g.f, g.t, NULL);
    rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-4, 1, fB, tB, NULL);
    sphdem_dem_stats st;
    sphdem_dem_stats_get(A, &st);
    touched += st.ncontacts == 1;
    uint64_t ka[4], kb[4];
    double ha[4 * SPHDEM_DEM_HIST_DOUBLES], hb[4 * SPHDEM_DEM_HIST_DOUBLES];
    const int64_t np = sphdem_dem_get_history(A, ka, ha, 4), nq = sphdem_dem_get_history(B, kb, hb, 4);
    same &= np == 2 && nq == 2 && st.nbuilds == 1;
    for (int64_t k = 0; same && k < np; k++) {
      same &= ka[k] == kb[k];
      for (int c = 0; c < SPHDEM_DEM_HIST_DOUBLES; c++)
        same &= ha[SPHDEM_DEM_HIST_DOUBLES * k + c] == hb[SPHDEM_DEM_HIST_DOUBLES * k + c];
    }
    for (int k = 0; k < 3 * n; k++) same &= fabs(g.f[k] - fB[k]) <= 1e-12 * (1.0 + fabs(fB[k]));
  }
  printf("  visited set: a pair that separates with its grains back where they were built: history %s as the "
         "pair-parallel pass's over 6 steps (%d with the contact)\n", same ? "the same bits" : "DIFFERENT", touched);
  TEST_ASSERT(rc == 0 && touched == 2, "visited set: rc %d (%s), %d steps with the contact", rc,
              sphdem_dem_last_error(A), touched);
  TEST_ASSERT(same, "visited set: history or forces differ from the pair-parallel pass (or the list was rebuilt)");
  sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
  free_grains(&g);
}

/* sphdem_dem_same_tags: the caller's word that a call gets the last call's grains spares the tag comparison and
 * changes nothing (the same bits as a context that compares); it holds for one call only, so grains reordered at
 * the next call are still found (a new build, and the forces of the new order). */
static void test_same_tags(void) {
  const int n = 400;
  double lo[3], hi[3];
  grains g = packing(n, 0.3, 0.5, lo, hi);
  sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
  sphdem_dem A = make(&p), B = make(&p);
  double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
  int rc = 0, differ = 0;
  TEST_ASSERT(sphdem_dem_same_tags(NULL) == SPHDEM_ERR_ARG, "same_tags(NULL) must fail");
  sphdem_dem_stats s0, s1;
  for (int s = 0; s < 6; s++) {
    if (s == 5) { /* reordered: the first and last grains change places (B is not told: it must find out) */
      sphdem_dem_stats_get(B, &s0);
      const int j = n - 1;
      int64_t tt = g.tag[0]; g.tag[0] = g.tag[j]; g.tag[j] = tt;
      double r = g.r[0]; g.r[0] = g.r[j]; g.r[j] = r;
      r = g.m[0]; g.m[0] = g.m[j]; g.m[j] = r;
      for (int d = 0; d < 3; d++) {
        r = g.x[d]; g.x[d] = g.x[3 * j + d]; g.x[3 * j + d] = r;
        r = g.v[d]; g.v[d] = g.v[3 * j + d]; g.v[3 * j + d] = r;
        r = g.om[d]; g.om[d] = g.om[3 * j + d]; g.om[3 * j + d] = r;
      }
    }
    rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
    if (s > 0 && s < 5) rc |= sphdem_dem_same_tags(B);
    rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, fB, tB, NULL);
    differ += memcmp(fB, g.f, sizeof(double) * 3 * n) != 0 || memcmp(tB, g.t, sizeof(double) * 3 * n) != 0;
    for (int k = 0; k < 3 * n; k++) g.x[k] += 1e-5 * g.v[k];
  }
  sphdem_dem_stats_get(B, &s1);
  printf("  same_tags: %lld contacts, forces of 6 calls differ in %d; the reordered call built %lld list(s)\n",
         (long long)s1.ncontacts, differ, (long long)(s1.nbuilds - s0.nbuilds));
  TEST_ASSERT(rc == 0 && s1.ncontacts > 50, "same_tags: %s", sphdem_dem_last_error(B));
  TEST_ASSERT(differ == 0, "same_tags: the forces differ from a context that compares the tags (%d calls)", differ);
  TEST_ASSERT(s1.nbuilds == s0.nbuilds + 1, "same_tags: the reordered grains built %lld lists, expected 1",
              (long long)(s1.nbuilds - s0.nbuilds));
  sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
  free(fB); free(tB);
  free_grains(&g);
}

/* A box that changes between calls (an engine's fix deform): new box bounds alone keep the pair list, and the change
 * of the periodic lengths counts with the grains' moves, so that periodic images brought together by a shrinking
 * box are still found. Against a context that builds its list at every call, with the grains fixed in space and the
 * box shrinking (no remap: only the images move) and with the grains remapped with the box: the same forces, with
 * fewer builds. */
static void test_changing_box(void) {
  const int n = 400;
  for (int remap = 0; remap < 2; remap++) {
    double lo[3], hi[3];
    grains g = packing(n, 0.3, 0.0, lo, hi);
    for (int k = 0; k < 3 * n; k++) g.om[k] = 0.0;
    sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
    sphdem_dem A = make(&p), B = make(&p);
    double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
    int rc = 0, differ = 0;
    const int steps = 40;
    int64_t c0 = 0, c1 = 0;
    for (int s = 0; s < steps; s++) {
      const double f = 1.0 - 0.001; /* the box shrinks by 0.1 % a step along x and y (4 % in all) */
      for (int d = 0; d < 2; d++) {
        const double h = p.boxhi[d];
        p.boxhi[d] = h * f;
        if (remap)
          for (int i = 0; i < n; i++) g.x[3 * i + d] *= f;
      }
      rc |= sphdem_dem_set_params(A, &p) | sphdem_dem_set_params(B, &p) | sphdem_dem_request_build(B);
      rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, g.f, g.t, NULL);
      rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, NULL, 1e-5, 1, fB, tB, NULL);
      differ += memcmp(fB, g.f, sizeof(double) * 3 * n) != 0 || memcmp(tB, g.t, sizeof(double) * 3 * n) != 0;
      sphdem_dem_stats st;
      sphdem_dem_stats_get(A, &st);
      if (s == 0) c0 = st.ncontacts;
      c1 = st.ncontacts;
    }
    sphdem_dem_stats sa, sb;
    sphdem_dem_stats_get(A, &sa);
    sphdem_dem_stats_get(B, &sb);
    printf("  box shrinking 4 %% over %d calls, %s: contacts %lld -> %lld; forces differ from a build at every call "
           "in %d calls; builds %lld (every call: %lld)\n", steps, remap ? "grains remapped" : "grains fixed",
           (long long)c0, (long long)c1, differ, (long long)sa.nbuilds, (long long)sb.nbuilds);
    TEST_ASSERT(rc == 0 && c1 > c0, "changing box: %s (contacts %lld -> %lld)", sphdem_dem_last_error(A),
                (long long)c0, (long long)c1);
    TEST_ASSERT(differ == 0, "changing box: the forces differ from a list built at every call (%d calls)", differ);
    TEST_ASSERT(sa.nbuilds > 1 && sa.nbuilds < steps / 4, "changing box: %lld builds in %d calls",
                (long long)sa.nbuilds, steps);
    sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
    free(fB); free(tB);
    free_grains(&g);
  }
}

/* sphdem_dem_set_exclusions: grains of three classes (0, 1, 2) with pairs 1-1 and 1-2 excluded: the pair list
 * is that of no exclusions less exactly those pairs; removing the exclusions gives the whole list again; bad
 * tables are refused naming the fault. */
/* sphdem_dem_contacts: each touching pair evaluated again after a step, with the history that step left and the
 * same grains, adds up to the step's force and torque on every grain (the step advanced the history and the
 * evaluation for output reads it without advancing it, as the stock styles' compute pair/gran/local). That holds
 * for the LAMMPS laws (a sliding contact's history is set so that it gives the Coulomb force again) and for the
 * LIGGGHTS laws while no contact slides (LIGGGHTS adds the tangential damping to a force that the kept history
 * puts just below the limit, and epsd2 adds the rolling step to the kept torque without keeping it: for those
 * only the forces are compared, with mu 10), and for the granular model (the two-type table of the twin tests:
 * hertz/material, hertz, dmt; tsuji, viscoelastic, mass_velocity; linear_history, mindlin; sds rolling; marshall
 * and sds twisting). Nothing of the context changes (the next step gives the same
 * forces as a twin that never gave its contacts); a changed number of grains is refused. */
static void test_contacts(void) {
  const int n = 600;
  double lo[3], hi[3];
  for (int c = 0; c < 5; c++) {
    grains g = packing(n, 0.5, 0.5, lo, hi);
    int *fl = NULL;
    sphdem_dem_params p = hertz_params(0.02, c == 1 ? SPHDEM_DEM_PAIR_PARALLEL : SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
    const char *what = c == 0 ? "hertz, one thread" : c == 1 ? "hertz, pair-parallel" : c == 2 ? "liggghts hertz"
                       : c == 3 ? "liggghts hertz, epsd2" : "granular, the two-type table";
    if (c >= 2) {
      p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 5e6; p.nu = 0.45; p.en = 0.7; p.mu = 10.0;
      if (c == 3) p.mu_r = 0.05, p.rolling_model = SPHDEM_DEM_ROLL_EPSD2;
    }
    if (c == 4) {
      p.model = SPHDEM_DEM_GRANULAR;
      fl = malloc(sizeof(int) * n);
      for (int i = 0; i < n; i++) fl[i] = (i % 2) << SPHDEM_DEM_MATERIAL_SHIFT;
    }
    sphdem_dem A = make(&p), B = make(&p);
    if (c == 4) {
      sphdem_dem_granular tt[4];
      fill_granular(tt);
      sphdem_dem_set_granular(A, 2, tt);
      sphdem_dem_set_granular(B, 2, tt);
    }
    char msg[256];
    sphdem_grain_store st = NULL;
    int rc = sphdem_grains_create(&st, test_device(), msg, sizeof msg);
    int64_t stamp[SPHDEM_GRAINS_STAMP] = {1, 0, 0, 0, 0, 0};
    double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
    const double dt = 2e-5;
    for (int s = 0; s < 6 && !rc; s++) { /* a few steps of history (the grains do not move: shear grows each step) */
      stamp[0] = s;
      rc |= sphdem_grains_put(st, stamp, n, 0, g.x, g.v, g.om, g.r, g.m);
      rc |= sphdem_dem_compute_store(A, st, g.tag, fl, dt, s > 0, g.f, g.t, NULL);
      rc |= sphdem_dem_compute_store(B, st, g.tag, fl, dt, s > 0, fB, tB, NULL);
    }
    const int64_t cap = 40 * (int64_t)n;
    int32_t *ab = malloc(sizeof(int32_t) * 2 * cap);
    double *ft = malloc(sizeof(double) * SPHDEM_DEM_CONTACT_DOUBLES * cap), *hist = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * cap);
    double *roll = malloc(sizeof(double) * 3 * cap);
    const int64_t np = sphdem_dem_get_history(A, NULL, NULL, 0);
    uint64_t *k0 = malloc(sizeof(uint64_t) * np), *k1 = malloc(sizeof(uint64_t) * np);
    double *h0 = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np), *h1 = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np);
    sphdem_dem_get_history(A, k0, h0, np);
    const int64_t nc = rc ? -1 : sphdem_dem_contacts(A, st, cap, ab, ft, hist, roll);
    TEST_ASSERT(nc > n, "contacts (%s): %lld touching pairs (rc %d: %s)", what, (long long)nc, rc, sphdem_dem_last_error(A));
    double *fs = calloc(3 * (size_t)n, sizeof(double)), *ts = calloc(3 * (size_t)n, sizeof(double));
    int64_t slid = 0, rolled = 0;
    double dsep = 0; /* the separation given against the minimum image of x_a - x_b */
    for (int64_t k = 0; k < nc && k < cap; k++) {
      const int a = ab[2 * k], b = ab[2 * k + 1];
      const double *c4 = ft + SPHDEM_DEM_CONTACT_DOUBLES * k;
      for (int d = 0; d < 3; d++) {
        fs[3 * a + d] += c4[d], fs[3 * b + d] -= c4[d];
        ts[3 * a + d] += c4[3 + d], ts[3 * b + d] += c4[6 + d];
        const double L = hi[d] - lo[d], s0 = g.x[3 * a + d] - g.x[3 * b + d];
        dsep = fmax(dsep, fabs(c4[9 + d] - (s0 - L * rint(s0 / L))) / L);
      }
      const double *h = hist + SPHDEM_DEM_HIST_DOUBLES * k;
      slid += h[0] != 0.0 || h[1] != 0.0 || h[2] != 0.0;
      rolled += roll[3 * k] != 0.0 || roll[3 * k + 1] != 0.0 || roll[3 * k + 2] != 0.0;
    }
    double fmax = 0, tmax = 0, df = 0, dtq = 0;
    for (int i = 0; i < 3 * n; i++) {
      fmax = fmax > fabs(g.f[i]) ? fmax : fabs(g.f[i]);
      tmax = tmax > fabs(g.t[i]) ? tmax : fabs(g.t[i]);
      df = df > fabs(fs[i] - g.f[i]) ? df : fabs(fs[i] - g.f[i]);
      dtq = dtq > fabs(ts[i] - g.t[i]) ? dtq : fabs(ts[i] - g.t[i]);
    }
    printf("  contacts (%s): %lld touching pairs (%lld with shear, %lld with rolling torque), summed per grain vs the "
           "step: force %.2e, torque %.2e of the largest\n", what, (long long)nc, (long long)slid, (long long)rolled,
           df / fmax, dtq / tmax);
    TEST_ASSERT(dsep < 1e-15, "contacts (%s): separation %.3g of the box off the minimum image", what, dsep);
    TEST_ASSERT(slid > nc / 2 && (c != 3 || rolled > nc / 2), "contacts (%s): the history is not there (%lld, %lld)",
                what, (long long)slid, (long long)rolled);
    TEST_ASSERT(df <= 1e-12 * fmax && (c == 3 || dtq <= 1e-12 * tmax), "contacts (%s): force %.3g, torque %.3g off the "
                "step's", what, df / fmax, dtq / tmax);
    sphdem_dem_get_history(A, k1, h1, np);
    TEST_ASSERT(!memcmp(k0, k1, sizeof(uint64_t) * np) && !memcmp(h0, h1, sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np),
                "contacts (%s): the history changed", what);
    /* the next step: the same bits as the twin B */
    stamp[0] = 99;
    rc = sphdem_grains_put(st, stamp, n, 0, g.x, g.v, g.om, g.r, g.m);
    rc |= sphdem_dem_compute_store(A, st, g.tag, fl, dt, 1, g.f, g.t, NULL);
    rc |= sphdem_dem_compute_store(B, st, g.tag, fl, dt, 1, fB, tB, NULL);
    double dn = 0; /* (the pair-parallel pass adds atomically: its sums may differ in the last bits) */
    for (int i = 0; i < 3 * n; i++) {
      dn = dn > fabs(g.f[i] - fB[i]) / fmax ? dn : fabs(g.f[i] - fB[i]) / fmax;
      dn = dn > fabs(g.t[i] - tB[i]) / tmax ? dn : fabs(g.t[i] - tB[i]) / tmax;
    }
    TEST_ASSERT(rc == 0 && (c == 1 ? dn < 1e-13 : dn == 0.0), "contacts (%s): the next step differs from the twin's by "
                "%.3g", what, dn);
    /* fewer pairs than room: the count, nothing written past max; other grains: refused */
    TEST_ASSERT(sphdem_dem_contacts(A, st, 3, ab, ft, NULL, NULL) == nc, "contacts (%s): count with max 3", what);
    rc = sphdem_grains_put(st, stamp, n - 1, 0, g.x, g.v, g.om, g.r, g.m);
    const int64_t bad = sphdem_dem_contacts(A, st, cap, ab, ft, NULL, NULL);
    TEST_ASSERT(rc == 0 && bad == -SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "599 grains given"),
                "contacts (%s): other grains: %lld '%s'", what, (long long)bad, sphdem_dem_last_error(A));
    free(fs); free(ts); free(ab); free(ft); free(hist); free(roll); free(k0); free(k1); free(h0); free(h1);
    free(fB); free(tB); free(fl);
    sphdem_grains_destroy(&st);
    sphdem_dem_destroy(&A);
    sphdem_dem_destroy(&B);
    free_grains(&g);
  }
}

/* sphdem_dem_step_contacts: the contacts of a step exactly as it evaluated them, also for the laws whose evaluation
 * with the kept history does not give the step's force again: LIGGGHTS hertz with mu 0.3 (many contacts slide: the
 * tangential damping), with epsd2 rolling, and LAMMPS hertz. The recorded forces and torques, summed per grain,
 * equal the step's within 1e-12 of the largest; the history is unchanged; without sphdem_dem_keep_step_history
 * before the last evaluation it is refused. */
static void test_step_contacts(void) {
  const int n = 600;
  double lo[3], hi[3];
  for (int c = 0; c < 3; c++) {
    grains g = packing(n, 0.5, 0.5, lo, hi);
    sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
    const char *what = c == 0 ? "liggghts hertz, mu 0.3" : c == 1 ? "liggghts hertz, mu 0.3, epsd2" : "lammps hertz";
    if (c < 2) {
      p.model = SPHDEM_DEM_HERTZ_LIGGGHTS; p.E = 5e6; p.nu = 0.45; p.en = 0.7; p.mu = 0.3;
      if (c == 1) p.mu_r = 0.05, p.rolling_model = SPHDEM_DEM_ROLL_EPSD2;
    }
    sphdem_dem A = make(&p);
    char msg[256];
    sphdem_grain_store st = NULL;
    int rc = sphdem_grains_create(&st, test_device(), msg, sizeof msg);
    int64_t stamp[SPHDEM_GRAINS_STAMP] = {1, 0, 0, 0, 0, 0};
    const double dt = 2e-5;
    for (int s = 0; s < 8 && !rc; s++) { /* the grains do not move: the shear grows each step until they slide */
      stamp[0] = s;
      rc |= sphdem_grains_put(st, stamp, n, 0, g.x, g.v, g.om, g.r, g.m);
      if (s == 7) rc |= sphdem_dem_keep_step_history(A);
      rc |= sphdem_dem_compute_store(A, st, g.tag, NULL, dt, s > 0, g.f, g.t, NULL);
    }
    const int64_t cap = 40 * (int64_t)n, np = sphdem_dem_get_history(A, NULL, NULL, 0);
    int32_t *ab = malloc(sizeof(int32_t) * 2 * cap);
    double *ft = malloc(sizeof(double) * SPHDEM_DEM_CONTACT_DOUBLES * cap);
    uint64_t *k0 = malloc(sizeof(uint64_t) * np), *k1 = malloc(sizeof(uint64_t) * np);
    double *h0 = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np), *h1 = malloc(sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np);
    sphdem_dem_get_history(A, k0, h0, np);
    const int64_t nc = rc ? -1 : sphdem_dem_step_contacts(A, st, cap, ab, ft);
    TEST_ASSERT(nc > n && nc <= cap, "step contacts (%s): %lld touching pairs (rc %d: %s)", what, (long long)nc, rc,
                sphdem_dem_last_error(A));
    double *fs = calloc(3 * (size_t)n, sizeof(double)), *ts = calloc(3 * (size_t)n, sizeof(double));
    for (int64_t k = 0; k < nc && k < cap; k++) {
      const int a = ab[2 * k], b = ab[2 * k + 1];
      const double *c4 = ft + SPHDEM_DEM_CONTACT_DOUBLES * k;
      for (int d = 0; d < 3; d++) fs[3 * a + d] += c4[d], fs[3 * b + d] -= c4[d], ts[3 * a + d] += c4[3 + d], ts[3 * b + d] += c4[6 + d];
    }
    /* the contacts of the kept history evaluated again without advancing it (sphdem_dem_contacts): not the step's
     * force where contacts slide (LIGGGHTS) */
    double *ft2 = malloc(sizeof(double) * SPHDEM_DEM_CONTACT_DOUBLES * cap), *fs2 = calloc(3 * (size_t)n, sizeof(double));
    const int64_t nc2 = sphdem_dem_contacts(A, st, cap, ab, ft2, NULL, NULL);
    for (int64_t k = 0; k < nc2 && k < cap; k++)
      for (int d = 0; d < 3; d++) fs2[3 * ab[2 * k] + d] += ft2[SPHDEM_DEM_CONTACT_DOUBLES * k + d], fs2[3 * ab[2 * k + 1] + d] -= ft2[SPHDEM_DEM_CONTACT_DOUBLES * k + d];
    double fbig = 0, tmax = 0, df = 0, dtq = 0, df2 = 0;
    for (int i = 0; i < 3 * n; i++) {
      fbig = fmax(fbig, fabs(g.f[i]));
      tmax = fmax(tmax, fabs(g.t[i]));
      df = fmax(df, fabs(fs[i] - g.f[i]));
      dtq = fmax(dtq, fabs(ts[i] - g.t[i]));
      df2 = fmax(df2, fabs(fs2[i] - g.f[i]));
    }
    printf("  step contacts (%s): %lld touching pairs; summed per grain vs the step: force %.2e, torque %.2e of the "
           "largest (the kept history evaluated again: force %.2e)\n", what, (long long)nc, df / fbig, dtq / tmax,
           df2 / fbig);
    TEST_ASSERT(df <= 1e-12 * fbig && dtq <= 1e-12 * tmax && !(df != df) && !(dtq != dtq),
                "step contacts (%s): force %.3g, torque %.3g off the step's", what, df / fbig, dtq / tmax);
    TEST_ASSERT(c == 2 || df2 > 1e-6 * fbig, "step contacts (%s): the scene does not slide (%.3g)", what, df2 / fbig);
    sphdem_dem_get_history(A, k1, h1, np);
    TEST_ASSERT(!memcmp(k0, k1, sizeof(uint64_t) * np) && !memcmp(h0, h1, sizeof(double) * SPHDEM_DEM_HIST_DOUBLES * np),
                "step contacts (%s): the history changed", what);
    /* an evaluation without the request: refused */
    stamp[0] = 99;
    rc = sphdem_grains_put(st, stamp, n, 0, g.x, g.v, g.om, g.r, g.m);
    rc |= sphdem_dem_compute_store(A, st, g.tag, NULL, dt, 1, g.f, g.t, NULL);
    const int64_t bad = sphdem_dem_step_contacts(A, st, cap, ab, ft);
    TEST_ASSERT(rc == 0 && bad == -SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "kept no history"),
                "step contacts (%s): without the request: %lld '%s'", what, (long long)bad, sphdem_dem_last_error(A));
    free(ab); free(ft); free(ft2); free(fs); free(ts); free(fs2); free(k0); free(k1); free(h0); free(h1);
    sphdem_grains_destroy(&st);
    sphdem_dem_destroy(&A);
    free_grains(&g);
  }
}

static void test_exclusions(void) {
  const int n = 500;
  double lo[3], hi[3];
  grains g = packing(n, 0.3, 0.5, lo, hi);
  int *fl = malloc(sizeof(int) * n);
  for (int i = 0; i < n; i++) fl[i] = (i % 3) << SPHDEM_DEM_CLASS_SHIFT;
  sphdem_dem_params p = hertz_params(0.02, SPHDEM_DEM_PARTICLE_PARALLEL, lo, hi, 1);
  sphdem_dem A = make(&p), B = make(&p);
  const uint16_t rows[3] = {0, (1u << 1) | (1u << 2), 1u << 1};
  int rc = sphdem_dem_set_exclusions(B, 3, rows);
  rc |= sphdem_dem_compute(A, n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 1, g.f, g.t, NULL);
  double *fB = malloc(sizeof(double) * 3 * n), *tB = malloc(sizeof(double) * 3 * n);
  rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 1, fB, tB, NULL);
  const int64_t cap = 40 * n;
  int64_t *pa = malloc(sizeof(int64_t) * 2 * cap), *pb = malloc(sizeof(int64_t) * 2 * cap);
  const int64_t na = sphdem_dem_debug_pairs(A, pa, cap), nb = sphdem_dem_debug_pairs(B, pb, cap);
  int64_t want = 0, bad = 0, dropped = 0;
  for (int64_t k = 0; k < na; k++) {
    const int64_t a = pa[2 * k], b = pa[2 * k + 1];
    const int ca = (int)(a % 3), cb = b >= 0 ? (int)(b % 3) : -1;
    const int excl = b >= 0 && ((rows[ca] >> cb) & 1);
    dropped += excl;
    want += !excl;
  }
  for (int64_t k = 0; k < nb; k++) {
    const int64_t a = pb[2 * k], b = pb[2 * k + 1];
    bad += b >= 0 && ((rows[a % 3] >> (b % 3)) & 1);
  }
  printf("  exclusions (classes 1-1, 1-2 of 3): %lld pairs without, %lld with (%lld dropped, %lld excluded kept)\n",
         (long long)na, (long long)nb, (long long)dropped, (long long)bad);
  TEST_ASSERT(rc == 0 && na > 100 && dropped > 20, "exclusions: rc %d, %lld pairs, %lld to drop", rc, (long long)na,
              (long long)dropped);
  TEST_ASSERT(nb == want && bad == 0, "exclusions: %lld pairs kept (expected %lld), %lld excluded pairs kept",
              (long long)nb, (long long)want, (long long)bad);
  /* the same exclusions given as none: the list of A again */
  rc = sphdem_dem_set_exclusions(B, 0, NULL);
  rc |= sphdem_dem_compute(B, n, g.tag, g.x, g.v, g.om, g.r, g.m, fl, 1e-5, 0, fB, tB, NULL);
  TEST_ASSERT(rc == 0 && sphdem_dem_debug_pairs(B, pb, cap) == na, "exclusions removed: the list is not whole again");
  /* bad tables */
  const uint16_t asym[2] = {1u << 1, 0}, wide[2] = {1u << 2, 0};
  TEST_ASSERT(sphdem_dem_set_exclusions(B, 2, asym) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(B), "symmetric"),
              "asymmetric exclusions: %s", sphdem_dem_last_error(B));
  TEST_ASSERT(sphdem_dem_set_exclusions(B, 2, wide) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(B), "rows[0]"),
              "exclusion of a class >= n: %s", sphdem_dem_last_error(B));
  TEST_ASSERT(sphdem_dem_set_exclusions(B, 17, rows) == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(B), "n 17"),
              "17 classes: %s", sphdem_dem_last_error(B));
  TEST_ASSERT(sphdem_dem_set_exclusions(B, 2, NULL) == SPHDEM_ERR_ARG, "rows NULL must fail");
  sphdem_dem_destroy(&A); sphdem_dem_destroy(&B);
  free(fB); free(tB); free(fl); free(pa); free(pb);
  free_grains(&g);
}

/* Heat conduction through the contacts (sphdem_dem_heat). Two grains of unequal radii: the heat flow of each contact
 * area against its analytic value (the overlap's circle radius from the two spheres' intersection, a^2 = r_a^2 - ((r^2
 * + r_a^2 - r_b^2) / 2r)^2, a formula other than the one the core uses), within 1e-14. A periodic packing of 600
 * grains (some lie within others) with random temperatures and conductivities (some 0) and half the grains outside the
 * group: every grain's
 * heat and directional heat against a sum over all pairs of grains by the minimum image (within 1e-12 of the
 * largest), the heat summing to zero (1e-13 of the sum of |Q|); sphdem_dem_heat_conductance gives the two grains'
 * flow too. Bad input names itself. */
static void test_heat(void) {
  char msg[256];
  { /* two grains */
    const double lo[3] = {-2, -2, -2}, hi[3] = {2, 2, 2}, ra = 0.5, rb = 0.3, r = 0.7;
    sphdem_dem_params p = hertz_params(0.05, -1, lo, hi, 0);
    sphdem_dem A = make(&p);
    int64_t tag[2] = {1, 2};
    double x[6] = {0.1, 0.2, 0.3, 0.1 + r * 0.6, 0.2 - r * 0.8, 0.3}, v[6] = {0}, om[6] = {0};
    double rad[2] = {ra, rb}, mass[2] = {1, 1}, f[6], t[6];
    sphdem_grain_store st = NULL;
    int rc = sphdem_grains_create(&st, test_device(), msg, sizeof msg);
    int64_t stamp[SPHDEM_GRAINS_STAMP] = {1, 0, 0, 0, 0, 0};
    rc |= sphdem_grains_put(st, stamp, 2, 0, x, v, om, rad, mass);
    rc |= sphdem_dem_compute_store(A, st, tag, NULL, 1e-5, 0, f, t, NULL);
    const double T[2] = {300, 400}, k[2] = {2, 3}, hk = 4 * 2 * 3 / 5.0;
    const double c = (r * r + ra * ra - rb * rb) / (2 * r), a2 = ra * ra - c * c;
    const double areas[3] = {M_PI * a2, M_PI * ra * ra, 0.1};
    const char *names[3] = {"overlap", "projection", "constant"};
    const int modes[3] = {SPHDEM_DEM_HEAT_AREA_OVERLAP, SPHDEM_DEM_HEAT_AREA_PROJECTION, SPHDEM_DEM_HEAT_AREA_CONSTANT};
    for (int m = 0; m < 3 && !rc; m++) {
      double q[2], dq[6];
      rc = sphdem_dem_heat(A, st, T, k, NULL, modes[m], 0.1, q, dq);
      const double Q = hk * sqrt(areas[m]) * (T[1] - T[0]);
      double err = fmax(fabs(q[0] - Q), fabs(q[1] + Q)) / Q;
      for (int d = 0; d < 3; d++)
        err = fmax(err, fmax(fabs(dq[d] - 0.5 * Q * (x[d] - x[3 + d])), fabs(dq[3 + d] - 0.5 * Q * (x[d] - x[3 + d]))) / (Q * r));
      /* the conductance of the one contact, as the output per contact takes it: the same flow */
      double rsq = 0.0;
      for (int d = 0; d < 3; d++) rsq += (x[d] - x[3 + d]) * (x[d] - x[3 + d]);
      const double h = sphdem_dem_heat_conductance(rsq, ra, rb, k[0], k[1], modes[m], 0.1);
      const double hq = fabs(h * (T[1] - T[0]) - Q) / Q;
      printf("  heat, two grains, area %s: Q = %.15g (analytic %.15g), largest difference %.2g; h (T_b - T_a) from "
             "sphdem_dem_heat_conductance %.2g off\n", names[m], q[0], Q, err, hq);
      TEST_ASSERT(!rc && err < 1e-14, "heat (%s): %.3g off the analytic flow (rc %d: %s)", names[m], err, rc,
                  sphdem_dem_last_error(A));
      TEST_ASSERT(hq < 1e-14 && fabs(h * (T[1] - T[0]) - q[0]) <= 1e-15 * Q, "heat_conductance (%s): %.3g off", names[m], hq);
    }
    /* bad input */
    double q[2];
    const double kneg[2] = {2, -1};
    rc = sphdem_dem_heat(A, st, T, k, NULL, 7, 0.1, q, NULL);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "area 7"), "heat: bad area mode (%s)",
                sphdem_dem_last_error(A));
    rc = sphdem_dem_heat(A, st, T, k, NULL, SPHDEM_DEM_HEAT_AREA_CONSTANT, 0.0, q, NULL);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "constant contact area"), "heat: area 0 (%s)",
                sphdem_dem_last_error(A));
    rc = sphdem_dem_heat(A, st, T, kneg, NULL, SPHDEM_DEM_HEAT_AREA_OVERLAP, 0.0, q, NULL);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "conductivity -1"), "heat: negative k (%s)",
                sphdem_dem_last_error(A));
    stamp[0] = 2;
    sphdem_grains_put(st, stamp, 1, 0, x, v, om, rad, mass);
    rc = sphdem_dem_heat(A, st, T, k, NULL, SPHDEM_DEM_HEAT_AREA_OVERLAP, 0.0, q, NULL);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_dem_last_error(A), "1 grains given"), "heat: grain count (%s)",
                sphdem_dem_last_error(A));
    sphdem_grains_destroy(&st);
    sphdem_dem_destroy(&A);
  }
  { /* a periodic packing */
    const int n = 600;
    double lo[3], hi[3];
    grains g = packing(n, 0.5, 0.5, lo, hi);
    sphdem_dem_params p = hertz_params(0.02, -1, lo, hi, 1);
    sphdem_dem A = make(&p);
    sphdem_grain_store st = NULL;
    int rc = sphdem_grains_create(&st, test_device(), msg, sizeof msg);
    int64_t stamp[SPHDEM_GRAINS_STAMP] = {1, 0, 0, 0, 0, 0};
    rc |= sphdem_grains_put(st, stamp, n, 0, g.x, g.v, g.om, g.r, g.m);
    rc |= sphdem_dem_compute_store(A, st, g.tag, NULL, 1e-5, 0, g.f, g.t, NULL);
    double *T = malloc(sizeof(double) * n), *k = malloc(sizeof(double) * n), *q = malloc(sizeof(double) * n);
    double *dq = malloc(sizeof(double) * 3 * n), *qr = calloc(n, sizeof(double)), *dqr = calloc(3 * (size_t)n, sizeof(double));
    int *mb = malloc(sizeof(int) * n);
    for (int i = 0; i < n; i++) {
      T[i] = 300 + 200 * urand();
      k[i] = i % 7 == 0 ? 0.0 : 0.5 + 10 * urand();
      mb[i] = i % 2;
    }
    rc |= sphdem_dem_heat(A, st, T, k, mb, SPHDEM_DEM_HEAT_AREA_OVERLAP, 0.0, q, dq);
    /* every pair of grains by the minimum image */
    double qabs = 0, qmax = 0, dmax = 0;
    int npairs = 0;
    for (int i = 0; i < n; i++)
      for (int j = i + 1; j < n; j++) {
        if (!mb[i] && !mb[j]) continue;
        double del[3], r2 = 0;
        for (int d = 0; d < 3; d++) {
          const double L = hi[d] - lo[d];
          del[d] = g.x[3 * i + d] - g.x[3 * j + d];
          del[d] -= L * rint(del[d] / L);
          r2 += del[d] * del[d];
        }
        const double ri = g.r[i], rj = g.r[j], rr = sqrt(r2);
        if (rr >= ri + rj) continue;
        const double c = (r2 + ri * ri - rj * rj) / (2 * rr);
        const double A2 = rr > fabs(ri - rj) ? M_PI * (ri * ri - c * c) : M_PI * fmin(ri, rj) * fmin(ri, rj);
        const double h = k[i] > 0 && k[j] > 0 ? 4 * k[i] * k[j] / (k[i] + k[j]) * sqrt(A2) : 0.0;
        /* the flow into the grain of lower tag (tags grow with the index here) */
        const double Q = h * (T[j] - T[i]);
        qr[i] += Q, qr[j] -= Q;
        for (int d = 0; d < 3; d++) dqr[3 * i + d] += 0.5 * Q * del[d], dqr[3 * j + d] += 0.5 * Q * del[d];
        qabs += fabs(Q);
        npairs++;
      }
    double dh = 0, ddh = 0, sum = 0;
    for (int i = 0; i < n; i++) {
      qmax = fmax(qmax, fabs(qr[i]));
      dh = fmax(dh, fabs(q[i] - qr[i]));
      sum += q[i];
      for (int d = 0; d < 3; d++) {
        dmax = fmax(dmax, fabs(dqr[3 * i + d]));
        ddh = fmax(ddh, fabs(dq[3 * i + d] - dqr[3 * i + d]));
      }
    }
    printf("  heat, periodic packing of %d grains: %d conducting contacts; heat %.2g, directional %.2g of the largest "
           "off the sum over all pairs; total %.2g of sum |Q|\n", n, npairs, dh / qmax, ddh / dmax, fabs(sum) / qabs);
    TEST_ASSERT(!rc && npairs > n / 2 && dh <= 1e-12 * qmax && ddh <= 1e-12 * dmax && fabs(sum) <= 1e-13 * qabs,
                "heat, packing: %d contacts, heat %.3g, directional %.3g, total %.3g (rc %d: %s)", npairs, dh / qmax,
                ddh / dmax, fabs(sum) / qabs, rc, sphdem_dem_last_error(A));
    free(T); free(k); free(q); free(dq); free(qr); free(dqr); free(mb);
    sphdem_grains_destroy(&st);
    sphdem_dem_destroy(&A);
    free_grains(&g);
  }
}

int main(void) {
  test_bad_params();
  test_bad_grains();
  test_first_contact();
  test_threaded();
  test_detection();
  test_single_contacts();
  test_dynamics();
  test_recontact_history();
  test_materials();
  test_epsd2();
  test_cohesion();
  test_granular();
  test_accumulate();
  test_ghost_copies();
  test_ghost_once();
  test_skipped_copies();
  test_serial_pass();
  test_visited_set();
  test_history_hand_over();
  test_same_tags();
  test_changing_box();
  test_exclusions();
  test_contacts();
  test_step_contacts();
  test_heat();
  return test_summary("unit_dem");
}
