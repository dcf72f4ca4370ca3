/* test_dem_drop.c - Yu 2024 §3.1: one sphere (d = 0.2 m) dropped from 0.5 m on a fixed plane, linear
 * spring-dashpot k = 5e4 N/m, e = 0.9 (damping from Yu eq 11 in its self-consistent form, reference
 * README "Linear spring-dashpot normal impact"). Height against the analytic piecewise solution (free
 * fall, damped oscillator under gravity, free flight) until just before the second impact; contact time
 * and rebound velocity against the same closed form. Both force algorithms. The paper does not give the
 * density; 2700 kg/m^3 is used (m = 11.3 kg). Integration: velocity Verlet in the driver, dt = t_c/50
 * (Yu §2.4). Bounds: height error < 1.2 % (the paper's) through the paper's three stages (fall, contact,
 * rebound to the apex), contact time within one step, rebound velocity within 1 %; over the descent that
 * follows the error grows with the rebound-velocity error, and a 4x smaller step must at least halve it.
 * At dt = t_c/100 the 1.2 % bound must hold at all times, down to the second impact. */
#include <math.h>
#include "testlib.h"

typedef struct { double g, r, y0, m, k, eta, t1, v1, tau, vr, w, zw, wd; } drop_ref;

/* overlap delta(tau) during contact: delta'' + (eta/m) delta' + (k/m) delta = g, delta(0) = 0, delta'(0) = v1 */
static void contact_state(const drop_ref *R, double tau, double *delta, double *ddelta) {
  double A = -R->g / (R->w * R->w), B = (R->v1 + R->zw * A) / R->wd;
  double e = exp(-R->zw * tau), c = cos(R->wd * tau), s = sin(R->wd * tau);
  *delta = R->g / (R->w * R->w) + e * (A * c + B * s);
  *ddelta = e * (-R->zw * (A * c + B * s) + R->wd * (-A * s + B * c));
}

static void reference_init(drop_ref *R) {
  R->w = sqrt(R->k / R->m);
  R->zw = 0.5 * R->eta / R->m;
  R->wd = sqrt(R->w * R->w - R->zw * R->zw);
  R->t1 = sqrt(2.0 * (R->y0 - R->r) / R->g);
  R->v1 = R->g * R->t1; /* overlap rate at impact */
  /* end of contact: first root of delta after tau = 0 (bracketed by stepping, then bisection) */
  double lo = 1e-9, hi = lo, d, dd;
  do { lo = hi; hi += 1e-4 * M_PI / R->wd; contact_state(R, hi, &d, &dd); } while (d > 0.0);
  for (int it = 0; it < 200; it++) {
    double mid = 0.5 * (lo + hi);
    contact_state(R, mid, &d, &dd);
    if (d > 0.0) lo = mid; else hi = mid;
  }
  R->tau = 0.5 * (lo + hi);
  contact_state(R, R->tau, &d, &dd);
  R->vr = -dd;
}

static double height(const drop_ref *R, double t) {
  if (t <= R->t1) return R->y0 - 0.5 * R->g * t * t;
  if (t <= R->t1 + R->tau) {
    double d, dd;
    contact_state(R, t - R->t1, &d, &dd);
    return R->r - d;
  }
  double s = t - R->t1 - R->tau;
  return R->r + R->vr * s - 0.5 * R->g * s * s;
}

typedef struct { double maxerr_apex, maxerr_all, tmaxerr, tc, vout; int rc; } drop_run;

/* One drop with time step dt until tend; errors before the rebound apex and over the whole run. */
static drop_run run_drop(const drop_ref *R, int algo, double dt, double tend, const char *csvname) {
  drop_run out = {0, 0, 0, 0, 0, 0};
  const double g = R->g;
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_HOOKE;
  p.algo = algo;
  p.kn = R->k; p.kt = 0; p.en = 0.9; p.mu = 0;
  p.skin = 0.02;
  sphdem_dem dem;
  out.rc = test_dem_on_floor(&p, &dem);
  if (!dem) return out;
  int64_t tag = 1;
  double x[3] = {0, R->y0, 0}, v[3] = {0, 0, 0}, om[3] = {0, 0, 0}, rad = R->r, mass = R->m, f[3], tq[3];
  double t = 0, tin = -1, tout = -1, tapex = R->t1 + R->tau + R->vr / g;
  int touching = 0, rc = out.rc;
  if (!rc) rc = sphdem_dem_compute(dem, 1, &tag, x, v, om, &rad, &mass, NULL, dt, 0, f, tq, NULL);
  FILE *csv = csvname ? fopen(csvname, "w") : NULL;
  if (csv) fprintf(csv, "t,y_sim,y_analytic\n");
  while (!rc && t + dt <= tend) {
    for (int d = 0; d < 3; d++) v[d] += 0.5 * dt * (f[d] / mass - (d == 1 ? g : 0.0));
    for (int d = 0; d < 3; d++) x[d] += dt * v[d];
    rc = sphdem_dem_compute(dem, 1, &tag, x, v, om, &rad, &mass, NULL, dt, 1, f, tq, NULL);
    for (int d = 0; d < 3; d++) v[d] += 0.5 * dt * (f[d] / mass - (d == 1 ? g : 0.0));
    t += dt;
    int now = f[1] != 0.0;
    if (now && !touching && tin < 0) tin = t;
    if (!now && touching && tout < 0) { tout = t; out.vout = v[1]; }
    touching = now;
    double ya = height(R, t), err = fabs(ya - x[1]) / ya;
    if (err > out.maxerr_all) { out.maxerr_all = err; out.tmaxerr = t; }
    if (t <= tapex && err > out.maxerr_apex) out.maxerr_apex = err;
    if (csv) fprintf(csv, "%.6f,%.9f,%.9f\n", t, x[1], ya);
  }
  if (csv) fclose(csv);
  if (rc) printf("compute: %s\n", sphdem_dem_last_error(dem));
  out.rc = rc;
  out.tc = tout - tin;
  sphdem_dem_destroy(&dem);
  return out;
}

int main(void) {
  const double g = 9.81, r = 0.1, y0 = 0.5, rho = 2700.0, k = 5e4, e = 0.9;
  drop_ref R;
  R.g = g; R.r = r; R.y0 = y0; R.k = k;
  R.m = rho * 4.0 / 3.0 * M_PI * r * r * r;
  double le = fabs(log(e));
  R.eta = 2.0 * sqrt(k * R.m) * le / sqrt(M_PI * M_PI + le * le); /* Yu eq 11, self-consistent form */
  reference_init(&R);
  double tc0 = M_PI / sqrt(k / R.m - pow(R.eta / (2 * R.m), 2));  /* README closed form (no gravity) */
  double dt = tc0 / 50.0, tend = R.t1 + R.tau + 1.9 * R.vr / g;   /* stop before the second impact */
  printf("analytic: m %.4f kg, impact t1 %.5f s, contact %.5f s (closed form without gravity %.5f s, "
         "e %.5f), rebound %.5f m/s (e_eff with gravity %.5f), apex %.4f s, end %.4f s, dt = t_c/50 = %.3g s\n",
         R.m, R.t1, R.tau, tc0, exp(-R.eta * tc0 / (2 * R.m)), R.vr, R.vr / R.v1, R.t1 + R.tau + R.vr / g, tend, dt);
  TEST_ASSERT(fabs(R.t1 - 0.286) < 0.001, "impact time %.4f vs Yu 2024 0.286 s", R.t1);
  TEST_ASSERT(fabs(exp(-R.eta * tc0 / (2 * R.m)) - e) < 1e-12, "eq 11 damping does not give e");

  for (int algo = 0; algo < 2; algo++) {
    drop_run a = run_drop(&R, algo, dt, tend, algo == 0 ? "dem_drop.csv" : NULL);
    if (a.rc == SPHDEM_ERR_NO_GPU) return test_skip("no usable GPU");
    TEST_ASSERT(a.rc == SPHDEM_OK, "run failed");
    printf("algo %d: height error max %.4f %% up to the rebound apex, %.4f %% up to the second impact (at t = %.4f s); "
           "contact %.5f s vs %.5f (diff %.2f dt); rebound %.5f vs %.5f m/s (%.3f %%)\n",
           algo, 100 * a.maxerr_apex, 100 * a.maxerr_all, a.tmaxerr, a.tc, R.tau, (a.tc - R.tau) / dt, a.vout, R.vr,
           100 * fabs(a.vout / R.vr - 1));
    TEST_ASSERT(a.maxerr_apex < 0.012, "height error %.4f %% >= 1.2 %% before the apex", 100 * a.maxerr_apex);
    TEST_ASSERT(a.tc > 0 && fabs(a.tc - R.tau) <= dt, "contact time %.5f vs %.5f (dt %.3g)", a.tc, R.tau, dt);
    TEST_ASSERT(fabs(a.vout / R.vr - 1) < 0.01, "rebound velocity %.5f vs %.5f", a.vout, R.vr);
    if (algo == 0) {
      /* the remaining error is the time discretisation: a 4x smaller step must at least halve it */
      drop_run b = run_drop(&R, algo, dt / 4, tend, NULL);
      printf("        dt/4: %.4f %% up to the second impact, rebound error %.3f %%\n", 100 * b.maxerr_all,
             100 * fabs(b.vout / R.vr - 1));
      TEST_ASSERT(b.rc == SPHDEM_OK && b.maxerr_all < 0.5 * a.maxerr_all, "no convergence in dt: %.4f %% vs %.4f %%",
                  100 * b.maxerr_all, 100 * a.maxerr_all);
      /* the bound at all times (fall, contact, rebound, descent to the second impact) at t_c/100 */
      drop_run c2 = run_drop(&R, algo, dt / 2, tend, NULL);
      printf("        dt/2 (t_c/100): %.4f %% up to the second impact (bound 1.2 %%), rebound error %.3f %%\n",
             100 * c2.maxerr_all, 100 * fabs(c2.vout / R.vr - 1));
      TEST_ASSERT(c2.rc == SPHDEM_OK && c2.maxerr_all < 0.012, "height error %.4f %% >= 1.2 %% at t_c/100",
                  100 * c2.maxerr_all);
    }
  }
  return test_summary("verify_dem_drop");
}
