/* mp.c - multiphase delta-plus SPH (Shi & Huang 2022): parameters, phase upload, per-particle arrays,
 * the passes that precede the rates pass, diagnostics. The physics is in mp_bodies.h. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mp_bodies.h"
#include "sph_internal.h"

#define TRYM(x) do { int rc_ = (x); if (rc_) return rc_; } while (0)

void sphdem_mp_params_default(sphdem_mp_params *m) {
  memset(m, 0, sizeof *m);
  m->nphase = 1;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) {
    m->phase[k].rho0 = 1000.0;
    m->phase[k].K = 1e-3;
    m->phase[k].N = 1.0;
  }
  m->eos = SPHDEM_EOS_LINEAR;
  m->diffusion = SPHDEM_DIFF_NONE;
  m->delta = 0.1;
  m->shift_R = 0.2;
  m->shift_n = 4.0;
  m->lam_surface = 0.55;
  m->lam_near = 0.90;
  m->alpha_visc = 0.125;
}

int sphdem_mp_params_check(const sphdem_mp_params *m, const sphdem_params *p, char *msg, size_t msglen) {
  char dummy[8];
  if (!msg || msglen == 0) { msg = dummy; msglen = sizeof dummy; }
  msg[0] = 0;
#define MCHECK(cond, ...) do { if (!(cond)) { snprintf(msg, msglen, __VA_ARGS__); return SPHDEM_ERR_ARG; } } while (0)
  MCHECK(m && p, "parameters missing");
  if (!m->enabled) return SPHDEM_OK;
  MCHECK(m->nphase >= 1 && m->nphase <= SPHDEM_MAX_PHASES, "nphase must be 1..%d (got %d)", SPHDEM_MAX_PHASES,
         m->nphase);
  for (int k = 0; k < m->nphase; k++) {
    const sphdem_phase *f = &m->phase[k];
    MCHECK(f->rho0 > 0 && isfinite(f->rho0), "phase %d: rho0 must be > 0 (got %g)", k + 1, f->rho0);
    MCHECK(f->tau_y >= 0 && isfinite(f->tau_y), "phase %d: yield stress tau_y must be >= 0 (got %g)", k + 1, f->tau_y);
    MCHECK(f->K >= 0 && isfinite(f->K), "phase %d: consistency K (viscosity) must be >= 0 (got %g)", k + 1, f->K);
    MCHECK(f->N > 0 && isfinite(f->N), "phase %d: flow index N must be > 0 (got %g)", k + 1, f->N);
    MCHECK(f->gdot_cut >= 0 && isfinite(f->gdot_cut), "phase %d: cut-off shear rate must be >= 0 (got %g)", k + 1,
           f->gdot_cut);
    MCHECK(f->c0 >= 0 && isfinite(f->c0), "phase %d: sound speed c0 must be > 0 (or 0: the fluid's) (got %g)", k + 1,
           f->c0);
    MCHECK(!(f->tau_y > 0 || f->N < 1) || f->gdot_cut > 0,
           "phase %d: a yield stress or a flow index N < 1 makes the viscosity infinite at rest; give a cut-off "
           "shear rate > 0 (eq 23)", k + 1);
  }
  MCHECK(m->eos == SPHDEM_EOS_TAIT || m->eos == SPHDEM_EOS_LINEAR, "eos must be tait or linear");
  MCHECK(m->p0 >= 0 && isfinite(m->p0), "background pressure p0 must be >= 0 (got %g)", m->p0);
  MCHECK(m->diffusion >= SPHDEM_DIFF_NONE && m->diffusion <= SPHDEM_DIFF_RENORM,
         "diffusion must be none, molteni or renormalised");
  MCHECK(m->delta >= 0 && m->delta <= 1, "diffusion delta must be in [0, 1] (got %g)", m->delta);
  MCHECK(m->shifting == 0 || m->shifting == 1, "shifting must be 0 or 1");
  MCHECK(m->shift_R >= 0 && m->shift_n > 0, "shifting R must be >= 0 and n > 0 (got %g, %g)", m->shift_R, m->shift_n);
  MCHECK(m->lam_surface > 0 && m->lam_surface <= m->lam_near && m->lam_near <= 1.5,
         "shifting thresholds need 0 < lam_surface <= lam_near <= 1.5 (got %g, %g)", m->lam_surface, m->lam_near);
  MCHECK(m->cs_les >= 0 && m->cs_les < 1, "Smagorinsky constant must be in [0, 1) (got %g)", m->cs_les);
  MCHECK(m->alpha_visc > 0 && m->alpha_visc <= 1, "alpha_visc must be in (0, 1] (got %g)", m->alpha_visc);
  if (m->single) {
    /* one fluid with the delta-plus terms: its viscosity is eq 24 with mu of visc morris (the same laminar
     * viscosity, written as Hu & Adams' inter-particle average); the other plain-fluid terms have a
     * delta-plus counterpart that replaces them */
    MCHECK(p->visc != SPHDEM_VISC_ARTIFICIAL,
           "visc artificial is not defined with the delta-plus terms (shifting, diffusion, les, eos, p0): they take "
           "the laminar viscous term of eq 24; use visc morris MU (and les CS for turbulence) or visc none");
    MCHECK(p->tensile_eps == 0, "tensile and the delta-plus terms (shifting, diffusion, les, eos, p0) are two cures "
           "for tensile instability; give one (p0 P0 with shifting is the delta-plus one)");
    MCHECK(p->delta == 0, "delta (Molteni-Colagrossi diffusion of rho) and diffusion (of (P - P0)/c0^2, eqs 16-18) "
           "are two density-diffusion terms; give one");
  } else {
    MCHECK(p->visc == SPHDEM_VISC_NONE,
           "the multiphase viscous term (eq 24, phase rheology) replaces visc morris/artificial; set visc none");
    MCHECK(p->tensile_eps == 0, "the tensile correction is a single-phase option; use a background pressure p0");
    MCHECK(p->delta == 0, "the single-phase delta term is replaced by the multiphase diffusion option");
  }
#undef MCHECK
  return SPHDEM_OK;
}

double sphdem_mp_viscosity(const sphdem_phase *ph, double gdot) { return hb_viscosity(ph, gdot); }

double sphdem_mp_pressure(const sphdem_mp_params *m, const sphdem_params *p, int k, double rho) {
  sphdem_dev D;
  memset(&D, 0, sizeof D);
  D.P = *p;
  D.mp.M = *m;
  D.gamma_is_7 = p->gamma == 7.0;
  D.mp.ck[k] = m->phase[k].c0 > 0 ? m->phase[k].c0 : p->c0;
  D.mp.Bk[k] = D.mp.ck[k] * D.mp.ck[k] * m->phase[k].rho0 / p->gamma;
  return mp_pressure_k(&D, k, rho);
}

double sphdem_mp_density(const sphdem_mp_params *m, const sphdem_params *p, int k, double pressure) {
  double r0 = m->phase[k].rho0, dp = pressure - m->p0, c = m->phase[k].c0 > 0 ? m->phase[k].c0 : p->c0;
  if (m->eos == SPHDEM_EOS_LINEAR) return r0 + dp / (c * c);
  double base = 1.0 + dp / (c * c * r0 / p->gamma);
  if (base < 1e-3) base = 1e-3;
  return r0 * pow(base, 1.0 / p->gamma);
}

/* ---- memory ------------------------------------------------------------------------------------------ */

static void mp_release(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  size_t n = (size_t)c->mp.cap;
  sphdem_dfree(c, (void **)&D->mp.ph, 4 * n);
  sphdem_dfree(c, (void **)&D->mp.mu_p, 8 * n);
  sphdem_dfree(c, (void **)&D->mp.gdot, 8 * n);
  sphdem_dfree(c, (void **)&D->mp.Lm, 48 * n);
  sphdem_dfree(c, (void **)&D->mp.gdr, 24 * n);
  sphdem_dfree(c, (void **)&D->mp.lam, 8 * n);
  sphdem_dfree(c, (void **)&D->mp.dus, 24 * n);
  c->mp.cap = 0;
  c->mp.ready = 0;
  D->mp.on = 0;
}

/* Arrays for n fluid particles. New entries are zero; grown arrays keep the entries they had, as arrays already
 * large enough do (so a rebuilt fluid's fields of the previous evaluation never come from uninitialised memory,
 * whichever block the allocator hands back); mp_rebuilt sets the phases. */
static int ensure_mp(struct sphdem_ctx_s *c, int64_t n) {
  sphdem_dev *D = &c->D;
  if (n <= c->mp.cap && c->mp.cap > 0) return SPHDEM_OK;
  const size_t old = (size_t)c->mp.cap, m = (size_t)(n > 0 ? n : 1);
  void **arr[7] = {(void **)&D->mp.ph, (void **)&D->mp.mu_p, (void **)&D->mp.gdot, (void **)&D->mp.Lm,
                   (void **)&D->mp.gdr, (void **)&D->mp.lam, (void **)&D->mp.dus};
  const size_t eb[7] = {4, 8, 8, 48, 24, 8, 24};
  for (int k = 0; k < 7; k++) {
    void *p = NULL;
    TRYM(sphdem_dalloc(c, &p, eb[k] * m));
    int rc = rt_zero(&c->rt, p, eb[k] * m);
    if (!rc && old && *arr[k]) rc = rt_d2d(&c->rt, p, *arr[k], eb[k] * old);
    if (rc) { sphdem_dfree(c, &p, eb[k] * m); return rc; }
    sphdem_dfree(c, arr[k], eb[k] * old);
    *arr[k] = p;
  }
  c->mp.cap = (int64_t)m;
  c->mp.ready = 0;
  return SPHDEM_OK;
}

static int mp_rebuilt(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  if (set != SPHDEM_SET_FLUID || !D->mp.on) return SPHDEM_OK;
  TRYM(ensure_mp(c, D->nf));
  c->mp.ready = 0;
  /* a rebuilt fluid starts in phase 0 until sphdem_set_fluid_phase */
  if (D->nf > 0) TRYM(rt_zero(&c->rt, D->mp.ph, 4 * (size_t)D->nf));
  return SPHDEM_OK;
}

void sphdem_mp_single_phase(const sphdem_params *p, sphdem_mp_params *m) {
  m->single = 1;
  m->nphase = 1;
  sphdem_phase *f = &m->phase[0];
  f->rho0 = p->rho0;
  f->tau_y = 0.0;
  f->K = p->visc == SPHDEM_VISC_MORRIS ? p->mu : 0.0;
  f->N = 1.0;
  f->gdot_cut = 0.0;
  f->c0 = 0.0;
}

int sphdem_mp_set(sphdem_ctx c, const sphdem_mp_params *m_in) {
  if (!c) return SPHDEM_ERR_ARG;
  if (!m_in) return sphdem_fail(c, SPHDEM_ERR_ARG, "mp_set: parameters missing");
  sphdem_mp_params mm = *m_in, *m = &mm;
  if (m->enabled && m->single) sphdem_mp_single_phase(&c->D.P, m);
  char msg[512];
  if (sphdem_mp_params_check(m, &c->D.P, msg, sizeof msg) != SPHDEM_OK)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "mp_set: %s", msg);
  sphdem_dev *D = &c->D;
  if (!m->enabled) { if (D->mp.on) c->nl_dirty = 1; mp_release(c); D->mp.M = *m; return SPHDEM_OK; }
  if (D->couple.on)
    return sphdem_fail(c, SPHDEM_ERR_ARG, m->single ? SPHDEM_MP_COUPLE_WHY :
                       "mp_set: the multiphase fluid cannot be combined with the SPH-DEM coupling yet");
  int was_on = D->mp.on;
  D->mp.M = *m;
  D->mp.on = 1;
  c->nl_dirty = 1; /* the CPU's fluid lists: full lists for the delta-plus gather, half lists otherwise */
  sphdem_rederive(c);
  if (!was_on) {
    TRYM(ensure_mp(c, D->nf));
    if (D->nf > 0) TRYM(rt_zero(&c->rt, D->mp.ph, 4 * (size_t)D->nf));
    c->mp.ready = 0;
  }
  return SPHDEM_OK;
}

int sphdem_mp_get(sphdem_ctx c, sphdem_mp_params *m) {
  if (!c || !m) return SPHDEM_ERR_ARG;
  if (!c->D.mp.on) { sphdem_mp_params_default(m); return SPHDEM_OK; }
  *m = c->D.mp.M;
  return SPHDEM_OK;
}

int sphdem_set_fluid_phase(sphdem_ctx c, int n, const int *phase) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (!D->mp.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "set_fluid_phase: the multiphase fluid is off (sphdem_mp_set)");
  if (n != D->nf) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid_phase: %d phases for %lld fluid particles", n,
                                     (long long)D->nf);
  if (n == 0) return SPHDEM_OK;
  if (!phase) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid_phase: phase array missing");
  for (int i = 0; i < n; i++)
    if (phase[i] < 0 || phase[i] >= D->mp.M.nphase)
      return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid_phase: particle %d has phase %d; phases are 0..%d", i,
                         phase[i], D->mp.M.nphase - 1);
  TRYM(ensure_mp(c, n));
  int32_t *ui = (int32_t *)malloc(4 * (size_t)n), *hp = (int32_t *)malloc(4 * (size_t)n);
  int rc = ui && hp ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "set_fluid_phase: cannot allocate %d entries", n);
  if (!rc) rc = rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)n);
  if (!rc) {
    for (int s = 0; s < n; s++) hp[s] = phase[ui[s]];
    rc = rt_h2d(&c->rt, D->mp.ph, hp, 4 * (size_t)n);
  }
  free(ui);
  free(hp);
  c->mp.ready = 0;
  return rc;
}

/* Before the rates pass (after the pressure and wall passes): per-phase max velocity when shifting,
 * then the gradient pass and the shifting pass. */
static int mp_prepare(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  TRYM(ensure_mp(c, D->nf));
  if (D->mp.M.shifting) {
    sphdem_red r;
    if (D->nf > 0) TRYM(c->ops->reduce(c, SPHDEM_SET_FLUID, &r));
    else red_init(&r);
    TRYM(sphdem_rt_allreduce(&c->rt, r.v2ph, SPHDEM_MAX_PHASES, SPHDEM_RED_MAX)); /* over the ranks' owned */
    for (int k = 0; k < SPHDEM_MAX_PHASES; k++) D->mp.umax_ph[k] = sqrt(r.v2ph[k]);
  }
  if (D->nf == 0) return SPHDEM_OK; /* many ranks: no fluid here */
  TRYM(c->ops->mp_grad(c));
  TRYM(rt_sync(&c->rt));
  if (D->mp.M.shifting) {
    TRYM(c->ops->mp_shift(c));
    TRYM(rt_sync(&c->rt));
  }
  c->mp.ready = 1;
  return SPHDEM_OK;
}

int sphdem_mp_get_fields(sphdem_ctx c, double *mu, double *gdot, double *lambda, double *shift) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (!D->mp.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "mp_get_fields: the multiphase fluid is off");
  if (!c->mp.ready) return sphdem_fail(c, SPHDEM_ERR_STATE, "mp_get_fields: no rates computed since the last upload");
  int64_t n = D->nf;
  if (n == 0) return SPHDEM_OK;
  int32_t *ui = (int32_t *)malloc(4 * (size_t)n);
  double *h = (double *)malloc(24 * (size_t)n);
  int rc = ui && h ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "mp_get_fields: cannot allocate %lld entries",
                                             (long long)n);
  if (!rc) rc = rt_sync(&c->rt);
  if (!rc) rc = rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)n);
  struct { double *dst; const double *src; int nc; } f[] = {{mu, D->mp.mu_p, 1}, {gdot, D->mp.gdot, 1},
                                                            {lambda, D->mp.lam, 1}, {shift, D->mp.dus, 3}};
  for (int k = 0; k < 4 && !rc; k++) {
    if (!f[k].dst) continue;
    rc = rt_d2h(&c->rt, h, f[k].src, 8 * (size_t)f[k].nc * (size_t)n);
    for (int64_t s = 0; s < n && !rc; s++)
      for (int d = 0; d < f[k].nc; d++) f[k].dst[(int64_t)ui[s] * f[k].nc + d] = h[f[k].nc * s + d];
  }
  free(ui);
  free(h);
  return rc;
}

static int mp_on(const struct sphdem_ctx_s *c) { return c->D.mp.on; }

/* The phase follows its particle (the other fields are recomputed by every rate pass). */
static int mp_sorted(struct sphdem_ctx_s *c, int set, int64_t n) {
  if (set != SPHDEM_SET_FLUID || !c->D.mp.ph || c->mp.cap < n) return SPHDEM_OK;
  return c->ops->gather(c, c->D.mp.ph, 4, n);
}

/* get_fluid: the EOS of each particle's phase. */
static int mp_host_pressure(struct sphdem_ctx_s *c, int64_t n, const double *rho, const int32_t *ui, double *p,
                            int *done) {
  const sphdem_dev *D = &c->D;
  if (!D->mp.on || !D->mp.ph || c->mp.cap < n) return SPHDEM_OK;
  int32_t *ph = (int32_t *)malloc(4 * (size_t)n);
  if (!ph) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "get_fluid: cannot allocate %lld phases", (long long)n);
  int rc = rt_d2h(&c->rt, ph, D->mp.ph, 4 * (size_t)n);
  if (rc) { free(ph); return rc; }
  for (int64_t s = 0; s < n; s++) p[ui[s]] = mp_pressure_k(D, ph[s], rho[s]);
  free(ph);
  *done = 1;
  return SPHDEM_OK;
}

/* The delta-plus / multiphase fluid as a feature of the fluid context: renormalisation, viscosity and shifting
 * passes after the pressure and wall passes, before the rates pass (timed with the rates). */
const sphdem_feature sphdem_feature_mp = {"delta-plus", mp_on, mp_rebuilt, mp_sorted, NULL, mp_prepare, NULL,
                                          mp_host_pressure, mp_release, SPHDEM_T_RATES};
