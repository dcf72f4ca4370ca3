/* test_api.c - C API contract: argument errors name the parameter, blow-up detection, momentum
 * conservation, and download/upload round trips that leave the evolution bit-identical. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static void base_params(sphdem_params *p, int dim) {
  sphdem_params_default(p);
  p->dim = dim; p->dx = 0.01; p->h = 0.013; p->rho0 = 1000; p->c0 = 10; p->skin = 0.003;
  p->visc = SPHDEM_VISC_ARTIFICIAL; p->alpha = 0.05;
}

static int expect_arg_error(sphdem_params *p, const char *word) {
  char msg[512];
  int rc = sphdem_params_check(p, msg, sizeof msg);
  int ok = rc == SPHDEM_ERR_ARG && strstr(msg, word) != NULL;
  if (!ok) printf("  params_check message '%s' lacks '%s'\n", msg, word);
  return ok;
}

/* periodic box of fluid on a lattice with random velocities */
static void periodic_box(scene *s, sphdem_params *p, int n1) {
  memset(s, 0, sizeof *s);
  double L = n1 * p->dx;
  for (int d = 0; d < p->dim; d++) { p->boxlo[d] = 0; p->boxhi[d] = L; p->periodic[d] = 1; }
  srand(7);
  for (int i = 0; i < n1; i++)
    for (int j = 0; j < n1; j++)
      for (int k = 0; k < (p->dim == 3 ? n1 : 1); k++) {
        double x[3] = {(i + 0.5) * p->dx, (j + 0.5) * p->dx, p->dim == 3 ? (k + 0.5) * p->dx : 0};
        scene_push_fluid(s, x, 1000, 1000 * pow(p->dx, p->dim));
        for (int d = 0; d < p->dim; d++) s->v[3 * (s->nf - 1) + d] = 0.5 * (rand() / (double)RAND_MAX - 0.5);
      }
}

static void momentum(sphdem_ctx c, int n, const double *mass, double *P) {
  double *v = (double *)malloc(24 * (size_t)n);
  sphdem_get_fluid(c, NULL, v, NULL, NULL, NULL);
  P[0] = P[1] = P[2] = 0;
  for (int i = 0; i < n; i++)
    for (int d = 0; d < 3; d++) P[d] += mass[i] * v[3 * i + d];
  free(v);
}

/* Keyword isolated: (a) a splash pair flying apart (2D, two particles dx apart, 0.2 m/s each, no gravity, no walls:
 * kernel sum 0.45 each) goes into tension without it and keeps P >= 0 with it; (b) in a periodic box (kernel sum ~1 everywhere) the
 * run is bit-identical with and without it. */
static void isolated_particles(sphdem_device dev) {
  for (int on = 0; on <= 1; on++) {
    sphdem_params p;
    base_params(&p, 2);
    p.boxlo[0] = p.boxlo[1] = -0.5; p.boxhi[0] = p.boxhi[1] = 0.5;
    p.isolated = on ? 0.5 : 0.0;
    scene s;
    memset(&s, 0, sizeof s);
    for (int k = 0; k < 2; k++) {
      double x[3] = {(k - 0.5) * p.dx, 0, 0};
      scene_push_fluid(&s, x, 1000, 1000 * p.dx * p.dx);
      s.v[3 * (s.nf - 1)] = k ? 0.2 : -0.2;
    }
    sphdem_ctx c = scene_start(&p, &s, dev);
    double dt = 0.2 * p.h / p.c0, pr[2], pmin = 1e30;
    for (int n = 0; n < 200; n++) {
      SPHDEM_CHECK_RC(c, scene_step(c, dt));
      SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, NULL, NULL, NULL, pr, NULL));
      for (int i = 0; i < 2; i++) pmin = fmin(pmin, pr[i]);
    }
    printf("  splash pair flying apart, isolated %s: lowest pressure over 200 steps %.4g Pa\n", on ? "0.5" : "off", pmin);
    if (on) TEST_ASSERT(pmin >= 0.0, "isolated 0.5: the splash pair never goes into tension (min P %.3g)", pmin);
    else TEST_ASSERT(pmin < -100.0, "without isolated the splash pair goes into tension (min P %.3g)", pmin);
    sphdem_destroy(&c);
    scene_free(&s);
  }
  double *xr[2];
  int nf = 0;
  for (int on = 0; on <= 1; on++) {
    sphdem_params p;
    base_params(&p, 2);
    scene s;
    periodic_box(&s, &p, 16);
    p.isolated = on ? 0.5 : 0.0;
    sphdem_ctx c = scene_start(&p, &s, dev);
    for (int n = 0; n < 50; n++) SPHDEM_CHECK_RC(c, scene_step(c, 1e-4));
    nf = s.nf;
    xr[on] = (double *)malloc(24 * (size_t)nf);
    SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, xr[on], NULL, NULL, NULL, NULL));
    sphdem_destroy(&c);
    scene_free(&s);
  }
  TEST_ASSERT(memcmp(xr[0], xr[1], 24 * (size_t)nf) == 0, "isolated 0.5 leaves a periodic box (no free surface) bit-identical");
  free(xr[0]); free(xr[1]);
}

/* Positions the core cannot bin and parameters that would divide by zero stop with an error that names
 * them: a NaN fluid position (by tag), an infinite wall position, a NaN probe point, particles spread
 * beyond any search grid in a huge box, h whose kernel constant underflows, the tensile correction with
 * W(dx) = 0. */
static void bad_positions(sphdem_device dev) {
  sphdem_params p;
  char msg[512];
  base_params(&p, 2); p.h = 1e-100; p.dx = 1e-100;
  TEST_ASSERT(expect_arg_error(&p, "h (smoothing length) 1e-100 is outside"), "h 1e-100 refused");
  base_params(&p, 2); p.tensile_eps = 0.01; p.dx = 2.0 * p.h;
  TEST_ASSERT(expect_arg_error(&p, "tensile correction needs dx < 2h"), "tensile with dx = 2h refused");
  p.tensile_eps = 0.0;
  TEST_ASSERT(sphdem_params_check(&p, msg, sizeof msg) == SPHDEM_OK, "dx = 2h without tensile: %s", msg);
  scene s;
  base_params(&p, 2);
  periodic_box(&s, &p, 12);
  sphdem_ctx c;
  SPHDEM_CHECK_RC(c, sphdem_create(&c, &p, dev, msg, sizeof msg));
  s.x[3 * 5 + 1] = NAN;
  int rc = sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "set_fluid: particle 5 (tag 6) has a non-finite position"),
              "NaN fluid position: rc %d '%s'", rc, sphdem_last_error(c));
  s.x[3 * 5 + 1] = 0.5 * p.dx;
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  double wx[6] = {0.01, 0.01, 0, 0.02, INFINITY, 0}, wm[2] = {0.1, 0.1};
  rc = sphdem_set_walls(c, 2, wx, NULL, NULL, wm);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "set_walls: particle 1") &&
              strstr(sphdem_last_error(c), "non-finite position"), "infinite wall position: '%s'", sphdem_last_error(c));
  double pts[6] = {0.03, 0.03, 0, NAN, 0.03, 0}, out[2 * SPHDEM_NPROBE];
  rc = sphdem_probe(c, 2, pts, out);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "probe: point 1"), "NaN probe point: '%s'",
              sphdem_last_error(c));
  sphdem_destroy(&c);
  /* a huge non-periodic box: particles 1e200 apart need more cells than any grid may have */
  sphdem_params q = p;
  for (int d = 0; d < 2; d++) { q.periodic[d] = 0; q.boxlo[d] = -1e300; q.boxhi[d] = 1e300; }
  SPHDEM_CHECK_RC(c, sphdem_create(&c, &q, dev, msg, sizeof msg));
  s.x[0] = 1e200; s.x[1] = -1e200;
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  rc = sphdem_compute_rates(c);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "search grid too large"),
              "particles 1e200 apart: rc %d '%s'", rc, sphdem_last_error(c));
  /* one particle 1e3 box lengths away still gets a grid (and the others their neighbours) */
  s.x[0] = 100.0; s.x[1] = 0.5 * p.dx;
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  sphdem_destroy(&c);
  scene_free(&s);
}

/* Set-up of a fluid at rest (sph_setup.c) against closed forms: the Tait-inverted hydrostatic density of one
 * fluid; two horizontal layers (light over heavy, linear EOS) with P = rho_top g d_top + rho_bot g (depth - d_top)
 * below the interface; the mirror images of ghost-wall particles and the refusal of one inside the box. */
static void setup_closed_forms(void) {
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.rho0 = 1000; p.c0 = 20; p.h = 0.013; p.dx = 0.01; p.gravity[1] = -9.81;
  int n = 40, which[40], ph[40];
  double x[120], rho[40];
  for (int i = 0; i < n; i++) {
    x[3 * i] = 0.01 * (i % 4); x[3 * i + 1] = 0.01 * (i / 4) + 0.005; x[3 * i + 2] = 0;
    which[i] = i; ph[i] = (i / 4) < 5 ? 0 : 1; /* rows 0-4 heavy (phase 0), rows 5-9 light (phase 1) */
  }
  double zs = 0.1, worst = 0;
  int rc = sphdem_initial_density(&p, NULL, 1, zs, n, x, NULL, n, which, rho);
  for (int i = 0; i < n; i++) {
    double d = zs - x[3 * i + 1], P = p.rho0 * 9.81 * d, B = sphdem_tait_B(&p);
    worst = fmax(worst, fabs(rho[i] - p.rho0 * pow(1 + P / B, 1 / p.gamma)) / p.rho0);
  }
  TEST_ASSERT(rc == SPHDEM_OK && worst < 1e-12, "single fluid: Tait hydrostatic density (rc %d, worst %.2e)", rc, worst);
  sphdem_mp_params m;
  sphdem_mp_params_default(&m);
  m.enabled = 1; m.nphase = 2; m.eos = SPHDEM_EOS_LINEAR;
  m.phase[0].rho0 = 2000; m.phase[1].rho0 = 1000;
  rc = sphdem_initial_density(&p, &m, 1, zs, n, x, ph, n, which, rho);
  worst = 0;
  for (int i = 0; i < n; i++) {
    double z = x[3 * i + 1], d = zs - z, dtop = zs - 0.05;
    double P = z >= 0.05 ? 1000 * 9.81 * d : 1000 * 9.81 * dtop + 2000 * 9.81 * (d - dtop);
    double want = m.phase[ph[i]].rho0 + P / (p.c0 * p.c0);
    worst = fmax(worst, fabs(rho[i] - want) / want);
  }
  /* binned by dx in depth: each particle's own bin counts half (the bin's mean density, integrated to the
   * particle's depth), exact here where bins hold one phase */
  TEST_ASSERT(rc == SPHDEM_OK && worst < 1e-9, "two layers: layered pressure through the phase EOS (rc %d, worst %.2e)",
              rc, worst);
  int bad[2] = {0, 7};
  rc = sphdem_initial_density(&p, &m, 1, zs, n, x, ph, 2, bad, rho);
  TEST_ASSERT(rc == SPHDEM_OK, "a subset of particles (rc %d)", rc);
  bad[1] = n;
  TEST_ASSERT(sphdem_initial_density(&p, &m, 1, zs, n, x, ph, 2, bad, rho) == SPHDEM_ERR_ARG, "index out of range refused");
  /* mirror points: box [0,1] x [0,2]; a wall particle below, one left of the box, one in the corner */
  double wx[9] = {0.5, -0.1, 0, -0.2, 1.0, 0, -0.1, -0.3, 0}, xi[9];
  double lo[3] = {0, 0, -1e300}, hi[3] = {1, 2, 1e300};
  int inside = 99;
  rc = sphdem_mirror_points(3, wx, lo, hi, xi, &inside);
  double want[9] = {0.5, 0.1, 0, 0.2, 1.0, 0, 0.1, 0.3, 0}, e = 0;
  for (int k = 0; k < 9; k++) e = fmax(e, fabs(xi[k] - want[k]));
  TEST_ASSERT(rc == SPHDEM_OK && inside == -1 && e < 1e-15, "mirror images across the faces (rc %d, inside %d, err %.1e)",
              rc, inside, e);
  wx[3] = 0.2;
  rc = sphdem_mirror_points(3, wx, lo, hi, xi, &inside);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && inside == 1, "a wall particle inside the box is named (rc %d, inside %d)", rc, inside);
  /* free surface: the highest particle (y 0.095) + dx/2 with gravity -y; the lowest - dx/2 with gravity +y */
  int axis = -1, up = 0;
  double zf = 0;
  rc = sphdem_free_surface(&p, n, x, NULL, &zf, &axis, &up);
  TEST_ASSERT(rc == SPHDEM_OK && axis == 1 && up == 1 && fabs(zf - 0.1) < 1e-15,
              "free surface above the highest particle (rc %d, axis %d, up %d, z %.17g)", rc, axis, up, zf);
  p.gravity[1] = 9.81;
  rc = sphdem_free_surface(&p, n, x, NULL, &zf, &axis, &up);
  TEST_ASSERT(rc == SPHDEM_OK && axis == 1 && up == -1 && fabs(zf - 0.0) < 1e-15,
              "gravity +y: free surface below the lowest particle (rc %d, up %d, z %.3g)", rc, up, zf);
  p.gravity[1] = -9.81;
  /* volume-keeping mass factor rho / rho0 of the phase; superficial start rho, m times max(eps, eps_min) */
  TEST_ASSERT(sphdem_volume_mass_factor(&p, NULL, 0, 1010.0) == 1010.0 / 1000.0 &&
              sphdem_volume_mass_factor(&p, &m, 0, 2020.0) == 2020.0 / 2000.0, "mass factor rho / rho0 of the phase");
  double eps[3] = {0.5, 0.1, 0.9}, r3[3] = {1000, 1000, 1000}, m3[3] = {1, 1, 1};
  int fr[2] = {0, 1};
  rc = sphdem_superficial_start(0.2, 2, fr, eps, r3, m3);
  TEST_ASSERT(rc == SPHDEM_OK && r3[0] == 500 && r3[1] == 200 && r3[2] == 1000 && m3[0] == 0.5 && m3[1] == 0.2 &&
              m3[2] == 1, "superficial start: rho and m of the fresh particles times max(eps, eps_min) (rc %d)", rc);
}

int main(void) {
  sphdem_device dev = test_device();
  bad_positions(dev);
  sphdem_params p;
  char msg[512];

  /* ---- argument checks name the parameter */
  base_params(&p, 2); p.h = -1; TEST_ASSERT(expect_arg_error(&p, "h (smoothing length)"), "h checked");
  base_params(&p, 2); p.dim = 4; TEST_ASSERT(expect_arg_error(&p, "dim must be 2 or 3"), "dim checked");
  base_params(&p, 2); p.visc = SPHDEM_VISC_MORRIS; p.mu = 0; TEST_ASSERT(expect_arg_error(&p, "morris"), "mu checked");
  base_params(&p, 2); p.xsph_eps = 2; TEST_ASSERT(expect_arg_error(&p, "xsph"), "xsph checked");
  base_params(&p, 2); p.isolated = 1.5; TEST_ASSERT(expect_arg_error(&p, "isolated"), "isolated checked");
  base_params(&p, 2); p.periodic[0] = 1; p.boxlo[0] = 0; p.boxhi[0] = 0.05;
  TEST_ASSERT(expect_arg_error(&p, "periodic box length"), "small periodic box rejected");
  base_params(&p, 2);
  sphdem_ctx c = NULL;
  p.c0 = 0;
  TEST_ASSERT(sphdem_create(&c, &p, dev, msg, sizeof msg) == SPHDEM_ERR_ARG && c == NULL && strstr(msg, "c0"),
              "create refuses c0 = 0 with a message naming c0 ('%s')", msg);
  base_params(&p, 2);
  if (!sphdem_gpu_available()) {
    int rc = sphdem_create(&c, &p, SPHDEM_DEVICE_GPU, msg, sizeof msg);
    TEST_ASSERT(rc == SPHDEM_ERR_NO_GPU && c == NULL && strlen(msg) > 10, "device gpu without a GPU: clear error ('%s')", msg);
    TEST_ASSERT(sphdem_create(&c, &p, SPHDEM_DEVICE_AUTO, msg, sizeof msg) == SPHDEM_OK &&
                sphdem_backend(c) == SPHDEM_DEVICE_CPU && strstr(sphdem_backend_note(c), "CPU"),
                "device auto falls back to the CPU with a note ('%s')", c ? sphdem_backend_note(c) : "");
    sphdem_destroy(&c);
  }
  TEST_ASSERT(strcmp(sphdem_strerror(SPHDEM_ERR_NAN), "non-finite value in the fluid state") == 0, "strerror");

  /* ---- probes: Shepard interpolation reproduces a uniform field; no fluid in reach gives weight 0 */
  {
    scene u;
    periodic_box(&u, &p, 12);
    sphdem_ctx cp;
    SPHDEM_CHECK_RC(cp, sphdem_create(&cp, &p, dev, msg, sizeof msg));
    for (int i = 0; i < u.nf; i++) u.v[3 * i] = 0.3, u.v[3 * i + 1] = -0.1;
    SPHDEM_CHECK_RC(cp, sphdem_set_fluid(cp, u.nf, u.tag, u.x, u.v, u.rho, u.mass, NULL));
    double pts[6] = {0.031, 0.077, 0, 0.0005, 0.119, 0}, out[2 * SPHDEM_NPROBE];
    SPHDEM_CHECK_RC(cp, sphdem_probe(cp, 2, pts, out));
    int ok = 1;
    for (int k = 0; k < 2; k++)
      ok &= fabs(out[6 * k + 1] - 1000) < 1e-9 && fabs(out[6 * k]) < 1e-6 && fabs(out[6 * k + 2] - 0.3) < 1e-12 &&
            fabs(out[6 * k + 3] + 0.1) < 1e-12 && fabs(out[6 * k + 5] - 1.0) < 0.05;
    TEST_ASSERT(ok, "probe of a uniform field: rho %.12g p %.3g vx %.12g vy %.12g shepard %.4f", out[1], out[0], out[2],
                out[3], out[5]);
    sphdem_params q = p;
    q.periodic[1] = 0; q.boxlo[1] = -1; q.boxhi[1] = 1;
    SPHDEM_CHECK_RC(cp, sphdem_destroy(&cp));
    SPHDEM_CHECK_RC(cp, sphdem_create(&cp, &q, dev, msg, sizeof msg));
    SPHDEM_CHECK_RC(cp, sphdem_set_fluid(cp, u.nf, u.tag, u.x, u.v, u.rho, u.mass, NULL));
    double far[3] = {0.05, 0.9, 0};
    SPHDEM_CHECK_RC(cp, sphdem_probe(cp, 1, far, out));
    TEST_ASSERT(out[5] == 0 && out[0] == 0 && out[1] == 0, "probe far from the fluid: zero weight and values");
    sphdem_destroy(&cp);
    scene_free(&u);
  }

  /* ---- kick before any rates is a state error, not a crash */
  scene s;
  periodic_box(&s, &p, 12);
  SPHDEM_CHECK_RC(c, sphdem_create(&c, &p, dev, msg, sizeof msg));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  TEST_ASSERT(sphdem_kick(c, 1e-4) == SPHDEM_ERR_STATE && strstr(sphdem_last_error(c), "compute_rates"),
              "kick before rates: %s", sphdem_last_error(c));
  /* ---- momentum is conserved to round-off by the pairwise-antisymmetric forces */
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double P0[3], P1[3];
  momentum(c, s.nf, s.mass, P0);
  double dt = 0.2 * p.h / p.c0, scale = 0;
  for (int i = 0; i < s.nf; i++) scale += s.mass[i] * 0.25;
  for (int n = 0; n < 200; n++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  momentum(c, s.nf, s.mass, P1);
  double dP = fabs(P1[0] - P0[0]) + fabs(P1[1] - P0[1]);
  TEST_ASSERT(dP < 1e-12 * scale, "momentum drift %.3e relative to sum m|v| %.3e", dP, scale);
  printf("  periodic box, 200 steps: momentum change %.2e (scale %.2e), sorts %lld\n", dP, scale,
         (long long)sphdem_nsorts(c));

  /* ---- stability check: time step above the stable one is reported with the limit */
  sphdem_stats st;
  int rc = sphdem_stats_get(c, 10 * dt, &st);
  TEST_ASSERT(rc == SPHDEM_ERR_UNSTABLE && strstr(sphdem_last_error(c), "Set the timestep to"),
              "too large dt reported: %s", sphdem_last_error(c));
  TEST_ASSERT(sphdem_stats_get(c, dt, &st) == SPHDEM_OK && st.dt_stable > dt && st.nfluid == s.nf, "stable dt ok");

  /* ---- round trip mid-run (download, shuffle caller order, in-place upload) changes nothing */
  sphdem_ctx c2;
  SPHDEM_CHECK_RC(c2, sphdem_create(&c2, &p, dev, msg, sizeof msg));
  SPHDEM_CHECK_RC(c2, sphdem_set_fluid(c2, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c2, sphdem_compute_rates(c2));
  sphdem_ctx c3;
  SPHDEM_CHECK_RC(c3, sphdem_create(&c3, &p, dev, msg, sizeof msg));
  SPHDEM_CHECK_RC(c3, sphdem_set_fluid(c3, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c3, sphdem_compute_rates(c3));
  int n = s.nf;
  double *x = malloc(24 * n), *v = malloc(24 * n), *rho = malloc(8 * n), *st7 = malloc(8 * SPHDEM_NSTATE * n);
  double *x2 = malloc(24 * n), *x3 = malloc(24 * n), *m = malloc(8 * n);
  int64_t *tg = malloc(8 * n);
  for (int k = 0; k < 120; k++) {
    SPHDEM_CHECK_RC(c2, scene_step(c2, dt));
    SPHDEM_CHECK_RC(c3, sphdem_kick(c3, 0.5 * dt));
    SPHDEM_CHECK_RC(c3, sphdem_drift(c3, dt));
    if (k % 7 == 3) { /* as the engine does between the half steps: download, reorder, upload */
      SPHDEM_CHECK_RC(c3, sphdem_get_fluid(c3, x, v, rho, NULL, st7));
      int shift = k % n;
      double *xs = malloc(24 * n), *vs = malloc(24 * n), *rs = malloc(8 * n), *ss = malloc(8 * SPHDEM_NSTATE * n);
      for (int i = 0; i < n; i++) {
        int j = (i + shift) % n; /* caller index i holds particle j */
        tg[i] = s.tag[j]; m[i] = s.mass[j]; rs[i] = rho[j];
        memcpy(xs + 3 * i, x + 3 * j, 24); memcpy(vs + 3 * i, v + 3 * j, 24);
        memcpy(ss + SPHDEM_NSTATE * i, st7 + SPHDEM_NSTATE * j, 8 * SPHDEM_NSTATE);
      }
      SPHDEM_CHECK_RC(c3, sphdem_set_fluid(c3, n, tg, xs, vs, rs, m, ss));
      /* download again in the new caller order and restore the original order for the test */
      SPHDEM_CHECK_RC(c3, sphdem_get_fluid(c3, xs, NULL, NULL, NULL, NULL));
      for (int i = 0; i < n; i++) memcpy(x + 3 * ((i + shift) % n), xs + 3 * i, 24);
      SPHDEM_CHECK_RC(c3, sphdem_set_fluid(c3, n, s.tag, x, v, rho, s.mass, st7));
      free(xs); free(vs); free(rs); free(ss);
    }
    SPHDEM_CHECK_RC(c3, sphdem_compute_rates(c3));
    SPHDEM_CHECK_RC(c3, sphdem_kick(c3, 0.5 * dt));
  }
  SPHDEM_CHECK_RC(c2, sphdem_get_fluid(c2, x2, NULL, NULL, NULL, NULL));
  SPHDEM_CHECK_RC(c3, sphdem_get_fluid(c3, x3, NULL, NULL, NULL, NULL));
  TEST_ASSERT(memcmp(x2, x3, 24 * n) == 0, "round trips between half steps leave the run bit-identical");

  /* ---- blow-up detection: non-finite density, particle outside a wall-bounded box */
  SPHDEM_CHECK_RC(c3, sphdem_get_fluid(c3, x, v, rho, NULL, st7));
  rho[5] = NAN;
  TEST_ASSERT(sphdem_set_fluid(c3, n, s.tag, x, v, rho, s.mass, st7) == SPHDEM_ERR_ARG, "NaN density refused at upload");
  rho[5] = 1000;
  v[3 * 5] = NAN;
  SPHDEM_CHECK_RC(c3, sphdem_set_fluid(c3, n, s.tag, x, v, rho, s.mass, st7));
  rc = sphdem_stats_get(c3, dt, &st);
  TEST_ASSERT(rc == SPHDEM_ERR_NAN && st.nnan == 1 && strstr(sphdem_last_error(c3), "blew up"),
              "NaN velocity detected: %s", sphdem_last_error(c3));
  sphdem_params q = p;
  q.periodic[0] = 0; q.boxlo[0] = 0.0; q.boxhi[0] = 0.05;
  sphdem_ctx c4;
  SPHDEM_CHECK_RC(c4, sphdem_create(&c4, &q, dev, msg, sizeof msg));
  SPHDEM_CHECK_RC(c4, sphdem_set_fluid(c4, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  rc = sphdem_stats_get(c4, 0, &st);
  TEST_ASSERT(rc == SPHDEM_ERR_LOST && st.nlost > 0 && strstr(sphdem_last_error(c4), "left the box"),
              "particles outside the box detected: %s", sphdem_last_error(c4));
  sphdem_destroy(&c4);
  for (int i = 0; i < n; i++) rho[i] = 1300;
  v[3 * 5] = 0;
  SPHDEM_CHECK_RC(c3, sphdem_set_fluid(c3, n, s.tag, x, v, rho, s.mass, st7));
  rc = sphdem_stats_get(c3, 0, &st);
  TEST_ASSERT(rc == SPHDEM_ERR_DENSITY && strstr(sphdem_last_error(c3), "rho_err_max"),
              "density blow-up detected: %s", sphdem_last_error(c3));

  free(x); free(v); free(rho); free(st7); free(x2); free(x3); free(m); free(tg);
  scene_free(&s);
  sphdem_destroy(&c); sphdem_destroy(&c2); sphdem_destroy(&c3);
  TEST_ASSERT(c == NULL, "destroy clears the handle");
  isolated_particles(dev);
  setup_closed_forms();
  return test_summary("api");
}
