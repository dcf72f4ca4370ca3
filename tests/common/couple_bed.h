/* couple_bed.h - the coupled tank with a packed bed of grains at rest (SPH-DEM coupling), for unit_couple's
 * floating-bed case and for bench/bench_bed.c, which runs the same scene with its options changed and prints the
 * numbers. Fluid: the 0.1 x 0.05 x 0.1 m water column of tank_scene (dx 5 mm, h 1.3 dx, Morris viscosity).
 * Grains: a simple-cubic lattice of spacing dx, radius 0.39 dx, in 0 < z < 0.05 (bed_grains). */
#ifndef SPHDEM_TEST_COUPLE_BED_H
#define SPHDEM_TEST_COUPLE_BED_H
#include <math.h>
#include "scene.h"

static void base_params(sphdem_params *p, int dim) {
  sphdem_params_default(p);
  p->dim = dim; p->dx = 0.01; p->h = 0.013; p->rho0 = 1000; p->c0 = 10; p->skin = 0.003;
  p->visc = SPHDEM_VISC_ARTIFICIAL; p->alpha = 0.05;
}

static void tank_scene(sphdem_params *p, scene *s, int dim) {
  base_params(p, dim);
  p->dx = 0.005; p->h = 1.3 * p->dx; p->skin = 0.3 * p->dx; p->c0 = 10 * sqrt(9.81 * 0.1);
  p->gravity[dim - 1] = -9.81; p->visc = SPHDEM_VISC_MORRIS; p->mu = 1e-3;
  scene_tank(s, p, 0.1, 0.05, 0.15, 0.1, 0.1, 3);
}

/* Grains on a simple-cubic lattice of spacing a = dx, radius 0.39 a, filling 0 < x < 0.1, 0 < y < 0.05,
 * 0 < z < 0.05 of the tank (solid fraction 4/3 pi 0.39^3 = 0.2485). Returns the count; arrays malloc'ed. */
static int bed_grains(double a, double **gx, double **gv, double **gr) {
  int n1 = (int)lround(0.1 / a), n2 = (int)lround(0.05 / a), nz = (int)lround(0.05 / a), ng = 0;
  *gx = malloc(24 * (size_t)n1 * n2 * nz); *gv = calloc(3 * (size_t)n1 * n2 * nz, 8); *gr = malloc(8 * (size_t)n1 * n2 * nz);
  for (int k = 0; k < nz; k++)
    for (int j = 0; j < n2; j++)
      for (int i = 0; i < n1; i++, ng++) {
        (*gx)[3 * ng] = (i + 0.5) * a; (*gx)[3 * ng + 1] = (j + 0.5) * a; (*gx)[3 * ng + 2] = (k + 0.5) * a;
        (*gr)[ng] = 0.39 * a;
      }
  return ng;
}

/* The bed's options. Defaults (bed_opts_default): the whole lattice against the side walls and the floor, delta 0.1,
 * Ergun/Wen-Yu drag, wall_porosity fluid, pressure_form mass, dt 0.2 h / (1.2 c0), 300 steps. */
typedef struct {
  double delta, mu;           /* SPH delta term; fluid viscosity (0: tank_scene's 1e-3) */
  int drag, superficial;      /* coupling drag law; superficial (-1: the default) */
  int wall_porosity, eps_walls, pressure_form;
  double hc_over_h;           /* coupling smoothing length / h (0: the default) */
  int nograins;               /* the same tank without the bed */
  double shift, jitter;       /* grain lattice shifted by shift dx; each grain moved by up to +-jitter dx per axis */
  double inset, lift;         /* grains kept inset m from the side walls, lifted lift m off the floor */
  int relax;                  /* the water alone first for relax steps, its velocities zeroed every 20 steps */
  int damp;                   /* with the bed, damp steps with the velocities zeroed every 20 (a rest state?) */
  double dt_factor;           /* dt = dt_factor h / (1.2 c0) */
  int steps, trace;           /* steps; trace: porosity by wall distance, vmax every 100 steps, the fast particles */
} bed_opts;

typedef struct { double vmax, perr, buo, emin, vscale; int nin, nsteps; } bed_result;

static void bed_opts_default(bed_opts *o) {
  memset(o, 0, sizeof *o);
  o->delta = 0.1; o->drag = SPHDEM_DRAG_ERGUN_WENYU; o->superficial = -1; o->wall_porosity = 1; o->eps_walls = -1;
  o->dt_factor = 0.2; o->steps = 300;
}

/* Runs the bed on device dev; r gets the fluid's vmax, the largest |P - rho0 g (H - z)| / (rho0 g H), and the mean
 * vertical force on the interior grains in units of rho_f V g (Archimedes: 1). */
static void bed_run(const bed_opts *o, sphdem_device dev, bed_result *r) {
  sphdem_params p;
  scene s;
  tank_scene(&p, &s, 3);
  p.delta = o->delta; p.delta_hydro = 1;
  if (o->mu > 0) p.mu = o->mu;
  sphdem_ctx c;
  char msg[512];
  if (sphdem_create(&c, &p, dev, msg, sizeof msg) != SPHDEM_OK) { printf("create: %s\n", msg); exit(1); }
  sphdem_couple_params cp;
  sphdem_couple_params_default(&cp);
  cp.enabled = 1; cp.drag = o->drag; cp.mu = 1e-3;
  if (o->superficial >= 0) cp.superficial = o->superficial;
  cp.wall_porosity = o->wall_porosity;
  if (o->eps_walls >= 0) cp.eps_walls = o->eps_walls;
  if (o->hc_over_h > 0) cp.hc = o->hc_over_h * p.h;
  cp.pressure_form = o->pressure_form;
  SPHDEM_CHECK_RC(c, sphdem_couple_set(c, &cp));
  double *gx, *gv, *gr, rg = 0.39 * p.dx;
  int ng = bed_grains(p.dx, &gx, &gv, &gr);
  if (o->nograins) ng = 0;
  for (int j = 0; j < 3 * ng; j++) gx[j] += o->shift * p.dx;
  if (o->jitter != 0) {
    srand(7);
    for (int j = 0; j < 3 * ng; j++) gx[j] += o->jitter * p.dx * (2.0 * rand() / RAND_MAX - 1.0);
  }
  if (o->inset != 0 || o->lift != 0) { /* keep the grains away from the side walls / floor */
    int k = 0;
    for (int j = 0; j < ng; j++) {
      double *q = gx + 3 * j;
      if (q[0] < o->inset || q[0] > 0.1 - o->inset || q[1] < o->inset || q[1] > 0.05 - o->inset) continue;
      gx[3 * k] = q[0]; gx[3 * k + 1] = q[1]; gx[3 * k + 2] = q[2] + o->lift; gr[k] = gr[j]; k++;
    }
    ng = k;
  }
  SPHDEM_CHECK_RC(c, sphdem_set_walls(c, s.nw, s.wx, s.wv, NULL, s.wmass));
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  if (o->relax > 0) {
    double dtr = 0.2 * p.h / (1.2 * p.c0), *st = malloc(8 * SPHDEM_NSTATE * (size_t)s.nf);
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, 0, gx, gv, gr, NULL));
    SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
    for (int n = 1; n <= o->relax; n++) {
      SPHDEM_CHECK_RC(c, scene_step(c, dtr));
      if (n % 20 == 0 || n == o->relax) {
        SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, s.x, s.v, s.rho, NULL, st));
        memset(s.v, 0, 24 * (size_t)s.nf);
        SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
        SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
      }
    }
    free(st);
    printf("    relaxed the water alone for %d steps\n", o->relax);
  }
  SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double *eps = malloc(8 * (size_t)s.nf), *pr = malloc(8 * (size_t)s.nf), *x = malloc(24 * (size_t)s.nf);
  SPHDEM_CHECK_RC(c, sphdem_get_porosity(c, eps));
  if (o->trace) { /* porosity in the bed by distance to the nearest side wall or the floor */
    double sum[8] = {0}; int cnt[8] = {0};
    for (int i = 0; i < s.nf; i++) {
      const double *xi = s.x + 3 * i;
      if (xi[2] > 0.04) continue;
      double dmin = fmin(fmin(fmin(xi[0], 0.1 - xi[0]), fmin(xi[1], 0.05 - xi[1])), xi[2]);
      int k = (int)(dmin / p.dx); if (k > 7) k = 7;
      sum[k] += eps[i]; cnt[k]++;
    }
    for (int k = 0; k < 8; k++) if (cnt[k]) printf("    eps at %d-%d dx from a wall: %.4f (%d)\n", k, k + 1, sum[k] / cnt[k], cnt[k]);
  }
  double emin = 1;
  for (int i = 0; i < s.nf; i++) {
    double e = cp.superficial ? fmax(eps[i], cp.eps_min) : 1.0;
    emin = fmin(emin, e);
    s.rho[i] *= e;
    s.mass[i] *= e;
  }
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
  double dt = o->dt_factor * p.h / (1.2 * p.c0);
  if (o->damp > 0) {
    double *x0 = malloc(24 * (size_t)s.nf);
    memcpy(x0, s.x, 24 * (size_t)s.nf);
    for (int n = 1; n <= o->damp; n++) {
      SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
      SPHDEM_CHECK_RC(c, scene_step(c, dt));
      if (n % 20 == 0) {
        sphdem_stats sd;
        SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &sd));
        SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, s.x, s.v, s.rho, NULL, NULL));
        double dmax = 0;
        for (int i = 0; i < 3 * s.nf; i++) dmax = fmax(dmax, fabs(s.x[i] - x0[i]));
        if (n % 200 == 0) printf("    damped step %d: vmax before zeroing %.2e, amax %.2e, max displacement %.2e m\n", n, sd.vmax, sd.amax, dmax);
        if (n == o->damp)
          for (int i = 0; i < s.nf; i++) {
            double sp = sqrt(s.v[3*i]*s.v[3*i] + s.v[3*i+1]*s.v[3*i+1] + s.v[3*i+2]*s.v[3*i+2]);
            if (sp > 0.6 * sd.vmax)
              printf("      fast: x %.4f %.4f %.4f v %+.2e %+.2e %+.2e moved %+.1e %+.1e %+.1e\n", s.x[3*i], s.x[3*i+1],
                     s.x[3*i+2], s.v[3*i], s.v[3*i+1], s.v[3*i+2], s.x[3*i]-x0[3*i], s.x[3*i+1]-x0[3*i+1], s.x[3*i+2]-x0[3*i+2]);
          }
        memset(s.v, 0, 24 * (size_t)s.nf);
        SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, s.nf, s.tag, s.x, s.v, s.rho, s.mass, NULL));
        SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
        SPHDEM_CHECK_RC(c, sphdem_compute_rates(c));
      }
    }
    free(x0);
  }
  for (int n = 1; n <= o->steps; n++) {
    SPHDEM_CHECK_RC(c, sphdem_set_grains(c, ng, gx, gv, gr, NULL));
    SPHDEM_CHECK_RC(c, scene_step(c, dt));
    if (o->trace && n % 100 == 0) {
      sphdem_stats s1;
      SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &s1));
      printf("    step %d: vmax %.2e ke %.3e\n", n, s1.vmax, s1.ke);
    }
  }
  sphdem_stats st;
  SPHDEM_CHECK_RC(c, sphdem_stats_get(c, dt, &st));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, NULL, NULL, pr, NULL));
  if (o->trace) {
    double *vv = malloc(24 * (size_t)s.nf);
    SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, NULL, vv, NULL, NULL, NULL));
    for (int i = 0; i < s.nf; i++) {
      double sp = sqrt(vv[3*i]*vv[3*i] + vv[3*i+1]*vv[3*i+1] + vv[3*i+2]*vv[3*i+2]);
      if (sp > 0.5 * st.vmax) printf("    fast: x %.4f %.4f %.4f |v| %.3e eps %.3f\n", x[3*i], x[3*i+1], x[3*i+2], sp, eps[i]);
    }
    free(vv);
  }
  double *f = malloc(24 * (size_t)ng + 8), buo = 0, V = 4.0 / 3 * M_PI * rg * rg * rg, perr = 0;
  SPHDEM_CHECK_RC(c, sphdem_get_grain_forces(c, f, NULL, NULL, NULL));
  int nin = 0;
  for (int j = 0; j < ng; j++)
    if (gx[3 * j + 2] < 0.035 && gx[3 * j] > 0.015 && gx[3 * j] < 0.085 && gx[3 * j + 1] > 0.015 && gx[3 * j + 1] < 0.035) {
      buo += f[3 * j + 2] / (1000 * V * 9.81); nin++;
    }
  buo = nin ? buo / nin : 1.0;
  for (int i = 0; i < s.nf; i++) perr = fmax(perr, fabs(pr[i] - 1000 * 9.81 * (0.1 - x[3 * i + 2])) / (1000 * 9.81 * 0.1));
  r->vmax = st.vmax; r->perr = perr; r->buo = buo; r->emin = emin; r->nin = nin; r->nsteps = o->steps;
  r->vscale = sqrt(9.81 * 0.1);
  printf("  3D packed bed at rest (min eps %.3f): after %d steps vmax %.2e m/s (%.2f%% of sqrt(gH)), max |P - rho0 g "
         "(H - z)| %.2f%% of rho0 g H, interior grains feel %.4f rho_f V g (mean of %d)\n", emin, o->steps, st.vmax,
         100 * st.vmax / r->vscale, 100 * perr, buo, nin);
  free(gx); free(gv); free(gr); free(eps); free(pr); free(x); free(f);
  scene_free(&s);
  sphdem_destroy(&c);
}
#endif
