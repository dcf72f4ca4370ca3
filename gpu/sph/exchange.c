/* exchange.c - many MPI ranks: the owners' values handed to their ghost copies in the middle of a rate
 * evaluation (sphdem_set_exchange): the fluid's rates, porosity and acceleration, the plain fluid's wall state.
 * Each rank then evaluates its owned particles only. Only the boundary slice moves between the device and the
 * host: the owned rows the engine sends (sphdem_set_exchange_rows) are gathered on the device, the ghosts' values
 * scattered into their cell-sorted slots, through slot maps made again after each sort; the same maps serve the
 * ghosts' updates between steps (sphdem_update_ghosts) and the per-step download of the sent rows
 * (sphdem_get_fluid_rows). The coupled grains' forces go the same way (couple.c): every owned grain, the ghosts. */
#include <stdlib.h>
#include <string.h>

#include "sph_internal.h"

#define TRY(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)

int sphdem_set_exchange(sphdem_ctx c, sphdem_exchange_fn fn, void *user) {
  if (!c) return SPHDEM_ERR_ARG;
  c->xfn = fn;
  c->xuser = user;
  c->D.xown = fn != NULL;
  return SPHDEM_OK;
}

double *sphdem_xbuf(struct sphdem_ctx_s *c, int64_t n) {
  if (n > c->xbuf_cap) {
    free(c->xbuf);
    c->xbuf_cap = n + n / 4 + 16;
    c->xbuf = (double *)malloc(sizeof(double) * (size_t)c->xbuf_cap);
    if (!c->xbuf) c->xbuf_cap = 0;
  }
  return c->xbuf;
}

/* ---- the slot maps of the owned rows and of the ghosts ---------------------------------------------------- */

int sphdem_set_exchange_rows(sphdem_ctx c, int set, int n, const int *rows) {
  if (!c) return SPHDEM_ERR_ARG;
  if (set != SPHDEM_SET_FLUID && set != SPHDEM_SET_WALL)
    return sphdem_fail(c, SPHDEM_ERR_ARG, "set_exchange_rows: set must be 0 (fluid) or 1 (walls), got %d", set);
  struct sphdem_xmap *m = &c->xm[set];
  m->valid = 0;
  if (n < 0) { m->nrows = -1; return SPHDEM_OK; }
  if (n > 0 && !rows) return sphdem_fail(c, SPHDEM_ERR_ARG, "set_exchange_rows: %d rows and no row array", n);
  if (n > m->cap_rows) {
    int32_t *r = (int32_t *)realloc(m->rows, sizeof(int32_t) * (size_t)n);
    if (!r) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "set_exchange_rows: cannot allocate %d rows", n);
    m->rows = r, m->cap_rows = n;
  }
  const int64_t n0 = set == SPHDEM_SET_FLUID ? c->D.nown : c->nwown;
  for (int r = 0; r < n; r++) {
    if (rows[r] < 0 || rows[r] >= n0)
      return sphdem_fail(c, SPHDEM_ERR_ARG, "set_exchange_rows: row %d is %d, outside the %lld owned %s particles", r,
                         rows[r], (long long)n0, set == SPHDEM_SET_FLUID ? "fluid" : "wall");
    m->rows[r] = rows[r];
  }
  m->nrows = n;
  return SPHDEM_OK;
}

/* Grow a device array of int32 or double to hold n entries (counted in rt->bytes). */
static int grow_dev(sphdem_ctx c, void **p, int64_t *cap, int64_t n, size_t eb) {
  if (n <= *cap && *p) return SPHDEM_OK;
  rt_free(&c->rt, p, eb * (size_t)*cap);
  *cap = 0;
  const int64_t m = n + n / 4 + 16;
  TRY(rt_alloc(&c->rt, p, eb * (size_t)m));
  *cap = m;
  return SPHDEM_OK;
}

void sphdem_free_xmaps(sphdem_ctx c) {
  for (int set = 0; set < 3; set++) {
    struct sphdem_xmap *m = &c->xm[set];
    free(m->rows);
    m->rows = NULL, m->cap_rows = 0;
    rt_free(&c->rt, (void **)&m->row_slot, 4 * (size_t)m->cap_row_slot);
    rt_free(&c->rt, (void **)&m->ghost_slot, 4 * (size_t)m->cap_ghost_slot);
    m->cap_row_slot = m->cap_ghost_slot = 0;
    m->valid = 0;
  }
  free(c->xinv);
  c->xinv = NULL, c->xinv_cap = 0;
  free(c->xio);
  c->xio = NULL, c->xio_cap = 0;
  rt_free(&c->rt, (void **)&c->xstage, 8 * (size_t)c->xstage_cap);
  c->xstage_cap = 0;
}

/* A set's slots (n) and owned ones (n0), and its slot -> caller index (uidx, or a tag array: tag - 1). */
static void set_counts(sphdem_ctx c, int set, int64_t *n, int64_t *n0, const int64_t **tag) {
  sphdem_dev *D = &c->D;
  *tag = NULL;
  if (set == SPHDEM_SET_FLUID) *n = D->nf, *n0 = D->nown;
  else if (set == SPHDEM_SET_WALL) *n = D->nw, *n0 = D->nwown, *tag = D->wtag;
  else *n = D->couple.ng, *n0 = c->couple.ngown < *n ? c->couple.ngown : *n, *tag = D->couple.gtag;
}

static const char *set_name(int set) { return set == SPHDEM_SET_FLUID ? "fluid" : set == SPHDEM_SET_WALL ? "wall" : "grain"; }

/* The set's maps on the device: the slot of each owned row (of sphdem_set_exchange_rows, or every owned one) and of
 * each ghost (caller index n0 + g), made again after the slots, the count or the owned count changed. */
static int xmap_ready(sphdem_ctx c, int set, struct sphdem_xmap **out) {
  sphdem_dev *D = &c->D;
  struct sphdem_xmap *m = &c->xm[set];
  *out = m;
  const int fluid = set == SPHDEM_SET_FLUID;
  int64_t n, n0;
  const int64_t *tag_dev;
  set_counts(c, set, &n, &n0, &tag_dev);
  const int64_t ng = n - n0;
  if (m->valid && m->gen == c->slot_gen[set] && m->n == n && m->n0 == n0) return SPHDEM_OK;
  const int64_t nr = m->nrows < 0 ? n0 : m->nrows;
  if (m->nrows > n0)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: %lld rows set for %lld owned %s particles",
                       (long long)m->nrows, (long long)n0, set_name(set));
  const int64_t need = 2 * n + nr + 1;
  if (need > c->xinv_cap) {
    free(c->xinv);
    c->xinv = (int32_t *)malloc(sizeof(int32_t) * (size_t)need);
    c->xinv_cap = c->xinv ? need : 0;
    if (!c->xinv) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld map entries", (long long)need);
  }
  int32_t *inv = c->xinv, *caller = inv + n, *rs = caller + n; /* caller index -> slot; slot -> caller; row slots */
  const int direct = c->backend == SPHDEM_DEVICE_CPU;
  if (n > 0) {
    TRY(rt_sync(&c->rt));
    if (fluid) {
      if (direct) memcpy(caller, D->uidx, 4 * (size_t)n);
      else TRY(rt_d2h(&c->rt, caller, D->uidx, 4 * (size_t)n));
    } else {
      const int64_t *wt = tag_dev;
      if (!direct) {
        int64_t *h = (int64_t *)sphdem_xbuf(c, n);
        if (!h) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld host values", (long long)n);
        TRY(rt_d2h(&c->rt, h, tag_dev, 8 * (size_t)n));
        wt = h;
      }
      for (int64_t s = 0; s < n; s++) caller[s] = (int32_t)(wt[s] - 1);
    }
  }
  for (int64_t i = 0; i < n; i++) inv[i] = -1;
  for (int64_t s = 0; s < n; s++) {
    if (caller[s] < 0 || caller[s] >= n || inv[caller[s]] >= 0)
      return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: slot %lld holds caller index %d of %lld", (long long)s,
                         caller[s], (long long)n);
    inv[caller[s]] = (int32_t)s;
  }
  for (int64_t r = 0; r < nr; r++) rs[r] = inv[m->nrows < 0 ? r : m->rows[r]];
  TRY(grow_dev(c, (void **)&m->row_slot, &m->cap_row_slot, nr, 4));
  TRY(grow_dev(c, (void **)&m->ghost_slot, &m->cap_ghost_slot, ng, 4));
  TRY(rt_h2d(&c->rt, m->row_slot, rs, 4 * (size_t)nr));
  TRY(rt_h2d(&c->rt, m->ghost_slot, inv + n0, 4 * (size_t)ng));
  m->nmapped_rows = nr;
  m->n = n, m->n0 = n0, m->gen = c->slot_gen[set], m->valid = 1;
  return SPHDEM_OK;
}

/* Device staging of n doubles. */
static double *xstage(sphdem_ctx c, int64_t n) {
  if (grow_dev(c, (void **)&c->xstage, &c->xstage_cap, n, 8) != SPHDEM_OK) return NULL;
  return c->xstage;
}

/* The rows' values of the device array dev (ncomp per slot) into host (row r's at host[stride rows[r] + off ..];
 * rows NULL: row r is caller index r). */
static int gather_rows(sphdem_ctx c, const struct sphdem_xmap *m, const double *dev, int ncomp, double *host,
                       int stride, int off) {
  const int64_t nr = m->nmapped_rows;
  if (nr == 0) return SPHDEM_OK;
  double *st = xstage(c, nr * ncomp), *h = sphdem_xbuf(c, nr * ncomp);
  if (!st || !h) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld staging values", (long long)nr);
  TRY(rt_gather(&c->rt, st, dev, m->row_slot, nr, ncomp));
  TRY(rt_d2h(&c->rt, h, st, 8 * (size_t)nr * (size_t)ncomp));
  for (int64_t r = 0; r < nr; r++) {
    const int64_t i = m->nrows < 0 ? r : m->rows[r];
    for (int d = 0; d < ncomp; d++) host[stride * i + off + d] = h[ncomp * r + d];
  }
  return SPHDEM_OK;
}

int sphdem_gather_owned_rows(sphdem_ctx c, int set, const double *dev, int ncomp, double *host, int stride, int off) {
  struct sphdem_xmap *m;
  TRY(xmap_ready(c, set, &m));
  return gather_rows(c, m, dev, ncomp, host, stride, off);
}

int sphdem_scatter_ghosts(sphdem_ctx c, int set, double *dev, int ncomp, const double *vals, int stride, int off) {
  struct sphdem_xmap *m;
  TRY(xmap_ready(c, set, &m));
  const int64_t ng = m->n - m->n0;
  if (ng == 0) return SPHDEM_OK;
  double *st = xstage(c, ng * ncomp), *h = sphdem_xbuf(c, ng * ncomp);
  if (!st || !h) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld staging values", (long long)ng);
  for (int64_t g = 0; g < ng; g++)
    for (int d = 0; d < ncomp; d++) h[ncomp * g + d] = vals[stride * g + off + d];
  TRY(rt_h2d(&c->rt, st, h, 8 * (size_t)ng * (size_t)ncomp));
  return rt_scatter(&c->rt, dev, st, m->ghost_slot, ng, ncomp);
}

/* The exchange of a set's device arrays arr[0..narr) (nc[k] values per slot): the owned rows' values
 * (sphdem_set_exchange_rows; every owned one by default) to fn in caller order, the ghosts' values back into their
 * slots. Only these rows and the ghosts cross between device and host. Collective: every rank calls it at the same
 * points, with or without particles. */
int sphdem_exchange_set(sphdem_ctx c, int what, int set, double *const *arr, const int *nc, int narr,
                        const char *what_name) {
  int64_t n, n0;
  const int64_t *tag_dev;
  set_counts(c, set, &n, &n0, &tag_dev);
  const int64_t ng = n - n0;
  int ncomp = 0;
  for (int k = 0; k < narr; k++) ncomp += nc[k];
  const double t0 = rt_now(); /* the whole exchange, the shim's communication included, is transfer time */
  struct sphdem_xmap *m = &c->xm[set];
  if (n > 0) {
    TRY(xmap_ready(c, set, &m));
    TRY(rt_sync(&c->rt));
  }
  /* own and ghost live past the staging that gather_rows and sphdem_scatter_ghosts take from sphdem_xbuf */
  const size_t want = (size_t)ncomp * (size_t)n + 1;
  if (want > c->xio_cap) {
    free(c->xio);
    c->xio = (double *)malloc(sizeof(double) * want);
    c->xio_cap = c->xio ? want : 0;
    if (!c->xio) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld host values", (long long)n);
  }
  double *own = c->xio, *ghost = own + (size_t)ncomp * (size_t)n0;
  if (n > 0)
    for (int k = 0, off = 0; k < narr; off += nc[k], k++) TRY(gather_rows(c, m, arr[k], nc[k], own, ncomp, off));
  if (c->xfn(c->xuser, what, ncomp, (int)n0, (int)ng, own, ghost) != 0)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: the owners' %s did not reach the ghosts", what_name);
  if (ng > 0)
    for (int k = 0, off = 0; k < narr; off += nc[k], k++)
      TRY(sphdem_scatter_ghosts(c, set, arr[k], nc[k], ghost, ncomp, off));
  const double dt = rt_now() - t0;
  c->timers[SPHDEM_T_TRANSFER] += dt;
  c->xtime += dt;
  return SPHDEM_OK;
}

/* Many ranks, plain fluid with Adami walls: the owned walls' state (pressure, density, extrapolated velocity,
 * porosity when coupled with superficial density) to the ghost walls. Collective. */
int sphdem_exchange_walls(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  double *const arr[4] = {D->wp, D->wrho, D->wvx, D->couple.wall_porosity};
  const int nc[4] = {1, 1, 3, 1};
  return sphdem_exchange_set(c, SPHDEM_XCHG_WALL, SPHDEM_SET_WALL, arr, nc, D->couple.wall_porosity ? 4 : 3, "wall state");
}

/* The fluid's fields: drho and a after the rate pass, the porosity after the coupling's porosity pass, a after
 * its reaction. */
int sphdem_exchange_fluid(struct sphdem_ctx_s *c, int what) {
  if (!c->xfn) return SPHDEM_OK;
  sphdem_dev *D = &c->D;
  double *arr[3] = {NULL, NULL, NULL};
  int nc[3] = {0, 0, 0}, narr = 1;
  switch (what) {
    case SPHDEM_XCHG_RATES: /* Runge-Kutta stages move the ghosts with v + u: u too */
      arr[0] = D->drho, nc[0] = 1, arr[1] = D->a, nc[1] = 3, narr = 2;
      if (c->rk_stepping) arr[2] = D->u, nc[2] = 3, narr = 3;
      break;
    case SPHDEM_XCHG_ACC: arr[0] = D->a, nc[0] = 3; break;
    case SPHDEM_XCHG_EPS: arr[0] = D->couple.eps, nc[0] = 1; break;
    default: return sphdem_fail(c, SPHDEM_ERR_ARG, "exchange: unknown fluid field %d", what);
  }
  return sphdem_exchange_set(c, what, SPHDEM_SET_FLUID, arr, nc, narr, "fluid values");
}

/* ---- the slice of the fluid the other ranks need, and the move since the neighbour build ---------------- */

int sphdem_fluid_moved(sphdem_ctx c, double *d2max) {
  if (!c || !d2max) return SPHDEM_ERR_ARG;
  *d2max = 0.0;
  if (c->D.nf == 0) return SPHDEM_OK;
  if (!c->edisp_ok) {
    sphdem_red r;
    TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
  }
  *d2max = c->edisp2;
  return SPHDEM_OK;
}
