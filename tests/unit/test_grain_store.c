/* test_grain_store.c - the grain store shared by the coupling, the DEM contacts and the gas grid: one put a
 * step read by the three contexts (the coupling and the gas grid through an index list into a larger atom set,
 * as fix sph/couple and fix cfd/grid read the pair style's store) gives bit for bit the forces of the three
 * separate uploads, with one grain upload a step instead of three; stamps; readers refuse what the store lacks. */
#include <math.h>
#define TEST_RNG_SEED 0x9E3779B97F4A7C15ull
#include "couple_bed.h"
#include "testlib.h"

enum { NSTEP = 4 };

static sphdem_ctx fluid_ctx(const sphdem_params *p, const scene *s) {
  sphdem_ctx c;
  char msg[512];
  if (sphdem_create(&c, p, test_device(), msg, sizeof msg) != SPHDEM_OK) { printf("create: %s\n", msg); exit(1); }
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = SPHDEM_DRAG_ERGUN_WENYU; cp.mu = 1e-3; cp.torque = 1;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s->nw, s->wx, s->wv, NULL, s->wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s->nf, s->tag, s->x, s->v, s->rho, s->mass, NULL));
  return c;
}

static sphdem_dem dem_ctx(void) {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.kn = 1e4; p.kt = 2e3; p.gamman = 1.0; p.mu = 0.3;
  char msg[256];
  sphdem_dem d = NULL;
  if (sphdem_dem_create(&d, &p, test_device(), msg, sizeof msg)) { printf("dem create: %s\n", msg); exit(1); }
  return d;
}

static sphdem_cfd gas_ctx(void) {
  sphdem_cfd_params p;
  sphdem_cfd_params_default(&p);
  p.nc[0] = 5; p.nc[1] = 3; p.nc[2] = 8;
  p.boxhi[0] = 0.1; p.boxhi[1] = 0.05; p.boxhi[2] = 0.16;
  for (int k = 0; k < 6; k++) p.bc[k] = SPHDEM_CFD_SLIP;
  p.bc[4] = SPHDEM_CFD_INLET; p.inlet_u[4] = 0.05; p.bc[5] = SPHDEM_CFD_OUTLET;
  sphdem_cfd c;
  char msg[512];
  if (sphdem_cfd_create(&c, &p, test_device(), msg, sizeof msg)) { printf("cfd create: %s\n", msg); exit(1); }
  return c;
}

static int same(const double *a, const double *b, size_t n) { return n == 0 || !memcmp(a, b, sizeof(double) * n); }

int main(void) {
  sphdem_params p;
  scene s;
  memset(&s, 0, sizeof s);
  tank_scene(&p, &s, 3);
  /* the "atoms": grains of the bed (spacing 2 dx) with other atoms between them (radius 0.1 dx), as a pair style
   * sees every atom and fix sph/couple a group of them */
  double *bx, *bv, *br;
  const int nb = bed_grains(2 * p.dx, &bx, &bv, &br);
  const int na = 2 * nb;
  double *x = malloc(24 * (size_t)na), *v = malloc(24 * (size_t)na), *om = malloc(24 * (size_t)na);
  double *r = malloc(8 * (size_t)na), *m = malloc(8 * (size_t)na);
  int64_t *tag = malloc(8 * (size_t)na);
  int32_t *gi = malloc(4 * (size_t)nb);
  for (int a = 0; a < na; a++) {
    const int b = a / 2, grain = a % 2 == 0;
    for (int d = 0; d < 3; d++) {
      x[3 * a + d] = bx[3 * b + d] + (grain ? 0.0 : 0.5 * p.dx) + 0.1 * p.dx * (urand() - 0.5);
      v[3 * a + d] = 0.02 * (urand() - 0.5);
      om[3 * a + d] = 5.0 * (urand() - 0.5);
    }
    r[a] = grain ? br[b] : 0.1 * p.dx;
    m[a] = 2500.0 * 4.0 / 3.0 * M_PI * r[a] * r[a] * r[a];
    tag[a] = a + 1;
    if (grain) gi[b] = a;
  }
  /* the group's own copy (what fix sph/couple gathers) */
  double *gx = malloc(24 * (size_t)nb), *gv = malloc(24 * (size_t)nb), *gom = malloc(24 * (size_t)nb);
  double *gr = malloc(8 * (size_t)nb);
  sphdem_ctx fa = fluid_ctx(&p, &s), fb = fluid_ctx(&p, &s);
  sphdem_dem da = dem_ctx(), db = dem_ctx();
  sphdem_cfd ca = gas_ctx(), cb = gas_ctx();
  sphdem_grain_store g = NULL;
  char msg[256];
  TEST_ASSERT(sphdem_grains_create(&g, sphdem_backend(fa), msg, sizeof msg) == SPHDEM_OK, "store: %s", msg);
  size_t n3a = 3 * (size_t)na, n3b = 3 * (size_t)nb;
  double *f[2], *t[2], *cf[2], *ct[2], *cfd[2], *cfp[2], *eps[2], *gfd[2], *gfp[2];
  for (int k = 0; k < 2; k++) {
    f[k] = malloc(8 * n3a); t[k] = malloc(8 * n3a); cf[k] = malloc(8 * n3b); ct[k] = malloc(8 * n3b);
    cfd[k] = malloc(8 * n3b); cfp[k] = malloc(8 * n3b); gfd[k] = malloc(8 * n3b); gfp[k] = malloc(8 * n3b);
    eps[k] = malloc(8 * (size_t)s.nf);
  }
  int identical = 1;
  int64_t up_sep = 0, up_shared = 0;
  for (int step = 0; step < NSTEP; step++) {
    for (int i = 0; i < 3 * na; i++) x[i] += 0.05 * p.dx * v[i] / 0.02;
    for (int b = 0; b < nb; b++) {
      gr[b] = r[gi[b]];
      for (int d = 0; d < 3; d++) {
        gx[3 * b + d] = x[3 * gi[b] + d], gv[3 * b + d] = v[3 * gi[b] + d], gom[3 * b + d] = om[3 * gi[b] + d];
      }
    }
    /* separate uploads: each context is handed its grains */
    int64_t u0 = sphdem_grains_uploads(NULL);
    TEST_ASSERT(sphdem_dem_compute(da, na, tag, x, v, om, r, m, NULL, 1e-5, 1, f[0], t[0], NULL) == SPHDEM_OK, "dem: %s",
                sphdem_dem_last_error(da));
    SPHDEM_CHECK_RC(fa, sphdem_set_grains(fa, nb, gx, gv, gr, gom));
    SPHDEM_CHECK_RC(fa, sphdem_compute_rates(fa));
    TEST_ASSERT(sphdem_cfd_step(ca, 1e-4, nb, gx, gv, gr, gfd[0], gfp[0]) == SPHDEM_OK, "cfd: %s", sphdem_cfd_last_error(ca));
    int64_t u1 = sphdem_grains_uploads(NULL);
    /* one store: the atoms put once, the coupling and the gas grid read the grains through the index list */
    const int64_t st[SPHDEM_GRAINS_STAMP] = {step, 0, 0, 0, na, 0};
    TEST_ASSERT(!sphdem_grains_current(g, st), "step %d: not current before the put", step);
    TEST_ASSERT(sphdem_grains_put(g, st, na, 0, x, v, om, r, m) == SPHDEM_OK, "put: %s", sphdem_grains_last_error(g));
    TEST_ASSERT(sphdem_grains_current(g, st), "step %d: current after the put", step);
    TEST_ASSERT(sphdem_dem_compute_store(db, g, tag, NULL, 1e-5, 1, f[1], t[1], NULL) == SPHDEM_OK, "dem store: %s",
                sphdem_dem_last_error(db));
    SPHDEM_CHECK_RC(fb, sphdem_set_grains_store(fb, g, nb, gi, 1));
    SPHDEM_CHECK_RC(fb, sphdem_compute_rates(fb));
    TEST_ASSERT(sphdem_cfd_step_store(cb, 1e-4, g, nb, gi, gfd[1], gfp[1]) == SPHDEM_OK, "cfd store: %s",
                sphdem_cfd_last_error(cb));
    int64_t u2 = sphdem_grains_uploads(NULL);
    up_sep += u1 - u0, up_shared += u2 - u1;
    for (int k = 0; k < 2; k++) {
      sphdem_ctx c = k ? fb : fa;
      SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, cf[k], cfd[k], cfp[k], ct[k]));
      SPHDEM_CHECK_RC(c, sphdem_get_porosity(c, eps[k]));
    }
    identical &= same(f[0], f[1], n3a) && same(t[0], t[1], n3a) && same(cf[0], cf[1], n3b) && same(ct[0], ct[1], n3b) &&
                 same(cfd[0], cfd[1], n3b) && same(cfp[0], cfp[1], n3b) && same(eps[0], eps[1], (size_t)s.nf) &&
                 same(gfd[0], gfd[1], n3b) && same(gfp[0], gfp[1], n3b);
  }
  double fmax = 0, cmax = 0;
  for (size_t i = 0; i < n3a; i++) fmax = fmax > fabs(f[0][i]) ? fmax : fabs(f[0][i]);
  for (size_t i = 0; i < n3b; i++) cmax = cmax > fabs(cf[0][i]) ? cmax : fabs(cf[0][i]);
  printf("grain uploads per step: separate %.2f, one store %.2f (%d steps, %d atoms, %d grains; max |f| DEM %.3g, "
         "coupling %.3g)\n", (double)up_sep / NSTEP, (double)up_shared / NSTEP, NSTEP, na, nb, fmax, cmax);
  TEST_ASSERT(fmax > 0 && cmax > 0, "the scene has contacts and fluid forces (DEM %g, coupling %g)", fmax, cmax);
  TEST_ASSERT(identical, "forces, torques, porosity and gas forces bit-identical to the separate uploads");
  TEST_ASSERT(up_sep == 3 * NSTEP, "separate: 3 uploads a step (%lld in %d)", (long long)up_sep, NSTEP);
  TEST_ASSERT(up_shared == NSTEP, "one store: 1 upload a step (%lld in %d)", (long long)up_shared, NSTEP);
  TEST_ASSERT(sphdem_grains_uploads(g) == NSTEP, "the store counts its own uploads (%lld)",
              (long long)sphdem_grains_uploads(g));
  /* readers refuse what the store does not hold */
  int32_t bad = na;
  TEST_ASSERT(sphdem_set_grains_store(fb, g, 1, &bad, 0) == SPHDEM_ERR_ARG && strstr(sphdem_last_error(fb), "outside"),
              "index outside the store: %s", sphdem_last_error(fb));
  TEST_ASSERT(sphdem_set_grains_store(fb, g, na + 1, NULL, 0) == SPHDEM_ERR_ARG, "more grains than the store holds");
  const int64_t st2[SPHDEM_GRAINS_STAMP] = {99, 0, 0, 0, nb, 0};
  TEST_ASSERT(sphdem_grains_put(g, st2, nb, 0, gx, gv, NULL, gr, NULL) == SPHDEM_OK, "put without omega and mass");
  TEST_ASSERT(sphdem_set_grains_store(fb, g, nb, NULL, 1) == SPHDEM_ERR_ARG && strstr(sphdem_last_error(fb), "omega"),
              "spin asked of a store without it: %s", sphdem_last_error(fb));
  TEST_ASSERT(sphdem_dem_compute_store(db, g, tag, NULL, 1e-5, 1, f[1], t[1], NULL) == SPHDEM_ERR_ARG &&
                  strstr(sphdem_dem_last_error(db), "mass"),
              "DEM refuses a store without mass: %s", sphdem_dem_last_error(db));
  TEST_ASSERT(sphdem_grains_put(g, st2, -1, 0, gx, gv, NULL, gr, NULL) == SPHDEM_ERR_ARG, "negative count refused");
  sphdem_grains_destroy(&g);
  TEST_ASSERT(g == NULL, "destroy clears the handle");
  sphdem_destroy(&fa); sphdem_destroy(&fb);
  sphdem_dem_destroy(&da); sphdem_dem_destroy(&db);
  sphdem_cfd_destroy(&ca); sphdem_cfd_destroy(&cb);
  for (int k = 0; k < 2; k++) {
    free(f[k]); free(t[k]); free(cf[k]); free(ct[k]); free(cfd[k]); free(cfp[k]); free(gfd[k]); free(gfp[k]);
    free(eps[k]);
  }
  free(x); free(v); free(om); free(r); free(m); free(tag); free(gi);
  free(gx); free(gv); free(gom); free(gr); free(bx); free(bv); free(br);
  scene_free(&s);
  return test_summary("unit_grain_store");
}
