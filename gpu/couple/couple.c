/* couple.c - SPH-DEM coupling (He 2018 §2.3-2.4.1), host side: parameters, grain upload, the grain
 * (DEM, level 1) grid, the coupling steps of sphdem_compute_rates, downloads, stats and the pair hook.
 *
 * Flow inside sphdem_compute_rates when the coupling is on:
 *   (fluid sort if due) -> grain sort on the grain grid -> porosity pass (eq 26, per fluid particle,
 *   fluid->grain search) -> pressure pass (EOS with eps, eq 7) -> walls -> rates (eqs 6, 9-12) ->
 *   grain pass (eqs 27-32, per grain, grain->fluid search) -> reaction pass (eq 33, per fluid particle)
 *   -> grain forces downloaded to host memory (they stay until the next compute_rates).
 * Every pass is a gather (no atomics), so results are deterministic and identical on both backends.
 *
 * How eps enters eqs 6-7: the fluid particle's density variable is the superficial density
 * rho_bar = eps rho_f; continuity (eq 6) evolves rho_bar unchanged; the EOS (eq 7) gets the intrinsic
 * density rho_bar / eps (eps floored at eps_min); the momentum equation (eq 9) keeps P / rho_bar^2 (the
 * same density variable), so its pressure term is -grad P / rho_bar, and the kernel volumes m/rho_bar are
 * mixture volumes. With superficial = 0 eps is computed and used in the drag laws only.
 *
 * Dual grid (§2.4.1): SPH cells are the fluid grid (>= 2h + skin, sorted when particles moved skin/2);
 * grain cells are max(d_max, hc/2) (grains are re-binned at every upload, so they need no gap; the hc/2
 * floor caps the fluid->grain search at 4 layers for tiny grains). Fluid->grain: ceil(2 hc / grain cell)
 * layers; grain->fluid: ceil((2 hc + skin/2) / SPH cell) layers (1 when hc = h). The search range of
 * both directions is the coupling support 2 hc (centre to centre), so the paper's ceil(2h/d) and
 * ceil(d/2h) (for hc = h, d <= 2h) are the special cases.
 *
 * Not exchanged: the reaction of the optional rotational-drag torque (angular momentum goes to the grains
 * only). With superficial density and wall_porosity 1, wall particles get the porosity of the fluid beside them
 * (Shepard average, as eqs 13-14 extrapolate velocity and pressure) and act with the superficial density
 * eps_w rho_w (eq 15); with wall_porosity 0 (default) they act as plain fluid (eps_w = 1). wall_porosity 1 made the
 * rotating drum (examples/drum, coarse) stop at the start of the rotation: where a grain packs the fluid
 * against the wall, eps_w reaches the floor eps_min and the wall pressure term, ~ V_w P_w / (eps_w rho_w),
 * grows as 1/eps_w. Coupling time is counted in SPHDEM_T_COUPLE.
 * A fluid that starts inside a packed bed should be uploaded consistently: rho = eps rho_f and mass =
 * eps rho_f V (V its lattice volume; eps from get_porosity after a first compute_rates), else the EOS
 * sees a compression of 1/eps and pushes the fluid out of the bed (unit_couple's packed bed does this). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "couple_bodies.h"
#include "grains.h"
#include "sph_internal.h"

#define TRYC(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)
/* grain cells are at least hc/2, so the fluid->grain search spans at most this many layers */
#define SPHDEM_COUPLE_MAX_LAYERS 4

void sphdem_couple_params_default(sphdem_couple_params *c) {
  memset(c, 0, sizeof *c);
  c->eps_min = 0.2;
  c->superficial = 1;
}

static int couple_check(const sphdem_couple_params *cp, const sphdem_params *P, char *msg, size_t len) {
#define CCHECK(cond, ...) do { if (!(cond)) { snprintf(msg, len, __VA_ARGS__); return SPHDEM_ERR_ARG; } } while (0)
  CCHECK(cp->enabled == 0 || cp->enabled == 1, "enabled must be 0 or 1 (got %d)", cp->enabled);
  if (!cp->enabled) return SPHDEM_OK;
  CCHECK(cp->hc >= 0 && isfinite(cp->hc), "hc (coupling smoothing length) must be >= 0, 0 = the fluid h (got %g)", cp->hc);
  CCHECK(cp->drag >= SPHDEM_DRAG_NONE && cp->drag <= SPHDEM_DRAG_SCHILLER_NAUMANN,
         "drag must be none (0), ergun-wenyu (1), difelice (2) or schiller-naumann (3) (got %d)", cp->drag);
  CCHECK(cp->torque == 0 || cp->torque == 1, "torque must be 0 or 1 (got %d)", cp->torque);
  CCHECK((cp->drag == SPHDEM_DRAG_NONE && !cp->torque) || (cp->mu > 0 && isfinite(cp->mu)),
         "mu (fluid viscosity of the drag law) must be > 0 (got %g)", cp->mu);
  CCHECK(cp->eps_min > 0 && cp->eps_min < 1, "eps_min (porosity floor) must be in (0, 1) (got %g)", cp->eps_min);
  CCHECK(cp->superficial == 0 || cp->superficial == 1, "superficial must be 0 or 1 (got %d)", cp->superficial);
  CCHECK(cp->wall_porosity == 0 || cp->wall_porosity == 1, "wall_porosity (wall porosity) must be 0 or 1 (got %d)", cp->wall_porosity);
  CCHECK(cp->immersion >= 0 && cp->immersion <= 1, "immersion must be in [0, 1], 0 = off (got %g)", cp->immersion);
  CCHECK(cp->eps_walls == 0 || cp->eps_walls == 1, "eps_walls must be 0 or 1 (got %d)", cp->eps_walls);
  CCHECK(cp->pressure_form == 0 || cp->pressure_form == 1, "pressure_form must be 0 (mass) or 1 (volume) (got %d)",
         cp->pressure_form);
  CCHECK(cp->dmax >= 0 && isfinite(cp->dmax), "dmax (largest grain diameter) must be >= 0 (got %g)", cp->dmax);
  double hc = cp->hc > 0 ? cp->hc : P->h;
  /* the kernel constant 21 / (16 pi hc^3) must neither divide by an underflowed hc^3 nor vanish */
  CCHECK(hc >= 1e-60 && hc <= 1e60, "hc (coupling smoothing length) %g is outside [1e-60, 1e60]", hc);
  for (int d = 0; d < P->dim; d++)
    if (P->periodic[d]) {
      double L = P->boxhi[d] - P->boxlo[d];
      CCHECK(L >= 6.0 * hc, "hc %g too large for the periodic box: length %g on axis %c is below 3 (2 hc) = %g",
             hc, L, "xyz"[d], 6.0 * hc);
    }
  return SPHDEM_OK;
#undef CCHECK
}

/* ---- memory ------------------------------------------------------------------------------------ */

static void free_grains(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  size_t n = (size_t)c->couple.cap_g;
  if (!n) return;
  void **p24[] = {(void **)&D->couple.gx, (void **)&D->couple.gv, (void **)&D->couple.gom, (void **)&D->couple.gf,
                  (void **)&D->couple.gfd, (void **)&D->couple.gfpg, (void **)&D->couple.gtq};
  for (size_t k = 0; k < sizeof p24 / sizeof p24[0]; k++) sphdem_dfree(c, p24[k], 24 * n);
  sphdem_dfree(c, (void **)&D->couple.grad, 8 * n);
  sphdem_dfree(c, (void **)&D->couple.grain_shepard, 8 * n);
  sphdem_dfree(c, (void **)&D->couple.gtag, 8 * n);
  sphdem_dfree(c, (void **)&D->couple.gcell, 4 * n);
  c->couple.cap_g = 0;
}

static int ensure_grains(struct sphdem_ctx_s *c, int64_t n) {
  if (n <= c->couple.cap_g && c->couple.cap_g > 0) return SPHDEM_OK;
  free_grains(c);
  sphdem_dev *D = &c->D;
  size_t m = (size_t)(n > 0 ? n : 1);
  void **p24[] = {(void **)&D->couple.gx, (void **)&D->couple.gv, (void **)&D->couple.gom, (void **)&D->couple.gf,
                  (void **)&D->couple.gfd, (void **)&D->couple.gfpg, (void **)&D->couple.gtq};
  for (size_t k = 0; k < sizeof p24 / sizeof p24[0]; k++) TRYC(sphdem_dalloc(c, p24[k], 24 * m));
  TRYC(sphdem_dalloc(c, (void **)&D->couple.grad, 8 * m));
  TRYC(sphdem_dalloc(c, (void **)&D->couple.grain_shepard, 8 * m));
  TRYC(sphdem_dalloc(c, (void **)&D->couple.gtag, 8 * m));
  TRYC(sphdem_dalloc(c, (void **)&D->couple.gcell, 4 * m));
  c->couple.cap_g = (int64_t)m;
  return sphdem_ensure_scratch(c, (int64_t)m);
}

static int ensure_grain_cells(struct sphdem_ctx_s *c, int64_t n) {
  if (n <= c->couple.cap_gcells) return SPHDEM_OK;
  sphdem_dfree(c, (void **)&c->D.couple.gcstart, 4 * (size_t)c->couple.cap_gcells);
  sphdem_dfree(c, (void **)&c->D.couple.gcend, 4 * (size_t)c->couple.cap_gcells);
  c->couple.cap_gcells = 0;
  TRYC(sphdem_dalloc(c, (void **)&c->D.couple.gcstart, 4 * (size_t)n));
  TRYC(sphdem_dalloc(c, (void **)&c->D.couple.gcend, 4 * (size_t)n));
  c->couple.cap_gcells = n;
  return SPHDEM_OK;
}

static int ensure_couple_fluid(struct sphdem_ctx_s *c, int64_t n) {
  if (n <= c->couple.cap_cf && c->couple.cap_cf > 0) return SPHDEM_OK;
  sphdem_dfree(c, (void **)&c->D.couple.eps, 8 * (size_t)c->couple.cap_cf);
  sphdem_dfree(c, (void **)&c->D.couple.fr, 24 * (size_t)c->couple.cap_cf);
  c->couple.cap_cf = 0;
  size_t m = (size_t)(n > 0 ? n : 1);
  TRYC(sphdem_dalloc(c, (void **)&c->D.couple.eps, 8 * m));
  TRYC(sphdem_dalloc(c, (void **)&c->D.couple.fr, 24 * m));
  c->couple.cap_cf = (int64_t)m;
  return rt_zero(&c->rt, c->D.couple.fr, 24 * m); /* read by the wall pass before the first reaction pass */
}

/* The fluid set was rebuilt (set_fluid with new particles): the porosity array must cover it before any
 * pass reads it (reductions of the next sort read eps through eos_density); 1 until the next porosity pass. */
static int couple_rebuilt(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  if (set != SPHDEM_SET_FLUID || !D->couple.on || !D->couple.eps) return SPHDEM_OK;
  TRYC(ensure_couple_fluid(c, D->nf));
  if (D->nf == 0) return SPHDEM_OK;
  double *ones = (double *)malloc(8 * (size_t)D->nf);
  if (!ones) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate %lld doubles", (long long)D->nf);
  for (int64_t i = 0; i < D->nf; i++) ones[i] = 1.0;
  int rc = rt_h2d(&c->rt, D->couple.eps, ones, 8 * (size_t)D->nf);
  free(ones);
  if (!rc) rc = rt_zero(&c->rt, D->couple.fr, 24 * (size_t)D->nf); /* grain forces are kept (until compute_rates) */
  return rc;
}

static void couple_release(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  sphdem_cpu_couple_lists_free(c); /* CPU pair lists (host memory; nothing on the GPU backend) */
  sphdem_dfree(c, (void **)&D->couple.wall_porosity, 8 * (size_t)c->couple.cap_cw);
  c->couple.cap_cw = 0;
  free_grains(c);
  sphdem_dfree(c, (void **)&D->couple.gcstart, 4 * (size_t)c->couple.cap_gcells);
  sphdem_dfree(c, (void **)&D->couple.gcend, 4 * (size_t)c->couple.cap_gcells);
  c->couple.cap_gcells = 0;
  sphdem_dfree(c, (void **)&D->couple.eps, 8 * (size_t)c->couple.cap_cf);
  sphdem_dfree(c, (void **)&D->couple.fr, 24 * (size_t)c->couple.cap_cf);
  c->couple.cap_cf = 0;
  free(c->couple.hgf);
  c->couple.hgf = NULL;
  c->couple.cap_hgf = 0;
  sphdem_idx_free(&c->rt, &c->couple.gidx_buf);
  sphdem_grains_destroy(&c->couple.gstore);
  D->couple.ng = 0;
  D->couple.on = D->couple.eos = D->couple.pressure_volume_form = 0;
  c->couple.nforces = 0;
  c->couple.forces_valid = 0;
  c->couple.grains_dirty = 0;
}

/* ---- API ------------------------------------------------------------------------------------------ */

int sphdem_couple_set(sphdem_ctx c, const sphdem_couple_params *cp) {
  if (!c) return SPHDEM_ERR_ARG;
  if (!cp) return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_set: parameters missing");
  char msg[512];
  if (couple_check(cp, &c->D.P, msg, sizeof msg) != SPHDEM_OK)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_set: %s", msg);
  if (cp->enabled && c->D.mp.on)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_set: the SPH-DEM coupling cannot be combined with the multiphase "
                                          "fluid yet");
  c->couple.cp = *cp;
  sphdem_dev *D = &c->D;
  if (!cp->enabled) { /* off and free */
    couple_release(c);
    return SPHDEM_OK;
  }
  int was_on = D->couple.on;
  D->couple.on = 1;
  D->couple.eos = cp->superficial;
  D->couple.pressure_volume_form = cp->pressure_form;
  D->couple.immersion_s = cp->immersion;
  D->couple.eps_wall_share = cp->eps_walls;
  D->couple.drag = cp->drag;
  D->couple.torque = cp->torque;
  D->couple.cmu = cp->mu;
  D->couple.eps_floor = cp->eps_min;
  D->couple.hc = cp->hc > 0 ? cp->hc : D->P.h;
  D->couple.inv_hc = 1.0 / D->couple.hc;
  D->couple.alphaC = wendland_alpha(D->P.dim, D->couple.hc);
  D->couple.support2c = 4.0 * D->couple.hc * D->couple.hc;
  if (!was_on) { D->couple.ng = 0; c->couple.grains_dirty = 1; }
  else c->couple.grains_dirty = 1; /* dmax or hc may have changed the grain grid */
  return SPHDEM_OK;
}

int sphdem_couple_get(sphdem_ctx c, sphdem_couple_params *cp) {
  if (!c || !cp) return SPHDEM_ERR_ARG;
  if (!c->D.couple.on) sphdem_couple_params_default(cp);
  else *cp = c->couple.cp;
  return SPHDEM_OK;
}

/* The grains of the coupling from a store: checked on the host view, copied on the device into the coupling's
 * arrays (which the grain sort permutes), bounding box and largest diameter from the host view. */
int sphdem_set_grains_store(sphdem_ctx c, sphdem_grain_store g, int n, const int32_t *idx, int with_omega) {
  if (!c) return SPHDEM_ERR_ARG;
  TRYC(sphdem_grains_check(g, &c->rt, c->backend, n, idx, "set_grains"));
  if (with_omega && n > 0 && !g->hom) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_grains: the grain store has no omega");
  const double *x = g->hx, *v = g->hv, *radius = g->hrad;
  int dim = c->D.P.dim;
  for (int i = 0; i < n; i++) {
    const int64_t s = sphdem_grains_at(idx, i);
    if (!(radius[s] > 0) || !isfinite(radius[s]))
      return sphdem_fail(c, SPHDEM_ERR_ARG, "set_grains: grain %d has radius %g; must be > 0", i, radius[s]);
    for (int d = 0; d < dim; d++)
      if (!isfinite(x[3 * s + d]) || !isfinite(v[3 * s + d]))
        return sphdem_fail(c, SPHDEM_ERR_ARG, "set_grains: grain %d has a non-finite position or velocity", i);
  }
  sphdem_dev *D = &c->D;
  if (!D->couple.on) return SPHDEM_OK; /* ignored while the coupling is off */
  TRYC(ensure_grains(c, n));
  if (n > 0) {
    int64_t *tag = (int64_t *)malloc(8 * (size_t)n);
    if (!tag) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "set_grains: cannot allocate %d tags", n);
    for (int i = 0; i < n; i++) tag[i] = i + 1;
    int rc = rt_h2d(&c->rt, D->couple.gtag, tag, 8 * (size_t)n);
    free(tag);
    TRYC(rc);
    sphdem_slots_changed(c, SPHDEM_SET_GRAIN);
    const int32_t *id = NULL;
    TRYC(sphdem_grains_device(g, &c->rt));
    TRYC(sphdem_idx_upload(&c->rt, &c->couple.gidx_buf, idx, n, &id));
    TRYC(sphdem_grains_copy(&c->rt, D->couple.gx, g->dx, id, n, 3));
    TRYC(sphdem_grains_copy(&c->rt, D->couple.gv, g->dv, id, n, 3));
    TRYC(sphdem_grains_copy(&c->rt, D->couple.grad, g->drad, id, n, 1));
    if (with_omega) TRYC(sphdem_grains_copy(&c->rt, D->couple.gom, g->dom, id, n, 3));
    else TRYC(rt_zero(&c->rt, D->couple.gom, 24 * (size_t)n));
  }
  /* bounding box and largest diameter for the grain grid (host loop over the host arrays) */
  c->couple.gdmax = 0.0;
  for (int d = 0; d < 3; d++) { c->couple.gbb_lo[d] = 0.0; c->couple.gbb_hi[d] = 0.0; }
  for (int i = 0; i < n; i++) {
    const int64_t s = sphdem_grains_at(idx, i);
    for (int d = 0; d < dim; d++) {
      double xd = x[3 * s + d];
      if (i == 0 || xd < c->couple.gbb_lo[d]) c->couple.gbb_lo[d] = xd;
      if (i == 0 || xd > c->couple.gbb_hi[d]) c->couple.gbb_hi[d] = xd;
    }
    if (2.0 * radius[s] > c->couple.gdmax) c->couple.gdmax = 2.0 * radius[s];
  }
  D->couple.ng = n;
  c->couple.ngown = n;
  c->D.couple.ngown = n;
  c->couple.grains_dirty = 1;
  return SPHDEM_OK;
}

int sphdem_set_grains(sphdem_ctx c, int n, const double *x, const double *v, const double *radius,
                      const double *omega) {
  if (!c) return SPHDEM_ERR_ARG;
  if (n < 0) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_grains: negative grain count %d", n);
  if (n > 0 && (!x || !v || !radius))
    return sphdem_fail(c, SPHDEM_ERR_ARG, "set_grains: x, v and radius are required");
  TRYC(sphdem_grains_put_private(&c->couple.gstore, &c->rt, c->backend, n, x, v, omega, radius, NULL));
  return sphdem_set_grains_store(c, c->couple.gstore, n, NULL, omega != NULL);
}

int sphdem_couple_set_ghosts(sphdem_ctx c, int nghost) {
  if (!c) return SPHDEM_ERR_ARG;
  if (nghost < 0 || nghost > c->D.couple.ng)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_set_ghosts: %d ghost grains for %lld grains", nghost,
                       (long long)c->D.couple.ng);
  c->couple.ngown = c->D.couple.ng - nghost;
  c->D.couple.ngown = c->couple.ngown;
  return SPHDEM_OK;
}

/* ---- grain grid and the coupling steps of compute_rates ------------------------------------------- */

static int build_grain_grid(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  double dmax = c->couple.cp.dmax > 0 ? c->couple.cp.dmax : c->couple.gdmax;
  double cmin = fmax(dmax, 2.0 * D->couple.hc / SPHDEM_COUPLE_MAX_LAYERS), scale = 1.0;
  /* CPU, dmax not given: cells of at least h_c. The search box (2 ceil(2 h_c/cs) + 1)^3 cs^3 is then
   * 125 h_c^3, about what d_max cells give, but with 125 cells to visit instead of up to 729 (the cell
   * visits dominated the coupling on the CPU: bench/RESULTS.md, drum). The device keeps the paper's d_max
   * cells (He 2018 2.4.1) until it is measured there. Same pairs either way: only the summation order
   * changes. */
  if (c->couple.cp.dmax <= 0 && c->backend == SPHDEM_DEVICE_CPU) cmin = fmax(cmin, D->couple.hc);
  for (int iter = 0; iter < 64; iter++) {
    double total = 1.0; /* in double: three axes of up to 1e9 cells overflow int64 */
    for (int d = 0; d < 3; d++) {
      if (d >= D->P.dim) {
        D->couple.gnc[d] = 1; D->couple.gglo[d] = 0.0; D->couple.gcs[d] = 1.0; D->couple.gcs_inv[d] = 1.0;
        continue;
      }
      double lo, len, cs = cmin * scale;
      if (D->P.periodic[d]) { lo = D->P.boxlo[d]; len = D->P.boxhi[d] - D->P.boxlo[d]; }
      else { lo = c->couple.gbb_lo[d]; len = c->couple.gbb_hi[d] - c->couple.gbb_lo[d]; }
      int n = (int)fmin(floor(len / cs), 1e9);
      if (n < 1) n = 1;
      if (D->P.periodic[d]) cs = len / n;
      else if (len > 0) cs = fmax(cs, len / n);
      D->couple.gnc[d] = n; D->couple.gglo[d] = lo; D->couple.gcs[d] = cs; D->couple.gcs_inv[d] = 1.0 / cs;
      total *= n;
    }
    if (total <= SPHDEM_MAX_CELLS) {
      D->couple.gncells = (int64_t)total;
      return ensure_grain_cells(c, D->couple.gncells);
    }
    scale *= 1.26;
  }
  return sphdem_fail(c, SPHDEM_ERR_ARG, "couple: grain search grid too large");
}

static int sort_grains(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  TRYC(build_grain_grid(c));
  int64_t n = D->couple.ng;
  if (n > 0) {
    TRYC(sphdem_ensure_scratch(c, n));
    TRYC(c->ops->sort_perm(c, SPHDEM_SET_GRAIN));
    void *arr[] = {D->couple.gx, D->couple.gv, D->couple.gom, D->couple.grad, D->couple.gtag};
    int eb[] = {24, 24, 24, 8, 8};
    for (int k = 0; k < 5; k++) TRYC(c->ops->gather(c, arr[k], eb[k], n));
    sphdem_slots_changed(c, SPHDEM_SET_GRAIN);
    TRYC(c->ops->cell_ranges(c, SPHDEM_SET_GRAIN));
  } else {
    TRYC(rt_zero(&c->rt, D->couple.gcstart, 4 * (size_t)D->couple.gncells));
    TRYC(rt_zero(&c->rt, D->couple.gcend, 4 * (size_t)D->couple.gncells));
  }
  c->couple.grains_dirty = 0;
  return SPHDEM_OK;
}

static void set_layers(sphdem_dev *D) {
  for (int d = 0; d < 3; d++) {
    if (d >= D->P.dim) { D->couple.glay[d] = D->couple.flay[d] = 0; continue; }
    /* clamped in double before the cast: more layers than cells visit the same cells (walk_init) */
    double gl = ceil(2.0 * D->couple.hc * D->couple.gcs_inv[d]);
    double fl = ceil((2.0 * D->couple.hc + 0.5 * D->P.skin) * D->cs_inv[d]);
    D->couple.glay[d] = gl >= 1.0 ? (gl < (double)D->couple.gnc[d] ? (int)gl : D->couple.gnc[d]) : 1;
    D->couple.flay[d] = fl >= 1.0 ? (fl < (double)D->nc[d] ? (int)fl : D->nc[d]) : 1;
  }
}

/* Many ranks with an exchange: the owners' grain forces and Shepard sums to the ghost grains (the reaction on
 * this rank's fluid sums them), grains in upload order (gtag - 1). Collective. */
static int exchange_grains(struct sphdem_ctx_s *c) {
  if (!c->xfn) return SPHDEM_OK;
  sphdem_dev *D = &c->D;
  double *const arr[2] = {D->couple.gf, D->couple.grain_shepard};
  const int nc[2] = {3, 1};
  return sphdem_exchange_set(c, SPHDEM_XCHG_GRAIN, SPHDEM_SET_GRAIN, arr, nc, 2, "grain forces");
}

static int couple_prepare(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  if (D->nf == 0) return sphdem_exchange_fluid(c, SPHDEM_XCHG_EPS); /* many ranks: collective */
  TRYC(ensure_couple_fluid(c, D->nf));
  /* wall porosity (wall_porosity 1), written by the wall-state pass */
  if (D->couple.eos && c->couple.cp.wall_porosity && (D->nw > c->couple.cap_cw || !D->couple.wall_porosity)) {
    sphdem_dfree(c, (void **)&D->couple.wall_porosity, 8 * (size_t)c->couple.cap_cw);
    c->couple.cap_cw = 0;
    TRYC(sphdem_dalloc(c, (void **)&D->couple.wall_porosity, 8 * (size_t)(D->nw > 0 ? D->nw : 1)));
    c->couple.cap_cw = D->nw > 0 ? D->nw : 1;
  } else if ((!D->couple.eos || !c->couple.cp.wall_porosity) && D->couple.wall_porosity) {
    sphdem_dfree(c, (void **)&D->couple.wall_porosity, 8 * (size_t)c->couple.cap_cw);
    c->couple.cap_cw = 0;
  }
  if (c->couple.grains_dirty || D->couple.gncells == 0) TRYC(sort_grains(c));
  set_layers(D);
  TRYC(c->ops->couple_porosity(c));
  TRYC(rt_sync(&c->rt));
  /* many ranks: the ghosts' porosity from their owners (this rank's sums miss the grains beyond the band) */
  return sphdem_exchange_fluid(c, SPHDEM_XCHG_EPS);
}

static int couple_finish(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  int64_t n = D->couple.ng;
  if (n > 0 && D->nf > 0) {
    TRYC(c->ops->couple_grains(c));
    TRYC(rt_sync(&c->rt));
  } else if (n > 0) { /* no fluid on this rank (many ranks): no force on its grains */
    double *gz[4] = {D->couple.gf, D->couple.gfd, D->couple.gfpg, D->couple.gtq};
    for (int k = 0; k < 4; k++) TRYC(rt_zero(&c->rt, gz[k], 24 * (size_t)n));
    TRYC(rt_zero(&c->rt, D->couple.grain_shepard, 8 * (size_t)n));
  }
  TRYC(exchange_grains(c)); /* many ranks: the ghost grains' forces from their owners (collective) */
  if (n > 0 && D->nf > 0) TRYC(c->ops->couple_reaction(c));
  else if (D->nf > 0) TRYC(rt_zero(&c->rt, D->couple.fr, 24 * (size_t)D->nf));
  TRYC(rt_sync(&c->rt));
  /* many ranks: the ghosts' acceleration with their owners' reaction (collective) */
  TRYC(sphdem_exchange_fluid(c, SPHDEM_XCHG_ACC));
  /* grain forces to host memory, in upload order */
  if (12 * n > c->couple.cap_hgf) {
    free(c->couple.hgf);
    c->couple.hgf = (double *)malloc(8 * (size_t)(12 * n));
    c->couple.cap_hgf = c->couple.hgf ? 12 * n : 0;
    if (!c->couple.hgf) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate host force buffers");
  }
  if (n > 0) {
    int64_t *tag = (int64_t *)malloc(8 * (size_t)n);
    double *buf = (double *)malloc(24 * (size_t)n);
    int rc = tag && buf ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate host staging");
    if (!rc) rc = rt_d2h(&c->rt, tag, D->couple.gtag, 8 * (size_t)n);
    const double *src[4] = {D->couple.gf, D->couple.gfd, D->couple.gfpg, D->couple.gtq};
    for (int k = 0; !rc && k < 4; k++) {
      rc = rt_d2h(&c->rt, buf, src[k], 24 * (size_t)n);
      for (int64_t s = 0; !rc && s < n; s++)
        for (int d = 0; d < 3; d++) c->couple.hgf[3 * (k * n + (tag[s] - 1)) + d] = buf[3 * s + d];
    }
    free(tag);
    free(buf);
    TRYC(rc);
  }
  c->couple.nforces = n;
  c->couple.forces_valid = 1;
  return SPHDEM_OK;
}

int sphdem_get_grain_forces(sphdem_ctx c, double *f, double *fdrag, double *fpg, double *torque) {
  if (!c) return SPHDEM_ERR_ARG;
  if (!c->D.couple.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "get_grain_forces: the coupling is off");
  if (!c->couple.forces_valid)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "get_grain_forces: no forces yet (call sphdem_compute_rates "
                                             "after sphdem_set_grains)");
  int64_t n = c->couple.nforces;
  double *dst[4] = {f, fdrag, fpg, torque};
  for (int k = 0; k < 4; k++)
    if (dst[k] && n > 0) memcpy(dst[k], c->couple.hgf + 3 * k * n, 24 * (size_t)n);
  return SPHDEM_OK;
}

/* eps (nf) and optionally the reaction forces (3 nf) in upload order (host arrays of the caller). */
static int download_fluid_coupling(struct sphdem_ctx_s *c, double *eps, double *fr) {
  sphdem_dev *D = &c->D;
  int64_t n = D->nf;
  int32_t *ui = (int32_t *)malloc(4 * (size_t)n);
  double *buf = (double *)malloc(24 * (size_t)n);
  int rc = ui && buf ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate host staging");
  if (!rc) rc = rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)n);
  if (!rc && eps) {
    rc = rt_d2h(&c->rt, buf, D->couple.eps, 8 * (size_t)n);
    for (int64_t s = 0; !rc && s < n; s++) eps[ui[s]] = buf[s];
  }
  if (!rc && fr) {
    rc = rt_d2h(&c->rt, buf, D->couple.fr, 24 * (size_t)n);
    for (int64_t s = 0; !rc && s < n; s++)
      for (int d = 0; d < 3; d++) fr[3 * (int64_t)ui[s] + d] = buf[3 * s + d];
  }
  free(ui);
  free(buf);
  return rc;
}

int sphdem_get_porosity(sphdem_ctx c, double *eps) {
  if (!c) return SPHDEM_ERR_ARG;
  if (!c->D.couple.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "get_porosity: the coupling is off");
  if (c->D.nf == 0) return SPHDEM_OK;
  if (!eps) return sphdem_fail(c, SPHDEM_ERR_ARG, "get_porosity: eps is NULL");
  if (c->couple.cap_cf < c->D.nf || !c->couple.forces_valid)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "get_porosity: no porosity yet (call sphdem_compute_rates)");
  return download_fluid_coupling(c, eps, NULL);
}

int sphdem_couple_seed_porosity(sphdem_ctx c, int n, const double *eps) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (!D->couple.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "couple_seed_porosity: the coupling is off");
  if ((int64_t)n != D->nf)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_seed_porosity: n = %d, but %lld fluid particles are uploaded", n,
                       (long long)D->nf);
  if (n == 0) return SPHDEM_OK;
  if (!eps) return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_seed_porosity: eps is NULL");
  for (int i = 0; i < n; i++)
    if (!(eps[i] > 0.0 && eps[i] <= 1.0))
      return sphdem_fail(c, SPHDEM_ERR_ARG, "couple_seed_porosity: eps[%d] = %g is not in (0, 1]", i, eps[i]);
  TRYC(ensure_couple_fluid(c, D->nf));
  int32_t *ui = (int32_t *)malloc(4 * (size_t)n);
  double *buf = (double *)malloc(8 * (size_t)n);
  int rc = ui && buf ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate host staging");
  if (!rc) rc = rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)n);
  if (!rc) {
    for (int s = 0; s < n; s++) buf[s] = eps[ui[s]]; /* device slot s holds upload index ui[s] */
    rc = rt_h2d(&c->rt, D->couple.eps, buf, 8 * (size_t)n);
  }
  free(ui);
  free(buf);
  return rc;
}

int sphdem_couple_stats_get(sphdem_ctx c, sphdem_couple_stats *s) {
  if (!c || !s) return SPHDEM_ERR_ARG;
  memset(s, 0, sizeof *s);
  s->eps_min = 1.0;
  sphdem_dev *D = &c->D;
  if (!D->couple.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "couple_stats_get: the coupling is off");
  /* the owned grains and fluid of this rank (upload order: owned first), summed over the ranks (collective) */
  const int many = rt_nranks(&c->rt) > 1;
  double ng = (double)(c->couple.ngown < D->couple.ng ? c->couple.ngown : D->couple.ng);
  double valid = c->couple.forces_valid ? 1.0 : 0.0;
  if (many) {
    TRYC(sphdem_rt_allreduce(&c->rt, &ng, 1, SPHDEM_RED_SUM));
    TRYC(sphdem_rt_allreduce(&c->rt, &valid, 1, SPHDEM_RED_MIN));
  }
  s->ngrains = (int64_t)ng;
  if (!(valid > 0.5)) return SPHDEM_OK;
  long double fg[3] = {0, 0, 0}, ff[3] = {0, 0, 0};
  const int64_t ngo = c->couple.ngown < c->couple.nforces ? c->couple.ngown : c->couple.nforces;
  for (int64_t j = 0; j < ngo; j++)
    for (int d = 0; d < 3; d++) fg[d] += c->couple.hgf[3 * j + d];
  int64_t n = D->nown;
  if (n > 0 && c->couple.cap_cf >= D->nf) {
    double *e = (double *)malloc(8 * (size_t)D->nf), *fr = (double *)malloc(24 * (size_t)D->nf);
    int rc = e && fr ? download_fluid_coupling(c, e, fr)
                     : sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple_stats_get: cannot allocate host staging");
    for (int64_t a = 0; !rc && a < n; a++) {
      if (e[a] < s->eps_min) s->eps_min = e[a];
      for (int d = 0; d < 3; d++) ff[d] += fr[3 * a + d];
    }
    free(e);
    free(fr);
    TRYC(rc);
  }
  for (int d = 0; d < 3; d++) { s->f_grains[d] = (double)fg[d]; s->f_fluid[d] = (double)ff[d]; }
  if (many) {
    double sums[6] = {s->f_grains[0], s->f_grains[1], s->f_grains[2], s->f_fluid[0], s->f_fluid[1], s->f_fluid[2]};
    TRYC(sphdem_rt_allreduce(&c->rt, sums, 6, SPHDEM_RED_SUM));
    TRYC(sphdem_rt_allreduce(&c->rt, &s->eps_min, 1, SPHDEM_RED_MIN));
    for (int d = 0; d < 3; d++) { s->f_grains[d] = sums[d]; s->f_fluid[d] = sums[3 + d]; }
  }
  return SPHDEM_OK;
}

/* ---- testing hook ------------------------------------------------------------------------------------ */

static int cmp_pair(const void *a, const void *b) {
  const int64_t *x = (const int64_t *)a, *y = (const int64_t *)b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  if (x[1] != y[1]) return x[1] < y[1] ? -1 : 1;
  return 0;
}

/* Runs both searches of the passes (fluid->grain on the grain grid, grain->fluid on the SPH grid) on a
 * host copy of the device arrays; they must find the same pairs (else -SPHDEM_ERR_STATE with a message). */
int64_t sphdem_debug_couple_pairs(sphdem_ctx c, int64_t *pairs, int64_t maxpairs) {
  if (!c) return -SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (!D->couple.on) return -sphdem_fail(c, SPHDEM_ERR_STATE, "debug_couple_pairs: the coupling is off");
  if (c->need_sort || c->couple.grains_dirty || !c->couple.forces_valid)
    return -sphdem_fail(c, SPHDEM_ERR_STATE, "debug_couple_pairs: call sphdem_compute_rates first");
  int64_t nf = D->nf, ng = D->couple.ng;
  if (nf == 0 || ng == 0) return 0;
  sphdem_dev H = *D;
  H.x = (double *)malloc(24 * (size_t)nf);
  H.couple.gx = (double *)malloc(24 * (size_t)ng);
  H.cstart = (int32_t *)malloc(4 * (size_t)D->ncells);
  H.cend = (int32_t *)malloc(4 * (size_t)D->ncells);
  H.couple.gcstart = (int32_t *)malloc(4 * (size_t)D->couple.gncells);
  H.couple.gcend = (int32_t *)malloc(4 * (size_t)D->couple.gncells);
  int32_t *ui = (int32_t *)malloc(4 * (size_t)nf);
  int64_t *gt = (int64_t *)malloc(8 * (size_t)ng);
  int64_t cap = 1024, np[2] = {0, 0};
  int64_t *lst[2] = {(int64_t *)malloc(16 * (size_t)cap), (int64_t *)malloc(16 * (size_t)cap)};
  int64_t caps[2] = {cap, cap};
  int rc = H.x && H.couple.gx && H.cstart && H.cend && H.couple.gcstart && H.couple.gcend && ui && gt && lst[0] && lst[1]
               ? SPHDEM_OK : SPHDEM_ERR_ALLOC;
  if (!rc) rc = rt_d2h(&c->rt, H.x, D->x, 24 * (size_t)nf);
  if (!rc) rc = rt_d2h(&c->rt, H.couple.gx, D->couple.gx, 24 * (size_t)ng);
  if (!rc) rc = rt_d2h(&c->rt, H.cstart, D->cstart, 4 * (size_t)D->ncells);
  if (!rc) rc = rt_d2h(&c->rt, H.cend, D->cend, 4 * (size_t)D->ncells);
  if (!rc) rc = rt_d2h(&c->rt, H.couple.gcstart, D->couple.gcstart, 4 * (size_t)D->couple.gncells);
  if (!rc) rc = rt_d2h(&c->rt, H.couple.gcend, D->couple.gcend, 4 * (size_t)D->couple.gncells);
  if (!rc) rc = rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)nf);
  if (!rc) rc = rt_d2h(&c->rt, gt, D->couple.gtag, 8 * (size_t)ng);
  for (int dir = 0; dir < 2 && !rc; dir++) {
    int64_t nsrc = dir == 0 ? nf : ng;
    for (int64_t i = 0; i < nsrc && !rc; i++) {
      const double *xi = (dir == 0 ? H.x : H.couple.gx) + 3 * i;
      cell_walk w;
      int64_t cc;
      double r[3];
      if (dir == 0) walk_grains_around(&H, xi, &w);
      else walk_fluid_around(&H, xi, &w);
      while (!rc && walk_next(&w, &cc)) {
        int32_t b0 = dir == 0 ? H.couple.gcstart[cc] : H.cstart[cc], b1 = dir == 0 ? H.couple.gcend[cc] : H.cend[cc];
        for (int32_t k = b0; k < b1; k++) {
          const double *xk = (dir == 0 ? H.couple.gx : H.x) + 3 * k;
          if (separation(&H, xi, xk, r) >= H.couple.support2c) continue;
          if (np[dir] == caps[dir]) {
            int64_t *q = (int64_t *)realloc(lst[dir], 32 * (size_t)caps[dir]);
            if (!q) { rc = SPHDEM_ERR_ALLOC; break; }
            lst[dir] = q;
            caps[dir] *= 2;
          }
          int64_t fl = dir == 0 ? ui[i] : ui[k], gr = dir == 0 ? gt[k] - 1 : gt[i] - 1;
          lst[dir][2 * np[dir]] = fl;
          lst[dir][2 * np[dir] + 1] = gr;
          np[dir]++;
        }
      }
    }
  }
  int64_t out = 0;
  if (rc) {
    sphdem_fail(c, rc, "debug_couple_pairs: cannot allocate host copies");
    out = -rc;
  } else {
    qsort(lst[0], (size_t)np[0], 16, cmp_pair);
    qsort(lst[1], (size_t)np[1], 16, cmp_pair);
    if (np[0] != np[1] || memcmp(lst[0], lst[1], 16 * (size_t)np[0]) != 0) {
      out = -sphdem_fail(c, SPHDEM_ERR_STATE, "debug_couple_pairs: fluid->grain search found %lld pairs, "
                                              "grain->fluid search %lld (or different ones)",
                         (long long)np[0], (long long)np[1]);
    } else {
      for (int64_t k = 0; k < np[0] && k < maxpairs; k++) { pairs[2 * k] = lst[0][2 * k]; pairs[2 * k + 1] = lst[0][2 * k + 1]; }
      out = np[0];
    }
  }
  free(H.x); free(H.couple.gx); free(H.cstart); free(H.cend); free(H.couple.gcstart); free(H.couple.gcend);
  free(ui); free(gt); free(lst[0]); free(lst[1]);
  return out;
}

static int couple_on(const struct sphdem_ctx_s *c) { return c->D.couple.on; }

/* The porosity follows its particles (read by get_porosity, probe and get_fluid's pressure), and the last
 * reaction (read by the wall pass). */
static int couple_sorted(struct sphdem_ctx_s *c, int set, int64_t n) {
  sphdem_dev *D = &c->D;
  if (set != SPHDEM_SET_FLUID || c->couple.cap_cf < n) return SPHDEM_OK;
  if (D->couple.eps) TRYC(c->ops->gather(c, D->couple.eps, 8, n));
  if (D->couple.fr) TRYC(c->ops->gather(c, D->couple.fr, 24, n));
  return SPHDEM_OK;
}

/* get_fluid: superficial density, the EOS sees rho / eps (He 2018 eq 7); eps from the last compute_rates. */
static int couple_host_pressure(struct sphdem_ctx_s *c, int64_t n, const double *rho, const int32_t *ui, double *p,
                                int *done) {
  const sphdem_dev *D = &c->D;
  if (!D->couple.eos || !D->couple.eps || c->couple.cap_cf < n) return SPHDEM_OK;
  double *e = (double *)malloc(8 * (size_t)n);
  if (!e) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "get_fluid: cannot allocate %lld doubles", (long long)n);
  int rc = rt_d2h(&c->rt, e, D->couple.eps, 8 * (size_t)n);
  if (rc) { free(e); return rc; }
  for (int64_t s = 0; s < n; s++) p[ui[s]] = tait_pressure(D, rho[s] / fmax(e[s], D->couple.eps_floor));
  free(e);
  *done = 1;
  return SPHDEM_OK;
}

/* The coupling as a feature of the fluid context: grain sort and porosity before the EOS, grain forces and
 * the reaction on the fluid after the rates pass, both timed as SPHDEM_T_COUPLE. */
const sphdem_feature sphdem_feature_couple = {"couple", couple_on, couple_rebuilt, couple_sorted, couple_prepare,
                                              NULL, couple_finish, couple_host_pressure, couple_release,
                                              SPHDEM_T_COUPLE};
