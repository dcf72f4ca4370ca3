/* test_mp_poiseuille.c - two-phase plane Poiseuille flow (Shi & Huang 2022 §5.2): two layers of
 * equal density 1 kg/m^3, 1 m each, between no-slip walls y = 0 and y = 2 m, periodic in x, driven by
 * a body force of 2 m/s^2. Phase A (y < 1 m) Newtonian mu_A = 1 Pa s; phase B Newtonian with
 * mu_A/mu_B = 1..10, or phase A Bingham / power-law against Newtonian phase B (mu_B = 1).
 * The steady profile is the solution of tau(y) = tau0 - G y with du/dy from each layer's rheology and
 * u = 0 on both walls (data/reference/closed_forms.md "Two-layer plane Poiseuille"; for the non-Newtonian layer
 * the semi-analytical construction of Xenakis et al. 2015 that the paper cites), computed here by
 * bisection on tau0: once with the exact Herschel-Bulkley law, once with the law the solver uses
 * (viscosity held at its cut-off value below the cut-off shear rate, eq 23).
 *
 * Usage: verify_mp_poiseuille [newtonian|convergence|hb|hb_bingham|hb_power|rk4|all|accuracy] [TEND] [rk4|mls] (mls: fixed ghost
 * walls with MLS interpolation, Shi & Huang §3.4, instead of the Adami walls). accuracy (not in "all"):
 * the bench table mp_accuracy.csv (bench/mp_accuracy.py). rk4: mu_A/mu_B = 4 at res 20
 * with Runge-Kutta steps against velocity Verlet (same bound). precision (not in "all"): mu_A/mu_B = 4 at res 20,
 * the tests' terms (renormalised diffusion) and the delta-plus terms (with shifting), in the precisions mixed and
 * single against double: the L2 difference of the velocity profiles within 0.1 % (mixed) and 1 % (single) of
 * double's, each L2 against the exact profile within 2 %.  Writes mp_poiseuille.csv
 * (case, res, y, u_sim, u_exact, u_cutoff) and mp_poiseuille_MODE_summary.csv. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

#include <time.h>

static int use_rk4 = 0; /* third argument rk4: Runge-Kutta steps instead of velocity Verlet */
static int use_mls = 0; /* third argument mls: fixed ghost walls with MLS interpolation (§3.4) */
/* terms: -1 the tests' setting (renormalised diffusion, no shifting); 0 plain (neither); 1 delta-plus (both) */
static int terms = -1;
static double last_wall = 0; /* wall-clock seconds of the last run_case time loop */
static int precision = SPHDEM_PREC_DOUBLE; /* sphdem_params.precision of run_case */
static double *last_v = NULL;              /* the last run_case's final fluid velocities (3 per particle) */
static int last_nf = 0;

static double wall_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define H 2.0
#define A 1.0
#define G 2.0

typedef struct {
  const char *name;
  sphdem_phase ph[2];
} mp_case;

/* du/dy of a layer at shear stress tau: exact Herschel-Bulkley (cut == 0) or the solver's law, whose
 * viscosity below gdot_cut is mu_cut (cut == 1). */
static double shear_rate(const sphdem_phase *f, double tau, int cut) {
  double s = tau < 0 ? -1.0 : 1.0, t = fabs(tau);
  if (cut && (f->tau_y > 0 || f->N != 1.0) && f->gdot_cut > 0) {
    double mu_c = sphdem_mp_viscosity(f, f->gdot_cut);
    if (t <= mu_c * f->gdot_cut) return s * t / mu_c;
  }
  if (t <= f->tau_y) return 0.0;
  return s * pow((t - f->tau_y) / f->K, 1.0 / f->N);
}

/* u(y) on n points y_k = (k + 0.5) H / n for a given tau0 (trapezoid on a fine grid); returns u(H). */
static double integrate_profile(const mp_case *c, int cut, double tau0, int nfine, double *u) {
  double dy = H / nfine, uu = 0.0;
  for (int k = 0; k < nfine; k++) {
    double y0 = k * dy, y1 = y0 + dy, ym = y0 + 0.5 * dy;
    const sphdem_phase *f = &c->ph[ym < A ? 0 : 1];
    double g0 = shear_rate(f, tau0 - G * y0, cut), gm = shear_rate(f, tau0 - G * ym, cut);
    double g1 = shear_rate(f, tau0 - G * y1, cut);
    if (u) u[k] = uu + dy * (g0 + gm) / 4.0; /* value at the cell centre (trapezoid on the half cell) */
    uu += dy * (g0 + 4 * gm + g1) / 6.0;      /* Simpson */
  }
  return uu;
}

/* Steady profile on nfine cell centres: bisection on tau0 for u(H) = 0. */
static void steady_profile(const mp_case *c, int cut, int nfine, double *u) {
  double lo = 0.0, hi = G * H;
  for (int it = 0; it < 200; it++) {
    double mid = 0.5 * (lo + hi);
    if (integrate_profile(c, cut, mid, nfine, NULL) > 0) hi = mid; else lo = mid;
  }
  integrate_profile(c, cut, 0.5 * (lo + hi), nfine, u);
}

static double interp(const double *u, int nfine, double y) {
  double s = y / (H / nfine) - 0.5;
  int k = (int)floor(s);
  if (k < 0) return u[0] * (y / (0.5 * H / nfine));
  if (k >= nfine - 1) return u[nfine - 1] * ((H - y) / (0.5 * H / nfine));
  double w = s - k;
  return (1 - w) * u[k] + w * u[k + 1];
}

/* Runs the case at res particles across H to tend; returns the L2 error (paper §5.2) against the exact
 * profile and, in *err_cut, against the cut-off profile. */
static double run_case(const mp_case *cs, int res, double tend, FILE *out, double *err_cut, double *umax_out) {
  enum { NF = 4000 };
  static double ue[NF], uc[NF];
  steady_profile(cs, 0, NF, ue);
  steady_profile(cs, 1, NF, uc);
  double umax = 0;
  for (int k = 0; k < NF; k++) umax = fmax(umax, fabs(ue[k]));
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.dx = H / res; p.h = 1.5 * p.dx; p.rho0 = 1.0;
  p.c0 = 10.0 * fmax(umax, 0.1);
  p.gravity[0] = G; p.skin = 0.3 * p.dx;
  p.precision = precision;
  int ncol = (int)ceil(3.0 * (2.0 * p.h + p.skin) / p.dx) + 1;
  double Lx = ncol * p.dx;
  p.periodic[0] = 1; p.boxlo[0] = 0; p.boxhi[0] = Lx; p.boxlo[1] = -0.5 * H; p.boxhi[1] = 1.5 * H;
  sphdem_mp_params m;
  sphdem_mp_params_default(&m);
  m.enabled = 1; m.nphase = 2; m.phase[0] = cs->ph[0]; m.phase[1] = cs->ph[1];
  m.eos = SPHDEM_EOS_LINEAR; m.diffusion = SPHDEM_DIFF_RENORM; m.delta = 0.1;
  if (terms >= 0) { m.diffusion = terms ? SPHDEM_DIFF_RENORM : SPHDEM_DIFF_NONE; m.shifting = terms; }
  scene s;
  memset(&s, 0, sizeof s);
  double vol = p.dx * p.dx;
  int nl = 4;
  for (int j = -nl; j < res + nl; j++)
    for (int i = 0; i < ncol; i++) {
      double x[3] = {(i + 0.5) * p.dx, (j + 0.5) * p.dx, 0};
      if (j < 0 || j >= res) scene_push_wall(&s, x, p.rho0 * vol);
      else scene_push_fluid(&s, x, p.rho0, p.rho0 * vol);
    }
  int *phase = (int *)malloc(sizeof(int) * s.nf);
  for (int i = 0; i < s.nf; i++) phase[i] = s.x[3 * i + 1] < A ? 0 : 1;
  double lo[3] = {-1e300, 0, -1e300}, hi[3] = {1e300, H, 1e300}; /* MLS ghosts: mirror across y = 0, y = H */
  sphdem_ctx c = scene_start_mp(&p, &m, &s, phase, use_mls ? lo : NULL, hi, test_device());
  sphdem_stats st;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0, &st));
  double t = 0, dt = 0, w0 = wall_now();
  long nstep = 0;
  while (t < tend - 1e-12) {
    if (nstep % 20 == 0) {
      SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0, &st));
      dt = 0.8 * st.dt_stable;
    }
    if (t + dt > tend) dt = tend - t;
    SPHDEM_CHECK_RC(c, use_rk4 ? sphdem_step_rk4(c, dt) : scene_step(c, dt));
    t += dt;
    nstep++;
  }
  last_wall = wall_now() - w0;
  double *x = (double *)malloc(24 * (size_t)s.nf), *v = (double *)malloc(24 * (size_t)s.nf);
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, v, NULL, NULL, NULL));
  double e2 = 0, n2 = 0, c2 = 0, n2c = 0, usim = 0;
  for (int i = 0; i < s.nf; i++) {
    double y = x[3 * i + 1], a = interp(ue, NF, y), b = interp(uc, NF, y);
    e2 += (v[3 * i] - a) * (v[3 * i] - a); n2 += a * a;
    c2 += (v[3 * i] - b) * (v[3 * i] - b); n2c += b * b;
    usim = fmax(usim, v[3 * i]);
    if (out && x[3 * i] < p.dx) fprintf(out, "%s,%d,%.6f,%.6e,%.6e,%.6e\n", cs->name, res, y, v[3 * i], a, b);
  }
  printf("    %-22s res %3d: %d steps to t = %.2f s, u_max sim %.4f exact %.4f; L2 vs exact %.3f%%, vs cut-off law %.3f%%\n",
         cs->name, res, (int)nstep, t, usim, umax, 100 * sqrt(e2 / n2), 100 * sqrt(c2 / n2c));
  if (err_cut) *err_cut = sqrt(c2 / n2c);
  if (umax_out) *umax_out = umax;
  free(last_v);
  last_v = v;
  last_nf = s.nf;
  free(x); free(phase);
  scene_free(&s);
  sphdem_destroy(&c);
  return sqrt(e2 / n2);
}

static sphdem_phase newtonian(double mu) {
  sphdem_phase f = {1.0, 0.0, mu, 1.0, 0.0, 0.0};
  return f;
}

static sphdem_phase hb(double tau_y, double K, double N, double cut) {
  sphdem_phase f = {1.0, tau_y, K, N, cut, 0.0};
  return f;
}

int main(int argc, char **argv) {
  const char *which = argc > 1 ? argv[1] : "all";
  double tend = argc > 2 ? atof(argv[2]) : 5.0;
  int all = !strcmp(which, "all");
  use_rk4 = argc > 3 && !strcmp(argv[3], "rk4");
  use_mls = argc > 3 && !strcmp(argv[3], "mls");
  char fo[128], fs[128];
  snprintf(fo, sizeof fo, "mp_poiseuille_%s%s.csv", which, use_mls ? "_mls" : "");
  snprintf(fs, sizeof fs, "mp_poiseuille_%s%s_summary.csv", which, use_mls ? "_mls" : "");
  FILE *out = fopen(fo, "w"), *sum = fopen(fs, "w");
  fprintf(out, "case,res,y,u_sim,u_exact,u_cutoff\n");
  fprintf(sum, "case,res,l2_exact,l2_cutoff\n");
  if (all || !strcmp(which, "newtonian")) {
    printf("  Newtonian / Newtonian, mu_A = 1, res 40 (bound: L2 < 2 %%):\n");
    double ratios[] = {1, 2, 4, 10};
    for (int k = 0; k < 4; k++) {
      mp_case cs;
      char name[64];
      snprintf(name, sizeof name, "newt_ratio%g", ratios[k]);
      cs.name = name;
      cs.ph[0] = newtonian(1.0); cs.ph[1] = newtonian(1.0 / ratios[k]);
      double ec, e = run_case(&cs, 40, tend, out, &ec, NULL);
      fprintf(sum, "%s,40,%.6e,%.6e\n", name, e, ec);
      TEST_ASSERT(e < 0.02, "mu_A/mu_B = %g: L2 error %.3f%% < 2%%", ratios[k], 100 * e);
    }
  }
  if (all || !strcmp(which, "convergence")) {
    printf("  convergence, mu_A/mu_B = 4 (bound: order >= 1 from res 20 to 80, finest L2 < 2 %%):\n");
    int res[] = {20, 40, 80};
    double e[3];
    mp_case cs = {"conv_ratio4", {newtonian(1.0), newtonian(0.25)}};
    for (int k = 0; k < 3; k++) {
      double ec;
      e[k] = run_case(&cs, res[k], tend, out, &ec, NULL);
      fprintf(sum, "conv_ratio4,%d,%.6e,%.6e\n", res[k], e[k], ec);
    }
    double order = log(e[0] / e[2]) / log(4.0);
    printf("    observed order %.2f (20 -> 40: %.2f, 40 -> 80: %.2f)\n", order, log(e[0] / e[1]) / log(2.0),
           log(e[1] / e[2]) / log(2.0));
    TEST_ASSERT(order >= 1.0, "convergence order over res 20, 40, 80 is %.2f >= 1", order);
    TEST_ASSERT(e[2] < 0.02, "finest L2 error %.3f%% < 2%%", 100 * e[2]);
  }
  int hb_all = all || !strcmp(which, "hb"), hb_b = hb_all || !strcmp(which, "hb_bingham");
  int hb_p = hb_all || !strcmp(which, "hb_power");
  if (hb_b || hb_p) {
    printf("  non-Newtonian phase A / Newtonian phase B (mu_B = 1), res 40; error against the exact law vs\n"
           "  against the solver's cut-off law (bounds: cut-off law L2 < 2 %%; exact-law error falls with the cut-off):\n");
    struct { const char *name; double ty, N; } nn[] = {{"bingham_ty1", 1.0, 1.0}, {"powerlaw_N0.5", 0.0, 0.5},
                                                        {"powerlaw_N2", 0.0, 2.0}};
    for (int k = 0; k < 3; k++) {
      if ((k == 0 && !hb_b) || (k > 0 && !hb_p)) continue;
      double cuts[] = {1.0, 0.2};
      double ex[2], ec[2];
      for (int j = 0; j < 2; j++) {
        char name[64];
        snprintf(name, sizeof name, "%s_cut%g", nn[k].name, cuts[j]);
        mp_case cs;
        cs.name = name;
        cs.ph[0] = hb(nn[k].ty, 1.0, nn[k].N, cuts[j]);
        cs.ph[1] = newtonian(1.0);
        ex[j] = run_case(&cs, 40, tend, out, &ec[j], NULL);
        fprintf(sum, "%s,40,%.6e,%.6e\n", name, ex[j], ec[j]);
        TEST_ASSERT(ec[j] < 0.02, "%s: L2 against the cut-off law %.3f%% < 2%%", name, 100 * ec[j]);
      }
      TEST_ASSERT(ex[1] < ex[0], "%s: error against the exact law falls with the cut-off (%.3f%% at 1/s, %.3f%% "
                  "at 0.2/s)", nn[k].name, 100 * ex[0], 100 * ex[1]);
    }
  }
  if (all || !strcmp(which, "rk4")) {
    printf("  mu_A/mu_B = 4, res 20: velocity Verlet and fourth-order Runge-Kutta (bound: both < 2 %%, within 0.2 %% "
           "of each other)\n");
    mp_case cs = {"rk_ratio4", {newtonian(1.0), newtonian(0.25)}};
    int keep = use_rk4;
    use_rk4 = 0;
    double ev = run_case(&cs, 20, tend, NULL, NULL, NULL);
    use_rk4 = 1;
    double er = run_case(&cs, 20, tend, NULL, NULL, NULL);
    use_rk4 = keep;
    TEST_ASSERT(ev < 0.02 && er < 0.02, "Verlet %.3f%%, RK4 %.3f%% < 2%%", 100 * ev, 100 * er);
    TEST_ASSERT(fabs(ev - er) < 0.002, "RK4 and Verlet agree at steady state (%.3f%% vs %.3f%%)", 100 * er, 100 * ev);
  }
  if (!strcmp(which, "precision")) {
    printf("  mu_A/mu_B = 4, res 20: the precisions mixed and single against double (bounds: velocity difference\n"
           "  L2 < 0.1 %% of double's (mixed), < 1 %% (single); every L2 against the exact profile < 2 %%)\n");
    mp_case cs = {"prec_ratio4", {newtonian(1.0), newtonian(0.25)}};
    for (int tm = -1; tm <= 1; tm += 2) {
      terms = tm;
      precision = SPHDEM_PREC_DOUBLE;
      const double ed = run_case(&cs, 20, tend, NULL, NULL, NULL), wd = last_wall;
      const int n = last_nf;
      double *vd = (double *)malloc(24 * (size_t)n);
      memcpy(vd, last_v, 24 * (size_t)n);
      for (int pr = SPHDEM_PREC_MIXED; pr <= SPHDEM_PREC_SINGLE; pr++) {
        precision = pr;
        const double e = run_case(&cs, 20, tend, NULL, NULL, NULL);
        double d2 = 0, n2 = 0;
        for (int i = 0; i < 3 * n; i++) { d2 += (last_v[i] - vd[i]) * (last_v[i] - vd[i]); n2 += vd[i] * vd[i]; }
        const double dv = sqrt(d2 / n2), bound = pr == SPHDEM_PREC_MIXED ? 1e-3 : 1e-2;
        const char *pn = pr == SPHDEM_PREC_MIXED ? "mixed" : "single";
        printf("    %s terms, %-6s: L2 vs exact %.3f%% (double %.3f%%), velocity difference from double %.2e; wall "
               "time %.2f s (double %.2f s)\n", tm < 0 ? "tests'" : "delta-plus", pn, 100 * e, 100 * ed, dv, last_wall, wd);
        fprintf(sum, "%s_%s_%s,20,%.6e,%.6e\n", cs.name, tm < 0 ? "tests" : "dplus", pn, e, dv);
        TEST_ASSERT(dv < bound && dv > 0, "%s (%s terms): velocity difference from double %.2e in (0, %g)", pn,
                    tm < 0 ? "the tests'" : "delta-plus", dv, bound);
        TEST_ASSERT(e < 0.02, "%s: L2 against the exact profile %.3f%% < 2%%", pn, 100 * e);
      }
      free(vd);
    }
    precision = SPHDEM_PREC_DOUBLE;
    terms = -1;
  }
  if (!strcmp(which, "accuracy")) {
    /* accuracy against cost (bench/mp_accuracy.py): mu_A/mu_B = 4, Verlet / RK4 x plain / delta-plus x res */
    FILE *acc = fopen("mp_accuracy.csv", "w");
    fprintf(acc, "integrator,terms,res,l2,wall_s,wall_per_sim_s\n");
    mp_case cs = {"acc_ratio4", {newtonian(1.0), newtonian(0.25)}};
    int res[] = {20, 40, 80};
    for (int ig = 0; ig < 2; ig++)
      for (int tm = 0; tm < 2; tm++)
        for (int k = 0; k < 3; k++) {
          use_rk4 = ig; terms = tm;
          double e = run_case(&cs, res[k], tend, NULL, NULL, NULL);
          fprintf(acc, "%s,%s,%d,%.6e,%.4f,%.4f\n", ig ? "rk4" : "verlet", tm ? "delta-plus" : "plain", res[k], e,
                  last_wall, last_wall / tend);
          fflush(acc);
        }
    fclose(acc);
  }
  fclose(out);
  fclose(sum);
  return test_summary("mp_poiseuille");
}
