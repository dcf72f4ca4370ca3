/* sph_ctx.c - the plumbing of the fluid context that its features and backends share: error text, device
 * memory, sort scratch, the derived constants of the parameters, the timed reduction. Calls nothing above it
 * (the context code in sph.c, the features, the backends all call down into this file). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "sph_bodies.h"
#include "sph_internal.h"

#define DFREE(cx, p_, nb_) rt_free(&(cx)->rt, (void **)&(p_), (nb_))
#define TRY(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)

SPHDEM_RT_FAIL_FN(sphdem_fail, struct sphdem_ctx_s)

double sphdem_tait_B(const sphdem_params *p) { return p->c0 * p->c0 * p->rho0 / p->gamma; }

static void derive(sphdem_dev *D) {
  const sphdem_params *p = &D->P;
  D->B = sphdem_tait_B(p);
  D->h = p->h;
  D->inv_h = 1.0 / p->h;
  D->support2 = 4.0 * p->h * p->h;
  D->eta2 = 0.01 * p->h * p->h;
  D->alphaD = wendland_alpha(p->dim, p->h);
  const double w_dx = wendland_w(D->alphaD, p->dx / p->h);
  D->w_dx_inv = w_dx > 0.0 ? 1.0 / w_dx : 0.0; /* 0 (dx >= 2h) only without the tensile correction (checked) */
  D->gamma_is_7 = p->gamma == 7.0;
  D->tensile_n_is_4 = p->tensile_n == 4.0;
  for (int d = 0; d < 3; d++) D->L[d] = p->boxhi[d] - p->boxlo[d];
  /* multiphase: Tait constant per phase, wall volume m_w / rho0 */
  D->cmax = p->c0;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) {
    D->mp.ck[k] = D->mp.M.phase[k].c0 > 0 ? D->mp.M.phase[k].c0 : p->c0;
    D->mp.Bk[k] = D->mp.ck[k] * D->mp.ck[k] * D->mp.M.phase[k].rho0 / p->gamma;
    if (D->mp.on && k < D->mp.M.nphase) D->cmax = fmax(D->cmax, D->mp.ck[k]);
  }
  D->mp.wvol_inv_rho0 = 1.0 / p->rho0;
  pair_consts_set(D, &D->K);
  pair_consts_set_f(D, &D->Kf);
}

/* Derived constants (D->B, kernel constants, the multiphase constants) of D->P and D->mp.M. */
void sphdem_rederive(struct sphdem_ctx_s *c) { derive(&c->D); }

int sphdem_dalloc(struct sphdem_ctx_s *c, void **ptr, size_t bytes) { return rt_alloc(&c->rt, ptr, bytes); }

void sphdem_dfree(struct sphdem_ctx_s *c, void **ptr, size_t bytes) { rt_free(&c->rt, ptr, bytes ? bytes : 8); }

void sphdem_free_scratch(struct sphdem_ctx_s *c) {
  size_t n = (size_t)c->cap_scratch;
  if (!n) return;
  DFREE(c, c->perm, 4 * n); DFREE(c, c->scratch_d, 24 * n); DFREE(c, c->scratch_i, 8 * n);
  c->cap_scratch = 0;
}

int sphdem_ensure_scratch(struct sphdem_ctx_s *c, int64_t n) {
  if (n <= c->cap_scratch) return SPHDEM_OK;
  sphdem_free_scratch(c);
  size_t m = (size_t)n;
  TRY(sphdem_dalloc(c, (void **)&c->perm, 4 * m));
  TRY(sphdem_dalloc(c, (void **)&c->scratch_d, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&c->scratch_i, 8 * m));
  c->cap_scratch = n;
  return SPHDEM_OK;
}

int sphdem_timed_reduce(struct sphdem_ctx_s *c, int set, sphdem_red *r) {
  double t0 = rt_now();
  int rc = c->ops->reduce(c, set, r);
  c->timers[SPHDEM_T_REDUCE] += rt_now() - t0;
  if (rc == SPHDEM_OK && set == SPHDEM_SET_FLUID) c->edisp2 = r->edisp2max, c->edisp_ok = 1;
  return rc;
}
