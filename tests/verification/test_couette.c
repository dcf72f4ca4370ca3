/* test_couette.c - Couette start-up: the top wall moves at V0 (moving dummy walls, uploaded each
 * step with their velocity, He 2018 eqs 13-15) against the series solution of data/reference/closed_forms.md. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static double u_exact(double y, double t, const double *prm) {
  double V0 = prm[0], nu = prm[1], L = prm[2];
  double u = V0 * y / L;
  for (int n = 1; n < 400; n++)
    u += 2 * V0 / (n * M_PI) * (n % 2 ? -1.0 : 1.0) * sin(n * M_PI * y / L) * exp(-nu * n * n * M_PI * M_PI * t / (L * L));
  return u;
}

int main(int argc, char **argv) {
  int res = argc > 1 ? atoi(argv[1]) : 30;
  double L = 1e-3, nu = 1e-6, rho0 = 1000, V0 = 1.25e-5;
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.dx = L / res; p.h = 1.5 * p.dx; p.rho0 = rho0; p.c0 = 100 * V0;
  p.skin = 0.3 * p.dx;
  p.visc = SPHDEM_VISC_MORRIS; p.mu = nu * rho0;
  int nx = 20;
  double Lx = nx * p.dx;
  p.periodic[0] = 1; p.boxlo[0] = 0; p.boxhi[0] = Lx; p.boxlo[1] = -L; p.boxhi[1] = 2 * L;
  scene s;
  memset(&s, 0, sizeof s);
  double vol = p.dx * p.dx;
  for (int j = -4; j < res + 4; j++)
    for (int i = 0; i < nx; i++) {
      double x[3] = {(i + 0.5) * p.dx, (j + 0.5) * p.dx, 0};
      if (j < 0 || j >= res) {
        scene_push_wall(&s, x, rho0 * vol);
        if (j >= res) s.wv[3 * (s.nw - 1)] = V0; /* the moving lid */
      } else scene_push_fluid(&s, x, rho0, rho0 * vol);
    }
  sphdem_ctx c = scene_start(&p, &s, test_device());
  sphdem_stats st;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0, &st));
  double dt = 0.8 * st.dt_stable, t = 0, worst = 0;
  double times[] = {0.0225, 0.1125, 0.45};
  int k = 0;
  FILE *out = fopen("couette_profiles.csv", "w");
  fprintf(out, "t,y,u_sim,u_exact\n");
  printf("  %d fluid, %d wall particles (lid moving at %g m/s), dt %.3g s; L2 error relative to V0:\n", s.nf, s.nw,
         V0, dt);
  while (k < 3) {
    SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
    SPHDEM_CHECK_RC(c, sphdem_drift(c, dt));
    /* the engine's fix move: lid positions advance, re-uploaded with their velocity every step */
    for (int w = 0; w < s.nw; w++) s.wx[3 * w] += s.wv[3 * w] * dt;
    SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
    t += dt;
    if (t + 0.5 * dt < times[k]) continue;
    SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &st));
    double prm[3] = {V0, nu, L}, l2 = scene_profile_l2(c, s.nf, t, V0, p.dx, out, u_exact, prm);
    if (l2 > worst) worst = l2;
    k++;
  }
  fclose(out);
  TEST_ASSERT(worst < 0.02, "Couette profiles within 2%% of V0 in L2 at all times (worst %.2f%%)", 100 * worst);
  scene_free(&s);
  sphdem_destroy(&c);
  return test_summary("couette");
}
