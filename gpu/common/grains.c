/* grains.c - the grain store: the grains of a step handed once (host view borrowed from the caller, one device
 * copy made on the first read), read by every context of its backend. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "grains.h"

static int64_t uploads_total; /* of every store of the process */

int sphdem_grains_create(sphdem_grain_store *out, sphdem_device dev, char *msg, size_t msglen) {
  if (!out) return SPHDEM_ERR_ARG;
  *out = NULL;
  if (dev != SPHDEM_DEVICE_CPU && dev != SPHDEM_DEVICE_GPU) {
    if (msg && msglen) snprintf(msg, msglen, "grains_create: device %d; must be CPU (1) or GPU (2)", (int)dev);
    return SPHDEM_ERR_ARG;
  }
#ifndef SPHDEM_WITH_CUDA
  if (dev == SPHDEM_DEVICE_GPU) {
    if (msg && msglen) snprintf(msg, msglen, "grains_create: built without the CUDA backend");
    return SPHDEM_ERR_NO_GPU;
  }
#endif
  struct sphdem_grains_s *g = (struct sphdem_grains_s *)calloc(1, sizeof *g);
  if (!g) {
    if (msg && msglen) snprintf(msg, msglen, "grains_create: out of host memory");
    return SPHDEM_ERR_ALLOC;
  }
  sphdem_rt_init(&g->rt, dev);
  g->backend = dev;
  *out = g;
  return SPHDEM_OK;
}

int sphdem_grains_destroy(sphdem_grain_store *pg) {
  if (!pg || !*pg) return SPHDEM_OK;
  struct sphdem_grains_s *g = *pg;
  rt_free(&g->rt, (void **)&g->dbuf, sizeof(double) * 11 * (size_t)g->cap);
  free(g);
  *pg = NULL;
  return SPHDEM_OK;
}

const char *sphdem_grains_last_error(sphdem_grain_store g) { return g ? g->rt.err : "no grain store"; }

int sphdem_grains_put(sphdem_grain_store g, const int64_t stamp[SPHDEM_GRAINS_STAMP], int nown, int nghost,
                      const double *x, const double *v, const double *omega, const double *radius,
                      const double *mass) {
  if (!g) return SPHDEM_ERR_ARG;
  if (nown < 0 || nghost < 0 || (int64_t)nown + nghost > INT32_MAX)
    return rt_fail(&g->rt, SPHDEM_ERR_ARG, "grains_put: %d own and %d ghost grains", nown, nghost);
  if (nown + nghost > 0 && (!x || !v || !radius))
    return rt_fail(&g->rt, SPHDEM_ERR_ARG, "grains_put: x, v and radius are required");
  if (stamp) memcpy(g->stamp, stamp, sizeof g->stamp);
  else memset(g->stamp, 0, sizeof g->stamp);
  g->have = 1;
  g->nown = nown;
  g->nghost = nghost;
  g->hx = x, g->hv = v, g->hom = omega, g->hrad = radius, g->hmass = mass;
  g->on_device = 0;
  return SPHDEM_OK;
}

int sphdem_grains_current(sphdem_grain_store g, const int64_t stamp[SPHDEM_GRAINS_STAMP]) {
  return g && g->have && stamp && !memcmp(g->stamp, stamp, sizeof g->stamp);
}

int sphdem_grains_count(sphdem_grain_store g, int *nown, int *nghost) {
  if (!g) return SPHDEM_ERR_ARG;
  if (nown) *nown = g->have ? g->nown : 0;
  if (nghost) *nghost = g->have ? g->nghost : 0;
  return SPHDEM_OK;
}

int64_t sphdem_grains_uploads(sphdem_grain_store g) { return g ? g->uploads : uploads_total; }

int sphdem_grains_check(const struct sphdem_grains_s *g, sphdem_rt *rt, int backend, int n, const int32_t *idx,
                        const char *who) {
  if (!g) return rt_fail(rt, SPHDEM_ERR_ARG, "%s: no grain store", who);
  if (g->backend != backend)
    return rt_fail(rt, SPHDEM_ERR_ARG, "%s: the grain store is on the %s, the context on the %s", who,
                   g->backend == SPHDEM_DEVICE_GPU ? "GPU" : "CPU", backend == SPHDEM_DEVICE_GPU ? "GPU" : "CPU");
  const int64_t ns = g->have ? (int64_t)g->nown + g->nghost : 0;
  if (n < 0) return rt_fail(rt, SPHDEM_ERR_ARG, "%s: negative grain count %d", who, n);
  if (!idx && n > ns)
    return rt_fail(rt, SPHDEM_ERR_ARG, "%s: %d grains asked for, the store holds %lld", who, n, (long long)ns);
  for (int k = 0; idx && k < n; k++)
    if (idx[k] < 0 || idx[k] >= ns)
      return rt_fail(rt, SPHDEM_ERR_ARG, "%s: index %d of grain %d outside the store's %lld grains", who, idx[k], k,
                     (long long)ns);
  return SPHDEM_OK;
}

int sphdem_grains_device(struct sphdem_grains_s *g, sphdem_rt *rt) {
  if (g->on_device) return SPHDEM_OK;
  const int64_t n = (int64_t)g->nown + g->nghost;
  if (g->backend == SPHDEM_DEVICE_CPU) { /* the device is host memory: the loops read the caller's arrays */
    g->dx = (double *)g->hx, g->dv = (double *)g->hv, g->dom = (double *)g->hom;
    g->drad = (double *)g->hrad, g->dmass = (double *)g->hmass;
  } else {
    if (n > g->cap) {
      const int64_t cap = n + n / 4 + 16;
      rt_free(&g->rt, (void **)&g->dbuf, sizeof(double) * 11 * (size_t)g->cap);
      g->cap = 0;
      if (rt_alloc(&g->rt, (void **)&g->dbuf, sizeof(double) * 11 * (size_t)cap))
        return rt_fail(rt, SPHDEM_ERR_ALLOC, "grain store: %s", g->rt.err);
      g->cap = cap;
    }
    g->dx = g->dbuf, g->dv = g->dbuf + 3 * g->cap, g->dom = g->dbuf + 6 * g->cap;
    g->drad = g->dbuf + 9 * g->cap, g->dmass = g->dbuf + 10 * g->cap;
    const size_t b3 = sizeof(double) * 3 * (size_t)n, b1 = sizeof(double) * (size_t)n;
    int rc = rt_h2d(&g->rt, g->dx, g->hx, b3);
    if (!rc) rc = rt_h2d(&g->rt, g->dv, g->hv, b3);
    if (!rc) rc = g->hom ? rt_h2d(&g->rt, g->dom, g->hom, b3) : rt_zero(&g->rt, g->dom, b3);
    if (!rc) rc = rt_h2d(&g->rt, g->drad, g->hrad, b1);
    if (!rc) rc = g->hmass ? rt_h2d(&g->rt, g->dmass, g->hmass, b1) : rt_zero(&g->rt, g->dmass, b1);
    if (rc) return rt_fail(rt, rc, "grain store upload: %s", g->rt.err);
  }
  g->on_device = 1;
  if (n > 0) {
    g->uploads++;
    uploads_total++;
  }
  return SPHDEM_OK;
}

int sphdem_idx_upload(sphdem_rt *rt, sphdem_idx_buf *b, const int32_t *idx, int64_t n, const int32_t **out) {
  *out = NULL;
  if (!idx) return SPHDEM_OK;
  if (n > b->cap) {
    const int64_t cap = n + n / 4 + 16;
    rt_free(rt, (void **)&b->d, sizeof(int32_t) * (size_t)b->cap);
    b->cap = 0;
    int rc = rt_alloc(rt, (void **)&b->d, sizeof(int32_t) * (size_t)cap);
    if (rc) return rc;
    b->cap = cap;
  }
  int rc = rt_h2d(rt, b->d, idx, sizeof(int32_t) * (size_t)n);
  if (!rc) *out = b->d;
  return rc;
}

void sphdem_idx_free(sphdem_rt *rt, sphdem_idx_buf *b) {
  rt_free(rt, (void **)&b->d, sizeof(int32_t) * (size_t)b->cap);
  b->cap = 0;
}

int sphdem_grains_put_private(struct sphdem_grains_s **g, sphdem_rt *rt, int backend, int n, const double *x,
                              const double *v, const double *omega, const double *radius, const double *mass) {
  if (!*g) {
    char msg[256] = "";
    int rc = sphdem_grains_create(g, (sphdem_device)backend, msg, sizeof msg);
    if (rc) return rt_fail(rt, rc, "grain store: %s", msg);
  }
  int64_t stamp[SPHDEM_GRAINS_STAMP] = {0};
  stamp[0] = (*g)->stamp[0] + 1; /* a private store is read once per put */
  int rc = sphdem_grains_put(*g, stamp, n, 0, x, v, omega, radius, mass);
  if (rc) return rt_fail(rt, rc, "%s", (*g)->rt.err);
  return SPHDEM_OK;
}
