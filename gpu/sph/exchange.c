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

/* Many ranks, plain fluid with Adami walls: the owned walls' state (pressure, density, extrapolated velocity,
 * porosity when coupled with superficial density) to the ghost walls, walls in caller order (wtag - 1).
 * Collective. */
int sphdem_exchange_walls(struct sphdem_ctx_s *c) {
  sphdem_dev *D = &c->D;
  double *arr[4] = {D->wp, D->wrho, D->wvx, D->couple.wall_porosity};
  const int nc[4] = {1, 1, 3, 1};
  const int narr = D->couple.wall_porosity ? 4 : 3, ncomp = narr == 4 ? 6 : 5;
  const int64_t n = D->nw, n0 = D->nwown < n ? D->nwown : n, ng = n - n0;
  const double t0 = rt_now();
  double *own = sphdem_xbuf(c, (n + 1) * (int64_t)(2 * ncomp + 1));
  if (!own) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld host values", (long long)n);
  double *ghost = own + (size_t)ncomp * (size_t)n0, *h = ghost + (size_t)ncomp * (size_t)ng;
  int64_t *tag = (int64_t *)(h + (size_t)ncomp * (size_t)n);
  if (n > 0) {
    TRY(rt_sync(&c->rt));
    TRY(rt_d2h(&c->rt, tag, D->wtag, 8 * (size_t)n));
    for (int k = 0, off = 0; k < narr; off += nc[k], k++) {
      TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n));
      for (int64_t s = 0; s < n; s++)
        if (tag[s] - 1 < n0)
          for (int d = 0; d < nc[k]; d++) own[(size_t)ncomp * (tag[s] - 1) + off + d] = h[(size_t)nc[k] * s + d];
    }
  }
  if (c->xfn(c->xuser, SPHDEM_XCHG_WALL, ncomp, (int)n0, (int)ng, own, ghost) != 0)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: the owners' wall state did not reach the ghost walls");
  if (ng > 0)
    for (int k = 0, off = 0; k < narr; off += nc[k], k++) {
      TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n));
      for (int64_t s = 0; s < n; s++) {
        const int64_t g = tag[s] - 1 - n0;
        if (g >= 0)
          for (int d = 0; d < nc[k]; d++) h[(size_t)nc[k] * s + d] = ghost[(size_t)ncomp * g + off + d];
      }
      TRY(rt_h2d(&c->rt, arr[k], h, 8 * (size_t)nc[k] * (size_t)n));
    }
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  return SPHDEM_OK;
}

/* The owned values of the field's device arrays (sorted slots; slot s holds caller index uidx[s]) to the
 * exchange function in caller order, the ghosts' values back into their slots. Collective: every rank calls
 * it at the same points, with or without particles. */
int sphdem_exchange_fluid(struct sphdem_ctx_s *c, int what) {
  if (!c->xfn) return SPHDEM_OK;
  sphdem_dev *D = &c->D;
  double *arr[2] = {NULL, NULL};
  int nc[2] = {0, 0};
  switch (what) {
    case SPHDEM_XCHG_RATES: arr[0] = D->drho, nc[0] = 1, arr[1] = D->a, nc[1] = 3; break;
    case SPHDEM_XCHG_ACC: arr[0] = D->a, nc[0] = 3; break;
    case SPHDEM_XCHG_EPS: arr[0] = D->couple.eps, nc[0] = 1; break;
    default: return sphdem_fail(c, SPHDEM_ERR_ARG, "exchange: unknown fluid field %d", what);
  }
  const int64_t n = D->nf, n0 = D->nown, ng = n - n0;
  const int ncomp = nc[0] + nc[1];
  const double t0 = rt_now(); /* the whole exchange, the shim's communication included, is transfer time */
  double *own = sphdem_xbuf(c, (n + 1) * (int64_t)(ncomp + 4));
  if (!own) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "exchange: cannot allocate %lld host values", (long long)n);
  double *ghost = own + (size_t)ncomp * (size_t)n0, *h = ghost + (size_t)ncomp * (size_t)ng;
  int32_t *ui = (int32_t *)(h + 3 * (size_t)n); /* slot -> caller index, in the last n doubles */
  if (n > 0) {
    TRY(rt_sync(&c->rt));
    TRY(rt_d2h(&c->rt, ui, D->uidx, 4 * (size_t)n));
    for (int k = 0, off = 0; k < 2 && arr[k]; off += nc[k], k++) {
      TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n));
      for (int64_t s = 0; s < n; s++)
        if (ui[s] < n0)
          for (int d = 0; d < nc[k]; d++) own[(size_t)ncomp * ui[s] + off + d] = h[(size_t)nc[k] * s + d];
    }
  }
  if (c->xfn(c->xuser, what, ncomp, (int)n0, (int)ng, own, ghost) != 0)
    return sphdem_fail(c, SPHDEM_ERR_STATE, "exchange: the owners' values did not reach the ghosts (field %d)", what);
  if (ng > 0)
    for (int k = 0, off = 0; k < 2 && arr[k]; off += nc[k], k++) {
      TRY(rt_d2h(&c->rt, h, arr[k], 8 * (size_t)nc[k] * (size_t)n));
      for (int64_t s = 0; s < n; s++) {
        const int64_t g = (int64_t)ui[s] - n0;
        if (g >= 0)
          for (int d = 0; d < nc[k]; d++) h[(size_t)nc[k] * s + d] = ghost[(size_t)ncomp * g + off + d];
      }
      TRY(rt_h2d(&c->rt, arr[k], h, 8 * (size_t)nc[k] * (size_t)n));
    }
  c->timers[SPHDEM_T_TRANSFER] += rt_now() - t0;
  return SPHDEM_OK;
}
