/* couple.c - SPH-DEM coupling API (He 2018 §2.3). Placeholder: every call reports that the
 * coupling is not implemented yet; the implementation replaces this file. */
#include <string.h>
#include "sphdem_internal.h"

void sphdem_couple_params_default(sphdem_couple_params *c) {
  memset(c, 0, sizeof *c);
  c->eps_min = 0.2;
  c->superficial = 1;
}
#define SPHDEM_COUPLE_TODO_ return SPHDEM_ERR_STATE
int sphdem_couple_set(sphdem_ctx ctx, const sphdem_couple_params *c) { (void)ctx; (void)c; SPHDEM_COUPLE_TODO_; }
int sphdem_couple_get(sphdem_ctx ctx, sphdem_couple_params *c) { (void)ctx; (void)c; SPHDEM_COUPLE_TODO_; }
int sphdem_set_grains(sphdem_ctx ctx, int n, const double *x, const double *v, const double *radius,
                      const double *omega) { (void)ctx; (void)n; (void)x; (void)v; (void)radius; (void)omega; SPHDEM_COUPLE_TODO_; }
int sphdem_get_grain_forces(sphdem_ctx ctx, double *f, double *fdrag, double *fpg, double *torque) {
  (void)ctx; (void)f; (void)fdrag; (void)fpg; (void)torque; SPHDEM_COUPLE_TODO_; }
int sphdem_get_porosity(sphdem_ctx ctx, double *eps) { (void)ctx; (void)eps; SPHDEM_COUPLE_TODO_; }
int sphdem_couple_stats_get(sphdem_ctx ctx, sphdem_couple_stats *s) { (void)ctx; (void)s; SPHDEM_COUPLE_TODO_; }
int64_t sphdem_debug_couple_pairs(sphdem_ctx ctx, int64_t *pairs, int64_t maxpairs) {
  (void)ctx; (void)pairs; (void)maxpairs; return -SPHDEM_ERR_STATE; }
