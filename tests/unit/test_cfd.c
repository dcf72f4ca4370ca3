/* test_cfd.c - the gas grid of CFD-DEM (sphdem_cfd_*): parameter checks, the drag laws against their
 * closed forms, uniform flow and hydrostatic pressure in an empty column (along z and along x), mass
 * conservation and Newton's third law with moving grains (both voidage methods), solid volume kept by
 * the voidage, buoyancy of grains at rest (model A), plane Poiseuille flow between no-slip walls. */
#include <math.h>
#define TEST_RNG_SEED 0x2545F4914F6CDD1Dull
#include "testlib.h"

/* column nx x ny x nz of cells h, inflow along axis a from its low side, outlet at its high side, slip elsewhere */
static void column(sphdem_cfd_params *p, int a, int nx, int ny, int nz, double h, double U) {
  sphdem_cfd_params_default(p);
  p->nc[0] = nx; p->nc[1] = ny; p->nc[2] = nz;
  for (int d = 0; d < 3; d++) { p->boxlo[d] = -0.1 * d; p->boxhi[d] = p->boxlo[d] + h * p->nc[d]; }
  for (int s = 0; s < 6; s++) p->bc[s] = SPHDEM_CFD_SLIP;
  p->bc[2 * a] = SPHDEM_CFD_INLET;
  p->inlet_u[2 * a] = U;
  p->bc[2 * a + 1] = SPHDEM_CFD_OUTLET;
}

static void test_params(void) {
  sphdem_cfd_params p;
  char msg[512];
  sphdem_cfd_params_default(&p);
  int rc = sphdem_cfd_params_check(&p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "outlet"), "closed box rejected naming the outlet (%s)", msg);
  column(&p, 2, 2, 2, 4, 0.01, 1.0);
  TEST_ASSERT(sphdem_cfd_params_check(&p, msg, sizeof msg) == SPHDEM_OK, "column accepted (%s)", msg);
  p.drag = 7;
  rc = sphdem_cfd_params_check(&p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "drag") && strstr(msg, "gidaspow"), "bad drag named (%s)", msg);
  column(&p, 2, 2, 2, 4, 0.01, 1.0);
  p.npatch = 1;
  p.patch[0].side = 5;
  p.patch[0].hi[0] = p.patch[0].hi[1] = 1;
  rc = sphdem_cfd_params_check(&p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "patch") && strstr(msg, "inlet"), "patch on an outlet (%s)", msg);
  column(&p, 2, 2, 2, 4, 0.01, 1.0);
  p.eps_min = 1.5;
  rc = sphdem_cfd_params_check(&p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "eps_min"), "eps_min named (%s)", msg);
  /* cell counts whose product overflows int64 (2^21 cubed is 2^63) are refused, not wrapped past the limit */
  const int huge[4][3] = {{2097152, 2097152, 2097152}, {2147483647, 2147483647, 2}, {8193, 8192, 1}, {2147483647, 1, 1}};
  for (int k = 0; k < 4; k++) {
    column(&p, 2, huge[k][0], huge[k][1], huge[k][2], 1e-9, 1.0);
    rc = sphdem_cfd_params_check(&p, msg, sizeof msg);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "cells exceed the limit"), "%d x %d x %d cells refused (%s)",
                huge[k][0], huge[k][1], huge[k][2], msg);
    sphdem_cfd c = NULL;
    rc = sphdem_cfd_create(&c, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg);
    TEST_ASSERT(rc == SPHDEM_ERR_ARG && c == NULL && strstr(msg, "cells exceed the limit"),
                "create with %d x %d x %d cells refused (%s)", huge[k][0], huge[k][1], huge[k][2], msg);
  }
  if (!sphdem_gpu_available()) {
    column(&p, 2, 2, 2, 4, 0.01, 1.0);
    sphdem_cfd c;
    rc = sphdem_cfd_create(&c, &p, SPHDEM_DEVICE_GPU, msg, sizeof msg);
    TEST_ASSERT(rc == SPHDEM_ERR_NO_GPU && c == NULL && strstr(msg, "gpu"), "device gpu without one (%s)", msg);
  }
}

static void test_drag(void) {
  double rho = 1.2, mu = 1.8e-5, d = 1e-3, Vp = M_PI / 6 * d * d * d;
  for (double eps = 0.4; eps <= 0.8; eps += 0.2)
    for (double s = 0.01; s < 5; s *= 10) {
      double beta = 150 * (1 - eps) * (1 - eps) * mu / (eps * d * d) + 1.75 * (1 - eps) * rho * s / d;
      double K = sphdem_cfd_drag_coef(SPHDEM_CFD_DRAG_GIDASPOW, eps, s, d, rho, mu);
      TEST_ASSERT(fabs(K - beta * Vp / (1 - eps)) <= 1e-12 * K, "Ergun branch eps %g slip %g: %g vs %g", eps, s, K,
                  beta * Vp / (1 - eps));
    }
  /* a lone grain: Schiller-Naumann drag 3 pi mu d s (1 + 0.15 Re^0.687) */
  for (double s = 1e-3; s < 10; s *= 7) {
    double re = rho * s * d / mu;
    double f = sphdem_cfd_drag_coef(SPHDEM_CFD_DRAG_GIDASPOW, 1.0, s, d, rho, mu) * s;
    double ref = re < 1000 ? 3 * M_PI * mu * d * s * (1 + 0.15 * pow(re, 0.687))
                           : 0.44 * 0.5 * rho * s * s * M_PI * d * d / 4;
    TEST_ASSERT(fabs(f - ref) <= 1e-12 * ref, "single sphere Re %g: %g vs %g", re, f, ref);
  }
  /* Wen-Yu voidage function eps^-2.65 on beta (K carries eps^-1.65) */
  double K1 = sphdem_cfd_drag_coef(SPHDEM_CFD_DRAG_WENYU, 1.0, 1e-3, d, rho, mu);
  double K5 = sphdem_cfd_drag_coef(SPHDEM_CFD_DRAG_WENYU, 0.5, 2e-3, d, rho, mu); /* same Re */
  TEST_ASSERT(fabs(K5 / K1 - pow(0.5, -2.65)) < 1e-12 * K5 / K1, "Wen-Yu voidage function %g", K5 / K1);
  TEST_ASSERT(sphdem_cfd_drag_coef(SPHDEM_CFD_DRAG_NONE, 0.5, 1.0, d, rho, mu) == 0.0, "drag none");
}

/* empty column: one step gives the inflow everywhere and hydrostatic pressure */
/* a gas context on the backend under test after nsteps steps of dt without grains (create and steps asserted);
 * NULL where the create failed */
static sphdem_cfd gas_alone(const sphdem_cfd_params *p, int nsteps, double dt) {
  sphdem_cfd c;
  char msg[512];
  int rc = sphdem_cfd_create(&c, p, test_device(), msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "create: %s", msg);
  if (rc) return NULL;
  for (int s = 0; s < nsteps && !rc; s++) rc = sphdem_cfd_step(c, dt, 0, NULL, NULL, NULL, NULL, NULL);
  TEST_ASSERT(rc == SPHDEM_OK, "steps: %s", sphdem_cfd_last_error(c));
  return c;
}

static void test_empty(int a) {
  sphdem_cfd_params p;
  int nc[3] = {3, 4, 5};
  nc[a] = 12;
  double h = 0.01, U = 0.7, H = 12 * h;
  column(&p, a, nc[0], nc[1], nc[2], h, U);
  for (int d = 0; d < 3; d++) p.gravity[d] = 0;
  p.gravity[a] = -9.81;
  sphdem_cfd c = gas_alone(&p, 3, 1e-3);
  if (!c) return;
  int64_t n = (int64_t)nc[0] * nc[1] * nc[2];
  double *pp = malloc(sizeof(double) * n), *u = malloc(sizeof(double) * 3 * n), *eps = malloc(sizeof(double) * n);
  sphdem_cfd_get_fields(c, eps, pp, u);
  double eu = 0, ep = 0, ee = 0;
  for (int k = 0; k < nc[2]; k++)
    for (int j = 0; j < nc[1]; j++)
      for (int i = 0; i < nc[0]; i++) {
        int ix[3] = {i, j, k};
        int64_t ci = i + nc[0] * (j + (int64_t)nc[1] * k);
        for (int d = 0; d < 3; d++) eu = fmax(eu, fabs(u[3 * ci + d] - (d == a ? U : 0.0)));
        double z = (ix[a] + 0.5) * h;
        ep = fmax(ep, fabs(pp[ci] - 1.2 * 9.81 * (H - z)));
        ee = fmax(ee, fabs(eps[ci] - 1.0));
      }
  sphdem_cfd_stats S;
  sphdem_cfd_stats_get(c, &S);
  TEST_ASSERT(eu < 1e-9 * U, "axis %d: uniform inflow everywhere (max dev %.3g)", a, eu);
  TEST_ASSERT(ep < 1e-8 * 1.2 * 9.81 * H, "axis %d: hydrostatic gas pressure (max dev %.3g Pa)", a, ep);
  TEST_ASSERT(ee == 0.0, "axis %d: no grains, voidage 1", a);
  TEST_ASSERT(S.flow_axis == a && fabs(S.dp - 1.2 * 9.81 * 11 * h) < 1e-8, "axis %d: dp %.6g", a, S.dp);
  TEST_ASSERT(S.mass_err < 1e-10, "axis %d: mass error %.3g", a, S.mass_err);
  free(pp); free(u); free(eps);
  sphdem_cfd_destroy(&c);
}

/* moving grains: mass conservation, Newton's third law, solid volume, for both voidage methods */
static void test_grains(int voidage, int drag) {
  sphdem_cfd_params p;
  column(&p, 2, 6, 4, 16, 0.004, 0.8);
  p.bc[0] = p.bc[1] = SPHDEM_CFD_NOSLIP;
  p.voidage = voidage;
  p.drag = drag;
  p.npatch = 1;
  p.patch[0].side = 4;
  p.patch[0].lo[0] = 0.008; p.patch[0].hi[0] = 0.016;
  p.patch[0].lo[1] = -0.1; p.patch[0].hi[1] = 0.0;
  p.patch[0].u = 3.0;
  sphdem_cfd c;
  char msg[512];
  int rc = sphdem_cfd_create(&c, &p, test_device(), msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "create: %s", msg);
  if (rc) return;
  int n = 900;
  double *x = malloc(sizeof(double) * 3 * n), *v = malloc(sizeof(double) * 3 * n), *r = malloc(sizeof(double) * n);
  double *fd = malloc(sizeof(double) * 3 * n), *fp = malloc(sizeof(double) * 3 * n);
  double vs = 0;
  for (int i = 0; i < n; i++) {
    r[i] = 0.0005 * (0.8 + 0.4 * urand());
    vs += 4.0 / 3.0 * M_PI * r[i] * r[i] * r[i];
    for (int d = 0; d < 3; d++) {
      x[3 * i + d] = p.boxlo[d] + (p.boxhi[d] - p.boxlo[d]) * (d == 2 ? 0.5 : 1.0) * urand();
      v[3 * i + d] = 0.2 * (urand() - 0.5);
    }
  }
  double worst_mass = 0, worst_newton = 0, worst_vol = 0;
  int64_t ncell = 6 * 4 * 16;
  double *eps = malloc(sizeof(double) * ncell);
  for (int s = 0; s < 40 && !rc; s++) {
    for (int i = 0; i < 3 * n; i++) x[i] += 2e-4 * v[i];
    for (int i = 0; i < n; i++)
      for (int d = 0; d < 3; d++) { /* stay inside */
        double lo = p.boxlo[d] + 1e-4, hi = p.boxhi[d] - 1e-4;
        if (x[3 * i + d] < lo) { x[3 * i + d] = lo; v[3 * i + d] = fabs(v[3 * i + d]); }
        if (x[3 * i + d] > hi) { x[3 * i + d] = hi; v[3 * i + d] = -fabs(v[3 * i + d]); }
      }
    rc = sphdem_cfd_step(c, 2e-4, n, x, v, r, fd, fp);
    if (rc) break;
    sphdem_cfd_stats S;
    sphdem_cfd_stats_get(c, &S);
    worst_mass = fmax(worst_mass, S.mass_err);
    double fn = 0, fs = 0;
    for (int d = 0; d < 3; d++) {
      fn = fmax(fn, fabs(S.f_grains[d] + S.f_gas[d] - S.f_bound[d]));
      fs = fmax(fs, fabs(S.f_grains[d]) + fabs(S.f_gas[d]));
    }
    worst_newton = fmax(worst_newton, fn / fs);
    sphdem_cfd_get_fields(c, eps, NULL, NULL);
    double sol = 0, Vc = 0.004 * 0.004 * 0.004;
    for (int64_t k = 0; k < ncell; k++) sol += (1 - eps[k]) * Vc;
    worst_vol = fmax(worst_vol, fabs(sol - vs) / vs);
  }
  TEST_ASSERT(rc == SPHDEM_OK, "voidage %d drag %d: steps ran (%s)", voidage, drag, sphdem_cfd_last_error(c));
  TEST_ASSERT(worst_mass < 1e-7, "voidage %d drag %d: |div(eps u) + deps/dt| dt <= %.3g", voidage, drag, worst_mass);
  TEST_ASSERT(worst_newton < 1e-12, "voidage %d drag %d: grains + gas - boundary share = %.3g of the forces", voidage,
              drag, worst_newton);
  TEST_ASSERT(worst_vol < 1e-12, "voidage %d: solid volume kept (%.3g)", voidage, worst_vol);
  printf("  voidage %d drag %d: mass %.2e, Newton %.2e, volume %.2e\n", voidage, drag, worst_mass, worst_newton,
         worst_vol);
  free(x); free(v); free(r); free(fd); free(fp); free(eps);
  sphdem_cfd_destroy(&c);
}

/* grains at rest in still gas: the pressure gradient is rho_g g in every cell, the force on a grain is its
 * buoyancy -V rho_g g (model A), the drag is zero */
static void test_buoyancy(void) {
  sphdem_cfd_params p;
  column(&p, 2, 4, 4, 10, 0.005, 0.0);
  p.bc[4] = SPHDEM_CFD_NOSLIP;
  sphdem_cfd c;
  char msg[512];
  int rc = sphdem_cfd_create(&c, &p, test_device(), msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "create: %s", msg);
  if (rc) return;
  int n = 300;
  double *x = malloc(sizeof(double) * 3 * n), *v = calloc(3 * n, sizeof(double)), *r = malloc(sizeof(double) * n);
  double *fd = malloc(sizeof(double) * 3 * n), *fp = malloc(sizeof(double) * 3 * n);
  for (int i = 0; i < n; i++) {
    r[i] = 0.001;
    for (int d = 0; d < 3; d++) x[3 * i + d] = p.boxlo[d] + (p.boxhi[d] - p.boxlo[d]) * (d == 2 ? 0.6 : 1.0) * urand();
  }
  for (int s = 0; s < 3 && !rc; s++) rc = sphdem_cfd_step(c, 1e-3, n, x, v, r, fd, fp);
  TEST_ASSERT(rc == SPHDEM_OK, "steps: %s", sphdem_cfd_last_error(c));
  double V = 4.0 / 3.0 * M_PI * 1e-9, ref = V * 1.2 * 9.81, eb = 0, efd = 0;
  for (int i = 0; i < n; i++) {
    eb = fmax(eb, fabs(fp[3 * i + 2] - ref) + fabs(fp[3 * i]) + fabs(fp[3 * i + 1]));
    for (int d = 0; d < 3; d++) efd = fmax(efd, fabs(fd[3 * i + d]));
  }
  TEST_ASSERT(eb < 1e-9 * ref, "buoyancy of resting grains: max dev %.3g of %.3g", eb, ref);
  TEST_ASSERT(efd < 1e-9 * ref, "no drag at rest: %.3g", efd);
  free(x); free(v); free(r); free(fd); free(fp);
  sphdem_cfd_destroy(&c);
}

/* plane Poiseuille flow between no-slip walls at x = 0, W (slip in y), inflow U from zlo: the developed
 * profile near the outlet is u = 6 U (x/W)(1 - x/W) */
static void test_poiseuille(void) {
  sphdem_cfd_params p;
  int nx = 16;
  double W = 0.01, h = W / nx;
  column(&p, 2, nx, 1, 48, h, 0.1);
  p.bc[0] = p.bc[1] = SPHDEM_CFD_NOSLIP;
  p.rho_g = 1.0;
  p.mu_g = 1e-4;
  p.gravity[2] = 0;
  sphdem_cfd c = gas_alone(&p, 3000, 4e-4);
  if (!c) return;
  int64_t n = (int64_t)nx * 48;
  double *u = malloc(sizeof(double) * 3 * n);
  sphdem_cfd_get_fields(c, NULL, NULL, u);
  double e2 = 0, r2 = 0;
  int k = 40;
  for (int i = 0; i < nx; i++) {
    double xc = (i + 0.5) * h, ref = 6 * 0.1 * xc / W * (1 - xc / W);
    double uz = u[3 * (i + (int64_t)nx * k) + 2];
    e2 += (uz - ref) * (uz - ref);
    r2 += ref * ref;
  }
  double l2 = sqrt(e2 / r2);
  printf("  Poiseuille: L2 error of the profile %.3g %%\n", 100 * l2);
  TEST_ASSERT(l2 < 0.01, "Poiseuille profile L2 error %.3g (bound 1 %%)", l2);
  /* a gas step beyond the viscous limit is refused with a message */
  int rc = sphdem_cfd_step(c, 0.002, 0, NULL, NULL, NULL, NULL, NULL);
  TEST_ASSERT(rc == SPHDEM_ERR_UNSTABLE && strstr(sphdem_cfd_last_error(c), "viscous"), "viscous limit: %s",
              sphdem_cfd_last_error(c));
  free(u);
  sphdem_cfd_destroy(&c);
}

/* grains far outside the gas box (1e300 m) are clamped into the boundary cells, no int overflow */
static void test_far_grains(void) {
  sphdem_cfd_params p;
  column(&p, 2, 3, 3, 6, 0.01, 0.5);
  sphdem_cfd c;
  char msg[512];
  int rc = sphdem_cfd_create(&c, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "create: %s", msg);
  if (rc) return;
  double x[6] = {1e300, 0.015, -1e300, 0.015, 0.015 - 0.1, 0.03 - 0.2}, v[6] = {0}, r[2] = {1e-3, 1e-3};
  double fd[6], fp[6];
  rc = sphdem_cfd_step(c, 1e-4, 2, x, v, r, fd, fp);
  int finite = 1;
  for (int k = 0; k < 6; k++) finite &= isfinite(fd[k]) && isfinite(fp[k]);
  sphdem_cfd_stats S;
  sphdem_cfd_stats_get(c, &S);
  TEST_ASSERT(rc == SPHDEM_OK && finite && S.eps_min > 0.0 && S.eps_min < 1.0,
              "grain at 1e300: rc %d (%s), forces finite %d, eps_min %g", rc, sphdem_cfd_last_error(c), finite, S.eps_min);
  sphdem_cfd_destroy(&c);
}

int main(void) {
  test_params();
  test_far_grains();
  test_drag();
  for (int a = 0; a < 3; a++) test_empty(a);
  test_grains(SPHDEM_CFD_VOID_CENTROID, SPHDEM_CFD_DRAG_GIDASPOW);
  test_grains(SPHDEM_CFD_VOID_SMOOTH, SPHDEM_CFD_DRAG_GIDASPOW);
  test_grains(SPHDEM_CFD_VOID_SMOOTH, SPHDEM_CFD_DRAG_WENYU);
  test_buoyancy();
  test_poiseuille();
  return test_summary("unit_cfd");
}
