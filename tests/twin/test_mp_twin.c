/* test_mp_twin.c - CPU and CUDA backends on the same multiphase input (Shi & Huang 2022 terms all on:
 * Herschel-Bulkley and Newtonian phases, renormalised diffusion, shifting, Smagorinsky, Adami walls):
 * a 2D column of mud collapsing in water between MLS ghost walls (400 velocity-Verlet steps, then 10 Runge-Kutta steps) and a
 * 3D two-layer tank (200 steps); both resort on the way. Positions, density and viscosity agree to 1e-9 relative; the
 * 2D column again in precision mixed (the delta-plus pair terms in float: the backends' float arithmetic differs in
 * contraction, so 1e-6 relative). Exit 77
 * (skipped) without a GPU. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static int g_prec = SPHDEM_PREC_DOUBLE; /* the runs' precision */

static void run(int dim, sphdem_device dev, double *xo, double *ro, double *muo, int *nf) {
  double g = 9.81, W = 0.4, H = 0.3;
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = dim; p.dx = dim == 2 ? 0.01 : 0.02; p.h = 1.5 * p.dx; p.rho0 = 1000; p.c0 = 10 * sqrt(3 * g * H);
  p.gravity[dim - 1] = -g; p.skin = 0.3 * p.dx;
  p.precision = g_prec;
  sphdem_mp_params m;
  sphdem_mp_params_default(&m);
  m.enabled = 1; m.nphase = 2;
  sphdem_phase mud = {1800, 5, 0.5, 0.8, 2.0, 0}, water = {1000, 0, 1e-3, 1, 0, 0};
  m.phase[0] = mud; m.phase[1] = water;
  m.diffusion = SPHDEM_DIFF_RENORM; m.shifting = 1; m.cs_les = 0.12;
  scene s;
  scene_tank(&s, &p, W, dim == 3 ? 0.1 : 0.5, 0.5, W, H, 3); /* tank full to H with rho0 1000 hydrostatic */
  int *ph = (int *)malloc(sizeof(int) * s.nf);
  int up = dim - 1;
  for (int i = 0; i < s.nf; i++) {
    double x = s.x[3 * i], z = s.x[3 * i + up];
    ph[i] = dim == 2 ? (x < 0.12 && z < 0.2) == 0 : z >= 0.15; /* 2D: mud column at the left; 3D: mud below */
    if (ph[i] == 0) { s.rho[i] *= 1.8; s.mass[i] *= 1.8; }
  }
  /* 2D: fixed ghost walls with MLS interpolation at the mirror points (§3.4); 3D: Adami walls */
  double lo[3] = {0, 0, -1e300}, hi[3] = {W, 1e300, 1e300};
  sphdem_ctx c = scene_start_mp(&p, &m, &s, ph, dim == 2 ? lo : NULL, hi, dev);
  double dt = 0.2 * p.h / p.c0;
  int nv = dim == 2 ? 400 : 200, nr = dim == 2 ? 10 : 0;
  for (int n = 0; n < nv; n++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  for (int n = 0; n < nr; n++) SPHDEM_CHECK_RC(c, sphdem_step_rk4(c, dt));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, xo, NULL, ro, NULL, NULL));
  SPHDEM_CHECK_RC(c, sphdem_mp_get_fields(c, muo, NULL, NULL, NULL));
  *nf = s.nf;
  printf("  %dD %s: %d fluid, %d wall particles, %lld sorts\n", dim, dev == SPHDEM_DEVICE_GPU ? "gpu" : "cpu", s.nf, s.nw,
         (long long)sphdem_nsorts(c));
  free(ph);
  scene_free(&s);
  sphdem_destroy(&c);
}

static double reldiff(const double *a, const double *b, int n) {
  double d = 0, s = 0;
  for (int i = 0; i < n; i++) { d = fmax(d, fabs(a[i] - b[i])); s = fmax(s, fabs(a[i])); }
  return s > 0 ? d / s : d;
}

int main(void) {
  /* SPHDEM_TWIN_SELFTEST=1: both runs on the CPU (a smoke test of the scene where no GPU exists) */
  int self = getenv("SPHDEM_TWIN_SELFTEST") != NULL;
  if (!self && !sphdem_gpu_available()) {
    return test_skip("no usable GPU: twin test");
  }
  for (int k = 0; k < 3; k++) {
    const int dim = k == 1 ? 3 : 2;
    const double bound = k < 2 ? 1e-9 : 1e-6;
    const char *pn = k < 2 ? "double" : "mixed";
    g_prec = k < 2 ? SPHDEM_PREC_DOUBLE : SPHDEM_PREC_MIXED;
    enum { NMAX = 20000 };
    static double xc[3 * NMAX], xg[3 * NMAX], rc[NMAX], rg[NMAX], mc[NMAX], mg[NMAX];
    int nc, ng;
    run(dim, SPHDEM_DEVICE_CPU, xc, rc, mc, &nc);
    run(dim, self ? SPHDEM_DEVICE_CPU : SPHDEM_DEVICE_GPU, xg, rg, mg, &ng);
    TEST_ASSERT(nc == ng, "%dD %s: same particle count", dim, pn);
    double ex = reldiff(xc, xg, 3 * nc), er = reldiff(rc, rg, nc), em = reldiff(mc, mg, nc);
    TEST_ASSERT(ex < bound && er < bound && em < bound, "%dD %s: CPU vs GPU x %.2e, rho %.2e, mu %.2e (bound %g)", dim,
                pn, ex, er, em, bound);
  }
  return test_summary("mp_twin");
}
