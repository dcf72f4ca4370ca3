#define _POSIX_C_SOURCE 200809L
/* test_twin.c - CPU and CUDA backends on the same input: 2D and 3D dam breaks with every term on, and a
 * coupled SPH-DEM tank (grains settling in water, every coupling term on: porosity in the EOS, Ergun/Wen-Yu
 * drag, pressure gradient, rotational drag, reaction; and without the rotational drag); positions, fluid density
 * and grain forces after 100 steps agree to 1e-9 relative (double precision); the dam breaks again in precision
 * mixed (float pair terms: the backends' float sums differ in order, so positions agree to 1e-7 relative). Exit 77
 * (skipped) without a GPU. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static int g_prec = SPHDEM_PREC_DOUBLE; /* the dam breaks' precision */
static void run(int dim, sphdem_device dev, int nsteps, double *xout, int *nf) {
  double a = 0.1, g = 9.81;
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = dim; p.dx = a / (dim == 2 ? 40 : 12); p.h = 1.3 * p.dx; p.rho0 = 1000; p.c0 = 10 * sqrt(2 * g * a);
  p.gravity[dim - 1] = -g; p.skin = 0.3 * p.dx;
  p.visc = SPHDEM_VISC_MORRIS; p.mu = 1e-3; p.xsph_eps = 0.3; p.tensile_eps = 0.01; p.delta = 0.1; p.delta_hydro = 1;
  p.rep_D = 5 * g * a; p.rep_r0 = p.dx;
  p.precision = g_prec;
  scene s;
  scene_tank(&s, &p, 3 * a, 0.5 * a, 3 * a, a, 2 * a, 3);
  sphdem_ctx c = scene_start(&p, &s, dev);
  double dt = 0.2 * p.h / (1.2 * p.c0);
  for (int n = 0; n < nsteps; n++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, xout, NULL, NULL, NULL, NULL));
  *nf = s.nf;
  printf("  %dD %s: %d fluid, %d wall particles, %lld sorts (%s)\n", dim, dev == SPHDEM_DEVICE_GPU ? "gpu" : "cpu", s.nf,
         s.nw, (long long)sphdem_nsorts(c), sphdem_backend_note(c));
  scene_free(&s);
  sphdem_destroy(&c);
}

/* Coupled case: 3D tank of still water, NG grains integrated here (velocity Verlet with the fluid force and
 * gravity, spin held), the fluid by the core. Outputs fluid x and rho, grain x and forces. */
#define NG 8
/* 1: also immersion 0.5, eps_walls and wall_porosity fluid; 2: pressure_form volume; 3: no rotational drag (the
 * CPU's grain pass then takes the kernel values from its pair lists) */
static int g_keywords = 0;
static void run_coupled(sphdem_device dev, int nsteps, double *xout, double *rout, double *gxo, double *gfo, int *nf) {
  double a = 0.1, g = 9.81;
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 3; p.dx = a / 12; p.h = 1.3 * p.dx; p.rho0 = 1000; p.c0 = 10 * sqrt(g * a);
  p.gravity[2] = -g; p.skin = 0.3 * p.dx;
  p.visc = SPHDEM_VISC_MORRIS; p.mu = 1e-3; p.xsph_eps = 0.3; p.delta = 0.1; p.delta_hydro = 1;
  scene s;
  scene_tank(&s, &p, a, 0.5 * a, 1.3 * a, a, a, 3);
  sphdem_ctx c = scene_start(&p, &s, dev);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3; cp.torque = g_keywords != 3;
  if (g_keywords == 1) { cp.immersion = 0.5; cp.eps_walls = 1; cp.wall_porosity = 1; }
  if (g_keywords == 2) cp.pressure_form = 1;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  double gx[3 * NG], gv[3 * NG] = {0}, gr[NG], om[3 * NG], f[3 * NG], m[NG];
  for (int j = 0; j < NG; j++) { /* a cluster, so that porosities overlap */
    gx[3 * j] = 0.4 * a + 0.03 * a * (j % 3); gx[3 * j + 1] = 0.2 * a + 0.04 * a * (j % 2);
    gx[3 * j + 2] = 0.6 * a + 0.035 * a * (j % 4);
    gr[j] = (0.25 + 0.05 * j) * p.dx;
    m[j] = 2500 * 4.0 / 3 * 3.14159265358979323846 * gr[j] * gr[j] * gr[j];
    for (int d = 0; d < 3; d++) om[3 * j + d] = 5.0 * (d + 1) * (j % 2 ? 1 : -1);
  }
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, NG, gx, gv, gr, om));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, NULL, NULL, NULL));
  double dt = 0.2 * p.h / (1.2 * p.c0);
  for (int n = 0; n < nsteps; n++) {
    for (int j = 0; j < NG; j++)
      for (int d = 0; d < 3; d++) {
        gv[3 * j + d] += 0.5 * dt * (f[3 * j + d] / m[j] + p.gravity[d]);
        gx[3 * j + d] += dt * gv[3 * j + d];
      }
    SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
    SPHDEM_CHECK_RC(c, sphdem_drift(c, dt));
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, NG, gx, gv, gr, om));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
    SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, NULL, NULL, NULL));
    for (int j = 0; j < NG; j++)
      for (int d = 0; d < 3; d++) gv[3 * j + d] += 0.5 * dt * (f[3 * j + d] / m[j] + p.gravity[d]);
  }
  double tq[3 * NG];
  SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, gfo, NULL, NULL, tq));
  memcpy(gfo + 3 * NG, tq, sizeof tq);
  memcpy(gxo, gx, sizeof gx);
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, xout, NULL, rout, NULL, NULL));
  *nf = s.nf;
  printf("  coupled %s: %d fluid, %d wall particles, %d grains (%s)\n", dev == SPHDEM_DEVICE_GPU ? "gpu" : "cpu",
         s.nf, s.nw, NG, sphdem_backend_note(c));
  scene_free(&s);
  sphdem_destroy(&c);
}

static double rel_diff(const double *a, const double *b, int n, double floor_) {
  double worst = 0;
  for (int i = 0; i < n; i++) {
    double e = fabs(a[i] - b[i]) / (fabs(a[i]) + floor_);
    if (e > worst) worst = e;
  }
  return worst;
}

int main(void) {
  /* SPHDEM_TWIN_SELFTEST=1 compares the CPU backend with itself, to exercise this test without a GPU (ctest
   * twin_cpu_selftest); with SPHDEM_CPU_GATHER=1 in the second run's environment it compares the CPU's own
   * paths (half pair lists, wall lists, coupling pair lists) with the gather passes and cell walks that the
   * GPU uses (see run()) */
  int self = getenv("SPHDEM_TWIN_SELFTEST") != NULL;
  sphdem_device other = self ? SPHDEM_DEVICE_CPU : SPHDEM_DEVICE_GPU;
  if (!self && !sphdem_gpu_available()) {
    return test_skip("twin: no usable GPU (or built without CUDA)");
  }
  for (int k = 0; k < 4; k++) {
    const int dim = 2 + k % 2;
    g_prec = k < 2 ? SPHDEM_PREC_DOUBLE : SPHDEM_PREC_MIXED;
    const double bound = k < 2 ? 1e-9 : 1e-7;
    static double xc[3 * 200000], xg[3 * 200000];
    int nc = 0, ng = 0;
    unsetenv("SPHDEM_CPU_GATHER");
    run(dim, SPHDEM_DEVICE_CPU, 100, xc, &nc);
    if (self) setenv("SPHDEM_CPU_GATHER", "1", 1);
    run(dim, other, 100, xg, &ng);
    unsetenv("SPHDEM_CPU_GATHER");
    TEST_ASSERT(nc == ng, "same particle count");
    double worst = 0;
    for (int i = 0; i < 3 * nc; i++) {
      double e = fabs(xc[i] - xg[i]) / (fabs(xc[i]) + 0.1);
      if (e > worst) worst = e;
    }
    printf("  %dD %s: max relative position difference CPU vs GPU after 100 steps: %.3e\n", dim,
           k < 2 ? "double" : "mixed", worst);
    TEST_ASSERT(worst < bound, "%dD %s: positions agree to %g relative (got %.3e)", dim, k < 2 ? "double" : "mixed",
                bound, worst);
  }
  g_prec = SPHDEM_PREC_DOUBLE;
  for (g_keywords = 0; g_keywords <= 3; g_keywords++) {
    static double xc[3 * 20000], xg[3 * 20000], rc[20000], rg[20000];
    double gxc[3 * NG], gxg[3 * NG], fc[6 * NG], fg[6 * NG], fbig = 0, tbig = 0;
    int nc = 0, ng = 0;
    unsetenv("SPHDEM_CPU_GATHER");
    run_coupled(SPHDEM_DEVICE_CPU, 100, xc, rc, gxc, fc, &nc);
    if (self) setenv("SPHDEM_CPU_GATHER", "1", 1);
    run_coupled(other, 100, xg, rg, gxg, fg, &ng);
    unsetenv("SPHDEM_CPU_GATHER");
    TEST_ASSERT(nc == ng, "same particle count");
    for (int i = 0; i < 3 * NG; i++) { fbig = fmax(fbig, fabs(fc[i])); tbig = fmax(tbig, fabs(fc[3 * NG + i])); }
    double ex = rel_diff(xc, xg, 3 * nc, 0.1), er = rel_diff(rc, rg, nc, 0.0), eg = rel_diff(gxc, gxg, 3 * NG, 0.1);
    double ef = rel_diff(fc, fg, 3 * NG, fbig), et = tbig > 0 ? rel_diff(fc + 3 * NG, fg + 3 * NG, 3 * NG, tbig) : 0.0;
    printf("  coupled%s: max relative difference after 100 steps: fluid x %.3e, fluid rho %.3e, grain x %.3e, grain "
           "force %.3e, torque %.3e (of the largest)\n", g_keywords == 1 ? " (immersion, eps_walls, wall_porosity)" : g_keywords == 2 ? " (pressure_form volume)" : g_keywords == 3 ? " (no torque)" : "",
           ex, er, eg, ef, et);
    TEST_ASSERT(fbig > 0 && (tbig > 0) == (g_keywords != 3), "coupled: grain forces (and torques where on) are non-zero");
    TEST_ASSERT(ex < 1e-9 && er < 1e-9 && eg < 1e-9, "coupled: fluid x, rho and grain x agree to 1e-9 (%.2e %.2e %.2e)",
                ex, er, eg);
    TEST_ASSERT(ef < 1e-9 && et < 1e-9, "coupled: grain forces and torques agree to 1e-9 (%.2e %.2e)", ef, et);
  }
  return test_summary("twin");
}
