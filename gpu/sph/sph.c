/* sph.c - the sphdem context: parameters, particle upload/download, search grid, stepping, stats. */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sph_bodies.h"
#include "sph_internal.h"


const char *sphdem_strerror(int code) {
  switch (code) {
#define SPHDEM_CASE_(name, val, msg) case val: return msg;
    SPHDEM_ERROR_LIST(SPHDEM_CASE_)
#undef SPHDEM_CASE_
  }
  return "unknown sphdem error code";
}

const char *sphdem_last_error(sphdem_ctx c) { return c ? c->rt.err : "no context"; }
int sphdem_backend(sphdem_ctx c) { return c ? c->backend : SPHDEM_DEVICE_CPU; }
const char *sphdem_backend_note(sphdem_ctx c) { return c ? c->note : ""; }
int64_t sphdem_nsorts(sphdem_ctx c) { return c ? c->nsorts : 0; }
size_t sphdem_device_bytes(sphdem_ctx c) { return c ? c->rt.bytes : 0; }

void sphdem_timers(sphdem_ctx c, double t[SPHDEM_NTIMERS]) {
  for (int k = 0; k < SPHDEM_NTIMERS; k++) t[k] = c ? c->timers[k] : 0.0;
}
void sphdem_timers_reset(sphdem_ctx c) {
  if (c) memset(c->timers, 0, sizeof c->timers);
}

int sphdem_gpu_available(void) {
  char msg[256];
  return sphdem_rt_gpu_probe(msg, sizeof msg) == SPHDEM_OK;
}

/* ---- parameters ------------------------------------------------------------------------------ */

void sphdem_params_default(sphdem_params *p) {
  memset(p, 0, sizeof *p);
  p->dim = 3;
  p->gamma = 7.0;
  p->visc = SPHDEM_VISC_NONE;
  p->tensile_n = 4.0;
  p->cfl = 0.25;
  p->rho_err_max = 0.2;
  for (int d = 0; d < 3; d++) { p->boxlo[d] = -1e300; p->boxhi[d] = 1e300; }
}

#define CHECK(cond, ...) do { if (!(cond)) { snprintf(msg, msglen, __VA_ARGS__); return SPHDEM_ERR_ARG; } } while (0)

int sphdem_params_check(const sphdem_params *p, char *msg, size_t msglen) {
  char dummy[8];
  if (!msg || msglen == 0) { msg = dummy; msglen = sizeof dummy; }
  msg[0] = 0;
  CHECK(p, "parameters missing");
  CHECK(p->dim == 2 || p->dim == 3, "dim must be 2 or 3 (got %d)", p->dim);
  CHECK(p->h > 0 && isfinite(p->h), "h (smoothing length) must be > 0 (got %g)", p->h);
  CHECK(p->dx > 0 && isfinite(p->dx), "dx (initial particle spacing) must be > 0 (got %g)", p->dx);
  /* the kernel constant 21 / (16 pi h^3) must neither divide by an underflowed h^3 nor vanish */
  CHECK(p->h >= 1e-60 && p->h <= 1e60, "h (smoothing length) %g is outside [1e-60, 1e60]", p->h);
  CHECK(p->tensile_eps == 0 || p->dx < 2.0 * p->h,
        "tensile correction needs dx < 2h (W(dx) = 0 otherwise; got dx %g, h %g)", p->dx, p->h);
  CHECK(p->rho0 > 0, "rho0 (reference density) must be > 0 (got %g)", p->rho0);
  CHECK(p->c0 > 0, "c0 (sound speed) must be > 0 (got %g)", p->c0);
  CHECK(p->gamma >= 1, "gamma (Tait exponent) must be >= 1 (got %g)", p->gamma);
  CHECK(p->visc >= SPHDEM_VISC_NONE && p->visc <= SPHDEM_VISC_ARTIFICIAL,
        "visc must be none, morris or artificial");
  CHECK(p->visc != SPHDEM_VISC_MORRIS || p->mu > 0, "visc morris needs a dynamic viscosity mu > 0 (got %g)", p->mu);
  CHECK(p->visc != SPHDEM_VISC_ARTIFICIAL || p->alpha > 0, "visc artificial needs alpha > 0 (got %g)", p->alpha);
  CHECK(p->tensile_eps >= 0, "tensile eps must be >= 0 (got %g)", p->tensile_eps);
  CHECK(p->tensile_eps == 0 || p->tensile_n > 0, "tensile exponent n must be > 0 (got %g)", p->tensile_n);
  CHECK(p->xsph_eps >= 0 && p->xsph_eps <= 1, "xsph eps must be in [0, 1] (got %g)", p->xsph_eps);
  CHECK(p->delta >= 0 && p->delta <= 1, "delta (density diffusion) must be in [0, 1] (got %g)", p->delta);
  CHECK(p->precision >= SPHDEM_PREC_DOUBLE && p->precision <= SPHDEM_PREC_SINGLE,
        "precision must be double (0), mixed (1) or single (2) (got %d)", p->precision);
  CHECK(p->wall_clamp == 0 || p->wall_clamp == 1, "wall_clamp must be 0 or 1 (got %d)", p->wall_clamp);
  CHECK(p->isolated >= 0 && p->isolated < 1, "isolated (kernel-sum threshold) must be in [0, 1) (got %g)",
        p->isolated);
  CHECK(p->rep_D >= 0, "repulsion D must be >= 0 (got %g)", p->rep_D);
  CHECK(p->rep_D == 0 || p->rep_r0 > 0, "repulsion r0 must be > 0 (got %g)", p->rep_r0);
  CHECK(p->skin >= 0, "skin must be >= 0 (got %g)", p->skin);
  CHECK(p->cfl > 0 && p->cfl <= 1, "cfl must be in (0, 1] (got %g)", p->cfl);
  CHECK(p->rho_err_max > 0, "rho_err_max must be > 0 (got %g)", p->rho_err_max);
  for (int d = 0; d < p->dim; d++) {
    CHECK(p->boxhi[d] > p->boxlo[d], "box: hi must exceed lo on axis %c", "xyz"[d]);
    if (p->periodic[d]) {
      double L = p->boxhi[d] - p->boxlo[d];
      CHECK(L >= 3.0 * (2.0 * p->h + p->skin),
            "periodic box length %g on axis %c is below 3 (2h + skin) = %g; enlarge the box or "
            "reduce h/skin", L, "xyz"[d], 3.0 * (2.0 * p->h + p->skin));
    }
  }
  for (int d = 0; d < 3; d++) CHECK(isfinite(p->gravity[d]), "gravity must be finite");
  return SPHDEM_OK;
}

double sphdem_stokes_time(double rho_p, double d, double mu) { return rho_p * d * d / (18.0 * mu); }

double sphdem_hydrostatic_rho(const sphdem_params *p, double depth) {
  double g = sqrt(p->gravity[0] * p->gravity[0] + p->gravity[1] * p->gravity[1] +
                  (p->dim == 3 ? p->gravity[2] * p->gravity[2] : 0.0));
  double B = sphdem_tait_B(p);
  return p->rho0 * pow(1.0 + p->rho0 * g * depth / B, 1.0 / p->gamma);
}



int sphdem_set_params(sphdem_ctx c, const sphdem_params *p) {
  char msg[512];
  if (!c) return SPHDEM_ERR_ARG;
  if (sphdem_params_check(p, msg, sizeof msg) != SPHDEM_OK) return sphdem_fail(c, SPHDEM_ERR_ARG, "%s", msg);
  if (p->dim != c->D.P.dim || p->h != c->D.P.h)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "dim and h cannot change after the context is created");
  int box_changed = memcmp(p->boxlo, c->D.P.boxlo, sizeof p->boxlo) ||
                    memcmp(p->boxhi, c->D.P.boxhi, sizeof p->boxhi) ||
                    memcmp(p->periodic, c->D.P.periodic, sizeof p->periodic) || p->skin != c->D.P.skin;
  c->D.P = *p;
  sphdem_rederive(c);
  if (box_changed) c->need_sort = 1;
  return SPHDEM_OK;
}

int sphdem_get_params(sphdem_ctx c, sphdem_params *p) {
  if (!c || !p) return SPHDEM_ERR_ARG;
  *p = c->D.P;
  return SPHDEM_OK;
}

/* ---- memory ------------------------------------------------------------------------------------ */


#define DFREE(cx, p_, nb_) rt_free(&(cx)->rt, (void **)&(p_), (nb_))

static void free_fluid(sphdem_ctx c) {
  sphdem_dev *D = &c->D;
  size_t n = (size_t)c->cap_f;
  if (!n) return;
  DFREE(c, D->x, 24 * n); DFREE(c, D->v, 24 * n); DFREE(c, D->rho, 8 * n); DFREE(c, D->mass, 8 * n);
  DFREE(c, D->drho, 8 * n); DFREE(c, D->a, 24 * n); DFREE(c, D->u, 24 * n); DFREE(c, D->p, 8 * n);
  DFREE(c, D->x0, 24 * n); DFREE(c, D->xe, 24 * n); DFREE(c, D->rhop, 8 * n); DFREE(c, D->ve, 24 * n); DFREE(c, D->pr2, 8 * n); DFREE(c, D->tag, 8 * n); DFREE(c, D->uidx, 4 * n); DFREE(c, D->cell, 4 * n);
  c->cap_f = 0;
}

static void free_walls(sphdem_ctx c) {
  sphdem_dev *D = &c->D;
  size_t n = (size_t)c->cap_w;
  if (!n) return;
  DFREE(c, D->wx, 24 * n); DFREE(c, D->wv, 24 * n); DFREE(c, D->wa, 24 * n); DFREE(c, D->wmass, 8 * n);
  DFREE(c, D->wp, 8 * n); DFREE(c, D->wrho, 8 * n); DFREE(c, D->wvx, 24 * n); DFREE(c, D->wtag, 8 * n);
  DFREE(c, D->wcell, 4 * n); DFREE(c, c->wperm, 4 * n);
  c->cap_w = 0;
  c->wref_n = -1;
}


static void free_cells(sphdem_ctx c) {
  size_t n = (size_t)c->cap_cells;
  if (!n) return;
  DFREE(c, c->D.cstart, 4 * n); DFREE(c, c->D.cend, 4 * n);
  DFREE(c, c->D.wcstart, 4 * n); DFREE(c, c->D.wcend, 4 * n);
  c->cap_cells = 0;
}

#define TRY(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)



static int ensure_fluid(sphdem_ctx c, int64_t n) {
  if (n <= c->cap_f && c->cap_f > 0) return SPHDEM_OK;
  free_fluid(c);
  sphdem_dev *D = &c->D;
  size_t m = (size_t)(n > 0 ? n : 1);
  TRY(sphdem_dalloc(c, (void **)&D->x, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->v, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->rho, 8 * m)); TRY(sphdem_dalloc(c, (void **)&D->mass, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->drho, 8 * m)); TRY(sphdem_dalloc(c, (void **)&D->a, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->u, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->p, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->x0, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->tag, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->xe, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->rhop, 8 * m)); TRY(sphdem_dalloc(c, (void **)&D->ve, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->pr2, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->uidx, 4 * m)); TRY(sphdem_dalloc(c, (void **)&D->cell, 4 * m));
  c->cap_f = (int64_t)m;
  return sphdem_ensure_scratch(c, (int64_t)m);
}

static int ensure_walls(sphdem_ctx c, int64_t n) {
  if (n <= c->cap_w && c->cap_w > 0) return SPHDEM_OK;
  free_walls(c);
  sphdem_dev *D = &c->D;
  size_t m = (size_t)(n > 0 ? n : 1);
  TRY(sphdem_dalloc(c, (void **)&D->wx, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->wv, 24 * m));
  TRY(sphdem_dalloc(c, (void **)&D->wa, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->wmass, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->wp, 8 * m)); TRY(sphdem_dalloc(c, (void **)&D->wrho, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->wvx, 24 * m)); TRY(sphdem_dalloc(c, (void **)&D->wtag, 8 * m));
  TRY(sphdem_dalloc(c, (void **)&D->wcell, 4 * m)); TRY(sphdem_dalloc(c, (void **)&c->wperm, 4 * m));
  c->cap_w = (int64_t)m;
  c->wref_n = -1;
  return sphdem_ensure_scratch(c, (int64_t)m);
}

static int ensure_cells(sphdem_ctx c, int64_t n) {
  if (n <= c->cap_cells) return SPHDEM_OK;
  free_cells(c);
  size_t m = (size_t)n;
  TRY(sphdem_dalloc(c, (void **)&c->D.cstart, 4 * m)); TRY(sphdem_dalloc(c, (void **)&c->D.cend, 4 * m));
  TRY(sphdem_dalloc(c, (void **)&c->D.wcstart, 4 * m)); TRY(sphdem_dalloc(c, (void **)&c->D.wcend, 4 * m));
  c->cap_cells = n;
  return SPHDEM_OK;
}

/* Host staging buffers (plain malloc on both backends). */
static int ensure_host(sphdem_ctx c, int64_t n) {
  if (n <= c->cap_host) return SPHDEM_OK;
  free(c->hbuf); free(c->htag); free(c->huidx);
  size_t m = (size_t)(n > 0 ? n : 1);
  c->hbuf = (double *)malloc(sizeof(double) * SPHDEM_NSTATE * m);
  c->htag = (int64_t *)malloc(sizeof(int64_t) * m);
  c->huidx = (int32_t *)malloc(sizeof(int32_t) * m);
  c->host_tags_valid = 0;
  if (!c->hbuf || !c->htag || !c->huidx) {
    c->cap_host = 0;
    return sphdem_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate %lld host staging entries", (long long)m);
  }
  c->cap_host = (int64_t)m;
  return SPHDEM_OK;
}

/* ---- create / destroy ----------------------------------------------------------------------------- */

int sphdem_create(sphdem_ctx *out, const sphdem_params *p, sphdem_device dev, char *msg, size_t msglen) {
  char m[512];
  if (!out) return SPHDEM_ERR_ARG;
  *out = NULL;
  if (sphdem_params_check(p, m, sizeof m) != SPHDEM_OK) {
    if (msg && msglen) snprintf(msg, msglen, "%s", m);
    return SPHDEM_ERR_ARG;
  }
  if (dev != SPHDEM_DEVICE_AUTO && dev != SPHDEM_DEVICE_CPU && dev != SPHDEM_DEVICE_GPU) {
    if (msg && msglen) snprintf(msg, msglen, "device must be auto, cpu or gpu");
    return SPHDEM_ERR_ARG;
  }
  sphdem_ctx c = (sphdem_ctx)calloc(1, sizeof *c);
  if (!c) {
    if (msg && msglen) snprintf(msg, msglen, "cannot allocate the context");
    return SPHDEM_ERR_ALLOC;
  }
  for (int set = 0; set < 3; set++) c->xm[set].nrows = -1; /* every owned row */
  c->D.P = *p;
  sphdem_rederive(c);
  c->ops = &sphdem_cpu_ops;
  c->backend = SPHDEM_DEVICE_CPU;
  sphdem_rt_init(&c->rt, SPHDEM_DEVICE_CPU);
  if (dev != SPHDEM_DEVICE_CPU) {
#ifdef SPHDEM_WITH_CUDA
    int rc = sphdem_rt_gpu_probe(m, sizeof m);
    if (rc == SPHDEM_OK) rc = sphdem_cuda_init(c);
    if (rc == SPHDEM_OK) {
      c->ops = &sphdem_cuda_ops;
      c->backend = SPHDEM_DEVICE_GPU;
      sphdem_rt_init(&c->rt, SPHDEM_DEVICE_GPU);
      snprintf(c->note, sizeof c->note, "%s", m);
    } else if (dev == SPHDEM_DEVICE_GPU) {
      if (msg && msglen) snprintf(msg, msglen, "device gpu requested but no GPU is usable: %s", m);
      free(c);
      return SPHDEM_ERR_NO_GPU;
    } else {
      snprintf(c->note, sizeof c->note, "no usable GPU (%s); running on the CPU backend", m);
    }
#else
    if (dev == SPHDEM_DEVICE_GPU) {
      if (msg && msglen)
        snprintf(msg, msglen, "device gpu requested but this build has no CUDA backend (rebuild with "
                              "nvcc available and SPHDEM_CUDA=AUTO or ON)");
      free(c);
      return SPHDEM_ERR_NO_GPU;
    }
    snprintf(c->note, sizeof c->note, "built without CUDA; running on the CPU backend");
#endif
  }
  c->need_sort = 1;
  /* CPU backend: pair symmetry halves the fluid-pair work; SPHDEM_CPU_GATHER=1 selects the GPU's
   * gather formulation instead (the twin self-test compares the two) */
  c->cpu_sym = getenv("SPHDEM_CPU_GATHER") == NULL;
  *out = c;
  return SPHDEM_OK;
}


int sphdem_destroy(sphdem_ctx *pc) {
  if (!pc || !*pc) return SPHDEM_OK;
  sphdem_ctx c = *pc;
  for (const sphdem_feature *const *f = sphdem_features; *f; f++)
    if ((*f)->release) (*f)->release(c);
  free_fluid(c);
  free_walls(c);
  sphdem_free_scratch(c);
  sphdem_free_xmaps(c);
  free_cells(c);
#ifdef SPHDEM_WITH_CUDA
  if (c->backend == SPHDEM_DEVICE_GPU) sphdem_cuda_fini(c);
#endif
  free(c->hbuf); free(c->htag); free(c->huidx); free(c->hmap); free(c->xbuf);
  free(c->hwx0); free(c->hwm0); free(c->hwx1); free(c->hwm1);
  if (c->backend == SPHDEM_DEVICE_CPU) { free(c->D.nl_start); free(c->D.wl_start); free(c->D.nl); free(c->D.wl); free(c->D.wfl_start); free(c->D.wfl); free(c->symbuf); free(c->f8buf); free(c->nl_ghost); }
  free(c);
  *pc = NULL;
  return SPHDEM_OK;
}

/* ---- grid and sorting ------------------------------------------------------------------------------ */


/* Search grid over the periodic box / the particles' bounding box, cells >= 2h + skin. */
static int build_grid(sphdem_ctx c) {
  sphdem_dev *D = &c->D;
  sphdem_red rf, rw;
  TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &rf));
  if (D->nw > 0) {
    TRY(sphdem_timed_reduce(c, SPHDEM_SET_WALL, &rw));
    for (int d = 0; d < 3; d++) { rf.lo[d] = fmin(rf.lo[d], rw.lo[d]); rf.hi[d] = fmax(rf.hi[d], rw.hi[d]); }
  }
  double cmin = 2.0 * D->P.h + D->P.skin;
  double scale = 1.0;
  for (int iter = 0; iter < 64; iter++) {
    double total = 1.0; /* in double: three axes of up to 2^30 cells overflow int64 */
    for (int d = 0; d < 3; d++) {
      if (d >= D->P.dim) { D->nc[d] = 1; D->glo[d] = 0.0; D->cs[d] = 1.0; D->cs_inv[d] = 1.0; continue; }
      double lo, hi;
      if (D->P.periodic[d]) { lo = D->P.boxlo[d]; hi = D->P.boxhi[d]; }
      else {
        lo = rf.lo[d]; hi = rf.hi[d];
        if (!(hi >= lo)) { lo = 0.0; hi = 0.0; } /* empty or non-finite: one cell */
        /* keep runaway particles from inflating the grid: clamp to the box +/- its size */
        if (D->P.boxlo[d] > -1e299 && D->P.boxhi[d] < 1e299) {
          double Lb = D->P.boxhi[d] - D->P.boxlo[d];
          lo = fmax(lo, D->P.boxlo[d] - Lb); hi = fmin(hi, D->P.boxhi[d] + Lb);
          if (hi < lo) hi = lo;
        }
      }
      double len = hi - lo, cs = cmin * scale;
      int n = (int)fmin(floor(len / cs), 1073741824.0); /* clamped before the cast (huge boxes) */
      if (n < 1) n = 1;
      if (D->P.periodic[d]) {
        if (n < 3) return sphdem_fail(c, SPHDEM_ERR_ARG, "periodic axis %c holds fewer than 3 cells of 2h + skin", "xyz"[d]);
        cs = len / n;
      } else if (len > 0) {
        cs = fmax(cs, len / n);
      }
      D->nc[d] = n; D->glo[d] = lo; D->cs[d] = cs; D->cs_inv[d] = 1.0 / cs;
      total *= n;
    }
    if (total <= SPHDEM_MAX_CELLS) {
      D->ncells = (int64_t)total;
      return ensure_cells(c, D->ncells);
    }
    scale *= 1.26;
  }
  return sphdem_fail(c, SPHDEM_ERR_ARG, "search grid too large: the particles span %g x %g x %g with cells of "
                     "2h + skin = %g (more than %d cells)", rf.hi[0] - rf.lo[0], rf.hi[1] - rf.lo[1],
                     D->P.dim == 3 ? rf.hi[2] - rf.lo[2] : 0.0, cmin, SPHDEM_MAX_CELLS);
}

/* Sort one set by (cell, tag) and permute every array that carries state across steps. */
static int sort_set(sphdem_ctx c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = set == SPHDEM_SET_FLUID ? D->nf : D->nw;
  if (n == 0) return SPHDEM_OK;
  TRY(c->ops->sort_perm(c, set));
  if (set == SPHDEM_SET_FLUID) {
    void *arr[] = {D->x, D->v, D->a, D->u, D->rho, D->mass, D->drho, D->tag, D->uidx, D->xe};
    int eb[] = {24, 24, 24, 24, 8, 8, 8, 8, 4, 24};
    for (int k = 0; k < 10; k++) TRY(c->ops->gather(c, arr[k], eb[k], n));
    TRY(rt_d2d(&c->rt, D->x0, D->x, 24 * (size_t)n));
  } else {
    void *arr[] = {D->wx, D->wv, D->wa, D->wmass, D->wtag};
    int eb[] = {24, 24, 24, 8, 8};
    for (int k = 0; k < 5; k++) TRY(c->ops->gather(c, arr[k], eb[k], n));
    /* slot -> caller index: the permutation itself after a full upload, else the old map through it */
    if (c->walls_caller_order) TRY(rt_d2d(&c->rt, c->wperm, c->perm, 4 * (size_t)n));
    else TRY(c->ops->gather(c, c->wperm, 4, n));
    c->walls_caller_order = 0;
    if (c->cap_hw >= n) {
      memcpy(c->hwx0, c->hwx1, 24 * (size_t)n);
      memcpy(c->hwm0, c->hwm1, 8 * (size_t)n);
      c->wref_n = n;
    }
    c->wref_synced = 0; /* sort_all sets it */
  }
  for (const sphdem_feature *const *f = sphdem_features; *f; f++) /* the features' arrays follow their particles */
    if ((*f)->sorted) TRY((*f)->sorted(c, set, n));
  sphdem_slots_changed(c, set);
  c->wl_dirty = 1;
  if (set == SPHDEM_SET_FLUID) c->nl_dirty = 1;
  return c->ops->cell_ranges(c, set);
}

static int sort_all(sphdem_ctx c) {
  double t0 = rt_now();
  TRY(build_grid(c));
  TRY(sort_set(c, SPHDEM_SET_FLUID));
  TRY(sort_set(c, SPHDEM_SET_WALL));
  c->wref_synced = 1;
  TRY(rt_sync(&c->rt));
  c->timers[SPHDEM_T_SORT] += rt_now() - t0;
  c->need_sort = 0;
  c->need_wall_sort = 0;
  c->host_tags_valid = 0;
  c->nsorts++;
  return SPHDEM_OK;
}

/* ---- upload / download ----------------------------------------------------------------------------- */

static int up(sphdem_ctx c, void *dst, const void *src, size_t bytes) { return rt_h2d(&c->rt, dst, src, bytes); }
static int down(sphdem_ctx c, void *dst, const void *src, size_t bytes) { return rt_d2h(&c->rt, dst, src, bytes); }

/* Upload the per-particle state (drho, a, u) from the caller layout through staging; order[s] is the
 * caller index of device slot s (NULL = identity). state NULL means zero. */
static int upload_state(sphdem_ctx c, int64_t n, const int32_t *order, const double *state) {
  sphdem_dev *D = &c->D;
  double *h = c->hbuf;
  for (int64_t s = 0; s < n; s++) h[s] = state ? state[(order ? order[s] : s) * SPHDEM_NSTATE] : 0.0;
  TRY(up(c, D->drho, h, 8 * (size_t)n));
  for (int part = 0; part < 2; part++) {
    double *dst = part == 0 ? D->a : D->u;
    for (int64_t s = 0; s < n; s++)
      for (int d = 0; d < 3; d++)
        h[3 * s + d] = state ? state[(order ? order[s] : s) * SPHDEM_NSTATE + 1 + 3 * part + d] : 0.0;
    TRY(up(c, dst, h, 24 * (size_t)n));
  }
  return SPHDEM_OK;
}

static int upload_vec(sphdem_ctx c, double *dst, const double *src, int64_t n, int ncomp, const int32_t *order) {
  if (!order) return up(c, dst, src, 8 * (size_t)ncomp * (size_t)n);
  for (int64_t s = 0; s < n; s++)
    for (int d = 0; d < ncomp; d++) c->hbuf[ncomp * s + d] = src[(int64_t)order[s] * ncomp + d];
  return up(c, dst, c->hbuf, 8 * (size_t)ncomp * (size_t)n);
}

/* Device slot -> caller index for an upload whose tags equal the resident set; NULL if not equal. */
static int32_t *match_resident(sphdem_ctx c, int64_t n, const int64_t *tag) {
  int64_t maxtag = 0;
  for (int64_t i = 0; i < n; i++) {
    if (tag[i] <= 0) return NULL;
    if (tag[i] > maxtag) maxtag = tag[i];
  }
  if (maxtag > 8 * n + 1024) return NULL; /* sparse tags: rebuild instead of a huge map */
  if (maxtag + 1 > c->hmap_len) {
    free(c->hmap);
    c->hmap = (int64_t *)malloc(sizeof(int64_t) * (size_t)(maxtag + 1));
    c->hmap_len = c->hmap ? maxtag + 1 : 0;
    if (!c->hmap) return NULL;
  }
  for (int64_t t = 0; t <= maxtag; t++) c->hmap[t] = -1;
  for (int64_t i = 0; i < n; i++) {
    if (c->hmap[tag[i]] >= 0) return NULL;
    c->hmap[tag[i]] = i;
  }
  if (!c->host_tags_valid) {
    if (down(c, c->htag, c->D.tag, 8 * (size_t)n) != SPHDEM_OK) return NULL;
    c->host_tags_valid = 1;
  }
  for (int64_t s = 0; s < n; s++) {
    int64_t t = c->htag[s];
    if (t <= 0 || t > maxtag || c->hmap[t] < 0) return NULL;
    c->huidx[s] = (int32_t)c->hmap[t];
  }
  return c->huidx;
}

/* Positions are checked for finite values before they are binned; the index (and tag) of the first bad one. */
/* Precision single keeps positions in float: at |x| its spacing (ulp) is 2^(e - 23), |x| in [2^e, 2^(e+1)). Slow
 * particles then move in float steps (v dt ~ 0.2 (v / c0) dx at CFL 0.2): still water's bottom pressure is 0.1 %
 * off at a spacing of 5e-5 dx and 0.5 % at 1e-4 dx (verify_precision tank_scan), where single is refused. */
#define SPHDEM_SINGLE_ULP_MAX 1e-4

/* The float spacing at |x| (precision single). */
static double sphdem_float_ulp(double x) {
  float f = (float)fabs(x);
  return (double)(nextafterf(f, INFINITY) - f);
}

static int check_positions(sphdem_ctx c, const char *what, int64_t n, const int64_t *tag, const double *x) {
  double xmax = 0.0;
  for (int64_t i = 0; i < n; i++) {
    if (!isfinite(x[3 * i]) || !isfinite(x[3 * i + 1]) || !isfinite(x[3 * i + 2]))
      return sphdem_fail(c, SPHDEM_ERR_ARG, "%s: particle %lld (tag %lld) has a non-finite position (%g, %g, %g)",
                         what, (long long)i, (long long)(tag ? tag[i] : i + 1), x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    for (int d = 0; d < c->D.P.dim; d++) xmax = fmax(xmax, fabs(x[3 * i + d]));
  }
  if (c->D.P.precision == SPHDEM_PREC_SINGLE) {
    const double ulp = sphdem_float_ulp(xmax);
    if (ulp > SPHDEM_SINGLE_ULP_MAX * c->D.P.dx)
      return sphdem_fail(c, SPHDEM_ERR_ARG, "precision single: %s positions up to |x| = %g have a float spacing of "
                         "%.3g, %.2g dx (dx %g; the limit is %g dx, where still water's pressure is already 0.5 %% off: slow "
                         "particles move in float steps); use precision mixed (double positions) or put the origin "
                         "nearer the fluid",
                         !strcmp(what, "set_walls") ? "wall" : "fluid", xmax, ulp, ulp / c->D.P.dx, c->D.P.dx,
                         SPHDEM_SINGLE_ULP_MAX);
  }
  return SPHDEM_OK;
}

int sphdem_set_fluid(sphdem_ctx c, int n, const int64_t *tag, const double *x, const double *v,
                     const double *rho, const double *mass, const double *state) {
  if (!c) return SPHDEM_ERR_ARG;
  if (n < 0) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid: negative particle count");
  if (n > 0 && (!x || !v || !rho || !mass))
    return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid: x, v, rho and mass are required");
  c->D.iso.ok = 0;
  for (int64_t i = 0; i < n; i++) {
    if (!(mass[i] > 0) || !(rho[i] > 0))
      return sphdem_fail(c, SPHDEM_ERR_ARG, "set_fluid: particle %lld (tag %lld) has mass %g and density %g; "
                         "both must be > 0", (long long)i, (long long)(tag ? tag[i] : i + 1), mass[i], rho[i]);
  }
  TRY(check_positions(c, "set_fluid", n, tag, x));
  double t0 = rt_now();
  sphdem_dev *D = &c->D;
  TRY(ensure_host(c, n));
  int32_t *order = NULL;
  if (n > 0 && n == D->nf && tag) order = match_resident(c, n, tag);
  if (!order) {
    TRY(ensure_fluid(c, n));
    D->nf = n;
    if (n > 0) {
      for (int64_t i = 0; i < n; i++) { c->htag[i] = tag ? tag[i] : i + 1; c->huidx[i] = (int32_t)i; }
      TRY(up(c, D->tag, c->htag, 8 * (size_t)n));
      TRY(up(c, D->uidx, c->huidx, 4 * (size_t)n));
      c->host_tags_valid = 1;
    }
    for (const sphdem_feature *const *f = sphdem_features; *f; f++) /* arrays sized to the new set */
      if ((*f)->rebuilt) TRY((*f)->rebuilt(c, SPHDEM_SET_FLUID));
  } else {
    TRY(up(c, D->uidx, order, 4 * (size_t)n));
  }
  D->nown = n;
  sphdem_slots_changed(c, SPHDEM_SET_FLUID);
  c->xm[SPHDEM_SET_FLUID].nrows = -1; /* a new caller order: every owned row until sphdem_set_exchange_rows */
  if (n > 0) {
    TRY(upload_vec(c, D->x, x, n, 3, order));
    TRY(rt_d2d(&c->rt, D->xe, D->x, 24 * (size_t)n));
    /* a rebuilt fluid is sorted before its next pass; until then its moves are measured from here, not from
     * memory no sort has written */
    if (!order) TRY(rt_d2d(&c->rt, D->x0, D->x, 24 * (size_t)n));
    TRY(upload_vec(c, D->v, v, n, 3, order));
    TRY(upload_vec(c, D->rho, rho, n, 1, order));
    TRY(upload_vec(c, D->mass, mass, n, 1, order));
    TRY(upload_state(c, n, order, state));
  }
  c->have_rates = state != NULL;
  c->edisp2 = 0.0, c->edisp_ok = 1;
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  if (!order) {
    c->need_sort = 1;
  } else {
    /* data replaced in place: keep the order, but resort if positions moved beyond skin/2 */
    sphdem_red r;
    TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
    if (r.disp2max > 0.25 * D->P.skin * D->P.skin) c->need_sort = 1;
  }
  return SPHDEM_OK;
}

int sphdem_set_walls(sphdem_ctx c, int n, const double *x, const double *v, const double *a, const double *mass) {
  if (!c) return SPHDEM_ERR_ARG;
  if (n < 0) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_walls: negative particle count");
  if (n > 0 && (!x || !mass)) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_walls: x and mass are required");
  for (int64_t i = 0; i < n; i++)
    if (!(mass[i] > 0)) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_walls: wall particle %lld has mass %g; must be > 0",
                                           (long long)i, mass[i]);
  TRY(check_positions(c, "set_walls", n, NULL, x));
  double t0 = rt_now();
  sphdem_dev *D = &c->D;
  /* the same walls in the same order as at the last wall sort (same count and masses), each within skin/2 of its
   * position then (or all unmoved): the cells and lists of that sort still hold every pair within 2h, as the
   * fluid's do between its sorts (the fluid's own displacement counts from its sort: a sort of the moving walls
   * alone would not, so within skin/2 needs the walls' last sort to have been part of a fluid sort) */
  int same = n > 0 && n == c->wref_n && n == D->nw && !D->ghost.on && c->cap_hw >= n;
  double d2max = 0.0;
  for (int64_t i = 0; same && i < n; i++) {
    same = mass[i] == c->hwm0[i];
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) {
      const double e = x[3 * i + k] - c->hwx0[3 * i + k];
      d2 += e * e;
    }
    if (d2 > d2max) d2max = d2;
  }
  const int reuse = same && (d2max == 0.0 || (c->wref_synced && d2max <= 0.25 * D->P.skin * D->P.skin));
  if (n > c->cap_hw) {
    free(c->hwx0); free(c->hwm0); free(c->hwx1); free(c->hwm1);
    c->hwx0 = (double *)malloc(24 * (size_t)n); c->hwx1 = (double *)malloc(24 * (size_t)n);
    c->hwm0 = (double *)malloc(8 * (size_t)n); c->hwm1 = (double *)malloc(8 * (size_t)n);
    c->cap_hw = (c->hwx0 && c->hwx1 && c->hwm0 && c->hwm1) ? n : 0;
    c->wref_n = -1;
    if (!c->cap_hw) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate %lld host wall entries", (long long)n);
  }
  if (n > 0) {
    memcpy(c->hwx1, x, 24 * (size_t)n);
    memcpy(c->hwm1, mass, 8 * (size_t)n);
  }
  if (reuse) {
    D->nw = n;
    c->nwown = n;
    D->nwown = n;
    TRY(up(c, D->wx, x, 24 * (size_t)n));
    for (int part = 0; part < 2; part++) {
      const double *src = part == 0 ? v : a;
      double *dst = part == 0 ? D->wv : D->wa;
      if (src) TRY(up(c, dst, src, 24 * (size_t)n));
      else TRY(rt_zero(&c->rt, dst, 24 * (size_t)n));
    }
    int32_t *perm = c->perm; /* into the slots of the last sort (masses and tags are there already) */
    c->perm = c->wperm;
    int rc = SPHDEM_OK;
    double *arr[] = {D->wx, D->wv, D->wa};
    for (int k = 0; k < 3 && !rc; k++) rc = c->ops->gather(c, arr[k], 24, n);
    c->perm = perm;
    TRY(rc);
    c->nwall_reuse++;
    c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
    return SPHDEM_OK;
  }
  /* moved too far (or reordered) with the same count and masses: moving walls; their sort goes with a fluid sort,
   * so that the next uploads can keep it */
  if (same) c->need_sort = 1;
  c->walls_caller_order = 1;
  c->wref_n = -1;
  TRY(ensure_walls(c, n));
  TRY(ensure_host(c, n));
  D->nw = n;
  c->nwown = n;
  D->nwown = n;
  if (n > 0) {
    TRY(up(c, D->wx, x, 24 * (size_t)n));
    TRY(up(c, D->wmass, mass, 8 * (size_t)n));
    for (int part = 0; part < 2; part++) {
      const double *src = part == 0 ? v : a;
      double *dst = part == 0 ? D->wv : D->wa;
      if (src) TRY(up(c, dst, src, 24 * (size_t)n));
      else TRY(rt_zero(&c->rt, dst, 24 * (size_t)n));
    }
    for (int64_t i = 0; i < n; i++) c->htag[i] = i + 1;
    TRY(up(c, D->wtag, c->htag, 8 * (size_t)n));
    c->host_tags_valid = 0;
  }
  sphdem_slots_changed(c, SPHDEM_SET_WALL);
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  c->need_wall_sort = 1;
  for (const sphdem_feature *const *f = sphdem_features; *f; f++) /* ghost walls: Adami walls until set_wall_mirror */
    if ((*f)->rebuilt) TRY((*f)->rebuilt(c, SPHDEM_SET_WALL));
  return SPHDEM_OK;
}

/* The per-particle fluid arrays that travel between the device (sorted slots) and the caller's layout (upload
 * order): x, v, rho and the state columns drho, a (and with with_u the XSPH velocity u); host NULL = not asked. */
typedef struct { double *dev, *host; int ncomp, off, stride; } fluid_field;
static int fluid_fields(sphdem_dev *D, double *x, double *v, double *rho, double *state, int with_u,
                        fluid_field f[6]) {
  const fluid_field t[6] = {
    {D->x, x, 3, 0, 3}, {D->v, v, 3, 0, 3}, {D->rho, rho, 1, 0, 1},
    {D->drho, state, 1, 0, SPHDEM_NSTATE}, {D->a, state, 3, 1, SPHDEM_NSTATE}, {D->u, state, 3, 4, SPHDEM_NSTATE},
  };
  const int n = with_u ? 6 : 5;
  for (int k = 0; k < n; k++) f[k] = t[k];
  return n;
}

int sphdem_set_ghosts(sphdem_ctx c, int nghost, int nwghost) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (nghost > D->nf || nwghost > D->nw)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "set_ghosts: %d fluid and %d wall ghosts for %lld fluid and %lld wall "
                       "particles", nghost, nwghost, (long long)D->nf, (long long)D->nw);
  if (nghost >= 0) D->nown = D->nf - nghost;
  if (nwghost >= 0) c->nwown = D->nwown = D->nw - nwghost;
  return SPHDEM_OK;
}

/* The ghost slots get new values through the fluid's ghost map: only the ghosts' values cross to the device; the
 * owned entries are unchanged. */
int sphdem_update_ghosts(sphdem_ctx c, int nghost, const double *x, const double *v, const double *rho,
                         const double *state) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  const int64_t n = D->nf, n0 = D->nown;
  if (nghost != n - n0)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "update_ghosts: %d values for %lld ghost particles", nghost,
                       (long long)(n - n0));
  if (nghost == 0) return SPHDEM_OK;
  if (!x || !v || !rho) return sphdem_fail(c, SPHDEM_ERR_ARG, "update_ghosts: x, v and rho are required");
  TRY(check_positions(c, "update_ghosts", nghost, NULL, x));
  double t0 = rt_now();
  TRY(rt_sync(&c->rt));
  fluid_field f[6];
  const int nfld = fluid_fields(D, (double *)x, (double *)v, (double *)rho, (double *)state, 0, f); /* read only */
  for (int k = 0; k < nfld; k++)
    if (f[k].host) TRY(sphdem_scatter_ghosts(c, SPHDEM_SET_FLUID, f[k].dev, f[k].ncomp, f[k].host, f[k].stride, f[k].off));
  D->iso.ok = 0;
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  /* the ghosts moved (the owned particles were checked after their drift): resort when one went beyond skin/2 */
  double d2max = 0.0;
  if (c->backend == SPHDEM_DEVICE_CPU) { /* the ghost map is host memory here */
    const int32_t *gs = c->xm[SPHDEM_SET_FLUID].ghost_slot;
    for (int64_t g = 0; g < nghost; g++) {
      double r[3];
      const int64_t s = gs[g];
      const double *xs = D->x + 3 * s;
      const double d2 = isfinite(xs[0] + xs[1] + xs[2]) ? separation(D, xs, D->x0 + 3 * s, r) : 1e300;
      if (!(d2 <= d2max)) d2max = d2;
    }
  } else {
    sphdem_red r;
    TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
    d2max = r.disp2max;
  }
  if (!(d2max <= 0.25 * D->P.skin * D->P.skin)) c->need_sort = 1;
  return SPHDEM_OK;
}

/* Many ranks: the sent rows of the fields a step's ghosts take (x, v, rho, drho, a), through the fluid's row map. */
int sphdem_get_fluid_rows(sphdem_ctx c, double *x, double *v, double *rho, double *state) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (D->nf == 0) return SPHDEM_OK;
  const double t0 = rt_now();
  TRY(rt_sync(&c->rt));
  fluid_field f[6];
  const int nfld = fluid_fields(D, x, v, rho, state, 0, f);
  for (int k = 0; k < nfld; k++)
    if (f[k].host)
      TRY(sphdem_gather_owned_rows(c, SPHDEM_SET_FLUID, f[k].dev, f[k].ncomp, f[k].host, f[k].stride, f[k].off));
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  return SPHDEM_OK;
}

int sphdem_get_fluid(sphdem_ctx c, double *x, double *v, double *rho, double *p, double *state) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  int64_t n = D->nf;
  if (n == 0) return SPHDEM_OK;
  double t0 = rt_now();
  TRY(ensure_host(c, n));
  TRY(rt_sync(&c->rt));
  const int direct = c->backend == SPHDEM_DEVICE_CPU; /* the CPU's arrays are host memory: read in place */
  TRY(down(c, c->huidx, D->uidx, 4 * (size_t)n));
  const int32_t *ui = c->huidx;
  double *h = c->hbuf;
  fluid_field f[6];
  const int nfld = fluid_fields(D, x, v, rho, state, 1, f);
  for (int k = 0; k < nfld; k++) {
    if (!f[k].host) continue;
    const double *src = direct ? f[k].dev : h;
    if (!direct) TRY(down(c, h, f[k].dev, 8 * (size_t)f[k].ncomp * (size_t)n));
    for (int64_t s = 0; s < n; s++)
      for (int d = 0; d < f[k].ncomp; d++) f[k].host[(int64_t)ui[s] * f[k].stride + f[k].off + d] = src[f[k].ncomp * s + d];
  }
  if (p) {
    TRY(down(c, h, D->rho, 8 * (size_t)n));
    int done = 0; /* a feature's EOS (coupling: superficial density; delta-plus: per phase), else Tait */
    for (const sphdem_feature *const *f = sphdem_features; *f && !done; f++)
      if ((*f)->host_pressure) TRY((*f)->host_pressure(c, n, h, ui, p, &done));
    if (!done)
      for (int64_t s = 0; s < n; s++) p[ui[s]] = tait_pressure(D, h[s]);
  }
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  return SPHDEM_OK;
}

/* ---- stepping ---------------------------------------------------------------------------------------- */

/* The hooks of the active features at one point of a rate evaluation (sph_internal.h, sphdem_feature); the time
 * of a hook with its own timer goes there and into *tx. */
enum { HOOK_PREPARE, HOOK_PREPARE_RATES, HOOK_FINISH };
static int feature_hooks(struct sphdem_ctx_s *c, int which, double *tx) {
  for (const sphdem_feature *const *f = sphdem_features; *f; f++) {
    int (*h)(struct sphdem_ctx_s *) = which == HOOK_PREPARE         ? (*f)->prepare
                                      : which == HOOK_PREPARE_RATES ? (*f)->prepare_rates
                                                                    : (*f)->finish;
    if (!h || !(*f)->on(c)) continue;
    double t = rt_now();
    const double x0 = c->xtime; /* a hook's exchanges are booked as transfer, not in its own timer */
    TRY(h(c));
    const double dx = c->xtime - x0;
    t = rt_now() - t;
    if ((*f)->timer != SPHDEM_T_RATES) {
      c->timers[(*f)->timer] += t - dx;
      *tx += t;
    } else {
      *tx += dx;
    }
  }
  return SPHDEM_OK;
}

int sphdem_compute_rates(sphdem_ctx c) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  /* no fluid on this rank (many ranks): nothing to evaluate, but every hook and exchange still runs, since the
   * features and the exchanges take part in collective calls (delta-plus: the shifting speed; coupling: the
   * ghosts' porosity and forces; zero grain forces here) */
  const int empty = D->nf == 0;
  if (!empty && c->need_sort) TRY(sort_all(c));
  else if (!empty && c->need_wall_sort && D->nw > 0) {
    double t0 = rt_now();
    TRY(sort_set(c, SPHDEM_SET_WALL));
    TRY(rt_sync(&c->rt));
    c->timers[SPHDEM_T_SORT] += rt_now() - t0;
    c->need_wall_sort = 0;
  }
  if (!c->half_kicked) c->D.pred_dth = 0.0;
  double t0 = rt_now(), tx = 0.0; /* tx: time the features booked on their own timers */
  /* coupling: grain sort and porosity before the EOS; keyword isolated: the kernel sums */
  TRY(feature_hooks(c, HOOK_PREPARE, &tx));
  if (!empty) { TRY(c->ops->pressure(c)); TRY(rt_sync(&c->rt)); }
  double t1 = rt_now();
  /* many ranks, plain fluid: each rank the state of its own walls, the ghost walls' from their owners */
  D->xwall = D->xown && !D->ghost.on && !D->mp.on;
  if (!empty && D->nw > 0) { TRY(c->ops->wall_state(c)); TRY(rt_sync(&c->rt)); }
  double tw = rt_now();
  if (D->xwall) TRY(sphdem_exchange_walls(c));
  const double twx = rt_now() - tw; /* booked as transfer */
  double t2 = rt_now();
  TRY(feature_hooks(c, HOOK_PREPARE_RATES, &tx)); /* delta-plus: renormalisation, viscosity, shifting */
  if (!empty) { TRY(c->ops->rates(c)); TRY(rt_sync(&c->rt)); }
  double tq = rt_now();
  TRY(sphdem_exchange_fluid(c, SPHDEM_XCHG_RATES)); /* many ranks: the ghosts' rates from their owners */
  tx += rt_now() - tq;                              /* booked as transfer */
  TRY(feature_hooks(c, HOOK_FINISH, &tx)); /* coupling: grain forces, reaction on the fluid */
  double t3 = rt_now();
  c->timers[SPHDEM_T_WALL] += t2 - t1 - twx;
  c->timers[SPHDEM_T_RATES] += (t1 - t0) + (t3 - t2) - tx;
  c->have_rates = 1;
  return SPHDEM_OK;
}

/* Messages: the precision (6 to 17 digits) at which %g prints a and b differently, so "dt A exceeds B" never
 * shows two equal numbers; x rounded down to 3 digits, a suggested step that passes the check as printed. */
static int digits_apart(double a, double b) {
  char sa[40], sb[40];
  for (int p = 6; p < 17; p++) {
    snprintf(sa, sizeof sa, "%.*g", p, a);
    snprintf(sb, sizeof sb, "%.*g", p, b);
    if (strcmp(sa, sb) != 0) return p;
  }
  return 17;
}

static double round_down3(double x) {
  if (!(x > 0) || !isfinite(x)) return x;
  const double scale = pow(10.0, floor(log10(x)) - 2.0);
  double r = floor(x / scale) * scale;
  while (r > x) r -= scale;
  return r;
}

int sphdem_stats_get(sphdem_ctx c, double dt, sphdem_stats *s) {
  if (!c || !s) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  memset(s, 0, sizeof *s);
  sphdem_red r;
  if (D->nf > 0) TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
  else red_init(&r);
  /* many ranks: the owned particles of every rank (collective) */
  double gmax[4] = {r.v2max, r.a2max, r.rhoerr, r.numax};
  double gsum[5] = {r.ke, (double)r.nnan, (double)r.nlost, (double)D->nown, (double)c->nwown};
  if (rt_nranks(&c->rt) > 1) {
    TRY(sphdem_rt_allreduce(&c->rt, gmax, 4, SPHDEM_RED_MAX));
    TRY(sphdem_rt_allreduce(&c->rt, gsum, 5, SPHDEM_RED_SUM));
  }
  r.v2max = gmax[0]; r.a2max = gmax[1]; r.rhoerr = gmax[2]; r.numax = gmax[3];
  r.ke = gsum[0]; r.nnan = (int64_t)gsum[1]; r.nlost = (int64_t)gsum[2];
  s->nfluid = (int64_t)gsum[3];
  s->nwall = (int64_t)gsum[4];
  const sphdem_params *P = &D->P;
  s->vmax = sqrt(r.v2max);
  s->amax = sqrt(r.a2max);
  s->rho_err = r.rhoerr;
  s->ke = r.ke;
  s->nnan = r.nnan;
  s->nlost = r.nlost;
  s->dt_cfl = P->cfl * P->h / (D->cmax + s->vmax); /* the largest sound speed (multiphase: of any phase) */
  s->dt_visc = P->visc == SPHDEM_VISC_MORRIS ? 0.125 * P->h * P->h * P->rho0 / P->mu : DBL_MAX;
  /* multiphase: Shi & Huang eq 34 with the largest mu_i / rho_i of the last rate evaluation */
  if (D->mp.on) s->dt_visc = r.numax > 0 ? D->mp.M.alpha_visc * P->h * P->h / r.numax : DBL_MAX;
  s->dt_force = s->amax > 0 ? 0.25 * sqrt(P->h / s->amax) : DBL_MAX;
  s->dt_stable = fmin(s->dt_cfl, fmin(s->dt_visc, s->dt_force));
  /* after a blow-up the stable step of the wrecked state is no guide: say so instead of "stable 0 s" */
  char stable_txt[96];
  if (s->dt_stable > 0 && isfinite(s->dt_stable)) snprintf(stable_txt, sizeof stable_txt, "stable %g s", s->dt_stable);
  else snprintf(stable_txt, sizeof stable_txt, "no stable step of this state: its velocities or accelerations are not finite");
  if (r.nnan > 0)
    return sphdem_fail(c, SPHDEM_ERR_NAN,
                       "%lld fluid particles have a non-finite position, velocity or density: the simulation "
                       "blew up. Likely causes: a time step too large (%s), too few wall layers or no "
                       "repulsion letting particles enter walls, or h/dx too small.",
                       (long long)r.nnan, stable_txt);
  if (r.nlost > 0)
    return sphdem_fail(c, SPHDEM_ERR_LOST,
                       "%lld fluid particles left the box. Likely causes: walls missing or thinner than the "
                       "kernel support 2h (%g), no wall repulsion for a violent impact, or a time step too large "
                       "(%s).", (long long)r.nlost, 2.0 * P->h, stable_txt);
  if (r.rhoerr > P->rho_err_max)
    return sphdem_fail(c, SPHDEM_ERR_DENSITY,
                       "max |rho/rho0 - 1| = %.3g exceeds rho_err_max %.3g. Likely causes: c0 too low: the "
                       "compression scales as 1/c0^2, so c0 %g would need about %.3g to stay below rho_err_max "
                       "(vmax %.3g m/s, Mach vmax/c0 %.3g, should stay below 0.1; a slow fluid this compressed "
                       "holds a static pressure, e.g. hydrostatic, which needs c0 >= 10 sqrt(g H)); a time step "
                       "too large (stable %g s); or tensile clumping (try the tensile keyword).",
                       r.rhoerr, P->rho_err_max, P->c0, P->c0 * sqrt(r.rhoerr / P->rho_err_max), s->vmax,
                       s->vmax / P->c0, s->dt_stable);
  if (dt > 0 && dt > s->dt_stable) {
    const char *lim = s->dt_stable == s->dt_cfl ? (D->mp.on ? "the CFL condition cfl*h/(c0 + vmax) with the largest phase sound speed" : "the CFL condition cfl*h/(c0 + vmax)")
                      : s->dt_stable == s->dt_visc ? "the viscous condition 0.125 h^2 rho0/mu"
                                                   : "the force condition 0.25 sqrt(h/amax)";
    if (D->mp.on && s->dt_stable == s->dt_visc) lim = "the viscous condition alpha_visc h^2 min(rho_i/mu_i) (eq 34)";
    return sphdem_fail(c, SPHDEM_ERR_UNSTABLE,
                       "time step %.*g s exceeds the stable SPH time step %.*g s, limited by %s (CFL %g s, "
                       "viscous %g s, force %g s; vmax %g m/s, amax %g m/s^2). Set the timestep to %g or less.",
                       digits_apart(dt, s->dt_stable), dt, digits_apart(dt, s->dt_stable), s->dt_stable, lim,
                       s->dt_cfl, s->dt_visc == DBL_MAX ? INFINITY : s->dt_visc,
                       s->dt_force == DBL_MAX ? INFINITY : s->dt_force, s->vmax, s->amax, round_down3(s->dt_stable));
  }
  return SPHDEM_OK;
}

int sphdem_probe(sphdem_ctx c, int npts, const double *pts, double *out) {
  if (!c) return SPHDEM_ERR_ARG;
  if (npts < 0 || (npts > 0 && (!pts || !out))) return sphdem_fail(c, SPHDEM_ERR_ARG, "probe: bad point list");
  if (npts == 0) return SPHDEM_OK;
  for (int i = 0; i < npts; i++)
    if (!isfinite(pts[3 * i]) || !isfinite(pts[3 * i + 1]) || !isfinite(pts[3 * i + 2]))
      return sphdem_fail(c, SPHDEM_ERR_ARG, "probe: point %d (%g, %g, %g) is not finite", i, pts[3 * i],
                         pts[3 * i + 1], pts[3 * i + 2]);
  sphdem_dev *D = &c->D;
  if (D->nf == 0) { memset(out, 0, sizeof(double) * SPHDEM_NPROBE * (size_t)npts); return SPHDEM_OK; }
  if (c->need_sort) TRY(sort_all(c));
  double *dp = NULL, *dout = NULL;
  size_t bp = 24 * (size_t)npts, bo = 8 * SPHDEM_NPROBE * (size_t)npts;
  int rc = sphdem_dalloc(c, (void **)&dp, bp);
  if (!rc) rc = sphdem_dalloc(c, (void **)&dout, bo);
  if (!rc) rc = up(c, dp, pts, bp);
  if (!rc) rc = c->ops->probe(c, npts, dp, dout);
  if (!rc) rc = rt_sync(&c->rt);
  if (!rc) rc = down(c, out, dout, bo);
  DFREE(c, dp, bp);
  DFREE(c, dout, bo);
  return rc;
}

/* ---- testing hook ---------------------------------------------------------------------------------- */

int64_t sphdem_debug_pairs(sphdem_ctx c, int64_t *pairs, int64_t maxpairs) {
  if (!c) return -SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  int64_t n = D->nf, np = 0;
  if (n == 0) return 0;
  if (c->need_sort) { int rc = sort_all(c); if (rc) return -rc; }
  /* host copy of positions, cells and cell ranges, then the same neighbor-cell walk as the passes */
  sphdem_dev H = *D;
  H.x = (double *)malloc(24 * (size_t)n);
  H.cell = (int32_t *)malloc(4 * (size_t)n);
  H.cstart = (int32_t *)malloc(4 * (size_t)D->ncells);
  H.cend = (int32_t *)malloc(4 * (size_t)D->ncells);
  int32_t *ui = (int32_t *)malloc(4 * (size_t)n);
  int rc = (H.x && H.cell && H.cstart && H.cend && ui) ? SPHDEM_OK : SPHDEM_ERR_ALLOC;
  if (!rc) rc = down(c, H.x, D->x, 24 * (size_t)n);
  if (!rc) rc = down(c, H.cell, D->cell, 4 * (size_t)n);
  if (!rc) rc = down(c, H.cstart, D->cstart, 4 * (size_t)D->ncells);
  if (!rc) rc = down(c, H.cend, D->cend, 4 * (size_t)D->ncells);
  if (!rc) rc = down(c, ui, D->uidx, 4 * (size_t)n);
  for (int64_t a = 0; !rc && a < n; a++) {
    int32_t cells[27];
    double r[3];
    int nn = neighbor_cells(&H, H.cell[a], cells);
    for (int k = 0; k < nn; k++)
      for (int32_t b = H.cstart[cells[k]]; b < H.cend[cells[k]]; b++) {
        if (ui[b] <= ui[a]) continue;
        if (separation(&H, H.x + 3 * a, H.x + 3 * b, r) >= H.support2) continue;
        if (np < maxpairs) { pairs[2 * np] = ui[a]; pairs[2 * np + 1] = ui[b]; }
        np++;
      }
  }
  free(H.x); free(H.cell); free(H.cstart); free(H.cend); free(ui);
  return rc ? -rc : np;
}

/* ---- set-up check: particles on top of each other ---------------------------------------------------- */

/* Fluid pairs and fluid-wall pairs closer than rmin, by the same cell walk as the passes (host copies of
 * the sorted positions; set-up only). out: [0] fluid pairs, [1] fluid-wall pairs, then the closest pair of
 * each kind: [2], [3] the fluid tags (lower first) and [4] their distance; [5] the fluid tag, [6] the wall's
 * caller index and [7] their distance (-1 where there is none). */
int sphdem_check_spacing(sphdem_ctx c, double rmin, double out[8]) {
  if (!c || !out) return SPHDEM_ERR_ARG;
  for (int k = 0; k < 8; k++) out[k] = k < 2 ? 0.0 : -1.0;
  sphdem_dev *D = &c->D;
  const int64_t n = D->nf, nw = D->nw;
  if (n == 0 || !(rmin > 0)) return SPHDEM_OK;
  if (c->need_sort) TRY(sort_all(c));
  else if (c->need_wall_sort && nw > 0) {
    TRY(sort_set(c, SPHDEM_SET_WALL));
    TRY(rt_sync(&c->rt));
    c->need_wall_sort = 0;
  }
  sphdem_dev H = *D;
  const size_t nc = (size_t)D->ncells;
  H.x = (double *)malloc(24 * (size_t)n);
  H.cell = (int32_t *)malloc(4 * (size_t)n);
  H.tag = (int64_t *)malloc(8 * (size_t)n);
  H.cstart = (int32_t *)malloc(4 * nc);
  H.cend = (int32_t *)malloc(4 * nc);
  H.wx = nw ? (double *)malloc(24 * (size_t)nw) : NULL;
  H.wtag = nw ? (int64_t *)malloc(8 * (size_t)nw) : NULL;
  H.wcstart = nw ? (int32_t *)malloc(4 * nc) : NULL;
  H.wcend = nw ? (int32_t *)malloc(4 * nc) : NULL;
  int rc = (H.x && H.cell && H.tag && H.cstart && H.cend && (!nw || (H.wx && H.wtag && H.wcstart && H.wcend)))
               ? SPHDEM_OK
               : sphdem_fail(c, SPHDEM_ERR_ALLOC, "check_spacing: cannot allocate host copies of %lld particles",
                             (long long)(n + nw));
  if (!rc) rc = down(c, H.x, D->x, 24 * (size_t)n);
  if (!rc) rc = down(c, H.cell, D->cell, 4 * (size_t)n);
  if (!rc) rc = down(c, H.tag, D->tag, 8 * (size_t)n);
  if (!rc) rc = down(c, H.cstart, D->cstart, 4 * nc);
  if (!rc) rc = down(c, H.cend, D->cend, 4 * nc);
  if (!rc && nw) rc = down(c, H.wx, D->wx, 24 * (size_t)nw);
  if (!rc && nw) rc = down(c, H.wtag, D->wtag, 8 * (size_t)nw);
  if (!rc && nw) rc = down(c, H.wcstart, D->wcstart, 4 * nc);
  if (!rc && nw) rc = down(c, H.wcend, D->wcend, 4 * nc);
  const double r2min = rmin * rmin;
  double best_f = INFINITY, best_w = INFINITY;
  for (int64_t a = 0; !rc && a < n; a++) {
    int32_t cells[27];
    double r[3];
    if (H.cell[a] < 0 || H.cell[a] >= D->ncells) continue; /* outside the grid: not a spacing question */
    int nn = neighbor_cells(&H, H.cell[a], cells);
    for (int k = 0; k < nn; k++) {
      for (int32_t b = H.cstart[cells[k]]; b < H.cend[cells[k]]; b++) {
        if (H.tag[b] <= H.tag[a]) continue;
        double d2 = separation(&H, H.x + 3 * a, H.x + 3 * b, r);
        if (!(d2 < r2min)) continue;
        out[0] += 1.0;
        if (d2 < best_f) { best_f = d2; out[2] = (double)H.tag[a]; out[3] = (double)H.tag[b]; out[4] = sqrt(d2); }
      }
      if (!nw) continue;
      for (int32_t w = H.wcstart[cells[k]]; w < H.wcend[cells[k]]; w++) {
        double d2 = separation(&H, H.x + 3 * a, H.wx + 3 * w, r);
        if (!(d2 < r2min)) continue;
        out[1] += 1.0;
        if (d2 < best_w) { best_w = d2; out[5] = (double)H.tag[a]; out[6] = (double)(H.wtag[w] - 1); out[7] = sqrt(d2); }
      }
    }
  }
  free(H.x); free(H.cell); free(H.tag); free(H.cstart); free(H.cend);
  free(H.wx); free(H.wtag); free(H.wcstart); free(H.wcend);
  return rc;
}

/* Wall pressure and density of the last rate evaluation in the order of the last sphdem_set_walls (for the
 * failure dump; either pointer may be NULL). */
int sphdem_get_wall_state(sphdem_ctx c, double *p, double *rho) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  const int64_t n = D->nw;
  if (n == 0 || (!p && !rho)) return SPHDEM_OK;
  if (!D->wp || !D->wrho) return sphdem_fail(c, SPHDEM_ERR_STATE, "get_wall_state: no wall state yet");
  double *h = (double *)malloc(8 * (size_t)n);
  int64_t *t = (int64_t *)malloc(8 * (size_t)n);
  int rc = h && t ? SPHDEM_OK : sphdem_fail(c, SPHDEM_ERR_ALLOC, "get_wall_state: cannot allocate %lld values",
                                            (long long)n);
  if (!rc) rc = rt_sync(&c->rt);
  if (!rc) rc = down(c, t, D->wtag, 8 * (size_t)n);
  for (int k = 0; !rc && k < 2; k++) {
    double *dst = k == 0 ? p : rho;
    if (!dst) continue;
    rc = down(c, h, k == 0 ? D->wp : D->wrho, 8 * (size_t)n);
    for (int64_t s = 0; !rc && s < n; s++)
      if (t[s] >= 1 && t[s] <= n) dst[t[s] - 1] = h[s];
  }
  free(h);
  free(t);
  return rc;
}

int sphdem_set_comm(sphdem_ctx c, const sphdem_comm *comm) {
  if (!c) return SPHDEM_ERR_ARG;
  if (comm) c->rt.comm = *comm;
  else memset(&c->rt.comm, 0, sizeof c->rt.comm);
  return SPHDEM_OK;
}
