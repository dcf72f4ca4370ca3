/* test_poiseuille.c - plane Poiseuille start-up (Morris, Fox & Zhu 1997): Morris viscosity (He 2018
 * eq 10) with no-slip Adami walls (eq 13) against the series solution of data/reference/closed_forms.md.
 * Usage: verify_poiseuille [RES]; h/dx 1.5 (1.3 gives ~3 % at steady state). */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static double u_exact(double y, double t, const double *prm) {
  double F = prm[0], nu = prm[1], L = prm[2];
  double u = F / (2 * nu) * y * (L - y);
  for (int n = 0; n < 200; n++) {
    double k = 2 * n + 1;
    u -= 4 * F * L * L / (nu * M_PI * M_PI * M_PI * k * k * k) * sin(k * M_PI * y / L) *
         exp(-k * k * M_PI * M_PI * nu * t / (L * L));
  }
  return u;
}

int main(int argc, char **argv) {
  int res = argc > 1 ? atoi(argv[1]) : 30;
  double L = 1e-3, nu = 1e-6, rho0 = 1000, F = 1e-4, umax = F * L * L / (8 * nu);
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.dx = L / res; p.h = 1.5 * p.dx; p.rho0 = rho0; p.c0 = 10 * umax * 10;
  p.gravity[0] = F; p.skin = 0.3 * p.dx;
  p.visc = SPHDEM_VISC_MORRIS; p.mu = nu * rho0;
  double Lx = 20 * p.dx;
  p.periodic[0] = 1; p.boxlo[0] = 0; p.boxhi[0] = Lx; p.boxlo[1] = -L; p.boxhi[1] = 2 * L;
  scene s;
  memset(&s, 0, sizeof s);
  double vol = p.dx * p.dx;
  for (int j = -3; j < res + 3; j++)
    for (int i = 0; i < 20; i++) {
      double x[3] = {(i + 0.5) * p.dx, (j + 0.5) * p.dx, 0};
      if (j < 0 || j >= res) scene_push_wall(&s, x, rho0 * vol);
      else scene_push_fluid(&s, x, rho0, rho0 * vol);
    }
  sphdem_ctx c = scene_start(&p, &s, test_device());
  sphdem_stats st;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0, &st));
  double dt = 0.8 * st.dt_stable;
  double times[] = {0.0225, 0.045, 0.1125, 0.225, 1.0};
  int nt = 5, k = 0;
  double t = 0, worst_late = 0;
  FILE *out = fopen("poiseuille_profiles.csv", "w");
  fprintf(out, "t,y,u_sim,u_exact\n");
  printf("  %d fluid particles, dt %.3g s (viscous limit); L2 error relative to u_max:\n", s.nf, dt);
  while (k < nt) {
    SPHDEM_CHECK_RC(c, scene_step(c, dt));
    t += dt;
    if (t + 0.5 * dt < times[k]) continue;
    SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &st));
    double prm[3] = {F, nu, L}, l2 = scene_profile_l2(c, s.nf, t, umax, p.dx, out, u_exact, prm);
    if (t > 0.1 && l2 > worst_late) worst_late = l2;
    TEST_ASSERT(l2 < 0.05, "profile at t = %.4f within 5%% of u_max in L2 (got %.2f%%)", t, 100 * l2);
    k++;
  }
  fclose(out);
  TEST_ASSERT(worst_late < 0.02, "developed profile (t > 0.1 s) within 2%% of u_max in L2 (got %.2f%%)", 100 * worst_late);
  scene_free(&s);
  sphdem_destroy(&c);
  return test_summary("poiseuille");
}
