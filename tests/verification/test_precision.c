/* test_precision.c - the precisions mixed and single (sphdem_params.precision) against double.
 * Usage: verify_precision rates|tank|dambreak
 *   rates     one rate evaluation of a stirred 2D and 3D tank, for each pair-term variant of the float loop
 *             (viscosity none / Morris / artificial, tensile n = 4 and n = 3, delta-SPH plain / hydrostatic, XSPH):
 *             the density rate and acceleration of mixed and single against double, relative to their largest
 *             value, on the CPU's half-list pass (its AVX2 and baseline builds) and on the GPU-like gather pass.
 *             Bounds 2e-6 (mixed) and 2e-5 (single, whose separations come from float positions): float
 *             rounding (6e-8) of terms summed over ~20-60 neighbours with cancellation; measured up to 4.4e-7
 *             (mixed) and 3.6e-6 (single). Either must also differ from double (the float terms ran).
 *   tank      still water 0.6 s (hydrostatic tank of verify_hydrostatic at 20 particles across): the time-averaged
 *             bottom-row pressure of mixed and single within 0.1 % of double; the same tank 1e4 m from the origin
 *             (float spacing 0.2 dx): single is refused with a message that names the precision, mixed stays within
 *             0.1 % of double. (tank_scan, not a ctest group: single at 0.5-30 m from the origin, the table of
 *             doc/fix_sph_fluid.md.)
 *   dambreak  the 2D dam break of verify_dambreak2d (a/dx = 40) to T = 2.5: the surge front of mixed within 0.1 % of
 *             double; single within 3 % (measured 1.0 %: where the flow is slow its particles move in float steps). */
#include <math.h>
#define TEST_RNG_SEED 20261203ull
#include "scene.h"
#include "testlib.h"

static const char *prec_name(int p) { return p == SPHDEM_PREC_MIXED ? "mixed" : p == SPHDEM_PREC_SINGLE ? "single" : "double"; }

/* ---- rates ---------------------------------------------------------------------------------------------------- */

typedef struct {
  const char *name;
  int dim, visc;
  double tensile_n, delta;
  int hydro;
  double xsph;
} rates_case;

/* One rate evaluation of the stirred tank in precision prec; the state (drho, a, u per particle) into st. */
static int rates_of(const rates_case *k, int prec, double *st, int *nf_out) {
  sphdem_params p;
  sphdem_params_default(&p);
  const double W = 0.1, H = 0.1, g = 9.81;
  p.dim = k->dim; p.dx = W / (k->dim == 2 ? 24 : 10); p.h = 1.3 * p.dx;
  p.rho0 = 1000; p.c0 = 10 * sqrt(g * H); p.gravity[k->dim - 1] = -g; p.skin = 0.3 * p.dx;
  p.visc = k->visc; p.alpha = 0.05; p.mu = 1e-2;
  p.tensile_eps = k->tensile_n > 0 ? 0.01 : 0.0; p.tensile_n = k->tensile_n > 0 ? k->tensile_n : 4.0;
  p.delta = k->delta; p.delta_hydro = k->hydro; p.xsph_eps = k->xsph;
  p.precision = prec;
  scene s;
  scene_tank(&s, &p, W, k->dim == 3 ? W : 0, 1.5 * H, W, H, 3);
  /* stirred and compressed: velocities of 10 % of c0 and densities 1 % off hydrostatic, so that every term is on */
  test_rng_ = TEST_RNG_SEED;
  for (int i = 0; i < s.nf; i++) {
    for (int d = 0; d < k->dim; d++) s.v[3 * i + d] = 0.1 * p.c0 * (2 * urand() - 1);
    s.rho[i] *= 1 + 0.01 * (2 * urand() - 1);
  }
  sphdem_ctx c = scene_start(&p, &s, test_device());
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, NULL, NULL, NULL, NULL, st));
  *nf_out = s.nf;
  sphdem_destroy(&c);
  scene_free(&s);
  return 0;
}

/* max |x - y| / max |y| over the components [k0, k1) of the state records */
static double rel_diff(const double *x, const double *y, int n, int k0, int k1) {
  double dmax = 0, ymax = 0;
  for (int i = 0; i < n; i++)
    for (int k = k0; k < k1; k++) {
      dmax = fmax(dmax, fabs(x[SPHDEM_NSTATE * i + k] - y[SPHDEM_NSTATE * i + k]));
      ymax = fmax(ymax, fabs(y[SPHDEM_NSTATE * i + k]));
    }
  return ymax > 0 ? dmax / ymax : dmax;
}

static void test_rates(void) {
  const rates_case cases[] = {
    {"2D artificial, tensile n=4 (dam break)", 2, SPHDEM_VISC_ARTIFICIAL, 4, 0.0, 0, 0.0},
    {"2D Morris, delta hydrostatic, XSPH", 2, SPHDEM_VISC_MORRIS, 0, 0.1, 1, 0.3},
    {"2D none, delta plain, tensile n=3 (general loop)", 2, SPHDEM_VISC_NONE, 3, 0.1, 0, 0.0},
    {"3D artificial, delta plain, XSPH", 3, SPHDEM_VISC_ARTIFICIAL, 0, 0.1, 0, 0.3},
    {"3D Morris, tensile n=4", 3, SPHDEM_VISC_MORRIS, 4, 0.0, 0, 0.0},
  };
  const char *paths[][2] = {{"half lists, AVX2 where the CPU has it", NULL}, {"half lists, baseline build", "generic"},
                            {"gather (GPU-like)", "gather"}};
  const int on_gpu = test_device() == SPHDEM_DEVICE_GPU;
  for (unsigned k = 0; k < sizeof cases / sizeof cases[0]; k++) {
    int nf = 0;
    double *ref = NULL, *st = NULL;
    for (int path = 0; path < (on_gpu ? 1 : 3); path++) {
      unsetenv("SPHDEM_CPU_FLOAT");
      unsetenv("SPHDEM_CPU_GATHER");
      if (paths[path][1] && !strcmp(paths[path][1], "generic")) setenv("SPHDEM_CPU_FLOAT", "generic", 1);
      if (paths[path][1] && !strcmp(paths[path][1], "gather")) setenv("SPHDEM_CPU_GATHER", "1", 1);
      if (!ref) {
        /* nf is known after the first run: size the buffers generously */
        ref = malloc(sizeof(double) * SPHDEM_NSTATE * 20000);
        st = malloc(sizeof(double) * SPHDEM_NSTATE * 20000);
      }
      rates_of(&cases[k], SPHDEM_PREC_DOUBLE, ref, &nf);
      for (int prec = SPHDEM_PREC_MIXED; prec <= SPHDEM_PREC_SINGLE; prec++) {
        rates_of(&cases[k], prec, st, &nf);
        const double ed = rel_diff(st, ref, nf, 0, 1), ea = rel_diff(st, ref, nf, 1, 4);
        printf("  %-48s %-38s %-6s: drho %.2e, a %.2e (of the largest)\n", cases[k].name,
               on_gpu ? "GPU" : paths[path][0], prec_name(prec), ed, ea);
        const double bound = prec == SPHDEM_PREC_MIXED ? 2e-6 : 2e-5;
        TEST_ASSERT(ed < bound && ea < bound, "%s, %s, %s: drho %.2e, a %.2e against double (bound %.0e)",
                    cases[k].name, on_gpu ? "GPU" : paths[path][0], prec_name(prec), ed, ea, bound);
        /* the float terms ran: a difference from double at float's rounding, not zero */
        TEST_ASSERT(ea > 1e-9, "%s, %s, %s: identical to double (a %.2e): the float pair terms did not run",
                    cases[k].name, on_gpu ? "GPU" : paths[path][0], prec_name(prec), ea);
      }
    }
    unsetenv("SPHDEM_CPU_FLOAT");
    unsetenv("SPHDEM_CPU_GATHER");
    free(ref); free(st);
  }
}

/* ---- tank ----------------------------------------------------------------------------------------------------- */

/* Time-averaged bottom-row pressure of the still tank shifted by x0 along x, precision prec; *refused = 1 when the
 * core refused the fluid (its message printed). */
static double tank_bottom(int prec, double x0, int *refused) {
  const double W = 0.1, H = 0.2;
  const int res = 20;
  sphdem_params p;
  scene_params_still_tank(&p, W, H, res);
  p.precision = prec;
  scene s;
  scene_tank(&s, &p, W, 0, 1.5 * H, W, H, 3);
  for (int i = 0; i < s.nf; i++) s.x[3 * i] += x0;
  for (int i = 0; i < s.nw; i++) s.wx[3 * i] += x0;
  *refused = 0;
  sphdem_ctx c;
  char msg[512];
  if (sphdem_create(&c, &p, test_device(), msg, sizeof msg) != SPHDEM_OK) { printf("create: %s\n", msg); exit(1); }
  if (sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass) != SPHDEM_OK ||
      sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL) != SPHDEM_OK) {
    printf("    %s at x0 = %g m refused: %s\n", prec_name(prec), x0, sphdem_last_error(c));
    *refused = strstr(sphdem_last_error(c), "precision single") != NULL;
    sphdem_destroy(&c);
    scene_free(&s);
    return NAN;
  }
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  const double dt = 0.2 * p.h / (1.2 * p.c0), t_end = 0.6, t_avg = 0.4;
  const int nsteps = (int)(t_end / dt);
  double *x = malloc(24 * (size_t)s.nf), *pr = malloc(8 * (size_t)s.nf), psum = 0;
  int pcnt = 0;
  for (int n = 1; n <= nsteps; n++) {
    SPHDEM_CHECK_RC(c, scene_step(c, dt));
    if (n * dt >= t_avg && n % 20 == 0) {
      SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, NULL, NULL, pr, NULL));
      for (int i = 0; i < s.nf; i++)
        if (x[3 * i + 1] < p.dx) { psum += pr[i]; pcnt++; }
    }
  }
  free(x); free(pr);
  sphdem_destroy(&c);
  scene_free(&s);
  return psum / pcnt;
}

/* single's bottom pressure against double at growing distances from the origin (not a ctest group: the table of
 * doc/fix_sph_fluid.md) */
static void test_tank_scan(void) {
  const double offsets[] = {0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 30.0};
  for (int k = 0; k < 8; k++) {
    int refused;
    const double pd = tank_bottom(SPHDEM_PREC_DOUBLE, offsets[k], &refused);
    const double pp = tank_bottom(SPHDEM_PREC_SINGLE, offsets[k], &refused);
    const double ulp = offsets[k] > 0 ? (double)(nextafterf((float)(offsets[k] + 0.1), INFINITY) - (float)(offsets[k] + 0.1)) : 0;
    printf("  x0 = %5.1f m (float spacing %.2g dx): single bottom pressure %.2f Pa, double %.2f Pa, %.4f%%\n",
           offsets[k], ulp / 0.005, pp, pd, 100 * fabs(pp - pd) / pd);
    fflush(stdout);
  }
}

static void test_tank(void) {
  const double offsets[] = {0.0, 1e4};
  for (int k = 0; k < 2; k++) {
    int refused;
    const double pd = tank_bottom(SPHDEM_PREC_DOUBLE, offsets[k], &refused);
    printf("  x0 = %g m: double bottom pressure %.2f Pa\n", offsets[k], pd);
    for (int prec = SPHDEM_PREC_MIXED; prec <= SPHDEM_PREC_SINGLE; prec++) {
      const double pp = tank_bottom(prec, offsets[k], &refused);
      if (prec == SPHDEM_PREC_SINGLE && offsets[k] > 100) {
        TEST_ASSERT(refused, "single at x0 = %g m (float spacing 0.2 dx) must be refused naming the precision", offsets[k]);
        continue;
      }
      const double e = fabs(pp - pd) / pd;
      printf("  x0 = %g m: %-6s bottom pressure %.2f Pa, %.4f%% from double\n", offsets[k], prec_name(prec), pp, 100 * e);
      TEST_ASSERT(e < 1e-3, "%s at x0 = %g m: bottom pressure %.4f%% from double (bound 0.1%%)", prec_name(prec),
                  offsets[k], 100 * e);
    }
  }
}

/* ---- dam break ------------------------------------------------------------------------------------------------ */

static double dambreak_front(int prec) {
  const double a = 0.1, g = 9.81;
  const int res = 40;
  sphdem_params p;
  scene_params_dambreak2d(&p, a, res);
  p.precision = prec;
  scene s;
  scene_tank(&s, &p, 5 * a, 0, 4 * a, a, 2 * a, 3);
  sphdem_ctx c = scene_start(&p, &s, test_device());
  const double dt = 0.2 * p.h / (1.2 * p.c0), tscale = sqrt(2 * g / a);
  const int nsteps = (int)(2.5 / tscale / dt);
  for (int n = 0; n < nsteps; n++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, s.x, NULL, NULL, NULL, NULL));
  double z = 0;
  for (int i = 0; i < s.nf; i++) z = fmax(z, s.x[3 * i] / a);
  sphdem_destroy(&c);
  scene_free(&s);
  return z;
}

static void test_dambreak(void) {
  const double zd = dambreak_front(SPHDEM_PREC_DOUBLE);
  printf("  front at T = 2.5: double Z = %.5f\n", zd);
  for (int prec = SPHDEM_PREC_MIXED; prec <= SPHDEM_PREC_SINGLE; prec++) {
    const double z = dambreak_front(prec), e = fabs(z - zd) / zd;
    printf("  front at T = 2.5: %-6s Z = %.5f, %.4f%% from double\n", prec_name(prec), z, 100 * e);
    /* single: measured 1.04 % (its slow particles move in float steps); its bound documents that, 0.1 % is mixed's */
    const double bound = prec == SPHDEM_PREC_MIXED ? 1e-3 : 3e-2;
    TEST_ASSERT(e < bound, "%s: surge front %.4f%% from double (bound %g%%)", prec_name(prec), 100 * e, 100 * bound);
  }
}

int main(int argc, char **argv) {
  const char *grp = argc > 1 ? argv[1] : "rates";
  if (!strcmp(grp, "rates")) test_rates();
  else if (!strcmp(grp, "tank")) test_tank();
  else if (!strcmp(grp, "tank_scan")) test_tank_scan();
  else if (!strcmp(grp, "dambreak")) test_dambreak();
  else { fprintf(stderr, "verify_precision: group must be rates, tank or dambreak (got %s)\n", grp); return 2; }
  return test_summary("verify_precision");
}
