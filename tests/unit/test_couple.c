/* test_couple.c - SPH-DEM coupling core (He 2018 §2.3-2.4.1): dual-grid pairs vs brute force, porosity
 * (eq 26) vs analytic values, drag laws vs closed forms, momentum exchange summing to zero (eq 33),
 * coupling off == bit-identical to the uncoupled run, argument errors naming the field. */
#include <math.h>
#include "couple_bodies.h"
#include "couple_bed.h"
#include "testlib.h"

static double urand(void) { return rand() / (RAND_MAX + 1.0); }

static int cmp_pair(const void *a, const void *b) {
  const int64_t *x = (const int64_t *)a, *y = (const int64_t *)b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  if (x[1] != y[1]) return x[1] < y[1] ? -1 : 1;
  return 0;
}

static sphdem_ctx make_ctx(const sphdem_params *p) {
  sphdem_ctx c;
  char msg[512];
  if (sphdem_create(&c, p, test_device(), msg, sizeof msg) != SPHDEM_OK) { printf("create: %s\n", msg); exit(1); }
  return c;
}

/* ---- dual-grid search vs brute force ---------------------------------------------------------------- */
static void pairs_case(int dim, int periodic, double ratio, double hc_over_h, unsigned seed) {
  sphdem_params p;
  base_params(&p, dim);
  double L = dim == 3 ? 0.12 : 0.3;
  for (int d = 0; d < dim; d++) { p.boxlo[d] = 0; p.boxhi[d] = L; p.periodic[d] = periodic; }
  srand(seed);
  int nf = dim == 3 ? 3000 : 2000, ng = dim == 3 ? 150 : 120;
  scene s;
  memset(&s, 0, sizeof s);
  for (int i = 0; i < nf; i++) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < dim; d++) x[d] = L * urand();
    scene_push_fluid(&s, x, 1000, 1000 * pow(p.dx, dim));
  }
  for (int i = 0; i < nf; i++) s.tag[i] = (int64_t)((i * 7919L) % nf) + 1;
  double dmax = ratio * 2 * p.h, *gx = calloc(3 * (size_t)ng, 8), *gv = calloc(3 * (size_t)ng, 8), *gr = malloc(8 * (size_t)ng);
  for (int j = 0; j < ng; j++) {
    for (int d = 0; d < dim; d++) gx[3 * j + d] = periodic ? L * (1.2 * urand() - 0.1) : L * urand(); /* outside the box: wrapped */
    gr[j] = 0.5 * dmax * (0.5 + 0.5 * urand());
  }
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3; cp.hc = hc_over_h * p.h;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  int64_t maxp = (int64_t)nf * ng, *got = malloc(16 * (size_t)maxp), *ref = malloc(16 * (size_t)maxp), nr = 0;
  int64_t ng_ = sphdem_debug_couple_pairs(c, got, maxp);
  if (ng_ < 0) printf("  debug_couple_pairs: %s\n", sphdem_last_error(c));
  double hc = cp.hc, rc2 = 4 * hc * hc;
  for (int i = 0; i < nf; i++)
    for (int j = 0; j < ng; j++) {
      double r2 = 0;
      for (int d = 0; d < dim; d++) {
        double dd = s.x[3 * i + d] - gx[3 * j + d];
        if (periodic) dd -= L * rint(dd / L);
        r2 += dd * dd;
      }
      if (r2 < rc2) { ref[2 * nr] = i; ref[2 * nr + 1] = j; nr++; }
    }
  if (ng_ > 0) qsort(got, (size_t)ng_, 16, cmp_pair);
  qsort(ref, (size_t)nr, 16, cmp_pair);
  int same = ng_ == nr && memcmp(got, ref, 16 * (size_t)nr) == 0;
  TEST_ASSERT(same && nr > 0, "%dD periodic %d d/2h %.2f hc/h %.1f: dual grid %lld pairs, brute force %lld", dim,
              periodic, ratio, hc_over_h, (long long)ng_, (long long)nr);
  printf("  %dD periodic %d d/2h %.2f hc/h %.1f: %lld (fluid, grain) pairs match brute force (both searches)\n",
         dim, periodic, ratio, hc_over_h, (long long)nr);
  free(got); free(ref); free(gx); free(gv); free(gr);
  scene_free(&s);
  sphdem_destroy(&c);
}

/* ---- porosity ------------------------------------------------------------------------------------------ */
static void porosity_single(int dim) {
  sphdem_params p;
  base_params(&p, dim);
  srand(3);
  scene s;
  memset(&s, 0, sizeof s);
  double g[3] = {0.05, 0.05, dim == 3 ? 0.05 : 0}, r = 0.004, hc = 1.2 * p.h;
  for (int i = 0; i < 800; i++) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < dim; d++) x[d] = g[d] + 2.5 * hc * (2 * urand() - 1);
    scene_push_fluid(&s, x, 1000, 1000 * pow(p.dx, dim));
  }
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.hc = hc;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  double v0[3] = {0, 0, 0};
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 1, g, v0, &r, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double *eps = malloc(8 * (size_t)s.nf), worst = 0, V = dim == 3 ? 4.0 / 3 * M_PI * r * r * r : M_PI * r * r;
  SPHDEM_CHECK_RC(c, sphdem_get_porosity(c, eps));
  double aD = dim == 3 ? 21 / (16 * M_PI * hc * hc * hc) : 7 / (4 * M_PI * hc * hc);
  int inside = 0;
  for (int i = 0; i < s.nf; i++) {
    double r2 = 0;
    for (int d = 0; d < dim; d++) r2 += (s.x[3 * i + d] - g[d]) * (s.x[3 * i + d] - g[d]);
    double q = sqrt(r2) / hc, W = q < 2 ? aD * pow(1 - q / 2, 4) * (1 + 2 * q) : 0, e = fabs(eps[i] - (1 - V * W));
    if (e > worst) worst = e;
    inside += q < 2;
  }
  TEST_ASSERT(worst < 1e-14 && inside > 10, "%dD single grain: eps = 1 - V W(r, hc) to %.2e", dim, worst);
  printf("  %dD single grain: porosity at %d fluid particles within 2hc equals 1 - V W to %.1e\n", dim, inside, worst);
  free(eps);
  scene_free(&s);
  sphdem_destroy(&c);
}

/* Simple cubic (square in 2D) periodic packing of spacing a = hc/2: eps = 1 - V/a^dim up to the kernel's
 * lattice-sum error (1.5e-4 of the solid fraction for Wendland C2 at a = h/2 in 3D). */
static void porosity_packing(int dim, double r_over_a) {
  sphdem_params p;
  base_params(&p, dim);
  double hc = p.h, a = 0.5 * hc;
  int m = 24;
  double L = m * a;
  for (int d = 0; d < dim; d++) { p.boxlo[d] = 0; p.boxhi[d] = L; p.periodic[d] = 1; }
  int ng = dim == 3 ? m * m * m : m * m;
  double *gx = calloc(3 * (size_t)ng, 8), *gv = calloc(3 * (size_t)ng, 8), *gr = malloc(8 * (size_t)ng);
  int j = 0;
  for (int k = 0; k < (dim == 3 ? m : 1); k++)
    for (int jj = 0; jj < m; jj++)
      for (int i = 0; i < m; i++, j++) {
        gx[3 * j] = (i + 0.25) * a; gx[3 * j + 1] = (jj + 0.25) * a; gx[3 * j + 2] = dim == 3 ? (k + 0.25) * a : 0;
        gr[j] = r_over_a * a;
      }
  srand(11);
  scene s;
  memset(&s, 0, sizeof s);
  for (int i = 0; i < 500; i++) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < dim; d++) x[d] = L * urand();
    scene_push_fluid(&s, x, 1000, 1000 * pow(p.dx, dim));
  }
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double *eps = malloc(8 * (size_t)s.nf), worst = 0;
  SPHDEM_CHECK_RC(c, sphdem_get_porosity(c, eps));
  double phi = (dim == 3 ? 4.0 / 3 * M_PI * pow(r_over_a, 3) : M_PI * r_over_a * r_over_a);
  for (int i = 0; i < s.nf; i++) worst = fmax(worst, fabs(eps[i] - (1 - phi)));
  sphdem_couple_stats st;
  SPHDEM_CHECK_RC(c, sphdem_couple_stats_get(c, &st));
  double bound = dim == 3 ? 1e-3 * phi : 2e-3 * phi;
  TEST_ASSERT(worst < bound, "%dD packing r/a %.2f: eps vs 1 - phi = %.5f: max deviation %.2e (bound %.1e)", dim,
              r_over_a, 1 - phi, worst, bound);
  TEST_ASSERT(fabs(st.eps_min - (1 - phi)) <= worst + 1e-15, "stats eps_min %.6f", st.eps_min);
  printf("  %dD periodic packing a = hc/2, r/a = %.2f: eps = %.6f vs 1 - phi = %.6f (max deviation %.1e, %.1e of phi)\n",
         dim, r_over_a, eps[0], 1 - phi, worst, worst / phi);
  free(eps); free(gx); free(gv); free(gr);
  scene_free(&s);
  sphdem_destroy(&c);
}

/* ---- drag laws ------------------------------------------------------------------------------------------ */
static void drag_laws(void) {
  double mu = 1e-3, rho = 1000, d = 1e-3, V = M_PI * d * d * d / 6, A = M_PI * d * d / 4, w = 0.05;
  double Re = rho * d * w / mu, cd = 24 / Re * (1 + 0.15 * pow(Re, 0.687));
  double Fsn = drag_coefficient(SPHDEM_DRAG_SCHILLER_NAUMANN, mu, 0.7, rho, d, w) * V * w;
  TEST_ASSERT(fabs(Fsn / (0.5 * cd * rho * A * w * w) - 1) < 1e-13, "Schiller-Naumann: F = 1/2 C_D rho A w^2");
  double Fwy = drag_coefficient(SPHDEM_DRAG_ERGUN_WENYU, mu, 1.0, rho, d, w) * V * w;
  TEST_ASSERT(fabs(Fwy / Fsn - 1) < 1e-13, "Wen-Yu at eps = 1 equals the single-sphere drag");
  double e = 0.6, Ferg = drag_coefficient(SPHDEM_DRAG_ERGUN_WENYU, mu, e, rho, d, w);
  double beta = 150 * mu * (1 - e) * (1 - e) / (e * d * d) + 1.75 * (1 - e) * rho * w / d;
  TEST_ASSERT(fabs(Ferg * (1 - e) / beta - 1) < 1e-13, "Ergun: K (1 - eps) = beta of eq 31");
  double e2 = 0.9, Re2 = e2 * Re, cd2 = 24 / Re2 * (1 + 0.15 * pow(Re2, 0.687));
  double bwy = 0.75 * cd2 * e2 * (1 - e2) * rho * w * pow(e2, -2.65) / d;
  TEST_ASSERT(fabs(drag_coefficient(SPHDEM_DRAG_ERGUN_WENYU, mu, e2, rho, d, w) * (1 - e2) / bwy - 1) < 1e-13,
              "Wen-Yu: K (1 - eps) = beta of eq 31");
  double chi = 3.7 - 0.65 * exp(-pow(1.5 - log10(Re2), 2) / 2), cdd = pow(0.63 + 4.8 / sqrt(Re2), 2);
  double Fdf = 0.5 * cdd * rho * A * e2 * e2 * w * w * pow(e2, -chi);
  TEST_ASSERT(fabs(drag_coefficient(SPHDEM_DRAG_DIFELICE, mu, e2, rho, d, w) * V * w / Fdf - 1) < 1e-13, "Di Felice 1994");
  /* Stokes limit, finite as w -> 0 */
  double K0 = drag_coefficient(SPHDEM_DRAG_SCHILLER_NAUMANN, mu, 1, rho, d, 0.0);
  TEST_ASSERT(fabs(K0 * V / (3 * M_PI * mu * d) - 1) < 1e-13, "w -> 0: Stokes drag 3 pi mu d");
  TEST_ASSERT(drag_coefficient(SPHDEM_DRAG_NONE, mu, 0.5, rho, d, w) == 0, "drag none");
  printf("  drag laws: Schiller-Naumann, Ergun / Wen-Yu (eq 31), Di Felice, Stokes limit match closed forms\n");
}

/* ---- momentum exchange, forces ------------------------------------------------------------------------- */
static double g_immersion = 0.0; /* immersion keyword of the momentum_exchange cases */
static int g_wall_eps = 0;        /* wall_porosity fluid (1) in the momentum_exchange cases */

static void momentum_exchange(int dim, int drag, int torque) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, dim);
  srand(5 + dim);
  int ng = 20;
  double gx[60] = {0}, gv[60] = {0}, gr[20], om[60] = {0};
  for (int j = 0; j < ng; j++) {
    gx[3 * j] = 0.1 * urand(); gx[3 * j + 1] = (dim == 3 ? 0.05 : 0.1) * urand();
    /* with immersion the grains reach above the surface (z = 0.1), so that some feel a share of the force */
    if (dim == 3) gx[3 * j + 2] = (g_immersion > 0 ? 0.115 : 0.1) * urand();
    for (int d = 0; d < dim; d++) { gv[3 * j + d] = 0.1 * (urand() - 0.5); om[3 * j + d] = 10 * (urand() - 0.5); }
    gr[j] = 0.001 + 0.002 * urand();
  }
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = drag; cp.mu = 1e-3; cp.torque = torque; cp.immersion = g_immersion;
  cp.wall_porosity = g_wall_eps;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  double dt = 0.2 * p.h / (1.2 * p.c0), worst = 0, fmag = 0;
  if (g_immersion > 0 || g_wall_eps) printf("  (immersion %g, wall_porosity %s)\n", g_immersion, g_wall_eps ? "fluid" : "none");
  for (int n = 0; n < 20; n++) {
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, om));
    if (n == 0) SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    else SPHDEM_CHECK_RC(c, scene_step(c, dt));
    sphdem_couple_stats st;
    SPHDEM_CHECK_RC(c, sphdem_couple_stats_get(c, &st));
    double f[60], fd[60], fp[60], tq[60], sum[3] = {0, 0, 0};
    SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, fd, fp, tq));
    double split = 0, fg = 0, res = 0;
    for (int j = 0; j < ng; j++)
      for (int d = 0; d < 3; d++) {
        sum[d] += f[3 * j + d];
        split = fmax(split, fabs(f[3 * j + d] - fd[3 * j + d] - fp[3 * j + d]));
      }
    for (int d = 0; d < 3; d++) {
      fg += st.f_grains[d] * st.f_grains[d];
      res += pow(st.f_grains[d] + st.f_fluid[d], 2);
      TEST_ASSERT(fabs(sum[d] - st.f_grains[d]) <= 1e-12 * fabs(sum[d]) + 1e-300, "stats f_grains = sum of forces");
    }
    TEST_ASSERT(split <= 1e-15 * sqrt(fg) + 1e-300, "f = fdrag + fpg");
    worst = fmax(worst, sqrt(res / fg));
    fmag = sqrt(fg);
    if (n == 19 && torque) {
      double tmax = 0;
      for (int j = 0; j < 3 * ng; j++) tmax = fmax(tmax, fabs(tq[j]));
      TEST_ASSERT(tmax > 0 && isfinite(tmax), "torque computed");
    }
    for (int j = 0; j < ng; j++)
      for (int d = 0; d < dim; d++) gx[3 * j + d] += dt * gv[3 * j + d];
  }
  TEST_ASSERT(worst < 1e-12, "%dD: |f_grains + f_fluid| / |f_grains| = %.2e over 20 steps", dim, worst);
  /* the fluid set rebuilt with more particles (new tags): the porosity array follows, the forces stay */
  {
    scene s2;
    sphdem_params p2 = p;
    scene_tank(&s2, &p2, 0.1, 0.05, 0.15, 0.1, 0.12, 3);
    for (int i = 0; i < s2.nf; i++) s2.tag[i] += 100000;
    double f0[60];
    SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s2.nf, s2.tag, s2.x, s2.v, s2.rho, s2.mass, NULL));
    TEST_ASSERT(sphdem_get_grain_forces(c, f0, NULL, NULL, NULL) == SPHDEM_OK, "forces kept after a fluid rebuild");
    sphdem_stats fs;
    SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0, &fs));
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, om));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    sphdem_couple_stats st;
    SPHDEM_CHECK_RC(c, sphdem_couple_stats_get(c, &st));
    double res = 0, fg = 0;
    for (int d = 0; d < 3; d++) { res += pow(st.f_grains[d] + st.f_fluid[d], 2); fg += pow(st.f_grains[d], 2); }
    TEST_ASSERT(s2.nf > s.nf && sqrt(res / fg) < 1e-12, "after a rebuild to %d fluid particles the exchange still sums to 0",
                s2.nf);
    scene_free(&s2);
  }
  printf("  %dD tank, 20 grains, drag %d torque %d: |sum f_grains + sum f_fluid| / |sum f_grains| <= %.2e "
         "(|sum f_grains| = %.3e N) over 20 steps\n", dim, drag, torque, worst, fmag);
  scene_free(&s);
  sphdem_destroy(&c);
}

/* ---- coupling off: bit-identical --------------------------------------------------------------------------- */
static void run_mode(int dim, int mode, double *x, double *v, double *rho, int *nf) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, dim);
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  double gx[3] = {0.05, 0.05, 0.05}, gv[3] = {0, -0.1, 0}, gr = 0.002;
  if (mode >= 1) { /* enabled, then: mode 1 disabled again; mode 2 enabled without grains */
    cp.enabled = 1; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3;
    SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
    if (mode == 1) {
      SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 1, gx, gv, &gr, NULL));
      cp.enabled = 0;
      SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
    }
  }
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double dt = 0.2 * p.h / (1.2 * p.c0);
  for (int n = 0; n < 30; n++) {
    if (mode == 1) SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 1, gx, gv, &gr, NULL)); /* ignored while off */
    SPHDEM_CHECK_RC(c, scene_step(c, dt));
  }
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, v, rho, NULL, NULL));
  *nf = s.nf;
  if (mode == 1) TEST_ASSERT(sphdem_get_grain_forces(c, gx, NULL, NULL, NULL) == SPHDEM_ERR_STATE, "forces while off");
  scene_free(&s);
  sphdem_destroy(&c);
}

static void disabled_identical(int dim) {
  static double x[3][3 * 20000], v[3][3 * 20000], rho[3][20000];
  int nf[3];
  for (int m = 0; m < 3; m++) run_mode(dim, m, x[m], v[m], rho[m], &nf[m]);
  for (int m = 1; m < 3; m++) {
    int same = nf[m] == nf[0] && !memcmp(x[m], x[0], 24 * (size_t)nf[0]) && !memcmp(v[m], v[0], 24 * (size_t)nf[0]) &&
               !memcmp(rho[m], rho[0], 8 * (size_t)nf[0]);
    TEST_ASSERT(same, "%dD: %s gives bit-identical x, v, rho after 30 steps", dim,
                m == 1 ? "coupling disabled" : "coupling on without grains");
  }
  printf("  %dD tank, %d fluid: coupling disabled and coupling without grains bit-identical to the uncoupled run\n",
         dim, nf[0]);
}

/* Keyword immersion: grains at rest in still water (3D tank, surface z = 0.1). A grain deep in the water (far from
 * walls, or beside a wall: the wall volume is not counted against it) feels bit-identically the force it feels
 * without the keyword; a grain just above the surface, touched by the top fluid layer, feels a share of it. */
static void immersion_forces(void) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, 3);
  double gx[12] = {0.05, 0.025, 0.05, 0.004, 0.025, 0.05, 0.05, 0.025, 0.1 + 0.9 * p.h, 0.05, 0.025, 0.1},
         gv[12] = {0}, gr[4] = {0.001, 0.001, 0.001, 0.001}, f[2][12];
  for (int on = 0; on <= 1; on++) {
    sphdem_ctx c = make_ctx(&p);
    sphdem_couple_params cp;
    sphdem_couple_params_default(&cp);
    cp.enabled = 1; cp.mu = 1e-3; cp.immersion = on ? 0.5 : 0.0;
    SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
    SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
    SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 4, gx, gv, gr, NULL));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f[on], NULL, NULL, NULL));
    sphdem_destroy(&c);
  }
  const char *name[4] = {"deep, centre", "deep, 4 mm from a wall", "above the surface (0.9 h)", "at the surface"};
  for (int j = 0; j < 4; j++)
    printf("  immersion 0.5: grain %-26s F_z %.4e N (off: %.4e N)\n", name[j], f[1][3 * j + 2], f[0][3 * j + 2]);
  TEST_ASSERT(memcmp(f[0], f[1], 6 * sizeof(double)) == 0, "immersion 0.5: submerged grains feel the same force");
  TEST_ASSERT(fabs(f[1][8]) < 0.8 * fabs(f[0][8]) && f[0][8] * f[1][8] >= 0,
              "immersion 0.5: a grain above the surface feels a share of the force (%.3e of %.3e)", f[1][8], f[0][8]);
  scene_free(&s);
}

/* A coupled context on the tank scene with the grains, after one rate evaluation; eps (nf) gets eq 26. */
static sphdem_ctx bed_ctx(const sphdem_params *p, scene *s, int eps_walls, int ng, const double *gx, const double *gv,
                          const double *gr, double *eps) {
  sphdem_ctx c = make_ctx(p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.mu = 1e-3; cp.eps_walls = eps_walls;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s->nw, s->wx, s->wv, NULL, s->wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s->nf, s->tag, s->x, s->v, s->rho, s->mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  SPHDEM_CHECK_RC(c, sphdem_get_porosity(c, eps));
  return c;
}

/* Keyword eps_walls: porosity of a uniform packing against the tank walls. Eq 26 sums the grain volumes in the
 * kernel, which the walls cut: beside a wall it counts fewer grains and gives too high a porosity. Divided by the
 * kernel share inside the walls (1 - wall volume sum), every fluid particle of the bed (those further than 2 h_c
 * from the bed's top) is within 1 % of the packing's porosity 1 - 4/3 pi 0.39^3; without the keyword the layer
 * beside the walls is more than 5 % too high (the paper's eq 26, kept as the default). */
static void porosity_walls(void) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, 3);
  double *gx, *gv, *gr, *eps = malloc(8 * (size_t)s.nf), e_true = 1.0 - 4.0 / 3.0 * M_PI * pow(0.39, 3);
  int ng = bed_grains(p.dx, &gx, &gv, &gr);
  double worst[2] = {0, 0}, wall_mean[2] = {0, 0};
  for (int on = 0; on <= 1; on++) {
    sphdem_ctx c = bed_ctx(&p, &s, on, ng, gx, gv, gr, eps);
    int nwall = 0, nbed = 0;
    for (int i = 0; i < s.nf; i++) {
      const double *xi = s.x + 3 * i;
      if (xi[2] > 0.05 - 2.0 * p.h) continue;
      double dmin = fmin(fmin(fmin(xi[0], 0.1 - xi[0]), fmin(xi[1], 0.05 - xi[1])), xi[2]);
      worst[on] = fmax(worst[on], fabs(eps[i] - e_true) / e_true);
      nbed++;
      if (dmin < p.dx) { wall_mean[on] += eps[i]; nwall++; }
    }
    wall_mean[on] /= nwall > 0 ? nwall : 1;
    printf("  eps_walls %s: %d bed particles, worst |eps - %.4f| %.2f%%; mean eps of the %d beside a wall %.4f\n",
           on ? "yes" : "no ", nbed, e_true, 100 * worst[on], nwall, wall_mean[on]);
    sphdem_destroy(&c);
  }
  TEST_ASSERT(worst[1] < 0.01, "eps_walls yes: uniform packing porosity within 1%% at the walls too (%.2f%%)", 100 * worst[1]);
  TEST_ASSERT(wall_mean[0] > 1.05 * e_true, "eps_walls no: eq 26 beside a wall is > 5%% high (%.4f vs %.4f)",
              wall_mean[0], e_true);
  free(gx); free(gv); free(gr); free(eps);
  scene_free(&s);
}

/* sphdem_couple_seed_porosity: a continued run (restart) whose rates are valid starts without a rate evaluation.
 * A fresh context given the superficial densities of a packed bed (rho_bar = eps rho) then reads eps = 1 until
 * its first compute_rates and its density check sees |eps - 1| = 0.25; seeded with the porosity of the first
 * context it sees the first context's density error, and the next compute_rates computes eq 26 itself. */
static void seed_porosity(void) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, 3);
  double *gx, *gv, *gr, *eps = malloc(8 * (size_t)s.nf), *eps2 = malloc(8 * (size_t)s.nf);
  int ng = bed_grains(p.dx, &gx, &gv, &gr);
  sphdem_couple_params cp;
  sphdem_ctx c = bed_ctx(&p, &s, 1, ng, gx, gv, gr, eps);
  SPHDEM_CHECK_RC(c, sphdem_couple_get(c, &cp));
  for (int i = 0; i < s.nf; i++) s.rho[i] *= fmax(eps[i], cp.eps_min); /* superficial densities, as stored */
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  sphdem_stats st0, st1, st2;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, 0.0, &st0));
  sphdem_destroy(&c);

  sphdem_ctx d = make_ctx(&p);
  SPHDEM_CHECK_RC(d, sphdem_couple_set(d, &cp));
  SPHDEM_CHECK_RC(d, sphdem_set_walls(d, s.nw, s.wx, s.wv, NULL, s.wmass));
  SPHDEM_CHECK_RC(d, sphdem_set_fluid(d, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(d, sphdem_set_grains(d, ng, gx, gv, gr, NULL));
  sphdem_stats_get(d, 0.0, &st1); /* may report the density error: that is the point */
  double bad = eps[0];
  eps[0] = 1.5;
  TEST_ASSERT(sphdem_couple_seed_porosity(d, s.nf, eps) == SPHDEM_ERR_ARG && strstr(sphdem_last_error(d), "eps[0]"),
              "seed_porosity: a value outside (0, 1] is refused, naming it");
  eps[0] = bad;
  TEST_ASSERT(sphdem_couple_seed_porosity(d, s.nf - 1, eps) == SPHDEM_ERR_ARG, "seed_porosity: a wrong count is refused");
  SPHDEM_CHECK_RC(d, sphdem_couple_seed_porosity(d, s.nf, eps));
  SPHDEM_CHECK_RC(d, sphdem_stats_get(d, 0.0, &st2));
  printf("  seed_porosity: packed bed, density error of the first context %.4f; fresh context %.4f unseeded, %.4f "
         "seeded\n", st0.rho_err, st1.rho_err, st2.rho_err);
  TEST_ASSERT(st1.rho_err > 0.2, "unseeded, the fresh context takes eps = 1 (density error %.3f)", st1.rho_err);
  TEST_ASSERT(fabs(st2.rho_err - st0.rho_err) < 1e-12, "seeded, it sees the first context's density error (%.3g vs %.3g)",
              st2.rho_err, st0.rho_err);
  for (int i = 0; i < s.nf; i++) eps2[i] = 0.5; /* a wrong seed is replaced by the next rate evaluation */
  SPHDEM_CHECK_RC(d, sphdem_couple_seed_porosity(d, s.nf, eps2));
  SPHDEM_CHECK_RC(d, sphdem_compute_rates(d));
  SPHDEM_CHECK_RC(d, sphdem_get_porosity(d, eps2));
  double worst = 0;
  for (int i = 0; i < s.nf; i++) worst = fmax(worst, fabs(eps2[i] - eps[i]));
  TEST_ASSERT(worst < 1e-14, "seed_porosity: compute_rates computes eq 26 again (max |diff| %.3g)", worst);
  sphdem_destroy(&d);
  sphdem_ctx e = make_ctx(&p);
  TEST_ASSERT(sphdem_couple_seed_porosity(e, 0, NULL) == SPHDEM_ERR_STATE, "seed_porosity: refused without coupling");
  sphdem_destroy(&e);
  free(gx); free(gv); free(gr); free(eps); free(eps2);
  scene_free(&s);
}

/* Keyword pressure_form volume: a packed bed at rest stays at rest. The bed of couple_bed.h kept 15 mm from the side
 * walls and lifted 20 mm off the floor (its edges are all inside the water), 400 steps (0.043 s). With the mass
 * form of eq 9 the masses m = eps m_0 weight the pressure gradient with the neighbours' porosity, the columns at
 * the bed's vertical edges are out of balance, and the flow grows (measured 2.4e-2 m/s at 400 steps, printed, not
 * asserted: it is the failure the keyword removes). With the volume form the bed is as quiet as the water without
 * grains (5.3e-3 m/s at 400 steps, the fastest particles at the free surface in both). Bound: 1 % of sqrt(g H). */
static void bed_floating(void) {
  double v[2], pe[2], bu[2], vscale = sqrt(9.81 * 0.1);
  for (int f = 0; f <= 1; f++) {
    bed_opts o;
    bed_result r;
    bed_opts_default(&o);
    o.inset = 0.015; o.lift = 0.02; o.steps = 400; o.pressure_form = f;
    bed_run(&o, test_device(), &r);
    v[f] = r.vmax; pe[f] = r.perr; bu[f] = r.buo;
  }
  printf("  floating packed bed, 400 steps: pressure_form mass vmax %.2e m/s, volume vmax %.2e m/s (bound %.2e); "
         "volume: pressure error %.2f%% of rho0 g H, Archimedes %.4f\n", v[0], v[1], 0.01 * vscale, 100 * pe[1], bu[1]);
  TEST_ASSERT(v[1] < 0.01 * vscale, "pressure_form volume: the floating packed bed stays at rest (vmax %.2e)", v[1]);
  TEST_ASSERT(pe[1] < 0.05, "pressure_form volume: pressure hydrostatic within 5%% of rho0 g H (%.2f%%)", 100 * pe[1]);
  TEST_ASSERT(fabs(bu[1] - 1) < 0.03, "pressure_form volume: interior grains feel Archimedes' force within 3%% (%.4f)",
              bu[1]);
}

/* ---- argument errors ---------------------------------------------------------------------------------------- */
static int bad(sphdem_ctx c, sphdem_couple_params cp, const char *word) {
  int rc = sphdem_couple_set(c, &cp);
  int ok = rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), word);
  if (!ok) printf("  couple_set message '%s' lacks '%s' (rc %d)\n", sphdem_last_error(c), word, rc);
  return ok;
}

static void argument_errors(void) {
  sphdem_params p;
  base_params(&p, 3);
  for (int d = 0; d < 3; d++) { p.boxlo[d] = 0; p.boxhi[d] = 0.1; }
  p.periodic[0] = 1;
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp, b;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3;
  TEST_ASSERT(sphdem_couple_set(c, &cp) == SPHDEM_OK, "valid parameters accepted: %s", sphdem_last_error(c));
  b = cp; b.hc = -1; TEST_ASSERT(bad(c, b, "hc"), "hc checked");
  b = cp; b.hc = 0.02; TEST_ASSERT(bad(c, b, "hc"), "hc vs periodic box checked");
  b = cp; b.drag = 9; TEST_ASSERT(bad(c, b, "drag"), "drag checked");
  b = cp; b.mu = 0; TEST_ASSERT(bad(c, b, "mu"), "mu checked");
  b = cp; b.drag = SPHDEM_DRAG_NONE; b.mu = 0; b.torque = 1; TEST_ASSERT(bad(c, b, "mu"), "mu checked for torque");
  b = cp; b.eps_min = 0; TEST_ASSERT(bad(c, b, "eps_min"), "eps_min checked");
  b = cp; b.eps_min = 1; TEST_ASSERT(bad(c, b, "eps_min"), "eps_min checked");
  b = cp; b.superficial = 2; TEST_ASSERT(bad(c, b, "superficial"), "superficial checked");
  b = cp; b.torque = -1; TEST_ASSERT(bad(c, b, "torque"), "torque checked");
  b = cp; b.dmax = -1; TEST_ASSERT(bad(c, b, "dmax"), "dmax checked");
  b = cp; b.pressure_form = 2; TEST_ASSERT(bad(c, b, "pressure_form"), "pressure_form checked");
  b = cp; b.enabled = 3; TEST_ASSERT(bad(c, b, "enabled"), "enabled checked");
  b = cp; b.hc = 1e-100; TEST_ASSERT(bad(c, b, "hc (coupling smoothing length) 1e-100 is outside"), "tiny hc checked");
  sphdem_couple_params got;
  SPHDEM_CHECK_RC(c, sphdem_couple_get(c, &got));
  TEST_ASSERT(got.enabled == 1 && got.drag == cp.drag && got.mu == cp.mu, "a rejected set keeps the previous parameters");
  double x[3] = {0.05, 0.05, 0.05}, v[3] = {0, 0, 0}, r = -1, xn[3] = {NAN, 0, 0}, r1 = 0.001;
  TEST_ASSERT(sphdem_set_grains(c, 1, x, v, &r, NULL) == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "radius"),
              "set_grains: radius checked (%s)", sphdem_last_error(c));
  TEST_ASSERT(sphdem_set_grains(c, 1, xn, v, &r1, NULL) == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "position"),
              "set_grains: position checked");
  TEST_ASSERT(sphdem_set_grains(c, -1, x, v, &r1, NULL) == SPHDEM_ERR_ARG, "set_grains: count checked");
  TEST_ASSERT(sphdem_get_grain_forces(c, NULL, NULL, NULL, NULL) == SPHDEM_ERR_STATE, "no forces before compute_rates");
  printf("  bad coupling parameters give SPHDEM_ERR_ARG with a message naming the field\n");
  sphdem_destroy(&c);
}

/* hc far above the cell sizes (1e8 m: more search layers than an int holds before clamping to the
 * grid) runs with the layers clamped to the grid: porosity 1 - V W(r, hc), finite grain forces */
static void huge_hc(void) {
  sphdem_params p;
  base_params(&p, 3);
  for (int d = 0; d < 3; d++) { p.boxlo[d] = 0; p.boxhi[d] = 0.1; }
  scene s;
  memset(&s, 0, sizeof s);
  srand(5);
  for (int i = 0; i < 200; i++) {
    double x[3] = {0.1 * urand(), 0.1 * urand(), 0.1 * urand()};
    scene_push_fluid(&s, x, 1000, 1000 * pow(p.dx, 3));
  }
  sphdem_ctx c = make_ctx(&p);
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.hc = 1e8; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  double g[6] = {0.03, 0.05, 0.05, 0.07, 0.05, 0.05}, gv[6] = {0.01, 0, 0, 0, 0, 0}, r[2] = {0.002, 0.002};
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 2, g, gv, r, NULL));
  int rc = sphdem_compute_rates(c);
  double *eps = malloc(8 * (size_t)s.nf), f[6] = {0};
  if (!rc) rc = sphdem_get_porosity(c, eps);
  if (!rc) rc = sphdem_get_grain_forces(c, f, NULL, NULL, NULL);
  double hc = cp.hc, V = 4.0 / 3 * M_PI * r[0] * r[0] * r[0], worst = 0;
  double aD = 21 / (16 * M_PI * hc * hc * hc);
  for (int i = 0; !rc && i < s.nf; i++) {
    double W = 0;
    for (int k = 0; k < 2; k++) {
      double r2 = 0;
      for (int d = 0; d < 3; d++) r2 += (s.x[3 * i + d] - g[3 * k + d]) * (s.x[3 * i + d] - g[3 * k + d]);
      double q = sqrt(r2) / hc;
      W += aD * pow(1 - q / 2, 4) * (1 + 2 * q);
    }
    worst = fmax(worst, fabs(eps[i] - (1 - V * W)));
  }
  int finite = 1;
  for (int k = 0; k < 6; k++) finite &= isfinite(f[k]);
  TEST_ASSERT(rc == SPHDEM_OK && worst < 1e-14 && finite, "hc 1e8: rc %d (%s), porosity error %.2e, forces finite %d",
              rc, sphdem_last_error(c), worst, finite);
  free(eps);
  scene_free(&s);
  sphdem_destroy(&c);
}

int main(void) {
  double ratios[] = {0.2, 0.5, 1.0, 2.0, 3.0};
  for (int dim = 2; dim <= 3; dim++)
    for (int per = 0; per <= 1; per++)
      for (int k = 0; k < 5; k++) pairs_case(dim, per, ratios[k], 1.0, 100u + 10 * dim + per + 7 * k);
  pairs_case(3, 1, 0.5, 1.4, 77u); /* hc > h: two SPH-cell layers */
  pairs_case(2, 0, 0.2, 2.5, 78u);
  for (int dim = 2; dim <= 3; dim++) porosity_single(dim);
  porosity_packing(3, 0.2);
  porosity_packing(3, 0.4);
  porosity_packing(2, 0.3);
  drag_laws();
  momentum_exchange(2, SPHDEM_DRAG_ERGUN_WENYU, 1);
  momentum_exchange(3, SPHDEM_DRAG_ERGUN_WENYU, 1);
  momentum_exchange(3, SPHDEM_DRAG_DIFELICE, 0);
  g_immersion = 0.5;
  momentum_exchange(3, SPHDEM_DRAG_ERGUN_WENYU, 1);
  g_immersion = 0.0;
  g_wall_eps = 1;
  momentum_exchange(3, SPHDEM_DRAG_ERGUN_WENYU, 1);
  g_wall_eps = 0;
  immersion_forces();
  porosity_walls();
  seed_porosity();
  for (int dim = 2; dim <= 3; dim++) disabled_identical(dim);
  bed_floating();
  argument_errors();
  huge_hc();
  return test_summary("couple");
}
