/* test_settling.c - one sphere settling in still water in a 3D tank (unresolved SPH-DEM, He 2018 §2.3).
 * The fluid is the core's; the grain is integrated here (velocity Verlet with the fluid force of
 * sphdem_get_grain_forces + gravity). Terminal velocity vs the Schiller-Naumann/Archimedes closed form of
 * data/reference/closed_forms.md ("Single sphere settling": dv/dt = g (rho_p - rho_f)/rho_p
 * - 3/4 rho_f |v| v C_D / (d rho_p), C_D = 24/Re (1 + 0.15 Re^0.687)), for two diameters and two density
 * ratios, asserted within 3 %. Water (rho 1000, mu 1e-3), h = 2 mm, grains 0.2 and 0.3 mm (d/h 0.1-0.15),
 * Re 1.8-12: the regime where the unresolved model holds (grain much smaller than the kernel).
 * The fluid (Morris viscosity mu = 1e-3, delta-SPH 0.1) is first relaxed to rest without the grain by kinetic
 * damping; the grain is then released at rest at 0.6 of the depth.
 * Writes settling_v.csv (case, t, v_sim, v_ode, u_fluid = -v_z of the fluid at the grain, probed); plot:
 * plot_settling.py beside this file.
 * Usage: verify_settling [T_END after release, default 0.04 s]. Scene: h/dx 1.3, fluid block 8 x 8 x 10
 * particles, 650 relaxation steps, superficial formulation on (the default). */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static const double g = 9.81, rhof = 1000.0, muf = 1e-3;

static double cd_sn(double re) { return re <= 1000 ? 24.0 / re * (1 + 0.15 * pow(re, 0.687)) : 0.44; }

/* right-hand side of the reference ODE (settling speed s = -v_z >= 0) */
static double ode_rhs(double s, double d, double rhop) {
  double re = rhof * d * fabs(s) / muf;
  double drag = re > 0 ? 0.75 * rhof * s * fabs(s) * cd_sn(re) / (d * rhop) : 0.0;
  return g * (rhop - rhof) / rhop - drag;
}

static double terminal(double d, double rhop) {
  double lo = 0, hi = 10;
  for (int i = 0; i < 200; i++) {
    double m = 0.5 * (lo + hi);
    if (ode_rhs(m, d, rhop) > 0) lo = m; else hi = m;
  }
  return 0.5 * (lo + hi);
}

int main(int argc, char **argv) {
  double h = 0.002, dx = h / 1.3;
  int nx = 8, nz = 10;
  double W = nx * dx, H = nz * dx;
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 3; p.dx = dx; p.h = h; p.rho0 = rhof; p.c0 = 10 * sqrt(g * H);
  p.gravity[2] = -g; p.skin = 0.3 * dx;
  p.visc = SPHDEM_VISC_MORRIS; p.mu = muf;
  p.delta = 0.1; p.delta_hydro = 1;
  for (int d = 0; d < 3; d++) { p.boxlo[d] = -4 * dx; p.boxhi[d] = (d == 2 ? 2 * H : W) + 4 * dx; }
  scene s;
  scene_tank(&s, &p, W, W, H + 2 * dx, W, H, 3);
  double dt = 0.2 * h / (1.2 * p.c0);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = SPHDEM_DRAG_SCHILLER_NAUMANN; cp.mu = muf;

  /* relax the fluid to rest, coupling on, no grain: kinetic damping (velocities zeroed whenever the kinetic
   * energy passes a maximum), then free steps */
  sphdem_ctx c = scene_start(&p, &s, test_device());
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  int nf = s.nf;
  double *x = malloc(24 * (size_t)nf), *v = malloc(24 * (size_t)nf), *rho = malloc(8 * (size_t)nf);
  double *st = malloc(8 * SPHDEM_NSTATE * (size_t)nf);
  int nrelax = 650, nfree = 30;
  double ke_prev = 0;
  for (int n = 1; n <= nrelax; n++) {
    SPHDEM_CHECK_RC(c, scene_step(c, dt));
    sphdem_stats rs;
    SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &rs));
    int peak = rs.ke < ke_prev;
    ke_prev = rs.ke;
    if (peak && n <= nrelax - nfree) {
      ke_prev = 0;
      SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, v, rho, NULL, st));
      memset(v, 0, 24 * (size_t)nf);
      for (int i = 0; i < nf; i++) for (int d = 0; d < 3; d++) st[SPHDEM_NSTATE * i + 4 + d] = 0.0;
      SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, nf, s.tag, x, v, rho, s.mass, st));
    }
  }
  sphdem_stats fs;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &fs));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, v, rho, NULL, st));
  sphdem_destroy(&c);
  printf("  tank %.1f x %.1f x %.1f mm, h %.1f mm, %d fluid + %d wall particles, dt %.2e s; after %d relaxation "
         "steps vmax %.2e m/s\n", 1e3 * W, 1e3 * W, 1e3 * H, 1e3 * h, nf, s.nw, dt, nrelax, fs.vmax);

  double t_end = argc > 1 ? atof(argv[1]) : 0.04;
  int nsteps = (int)ceil(t_end / dt);
  double dcase[4] = {0.2e-3, 0.3e-3, 0.2e-3, 0.3e-3}, rcase[4] = {2500, 2500, 1500, 1500};
  FILE *out = fopen("settling_v.csv", "w");
  fprintf(out, "case,d,rho_p,t,v_sim,v_ode,u_fluid\n");
  double worst = 0;
  for (int k = 0; k < 4; k++) {
    double d = dcase[k], rp = rcase[k], r = 0.5 * d, V = M_PI * d * d * d / 6, m = rp * V;
    c = scene_start(&p, &s, test_device());
    SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
    SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, nf, s.tag, x, v, rho, s.mass, st));
    double gx[3] = {0.5 * W, 0.5 * W, 0.6 * H}, gv[3] = {0, 0, 0}, f[3], fd[3], fp[3];
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 1, gx, gv, &r, NULL));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, fd, fp, NULL));
    double buoy = fp[2] / (rhof * V * g);
    double sode = 0, vt = terminal(d, rp), vavg = 0, uavg = 0;
    int navg = 0;
    for (int n = 1; n <= nsteps; n++) {
      /* grain: velocity Verlet, forces at the half-step velocity as for the fluid */
      for (int e = 0; e < 3; e++) gv[e] += 0.5 * dt * (f[e] / m + p.gravity[e]);
      for (int e = 0; e < 3; e++) gx[e] += dt * gv[e];
      SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
      SPHDEM_CHECK_RC(c, sphdem_drift(c, dt));
      SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 1, gx, gv, &r, NULL));
      SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
      SPHDEM_CHECK_RC(c, sphdem_kick(c, 0.5 * dt));
      SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, fd, fp, NULL));
      for (int e = 0; e < 3; e++) gv[e] += 0.5 * dt * (f[e] / m + p.gravity[e]);
      /* reference ODE, RK4 on the same step */
      double k1 = ode_rhs(sode, d, rp), k2 = ode_rhs(sode + 0.5 * dt * k1, d, rp);
      double k3 = ode_rhs(sode + 0.5 * dt * k2, d, rp), k4 = ode_rhs(sode + dt * k3, d, rp);
      sode += dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      double u = 0;
      if (n % 10 == 0 || n > nsteps - 50) {
        double pr[SPHDEM_NPROBE];
        SPHDEM_CHECK_RC(c, sphdem_probe(c, 1, gx, pr));
        u = pr[4];
        if (n % 10 == 0) fprintf(out, "%d,%g,%g,%.6e,%.6e,%.6e,%.6e\n", k, d, rp, n * dt, -gv[2], sode, -u);
      }
      if (n > nsteps - 50) { vavg += -gv[2]; uavg += -u; navg++; }
    }
    vavg /= navg; uavg /= navg;
    double err = fabs(vavg - vt) / vt;
    worst = fmax(worst, err);
    printf("  d %.1f mm, rho_p/rho_f %.1f: Re %.2f, buoyancy at release %.4f rho_f V g; terminal v %.5f m/s vs "
           "closed form %.5f (%+.2f%%); ODE at t_end %.5f; fluid velocity at the grain %.2e m/s (%.2f%% of v)\n",
           1e3 * d, rp / rhof, rhof * d * vt / muf, buoy, vavg, vt, 100 * (vavg - vt) / vt, sode, uavg, 100 * uavg / vavg);
    TEST_ASSERT(err < 0.03, "d %.1f mm rho_p %.0f: terminal velocity within 3%% of Schiller-Naumann (got %.2f%%)",
                1e3 * d, rp, 100 * err);
    TEST_ASSERT(fabs(sode - vt) / vt < 1e-3, "the reference ODE reached its terminal velocity by t_end");
    sphdem_destroy(&c);
  }
  fclose(out);
  printf("  worst terminal-velocity error %.2f%% (settling_v.csv)\n", 100 * worst);
  free(x); free(v); free(rho); free(st);
  scene_free(&s);
  return test_summary("settling");
}
