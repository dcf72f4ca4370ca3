/* scene.h - builds lattice tank scenes (fluid block + dummy wall layers) for the C-level tests and benches. */
#ifndef SPHDEM_TEST_SCENE_H
#define SPHDEM_TEST_SCENE_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sphdem.h"

typedef struct {
  int nf, nw, capf, capw;
  int64_t *tag;
  double *x, *v, *rho, *mass;    /* fluid */
  double *wx, *wv, *wmass;       /* walls */
} scene;

static void scene_push_fluid(scene *s, const double *x, double rho, double mass) {
  if (s->nf == s->capf) {
    s->capf = s->capf ? 2 * s->capf : 1024;
    s->tag = (int64_t *)realloc(s->tag, sizeof(int64_t) * s->capf);
    s->x = (double *)realloc(s->x, 24 * (size_t)s->capf);
    s->v = (double *)realloc(s->v, 24 * (size_t)s->capf);
    s->rho = (double *)realloc(s->rho, 8 * (size_t)s->capf);
    s->mass = (double *)realloc(s->mass, 8 * (size_t)s->capf);
  }
  int i = s->nf++;
  s->tag[i] = i + 1;
  for (int d = 0; d < 3; d++) { s->x[3 * i + d] = x[d]; s->v[3 * i + d] = 0.0; }
  s->rho[i] = rho;
  s->mass[i] = mass;
}

static void scene_push_wall(scene *s, const double *x, double mass) {
  if (s->nw == s->capw) {
    s->capw = s->capw ? 2 * s->capw : 1024;
    s->wx = (double *)realloc(s->wx, 24 * (size_t)s->capw);
    s->wv = (double *)realloc(s->wv, 24 * (size_t)s->capw);
    s->wmass = (double *)realloc(s->wmass, 8 * (size_t)s->capw);
  }
  int i = s->nw++;
  for (int d = 0; d < 3; d++) { s->wx[3 * i + d] = x[d]; s->wv[3 * i + d] = 0.0; }
  s->wmass[i] = mass;
}

/* The fluid of the still 2D tank of verify_hydrostatic (and verify_precision's tank): water H deep in a tank W wide,
 * res particles across, h = 1.5 dx, c0 = 10 sqrt(g H), artificial viscosity 0.02 (the box is the caller's). */
static inline void scene_params_still_tank(sphdem_params *p, double W, double H, int res) {
  const double g = 9.81;
  sphdem_params_default(p);
  p->dim = 2; p->dx = W / res; p->h = 1.5 * p->dx;
  p->rho0 = 1000; p->c0 = 10 * sqrt(g * H);
  p->gravity[1] = -g; p->skin = 0.3 * p->dx;
  p->visc = SPHDEM_VISC_ARTIFICIAL; p->alpha = 0.02;
}

/* The fluid and box of the 2D dam break of verify_dambreak2d (and verify_precision's): a column a wide and 2a high
 * in a tank 5a long, res particles across the column, h = 1.3 dx, c0 = 10 sqrt(2 g a), artificial viscosity 0.02. */
static inline void scene_params_dambreak2d(sphdem_params *p, double a, int res) {
  const double g = 9.81;
  sphdem_params_default(p);
  p->dim = 2; p->dx = a / res; p->h = 1.3 * p->dx; p->rho0 = 1000; p->c0 = 10 * sqrt(2 * g * a);
  p->gravity[1] = -g; p->skin = 0.3 * p->dx;
  p->visc = SPHDEM_VISC_ARTIFICIAL; p->alpha = 0.02;
  p->boxlo[0] = -0.05; p->boxhi[0] = 5 * a + 0.05; p->boxlo[1] = -0.05; p->boxhi[1] = 0.6;
}

/* Open-top tank [0,L] x [0,W] x [0,Ht] (2D: [0,L] x [0,Ht], vertical axis = last axis) with nl wall
 * layers, fluid block [0,fl] x [0,W] x [0,fh] at spacing dx, hydrostatic initial density and mass
 * rho dx^dim (so the SPH volume of each particle is its lattice volume). */
static void scene_tank(scene *s, const sphdem_params *p, double L, double W, double Ht, double fl, double fh, int nl) {
  memset(s, 0, sizeof *s);
  double dx = p->dx, vol = p->dim == 3 ? dx * dx * dx : dx * dx;
  int up = p->dim - 1; /* vertical axis */
  int nx = (int)lround(L / dx), ny = p->dim == 3 ? (int)lround(W / dx) : 1, nz = (int)lround(Ht / dx);
  int fx = (int)lround(fl / dx), fy = ny, fz = (int)lround(fh / dx);
  int ylo = p->dim == 3 ? -nl : 0, yhi = p->dim == 3 ? ny + nl : 1;
  for (int k = -nl; k < nz; k++)
    for (int j = ylo; j < yhi; j++)
      for (int i = -nl; i < nx + nl; i++) {
        double x[3] = {(i + 0.5) * dx, 0.0, 0.0};
        if (p->dim == 3) { x[1] = (j + 0.5) * dx; x[2] = (k + 0.5) * dx; }
        else x[1] = (k + 0.5) * dx;
        int inside = i >= 0 && i < nx && k >= 0 && (p->dim == 2 || (j >= 0 && j < ny));
        if (!inside) { scene_push_wall(s, x, p->rho0 * vol); continue; }
        if (i < fx && k < fz && (p->dim == 2 || j < fy)) {
          double depth = fh - x[up];
          double r = sphdem_hydrostatic_rho(p, depth);
          scene_push_fluid(s, x, r, r * vol); /* volume m/rho equals the lattice volume */
        }
      }
}

/* Mirror points of the wall particles for the fixed ghost walls (sphdem_set_wall_mirror): each coordinate
 * outside [lo, hi] is reflected across that face (the rule of fix sph/fluid's ghost mirror); 3 nw doubles,
 * caller frees. */
static double *scene_mirror(const scene *s, const double *lo, const double *hi) {
  double *xi = (double *)malloc(24 * (size_t)(s->nw > 0 ? s->nw : 1));
  for (int i = 0; i < s->nw; i++)
    for (int d = 0; d < 3; d++) {
      double x = s->wx[3 * i + d];
      xi[3 * i + d] = x < lo[d] ? 2 * lo[d] - x : x > hi[d] ? 2 * hi[d] - x : x;
    }
  return xi;
}

static void scene_free(scene *s) {
  free(s->tag); free(s->x); free(s->v); free(s->rho); free(s->mass);
  free(s->wx); free(s->wv); free(s->wmass);
  memset(s, 0, sizeof *s);
}

#define SPHDEM_CHECK_RC(ctx, call)                                                             \
  do {                                                                                         \
    int rc_ = (call);                                                                          \
    if (rc_ != SPHDEM_OK) {                                                                    \
      fprintf(stderr, "%s:%d: %s failed: %s (%s)\n", __FILE__, __LINE__, #call,                 \
              sphdem_strerror(rc_), sphdem_last_error(ctx));                                   \
      exit(1);                                                                                 \
    }                                                                                          \
  } while (0)

/* Context on device dev with the scene's walls and fluid uploaded and the first rates computed;
 * exits with the core's message on failure (test and benchmark drivers only). */
static inline sphdem_ctx scene_start(const sphdem_params *p, const scene *s, sphdem_device dev) {
  sphdem_ctx c;
  char msg[512];
  int rc = sphdem_create(&c, p, dev, msg, sizeof msg);
  if (rc != SPHDEM_OK) { fprintf(stderr, "sphdem_create: %s (%s)\n", sphdem_strerror(rc), msg); exit(1); }
  if (s->nw > 0) SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s->nw, s->wx, s->wv, NULL, s->wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s->nf, s->tag, s->x, s->v, s->rho, s->mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  return c;
}

/* Multiphase context (Shi & Huang 2022) on device dev: mp parameters, walls (MLS ghosts at the mirror points
 * of the box lo..hi when lo is not NULL, else Adami walls), fluid with its phases, first rates computed. */
static inline sphdem_ctx scene_start_mp(const sphdem_params *p, const sphdem_mp_params *m, const scene *s,
                                        const int *phase, const double *lo, const double *hi, sphdem_device dev) {
  sphdem_ctx c;
  char msg[512];
  int rc = sphdem_create(&c, p, dev, msg, sizeof msg);
  if (rc != SPHDEM_OK) { fprintf(stderr, "sphdem_create: %s (%s)\n", sphdem_strerror(rc), msg); exit(1); }
  SPHDEM_CHECK_RC(c, sphdem_mp_set(c, m));
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s->nw, s->wx, s->wv, NULL, s->wmass));
  if (lo) {
    double *xi = scene_mirror(s, lo, hi);
    SPHDEM_CHECK_RC(c, sphdem_set_wall_mirror(c, s->nw, xi));
    free(xi);
  }
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s->nf, s->tag, s->x, s->v, s->rho, s->mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid_phase(c, s->nf, phase));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  return c;
}

/* Channel-flow check: L2 error of the streamwise velocity against exact(y, t, ctx) relative to uref,
 * printed; the profile of the first particle column (x < col) is appended to out as t,y,u_sim,u_exact. */
static inline double scene_profile_l2(sphdem_ctx c, int nf, double t, double uref, double col, FILE *out,
                                      double (*exact)(double y, double t, const double *prm), const double *prm) {
  double *x = (double *)malloc(24 * (size_t)nf), *v = (double *)malloc(24 * (size_t)nf), e2 = 0;
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, v, NULL, NULL, NULL));
  for (int i = 0; i < nf; i++) {
    double ue = exact(x[3 * i + 1], t, prm), d = v[3 * i] - ue;
    e2 += d * d;
    if (out && x[3 * i] < col) fprintf(out, "%.5f,%.6e,%.6e,%.6e\n", t, x[3 * i + 1], v[3 * i], ue);
  }
  free(x); free(v);
  double l2 = sqrt(e2 / nf) / uref;
  printf("    t = %.4f s: %.2f%%\n", t, 100 * l2);
  return l2;
}

/* One velocity-Verlet step in the order the engine hooks use. */
static int scene_step(sphdem_ctx c, double dt) {
  int rc = sphdem_kick(c, 0.5 * dt);
  if (!rc) rc = sphdem_drift(c, dt);
  if (!rc) rc = sphdem_compute_rates(c);
  if (!rc) rc = sphdem_kick(c, 0.5 * dt);
  return rc;
}

#endif
