/* grains.h - the grain store of the shared runtime (not public): the grains of a step in one place, a host view
 * and a device copy, read by the coupling, the DEM contacts and the gas grid; the readers' helpers. */
#ifndef SPHDEM_GRAINS_INTERNAL_H
#define SPHDEM_GRAINS_INTERNAL_H

#include "runtime.h"

#ifdef __cplusplus
extern "C" {
#endif

struct sphdem_grains_s {
  sphdem_rt rt;
  int backend;                      /* SPHDEM_DEVICE_CPU / _GPU: readers must be of the same */
  int64_t stamp[SPHDEM_GRAINS_STAMP];
  int have;                         /* a put happened */
  int nown, nghost;
  const double *hx, *hv, *hom, *hrad, *hmass; /* host view: the caller's arrays (hom, hmass may be NULL) */
  double *dx, *dv, *dom, *drad, *dmass;       /* device view, valid while on_device (CPU: the host view) */
  int on_device;                    /* the device view holds the last put */
  double *dbuf;                     /* GPU: the device copy, 11 doubles a grain */
  int64_t cap;
  int64_t uploads;
};

/* A device copy of a reader's index list (grown as needed; freed with sphdem_idx_free). */
typedef struct {
  int32_t *d;
  int64_t cap;
} sphdem_idx_buf;

/* The checks every reader makes: the store exists, has been put, is of backend, holds the grains idx[0..n)
 * (or the first n); who names the caller in the message (set in rt). */
int sphdem_grains_check(const struct sphdem_grains_s *g, sphdem_rt *rt, int backend, int n, const int32_t *idx,
                        const char *who);
/* The device view of the last put (uploaded on the first call after a put); errors go to rt. */
int sphdem_grains_device(struct sphdem_grains_s *g, sphdem_rt *rt);
/* Host value of grain k of a reader's view: store grain idx[k], or k when idx is NULL. */
static inline int64_t sphdem_grains_at(const int32_t *idx, int64_t k) { return idx ? (int64_t)idx[k] : k; }
/* dst = n rows (width doubles) of a device array src of the store, picked by the reader's view; idx_d is the
 * device copy of idx (NULL: the first n rows). */
static inline int sphdem_grains_copy(sphdem_rt *rt, double *dst, const double *src, const int32_t *idx_d,
                                     int64_t n, int width) {
  return idx_d ? rt_gather(rt, dst, src, idx_d, n, width) : rt_d2d(rt, dst, src, sizeof(double) * width * n);
}
/* Upload idx[0..n) into b (NULL idx: nothing, b->d stays as it is); *out the device list or NULL. */
int sphdem_idx_upload(sphdem_rt *rt, sphdem_idx_buf *b, const int32_t *idx, int64_t n, const int32_t **out);
void sphdem_idx_free(sphdem_rt *rt, sphdem_idx_buf *b);
/* The private store of a context's legacy call (sphdem_set_grains, sphdem_dem_compute, sphdem_cfd_step):
 * created on first use in *g on backend, then a put with a fresh stamp of n own grains. */
int sphdem_grains_put_private(struct sphdem_grains_s **g, sphdem_rt *rt, int backend, int n, const double *x,
                              const double *v, const double *omega, const double *radius, const double *mass);

#ifdef __cplusplus
}
#endif

#endif
