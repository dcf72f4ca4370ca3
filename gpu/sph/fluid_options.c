/* fluid_options.c - the fluid's smaller features (fluid_options.h), each behind the hooks of sphdem_feature:
 * the fixed ghost walls with MLS interpolation (Shi & Huang §3.4), the arrays of the fourth-order Runge-Kutta
 * integrator (sph_step.c runs it) and the kernel sums of the keyword isolated. */
#include <stdlib.h>

#include "sph_internal.h"

#define DFREE(cx, p_, nb_) rt_free(&(cx)->rt, (void **)&(p_), (nb_))
#define TRY(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)

/* ---- ghost walls ------------------------------------------------------------------------------------ */

int sphdem_set_wall_mirror(sphdem_ctx c, int n, const double *xi) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (!xi) { D->ghost.on = 0; return SPHDEM_OK; }
  if (n != D->nw) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_wall_mirror: %d points for %lld wall particles", n,
                                     (long long)D->nw);
  if (n == 0) return SPHDEM_OK;
  if (n > c->ghost.cap) {
    DFREE(c, D->ghost.wxi, 24 * (size_t)c->ghost.cap);
    DFREE(c, D->ghost.wmu, 8 * (size_t)c->ghost.cap);
    c->ghost.cap = 0;
    TRY(sphdem_dalloc(c, (void **)&D->ghost.wxi, 24 * (size_t)n));
    TRY(sphdem_dalloc(c, (void **)&D->ghost.wmu, 8 * (size_t)n));
    c->ghost.cap = n;
  }
  /* device order: wall tags are the caller index + 1 */
  int64_t *tag = (int64_t *)malloc(8 * (size_t)n);
  double *h = (double *)malloc(24 * (size_t)n);
  int rc = tag && h ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "set_wall_mirror: cannot allocate %d entries", n);
  if (!rc) rc = rt_d2h(&c->rt, tag, D->wtag, 8 * (size_t)n);
  if (!rc) {
    for (int64_t s = 0; s < n; s++)
      for (int d = 0; d < 3; d++) h[3 * s + d] = xi[3 * (tag[s] - 1) + d];
    rc = rt_h2d(&c->rt, D->ghost.wxi, h, 24 * (size_t)n);
  }
  free(tag);
  free(h);
  TRY(rc);
  TRY(rt_zero(&c->rt, D->ghost.wmu, 8 * (size_t)n));
  D->ghost.on = 1;
  return SPHDEM_OK;
}

static int ghost_on(const struct sphdem_ctx_s *c) { return c->D.ghost.on; }

/* A new wall set: Adami walls until sphdem_set_wall_mirror gives its mirror points. */
static int ghost_rebuilt(struct sphdem_ctx_s *c, int set) {
  if (set == SPHDEM_SET_WALL) c->D.ghost.on = 0;
  return SPHDEM_OK;
}

/* The mirror point follows its wall particle. */
static int ghost_sorted(struct sphdem_ctx_s *c, int set, int64_t n) {
  if (set != SPHDEM_SET_WALL || !c->D.ghost.on) return SPHDEM_OK;
  return c->ops->gather(c, c->D.ghost.wxi, 24, n);
}

static void ghost_release(struct sphdem_ctx_s *c) {
  DFREE(c, c->D.ghost.wxi, 24 * (size_t)c->ghost.cap);
  DFREE(c, c->D.ghost.wmu, 8 * (size_t)c->ghost.cap);
  c->ghost.cap = 0;
}

/* The wall-state pass reads D->ghost (MLS instead of Adami); no pass of its own. */
const sphdem_feature sphdem_feature_ghost = {
    "ghost walls", ghost_on, ghost_rebuilt, ghost_sorted, NULL, NULL, NULL, NULL, ghost_release, SPHDEM_T_RATES};

/* ---- Runge-Kutta ------------------------------------------------------------------------------------ */

static void rk_release(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  size_t n = (size_t)c->rk.cap;
  DFREE(c, D->rk.x0, 24 * n); DFREE(c, D->rk.v0, 24 * n); DFREE(c, D->rk.rho0, 8 * n);
  DFREE(c, D->rk.dx, 24 * n); DFREE(c, D->rk.dv, 24 * n); DFREE(c, D->rk.drho, 8 * n);
  c->rk.cap = 0;
}

int sphdem_rk_ensure(struct sphdem_ctx_s *c, int64_t n) {
  if (n <= c->rk.cap && c->rk.cap > 0) return SPHDEM_OK;
  rk_release(c);
  sphdem_dev *D = &c->D;
  size_t m = (size_t)(n > 0 ? n : 1);
  TRY(sphdem_dalloc(c, (void **)&D->rk.x0, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->rk.v0, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->rk.rho0, 8 * m)); TRY(sphdem_dalloc(c, (void **)&D->rk.dx, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->rk.dv, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->rk.drho, 8 * m));
  c->rk.cap = (int64_t)m;
  return SPHDEM_OK;
}

static int rk_on(const struct sphdem_ctx_s *c) { return c->rk.cap > 0; }

/* A resort between stages carries the state at t_n and the stage sums. */
static int rk_sorted(struct sphdem_ctx_s *c, int set, int64_t n) {
  sphdem_dev *D = &c->D;
  if (set != SPHDEM_SET_FLUID || !D->rk.x0 || c->rk.cap < n) return SPHDEM_OK;
  void *rk[] = {D->rk.x0, D->rk.v0, D->rk.dx, D->rk.dv, D->rk.rho0, D->rk.drho};
  int rb[] = {24, 24, 24, 24, 8, 8};
  for (int k = 0; k < 6; k++) TRY(c->ops->gather(c, rk[k], rb[k], n));
  return SPHDEM_OK;
}

/* The integrator (sphdem_step_rk4) drives the stages; the feature keeps its arrays in step with the fluid. */
const sphdem_feature sphdem_feature_rk = {
    "Runge-Kutta", rk_on, NULL, rk_sorted, NULL, NULL, NULL, NULL, rk_release, SPHDEM_T_RATES};

/* ---- kernel sums (keyword isolated) ------------------------------------------------------------------ */

/* Allocated while the keyword is on; computed fresh each evaluation, so not carried through sorts. */
static int iso_on(const struct sphdem_ctx_s *c) { return c->D.P.isolated > 0.0 || c->D.iso.ksum != NULL; }

static void iso_release(struct sphdem_ctx_s *c) {
  DFREE(c, c->D.iso.ksum, 8 * (size_t)c->iso.cap);
  c->iso.cap = 0;
}

/* Before the pressure pass: the array (freed when the keyword went off), then the kernel-sum pass. */
static int iso_prepare(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  const int on = D->P.isolated > 0.0;
  if (D->iso.ksum && (!on || c->iso.cap < D->nf)) iso_release(c); /* off, or too small */
  if (on && !D->iso.ksum) {
    size_t m = (size_t)(D->nf > 0 ? D->nf : 1);
    TRY(sphdem_dalloc(c, (void **)&D->iso.ksum, 8 * m));
    c->iso.cap = (int64_t)m;
  }
  D->iso.ok = D->iso.ksum != NULL;
  return c->ops->ksum(c); /* no elements while the keyword is off */
}

/* The kernel sums are in the old order until the next evaluation. */
static int iso_sorted(struct sphdem_ctx_s *c, int set, int64_t n) {
  (void)n;
  if (set == SPHDEM_SET_FLUID) c->D.iso.ok = 0;
  return SPHDEM_OK;
}

const sphdem_feature sphdem_feature_iso = {
    "isolated", iso_on, NULL, iso_sorted, iso_prepare, NULL, NULL, NULL, iso_release, SPHDEM_T_RATES};
