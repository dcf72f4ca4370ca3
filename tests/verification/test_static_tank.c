/* test_static_tank.c - two-layer static tank (Shi & Huang 2022 §5.1, Table 1): 2D tank 1.2 m wide, a
 * 0.6 m layer of phase A (rho 2000, Herschel-Bulkley tau_y 10 Pa, K 100 Pa s^N, N 0.8) under 0.6 m of
 * phase B (water, rho 1000, mu 1e-3), g = 9.8. Probes PA (0.3, 0.9), Pint (0.3, 0.6), PB (0.3, 0.3) against
 * the hydrostatic pressures 2940, 5880 and 11760 Pa (+ P0); interface particles crossing the interface.
 *
 * Usage: verify_static_tank [key=value ...] with dx=0.02 tend=1.5 diffusion=renorm|molteni|none
 *   shifting=1|0 eos=linear|tait ratio=2 (rho_A/rho_B) dtfac=0.8 (times the stable step) p0=0 cut=1
 *   c0=single|phase (phase: each phase its own sound speed 10 sqrt(p_max / rho_k)) integrator=verlet|rk4 walls=adami|mls (MLS: fixed ghosts mirrored across x = 0, x = W, y = 0) out=static_tank (prefix of the CSV files) check=1 (assert the paper's bounds)
 *   scene=tank|dambreak (dambreak: the tank full, phase A a 0.4 m x 0.6 m column at the left wall, phase B
 *   everywhere else; no probe bounds).
 * Prints one RESULT line (stable, probe errors, pressure noise, disorder, crossings) that
 * bench/mp_stability.py collects. */
#include <math.h>
#include "scene.h"
#include "testlib.h"

static const char *opt(int argc, char **argv, const char *key, const char *def) {
  size_t n = strlen(key);
  for (int i = 1; i < argc; i++)
    if (!strncmp(argv[i], key, n) && argv[i][n] == '=') return argv[i] + n + 1;
  return def;
}

/* Coefficient of variation of the nearest-neighbour distance (0 on a perfect lattice): particle disorder. */
static double disorder(const double *x, int n, double dx) {
  double s = 0, s2 = 0;
  int cnt = 0;
  int nx = (int)(1.4 / dx) + 4, ny = (int)(2.0 / dx) + 4;
  int *head = (int *)malloc(sizeof(int) * nx * ny), *next = (int *)malloc(sizeof(int) * n);
  for (int k = 0; k < nx * ny; k++) head[k] = -1;
  for (int i = 0; i < n; i++) {
    int cx = (int)((x[3 * i] + 0.2) / dx), cy = (int)((x[3 * i + 1] + 0.2) / dx);
    if (cx < 0 || cy < 0 || cx >= nx || cy >= ny) { next[i] = -2; continue; }
    next[i] = head[cy * nx + cx];
    head[cy * nx + cx] = i;
  }
  for (int i = 0; i < n; i++) {
    if (next[i] == -2) continue;
    int cx = (int)((x[3 * i] + 0.2) / dx), cy = (int)((x[3 * i + 1] + 0.2) / dx);
    double best = 1e300;
    for (int dy = -2; dy <= 2; dy++)
      for (int dxx = -2; dxx <= 2; dxx++) {
        int X = cx + dxx, Y = cy + dy;
        if (X < 0 || Y < 0 || X >= nx || Y >= ny) continue;
        for (int j = head[Y * nx + X]; j >= 0; j = next[j]) {
          if (j == i) continue;
          double a = x[3 * i] - x[3 * j], b = x[3 * i + 1] - x[3 * j + 1], r = sqrt(a * a + b * b);
          if (r < best) best = r;
        }
      }
    if (best < 1e299) { s += best; s2 += best * best; cnt++; }
  }
  free(head); free(next);
  double m = s / cnt;
  return sqrt(fmax(s2 / cnt - m * m, 0.0)) / m;
}

int main(int argc, char **argv) {
  double dx = atof(opt(argc, argv, "dx", "0.02")), tend = atof(opt(argc, argv, "tend", "1.5"));
  double ratio = atof(opt(argc, argv, "ratio", "2")), dtfac = atof(opt(argc, argv, "dtfac", "0.8"));
  double p0 = atof(opt(argc, argv, "p0", "0")), cut = atof(opt(argc, argv, "cut", "1"));
  const char *diff = opt(argc, argv, "diffusion", "renorm"), *eos = opt(argc, argv, "eos", "linear");
  int shifting = atoi(opt(argc, argv, "shifting", "1")), check = atoi(opt(argc, argv, "check", "1"));
  const char *prefix = opt(argc, argv, "out", "static_tank");
  int dambreak = !strcmp(opt(argc, argv, "scene", "tank"), "dambreak");
  int rk4 = !strcmp(opt(argc, argv, "integrator", "verlet"), "rk4");
  int mls = !strcmp(opt(argc, argv, "walls", "adami"), "mls");
  if (dambreak) check = 0;
  /* ratio rho_A/rho_B: up to 2 phase B is water (the paper's 2000/1000); above, phase A is water and phase B the
   * light phase (1000 / ratio: 1000 gives a water/air-like pair) */
  const double W = 1.2, HL = 0.6, g = 9.8, rhoB = ratio <= 2 ? 1000.0 : 1000.0 / ratio, rhoA = rhoB * ratio;

  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = 2; p.dx = dx; p.h = 1.5 * dx; p.rho0 = rhoA; /* wall volume m_w / rho0 (wall masses rho_A dx^2) */ p.gravity[1] = -g; p.skin = 0.3 * dx;
  double pmax = rhoB * g * HL + rhoA * g * HL;
  p.c0 = 10.0 * sqrt(pmax / rhoB); /* eq 5 with U_max ~ 0, rho0 of the lighter phase */
  p.boxlo[0] = -0.2; p.boxhi[0] = W + 0.2; p.boxlo[1] = -0.2; p.boxhi[1] = 1.8;
  p.rho_err_max = 0.5;
  sphdem_mp_params m;
  sphdem_mp_params_default(&m);
  m.enabled = 1; m.nphase = 2;
  sphdem_phase A = {rhoA, 10.0, 100.0, 0.8, cut, 0.0}, B = {rhoB, 0.0, 1e-3, 1.0, 0.0, 0.0};
  if (!strcmp(opt(argc, argv, "c0", "single"), "phase")) {
    /* a sound speed per phase: eq 5 with each phase's own density; the fluid's c0 is the heavy phase's */
    A.c0 = 10.0 * sqrt(pmax / rhoA);
    B.c0 = p.c0;
    p.c0 = A.c0;
  }
  m.phase[0] = A; m.phase[1] = B;
  m.eos = !strcmp(eos, "tait") ? SPHDEM_EOS_TAIT : SPHDEM_EOS_LINEAR;
  m.p0 = p0;
  m.diffusion = !strcmp(diff, "none") ? SPHDEM_DIFF_NONE : !strcmp(diff, "molteni") ? SPHDEM_DIFF_MOLTENI
                                                                                    : SPHDEM_DIFF_RENORM;
  m.shifting = shifting;

  /* hydrostatic start: pressure of the layers above, density from each phase's EOS */
  scene s;
  memset(&s, 0, sizeof s);
  int nl = 4, nx = (int)lround(W / dx), ny = (int)lround(2 * HL / dx), nyt = (int)lround(1.5 / dx);
  int *phase = NULL, cap = 0;
  for (int j = -nl; j < nyt; j++)
    for (int i = -nl; i < nx + nl; i++) {
      double x[3] = {(i + 0.5) * dx, (j + 0.5) * dx, 0};
      int inside = i >= 0 && i < nx && j >= 0;
      if (!inside) { scene_push_wall(&s, x, rhoA * dx * dx); continue; }
      if (j >= ny) continue;
      int k = x[1] < HL ? 0 : 1;
      double pr = x[1] >= HL ? rhoB * g * (2 * HL - x[1]) : rhoB * g * HL + rhoA * g * (HL - x[1]);
      if (dambreak) {
        k = x[0] < 0.4 && x[1] < HL ? 0 : 1;
        pr = k == 0 || x[0] < 0.4 ? pr : rhoB * g * (2 * HL - x[1]);
      }
      double rho = sphdem_mp_density(&m, &p, k, pr + p0);
      scene_push_fluid(&s, x, rho, rho * dx * dx);
      if (s.nf > cap) { cap = 2 * s.nf + 1024; phase = (int *)realloc(phase, sizeof(int) * cap); }
      phase[s.nf - 1] = k;
    }
  double lo[3] = {0, 0, -1e300}, hi[3] = {W, 1e300, 1e300}; /* MLS ghosts: mirror across x = 0, x = W, y = 0 */
  sphdem_ctx c = scene_start_mp(&p, &m, &s, phase, mls ? lo : NULL, hi, test_device());

  double probes[9] = {0.3, 0.9, 0, 0.3, 0.6, 0, 0.3, 0.3, 0};
  double exact[3] = {rhoB * g * 0.3 + p0, rhoB * g * HL + p0, rhoB * g * HL + rhoA * g * 0.3 + p0};
  char fn[256];
  snprintf(fn, sizeof fn, "%s_probes.csv", prefix);
  FILE *out = fopen(fn, "w");
  fprintf(out, "t,PA,Pint,PB,PA_exact,Pint_exact,PB_exact,PA_kernel,Pint_kernel,PB_kernel\n");
  printf("  %d fluid + %d wall particles, dx %g, c0 %.1f, diffusion %s, shifting %d, eos %s, rho_A/rho_B %g, "
         "dt %.2f x stable\n", s.nf, s.nw, dx, p.c0, diff, shifting, eos, ratio, dtfac);
  double t = 0, dt = 0, worst[3] = {0, 0, 0}, worst_raw[3] = {0, 0, 0}, po[3 * SPHDEM_NPROBE];
  double *xs = (double *)malloc(24 * (size_t)s.nf), *rs = (double *)malloc(8 * (size_t)s.nf);
  long n = 0;
  int stable = 1;
  sphdem_stats st;
  const char *why = "";
  while (t < tend - 1e-12) {
    if (n % 10 == 0) {
      int rc = sphdem_stats_get(c, 0, &st);
      if (rc) { stable = 0; why = sphdem_strerror(rc); break; }
      dt = dtfac * st.dt_stable;
    }
    int rc = rk4 ? sphdem_step_rk4(c, dt) : scene_step(c, dt);
    if (rc) { stable = 0; why = sphdem_strerror(rc); break; }
    t += dt;
    n++;
    if (!dambreak && (n % 50 == 0 || t >= tend - 1e-12)) {
      SPHDEM_CHECK_RC(c, sphdem_probe(c, 3, probes, po));
      /* reference as a kernel probe reads it: the Shepard average of the exact hydrostatic field at the
       * particles around the probe (the exact field has a kink at the interface that a kernel smooths) */
      SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, xs, NULL, rs, NULL, NULL));
      double ref[3];
      for (int k = 0; k < 3; k++) {
        double sw = 0, sp = 0, ad = 7.0 / (4.0 * M_PI * p.h * p.h);
        for (int i = 0; i < s.nf; i++) {
          double a = xs[3 * i] - probes[3 * k], b = xs[3 * i + 1] - probes[3 * k + 1], q = sqrt(a * a + b * b) / p.h;
          if (q >= 2) continue;
          double tq = 1 - 0.5 * q, w = s.mass[i] / rs[i] * ad * tq * tq * tq * tq * (1 + 2 * q), y = xs[3 * i + 1];
          double ph = y >= HL ? rhoB * g * fmax(2 * HL - y, 0.0) : rhoB * g * HL + rhoA * g * (HL - y);
          sw += w; sp += w * ph;
        }
        ref[k] = sp / sw + p0;
      }
      fprintf(out, "%.5f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f\n", t, po[0], po[SPHDEM_NPROBE],
              po[2 * SPHDEM_NPROBE], exact[0], exact[1], exact[2], ref[0], ref[1], ref[2]);
      if (t >= 1.0)
        for (int k = 0; k < 3; k++) {
          worst[k] = fmax(worst[k], fabs(po[k * SPHDEM_NPROBE] - ref[k]) / (exact[k] - p0));
          worst_raw[k] = fmax(worst_raw[k], fabs(po[k * SPHDEM_NPROBE] - exact[k]) / (exact[k] - p0));
        }
    }
  }
  fclose(out);
  double *x = (double *)malloc(24 * (size_t)s.nf), *pp = (double *)malloc(8 * (size_t)s.nf);
  double *pk = (double *)malloc(8 * SPHDEM_NPROBE * (size_t)s.nf);
  int cross = 0;
  double noise = 0, dis = 0;
  if (stable) {
    SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, NULL, NULL, pp, NULL));
    /* pressure noise: particle pressure against the kernel average at its own position, rms over the
     * fluid, relative to the bottom pressure rho_B g HL + rho_A g HL */
    SPHDEM_CHECK_RC(c, sphdem_probe(c, s.nf, x, pk));
    double e2 = 0;
    for (int i = 0; i < s.nf; i++) {
      double y = x[3 * i + 1], d = pp[i] - pk[SPHDEM_NPROBE * i];
      /* crossing (tank): a particle more than one spacing on the wrong side of the interface */
      if (!dambreak && ((phase[i] == 0 && y > HL + dx) || (phase[i] == 1 && y < HL - dx))) cross++;
      e2 += d * d;
    }
    noise = sqrt(e2 / s.nf) / (rhoB * g * HL + rhoA * g * HL);
    dis = disorder(x, s.nf, dx);
    snprintf(fn, sizeof fn, "%s_particles.csv", prefix);
    FILE *f = fopen(fn, "w");
    fprintf(f, "x,y,phase,p\n");
    for (int i = 0; i < s.nf; i++) fprintf(f, "%.5f,%.5f,%d,%.3f\n", x[3 * i], x[3 * i + 1], phase[i], pp[i]);
    fclose(f);
  }
  printf("  worst probe error from t = 1 s against the exact hydrostatic pressure: PA %.2f%%, Pint %.2f%%, PB %.2f%%\n",
         100 * worst_raw[0], 100 * worst_raw[1], 100 * worst_raw[2]);
  double vrms = 0;
  if (stable && sphdem_stats_get(c, 0, &st) == SPHDEM_OK) vrms = sqrt(2 * st.ke / ((rhoA + rhoB) * W * HL));
  printf("RESULT stable=%d reason=%s t=%.3f PA=%.4f Pint=%.4f PB=%.4f noise=%.4f disorder=%.4f crossings=%d vrms=%.3g\n",
         stable, stable ? "-" : why, t, worst[0], worst[1], worst[2], noise, dis, cross, vrms);
  if (check) {
    TEST_ASSERT(stable, "ran to t = %.2f s without a stop (%s)", tend, why);
    const char *nm[3] = {"PA", "Pint", "PB"};
    for (int k = 0; k < 3; k++)
      TEST_ASSERT(worst[k] < 0.02, "%s within 2%% of the kernel-read hydrostatic pressure from t = 1 s on (worst "
                  "%.2f%%)", nm[k], 100 * worst[k]);
    TEST_ASSERT(worst_raw[0] < 0.02 && worst_raw[2] < 0.02, "PA and PB within 2%% of the exact hydrostatic pressure "
                "from t = 1 s on (worst %.2f%%, %.2f%%)", 100 * worst_raw[0], 100 * worst_raw[2]);
    TEST_ASSERT(cross <= s.nf / 1000, "particles across the interface: %d (bound 0.1%% of %d)", cross, s.nf);
  }
  free(x); free(pp); free(pk); free(phase); free(xs); free(rs);
  scene_free(&s);
  sphdem_destroy(&c);
  return check ? test_summary("static_tank") : 0;
}
