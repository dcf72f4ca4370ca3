/* exchange.c - many MPI ranks: the owners' values handed to their ghost copies in the middle of a rate
 * evaluation (sphdem_set_exchange): the fluid's rates, porosity and acceleration, the plain fluid's wall state.
 * Each rank then evaluates its owned particles only. The grains' exchange is the coupling's (couple.c). */
#include <stdlib.h>

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

/* The exchange of the device arrays arr[0..narr) (nc[k] values per element, n elements in sorted slots; slot s
 * holds caller index uidx[s], or wtag[s] - 1 for walls): the owned elements' values (caller index < n0) to fn in
 * caller order, the ghosts' values back into their slots. The CPU backend's arrays are host memory and are read
 * and written in place; the GPU's travel whole through the staging (the ghosts are spread over the sorted slots).
 * Collective: every rank calls it at the same points, with or without elements. */
int sphdem_exchange_slots(struct sphdem_ctx_s *c, int what, int64_t n, int64_t n0, const int32_t *uidx_dev,
                          const int64_t *tag_dev, double *const *arr, const int *nc, int narr,
                          const char *what_name) {
  int ncomp = 0;
  for (int k = 0; k < narr; k++) ncomp += nc[k];
  const int64_t ng = n - n0;
  const int direct = c->backend == SPHDEM_DEVICE_CPU;
  const double t0 = rt_now(); /* the whole exchange, the shim's communication included, is transfer time */
  double *own = sphdem_xbuf(c, (n + 1) * (int64_t)(ncomp + 4));
  if (!own) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld host values", (long long)n);
  double *ghost = own + (size_t)ncomp * (size_t)n0, *h = ghost + (size_t)ncomp * (size_t)ng;
  int64_t *cidx = (int64_t *)(h + 3 * (size_t)n); /* slot -> caller index, in the last n doubles */
  if (n > 0) {
    TRY(rt_sync(&c->rt));
    if (uidx_dev) {
      const int32_t *ui = uidx_dev;
      if (!direct) { TRY(rt_d2h(&c->rt, h, uidx_dev, 4 * (size_t)n)); ui = (const int32_t *)h; }
      for (int64_t s = 0; s < n; s++) cidx[s] = ui[s];
    } else {
      if (direct) for (int64_t s = 0; s < n; s++) cidx[s] = tag_dev[s] - 1;
      else {
        TRY(rt_d2h(&c->rt, cidx, tag_dev, 8 * (size_t)n));
        for (int64_t s = 0; s < n; s++) cidx[s] -= 1;
      }
    }
    for (int k = 0, off = 0; k < narr; off += nc[k], k++) {
      const double *src = arr[k];
      if (!direct) { TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n)); src = h; }
      for (int64_t s = 0; s < n; s++)
        if (cidx[s] < n0)
          for (int d = 0; d < nc[k]; d++) own[(size_t)ncomp * cidx[s] + off + d] = src[(size_t)nc[k] * s + d];
    }
  }
  if (c->xfn(c->xuser, what, ncomp, (int)n0, (int)ng, own, ghost) != 0)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: the owners' %s did not reach the ghosts", what_name);
  if (ng > 0)
    for (int k = 0, off = 0; k < narr; off += nc[k], k++) {
      double *dst = arr[k];
      if (!direct) { TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n)); dst = h; }
      for (int64_t s = 0; s < n; s++) {
        const int64_t g = cidx[s] - n0;
        if (g >= 0)
          for (int d = 0; d < nc[k]; d++) dst[(size_t)nc[k] * s + d] = ghost[(size_t)ncomp * g + off + d];
      }
      if (!direct) TRY(rt_h2d(&c->rt, arr[k], h, 8 * (size_t)nc[k] * (size_t)n));
    }
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
  const int64_t n0 = D->nwown < D->nw ? D->nwown : D->nw;
  return sphdem_exchange_slots(c, SPHDEM_XCHG_WALL, D->nw, n0, NULL, D->wtag, arr, nc,
                               D->couple.wall_porosity ? 4 : 3, "wall state");
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
  return sphdem_exchange_slots(c, what, D->nf, D->nown, D->uidx, NULL, arr, nc, narr, "fluid values");
}
