/* sph_setup.c - the initial state of a fluid at rest, for the engine shims: the free surface of the
 * hydrostatic start, the density of each fresh particle (rho0, hydrostatic, or the layered multiphase
 * pressure through its phase's EOS) and the mass that keeps its volume, the superficial start among grains,
 * and the mirror points of the fixed ghost walls. Context-free: plain arrays in, error codes out. */
#include <math.h>
#include <stdlib.h>

#include "sphdem.h"

/* The axis of the largest gravity component; *down_sign is +1 when the depth grows against it. */
static int gravity_axis(const sphdem_params *p, double *down_sign) {
  int axis = 0;
  for (int d = 1; d < 3; d++)
    if (fabs(p->gravity[d]) > fabs(p->gravity[axis])) axis = d;
  *down_sign = p->gravity[axis] < 0 ? 1.0 : -1.0;
  return axis;
}

/* Multiphase hydrostatic start: the fluid is binned in depth below zsurf (bins of dx); the mean reference
 * density of the particles in each bin, integrated from the surface down, gives p(depth) = g int rho dz at
 * the nb + 1 bin edges z[b] = b dx. Exact for horizontal layers; an estimate elsewhere (the fluid settles
 * from it). *z and *pres are allocated here (the caller frees them). */
static int layered_pressure(const sphdem_params *p, const sphdem_mp_params *m, double zsurf, int n,
                            const double *x, const int *phase, const sphdem_comm *comm, size_t *nb_out,
                            double **z_out, double **p_out) {
  double down_sign;
  const int axis = gravity_axis(p, &down_sign);
  const double g = fabs(p->gravity[axis]), bw = p->dx;
  double dmax = 0.0;
  for (int i = 0; i < n; i++) {
    const double depth = down_sign * (zsurf - x[3 * i + axis]);
    if (dmax < depth) dmax = depth;
  }
  const int many = comm && comm->allreduce && comm->nranks > 1; /* the bins of every rank's particles */
  if (many && comm->allreduce(comm->user, &dmax, 1, SPHDEM_RED_MAX) != 0) return SPHDEM_ERR_STATE;
  const size_t nb = (size_t)(dmax / bw) + 2;
  double *srho = calloc(nb, sizeof(double)), *cnt = calloc(nb, sizeof(double));
  double *z = calloc(nb + 1, sizeof(double)), *pr = calloc(nb + 1, sizeof(double));
  if (!srho || !cnt || !z || !pr) {
    free(srho), free(cnt), free(z), free(pr);
    return SPHDEM_ERR_ALLOC;
  }
  for (int i = 0; i < n; i++) {
    const double depth = down_sign * (zsurf - x[3 * i + axis]);
    if (depth < 0) continue;
    size_t b = (size_t)(depth / bw);
    if (b > nb - 1) b = nb - 1;
    srho[b] += m->phase[phase[i]].rho0;
    cnt[b] += 1.0;
  }
  if (many && (comm->allreduce(comm->user, srho, (int)nb, SPHDEM_RED_SUM) != 0 ||
               comm->allreduce(comm->user, cnt, (int)nb, SPHDEM_RED_SUM) != 0)) {
    free(srho), free(cnt), free(z), free(pr);
    return SPHDEM_ERR_STATE;
  }
  for (size_t b = 0; b < nb; b++) {
    z[b + 1] = (double)(b + 1) * bw;
    pr[b + 1] = pr[b] + (cnt[b] > 0 ? srho[b] / cnt[b] : 0.0) * g * bw;
  }
  free(srho), free(cnt);
  *nb_out = nb, *z_out = z, *p_out = pr;
  return SPHDEM_OK;
}

int sphdem_free_surface(const sphdem_params *p, int n, const double *x, const sphdem_comm *comm, double *zsurf,
                        int *axis, int *up) {
  if (!p || n < 0 || (n > 0 && !x) || !zsurf) return SPHDEM_ERR_ARG;
  double down_sign;
  const int ax = gravity_axis(p, &down_sign); /* the surface is where down_sign * x is largest */
  double top = -INFINITY;
  for (int i = 0; i < n; i++) {
    const double v = down_sign * x[3 * i + ax];
    if (top < v) top = v;
  }
  if (comm && comm->allreduce && comm->nranks > 1 && comm->allreduce(comm->user, &top, 1, SPHDEM_RED_MAX) != 0)
    return SPHDEM_ERR_STATE;
  *zsurf = down_sign * (top + 0.5 * p->dx);
  if (axis) *axis = ax;
  if (up) *up = down_sign > 0 ? 1 : -1;
  return SPHDEM_OK;
}

double sphdem_volume_mass_factor(const sphdem_params *p, const sphdem_mp_params *m, int phase, double rho) {
  const double rho0 = m && m->enabled ? m->phase[phase].rho0 : p->rho0;
  return rho / rho0;
}

int sphdem_superficial_start(double eps_min, int nout, const int *which, const double *eps, double *rho,
                             double *mass) {
  if (nout < 0 || (nout > 0 && (!which || !eps || !rho))) return SPHDEM_ERR_ARG;
  for (int j = 0; j < nout; j++) {
    const int k = which[j];
    const double e = eps[k] < eps_min ? eps_min : eps[k]; /* eps_min floor (NaN passes as in the fluid's sums) */
    rho[k] *= e;
    if (mass) mass[k] *= e;
  }
  return SPHDEM_OK;
}

int sphdem_initial_density(const sphdem_params *p, const sphdem_mp_params *m, int hydrostatic, double zsurf, int n,
                           const double *x, const int *phase, int nout, const int *which, double *rho) {
  return sphdem_initial_density_ranks(p, m, hydrostatic, zsurf, n, x, phase, nout, which, rho, NULL);
}

int sphdem_initial_density_ranks(const sphdem_params *p, const sphdem_mp_params *m, int hydrostatic, double zsurf,
                                 int n, const double *x, const int *phase, int nout, const int *which, double *rho,
                                 const sphdem_comm *comm) {
  const int mp = m && m->enabled;
  if (!p || n < 0 || nout < 0 || (nout > 0 && (!x || !which || !rho)) || (mp && n > 0 && !phase))
    return SPHDEM_ERR_ARG;
  if (hydrostatic && !(p->dx > 0)) return SPHDEM_ERR_ARG;
  for (int j = 0; j < nout; j++)
    if (which[j] < 0 || which[j] >= n) return SPHDEM_ERR_ARG;
  if (mp)
    for (int i = 0; i < n; i++)
      if (phase[i] < 0 || phase[i] >= m->nphase) return SPHDEM_ERR_ARG;
  const int layered = mp && hydrostatic;
  if (layered && comm && comm->allreduce && comm->nranks > 1) { /* collective: is a fresh particle anywhere? */
    double any = nout > 0 ? 1.0 : 0.0;
    if (comm->allreduce(comm->user, &any, 1, SPHDEM_RED_MAX) != 0) return SPHDEM_ERR_STATE;
    if (any == 0.0) return SPHDEM_OK;
  } else if (nout == 0) {
    return SPHDEM_OK;
  }

  double down_sign;
  const int axis = gravity_axis(p, &down_sign);
  size_t nb = 0;
  double *z = NULL, *pr = NULL;
  if (mp && hydrostatic) {
    const int rc = layered_pressure(p, m, zsurf, n, x, phase, comm, &nb, &z, &pr);
    if (rc != SPHDEM_OK) return rc;
  }
  for (int j = 0; j < nout; j++) {
    const int i = which[j];
    double depth = down_sign * (zsurf - x[3 * i + axis]);
    if (depth < 0.0) depth = 0.0;
    if (!mp) {
      rho[j] = hydrostatic ? sphdem_hydrostatic_rho(p, depth) : p->rho0;
      continue;
    }
    double pres = m->p0;
    if (hydrostatic) { /* linear between the bin edges */
      const double bw = z[1] - z[0];
      size_t b = (size_t)(depth / bw);
      if (b > nb - 1) b = nb - 1;
      const double w = (depth - z[b]) / bw;
      pres += (1.0 - w) * pr[b] + w * pr[b + 1];
    }
    rho[j] = sphdem_mp_density(m, p, phase[i], pres);
  }
  free(z), free(pr);
  return SPHDEM_OK;
}

int sphdem_mirror_points(int n, const double *x, const double lo[3], const double hi[3], double *xi, int *inside) {
  if (inside) *inside = -1;
  if (n < 0 || (n > 0 && (!x || !xi)) || !lo || !hi) return SPHDEM_ERR_ARG;
  for (int k = 0; k < n; k++) {
    int outside = 0;
    for (int d = 0; d < 3; d++) {
      double v = x[3 * k + d];
      if (v < lo[d]) v = 2.0 * lo[d] - v, outside = 1;
      else if (v > hi[d]) v = 2.0 * hi[d] - v, outside = 1;
      xi[3 * k + d] = v;
    }
    if (!outside) {
      if (inside) *inside = k;
      return SPHDEM_ERR_ARG;
    }
  }
  return SPHDEM_OK;
}
