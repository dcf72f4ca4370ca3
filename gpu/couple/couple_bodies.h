/* couple_bodies.h - unresolved SPH-DEM coupling of He 2018 §2.3 (eqs 26-33), written once for the CPU
 * loops (couple_cpu.c) and the CUDA kernels (couple_cuda.cu).
 *
 * Conventions (see also the notes in couple.c):
 * - One coupling kernel: Wendland (eq 5) with smoothing length hc (default the fluid h), support 2 hc,
 *   used for the porosity (eq 26), the Shepard interpolations at grains (eq 28, u, eps) and the
 *   reaction weights (eq 33), so one search range serves every term and the reaction sums exactly to
 *   minus the grain forces.
 * - The fluid density variable is the superficial density rho_bar = eps rho_f (eq 6); V_b = m_b/rho_bar_b
 *   is the mixture volume of particle b.
 * - Grain "volume" V_j: 4/3 pi r^3 in 3D; in 2D the disc area pi r^2 per unit depth, the measure the 2D
 *   kernel (1/area) integrates against, so that eq 26 stays a volume fraction and forces are per unit
 *   depth like the 2D fluid's masses. */
#ifndef SPHDEM_COUPLE_BODIES_H
#define SPHDEM_COUPLE_BODIES_H

#include "sph_bodies.h"

/* ---- search: a box of (2L+1)^dim cells around a cell, periodic wrap, each cell visited once ---- */

typedef struct {
  int x[3], x0[3], cnt[3], n[3], k[3]; /* x: current cell coordinates, x0: first ones, wrapped into [0, n) */
  int done;
} cell_walk;

SPHDEM_HD void walk_init(cell_walk *w, const int *nc, const int *periodic, int dim, const int *c, const int *L) {
  for (int d = 0; d < 3; d++) {
    w->n[d] = nc[d];
    w->k[d] = 0;
    int c0;
    if (d >= dim) { c0 = 0; w->cnt[d] = 1; }
    else if (periodic[d] && 2 * L[d] + 1 >= nc[d]) { c0 = 0; w->cnt[d] = nc[d]; } /* whole axis once */
    else if (periodic[d]) { c0 = c[d] - L[d]; w->cnt[d] = 2 * L[d] + 1; }
    else {
      int lo = c[d] - L[d] < 0 ? 0 : c[d] - L[d], hi = c[d] + L[d] > nc[d] - 1 ? nc[d] - 1 : c[d] + L[d];
      c0 = lo; w->cnt[d] = hi - lo + 1;
    }
    /* the walk steps and wraps by compare, not modulo: 3 modulos per cell cost more than the cell itself */
    int v = nc[d] > 0 ? c0 % nc[d] : 0;
    w->x0[d] = w->x[d] = v < 0 ? v + nc[d] : v;
  }
  w->done = w->cnt[0] <= 0 || w->cnt[1] <= 0 || w->cnt[2] <= 0;
}

/* Next cell of the box (x fastest); 0 when the box is exhausted. */
SPHDEM_HD int walk_next(cell_walk *w, int64_t *cell) {
  if (w->done) return 0;
  *cell = ((int64_t)w->x[2] * w->n[1] + w->x[1]) * w->n[0] + w->x[0];
  for (int d = 0; d < 3; d++) {
    if (++w->k[d] < w->cnt[d]) {
      if (++w->x[d] == w->n[d]) w->x[d] = 0;
      return 1;
    }
    w->k[d] = 0;
    w->x[d] = w->x0[d];
  }
  w->done = 1;
  return 1;
}

/* Fluid -> grain search: the fluid position is mapped into the grain grid, ceil(2 hc / cell) layers. */
SPHDEM_HD void walk_grains_around(const sphdem_dev *D, const double *x, cell_walk *w) {
  int c[3] = {0, 0, 0};
  for (int d = 0; d < D->P.dim; d++) c[d] = grain_grid_coord(D, d, x[d]);
  walk_init(w, D->couple.gnc, D->P.periodic, D->P.dim, c, D->couple.glay);
}

/* Grain -> fluid search: the grain is mapped into the SPH grid, ceil((2 hc + skin/2) / cell) layers
 * (fluid cells are from the last sort; particles moved at most skin/2 since). */
SPHDEM_HD void walk_fluid_around(const sphdem_dev *D, const double *x, cell_walk *w) {
  int c[3] = {0, 0, 0};
  for (int d = 0; d < D->P.dim; d++) c[d] = grid_coord(D, d, x[d]);
  walk_init(w, D->nc, D->P.periodic, D->P.dim, c, D->couple.flay);
}

/* ---- closed forms ------------------------------------------------------------------------------- */

/* Grain volume V_j: sphere in 3D, disc area per unit depth in 2D. */
SPHDEM_HD double grain_volume(int dim, double r) {
  return dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r;
}

/* C_D |w| of eq 32 (Schiller-Naumann below Re 1000, 0.44 above) with Re = k |w|; finite as w -> 0. */
SPHDEM_HD double drag_cd_times_w(double k, double w) {
  double re = k * w;
  if (!(re > 1e-300)) return 24.0 / k;                        /* limit w -> 0: 24/Re * w = 24/k */
  if (re <= 1000.0) return 24.0 * (1.0 + 0.15 * pow(re, 0.687)) / k; /* eq 32 */
  return 0.44 * w;
}

/* Di Felice 1994 C_D |w| (Dallavalle, C_D = (0.63 + 4.8/sqrt(Re))^2) with Re = k |w|. */
SPHDEM_HD double drag_difelice_cd_times_w(double k, double w) {
  double re = k * w;
  if (!(re > 1e-300)) return 23.04 / k;
  double s = 0.63 + 4.8 / sqrt(re);
  return s * s * w;
}

/* Drag coefficient K with F_d = K V_j (u - v) (eq 30: K = beta / (1 - eps)), written so that it stays
 * finite as eps -> 1 and |u - v| -> 0. eps porosity at the grain, rhof intrinsic fluid density, d the
 * grain diameter, w = |u - v|. */
SPHDEM_HD double drag_coefficient(int law, double mu, double eps, double rhof, double d, double w) {
  switch (law) {
    case SPHDEM_DRAG_ERGUN_WENYU:
      if (eps < 0.8) /* eq 31, Ergun, divided by (1 - eps) */
        return 150.0 * mu * (1.0 - eps) / (eps * d * d) + 1.75 * rhof * w / d;
      /* eq 31, Wen & Yu, divided by (1 - eps); Re_p = eps rho_f d |u - v| / mu (eq 32) */
      return 0.75 * drag_cd_times_w(eps * rhof * d / mu, w) * eps * rhof * pow(eps, -2.65) / d;
    case SPHDEM_DRAG_DIFELICE: {
      /* F = 1/2 C_D rho_f (pi d^2/4) eps^2 |u-v| (u-v) eps^-chi, chi = 3.7 - 0.65 exp(-(1.5 - log10 Re)^2 / 2),
       * Re = eps rho_f d |u - v| / mu; per grain volume (pi d^2/4)/V = 3/(2d) for a sphere */
      double k = eps * rhof * d / mu, re = k * w;
      double chi = re > 1e-300 ? 3.7 - 0.65 * exp(-0.5 * (1.5 - log10(re)) * (1.5 - log10(re))) : 3.7;
      return 0.75 * drag_difelice_cd_times_w(k, w) * rhof * pow(eps, 2.0 - chi) / d;
    }
    case SPHDEM_DRAG_SCHILLER_NAUMANN:
      /* single sphere: F = 1/2 C_D rho_f (pi d^2/4) |u-v| (u-v), C_D of eq 32 with Re = rho_f d |u-v| / mu */
      return 0.75 * drag_cd_times_w(rhof * d / mu, w) * rhof / d;
    default:
      return 0.0;
  }
}

/* ---- passes ------------------------------------------------------------------------------------- */

/* Porosity at fluid particle a (eq 26): eps_a = 1 - sum_j W_aj(hc) V_j.
 * eps_walls: the sum is divided by the share of the kernel inside the domain, 1 - sigma_w (sigma_w the wall
 * volume sum, V_w = m_w / rho0), floored at 0.1 (a corner of three walls leaves 1/8).
 * couple_porosity_add: grain j's term (returns 0 when j is outside the support); couple_porosity_finish:
 * the normalisation and the store. The CPU backend also records the pairs (couple_cpu.c). */
/* The coupling kernel W(hc) of a pair at squared distance r2 < (2 hc)^2 (eq 5): the one weight of eqs 26, 28
 * and 33. The CPU's pair lists keep it, so its grain-force and reaction passes do not evaluate it again. */
SPHDEM_HD double couple_kernel(const sphdem_dev *D, double r2) {
  return wendland_w(D->couple.alphaC, sqrt(r2) * D->couple.inv_hc);
}

/* Grain j's term of eq 26 with the pair's kernel value W. */
SPHDEM_HD void couple_porosity_add_w(const sphdem_dev *D, int32_t j, double W, double *s) {
  *s += grain_volume(D->P.dim, D->couple.grad[j]) * W;
}

SPHDEM_HD int couple_porosity_add(const sphdem_dev *D, const double *xa, int32_t j, double *s) {
  double r[3];
  double r2 = separation(D, xa, D->couple.gx + 3 * j, r);
  if (r2 >= D->couple.support2c) return 0;
  couple_porosity_add_w(D, j, couple_kernel(D, r2), s);
  return 1;
}

SPHDEM_HD void couple_porosity_finish(const sphdem_dev *D, int64_t a, double s) {
  const double *xa = D->x + 3 * a;
  if (D->couple.eps_wall_share && D->nw > 0 && s > 0.0) {
    double sw = 0.0;
    cell_walk w;
    int64_t cc;
    walk_fluid_around(D, xa, &w);
    while (walk_next(&w, &cc))
      wall_volume_sum_cell(D, xa, cc, D->couple.alphaC, D->couple.inv_hc, D->couple.support2c, &sw);
    double room = 1.0 - sw;
    s /= room > 0.1 ? room : 0.1;
  }
  D->couple.eps[a] = 1.0 - s;
}

SPHDEM_HD void couple_porosity_body(const sphdem_dev *D, int64_t a) {
  const double *xa = D->x + 3 * a;
  double s = 0.0;
  cell_walk w;
  int64_t cc;
  walk_grains_around(D, xa, &w);
  while (walk_next(&w, &cc))
    for (int32_t j = D->couple.gcstart[cc]; j < D->couple.gcend[cc]; j++) couple_porosity_add(D, xa, j, &s);
  couple_porosity_finish(D, a, s);
}

/* Fluid force on grain j (eqs 27-32). Shepard-corrected interpolations over the fluid particles b within
 * 2 hc, weights V_b W_jb, V_b = m_b / rho_b:
 *   (-grad P + div tau)_j = sum_b m_b theta_b W_jb / sum_b V_b W_jb        (eq 28, momentum rate per volume)
 * with theta_b = a_b - g, the pressure (+ tensile) and viscous acceleration of b from its fluid and wall
 * neighbours (eq 29, the pair_momentum terms of the rates pass; rho_b theta_b = -grad P + div tau);
 *   u_j, eps_j, rho_f,j = Shepard averages of v_b, eps_b (floored) and the intrinsic density.
 *   F_pg = V_j (-grad P + div tau)_j  (eq 27; its printed leading minus would make buoyancy point down)
 *   F_d  = K(eps_j, Re) V_j (u_j - v_j) (eq 30 and the drag laws).
 * Torque (optional): Stokes rotational drag T = k mu V_j (1/2 curl u - omega), k = 6 for a sphere
 * (8 pi mu r^3), 4 for a disc per unit depth (4 pi mu r^2); curl u by the SPH gradient. */
typedef struct {
  double sig, se, srf, su[3], sth[3], scr[3], sgr[3], sigw;
} couple_grain_acc;

/* Fluid particle b's terms of grain j's sums with the pair's kernel value W; r = x_j - x_b and q = |r| / hc are
 * read only with the torque (the CPU's cached lists pass NULL and 0 without it). */
SPHDEM_HD void couple_grain_add_w(const sphdem_dev *D, const double *r, double q, double W, int32_t b,
                                  couple_grain_acc *A) {
  double mb = D->mass[b], rhob = D->rhop[b], Vb = mb / rhob, wv = Vb * W, eb = fluid_eps(D, b);
  const double *vb = D->ve + 3 * b, *ab = D->a + 3 * b;
  A->sig += wv;
  A->se += wv * eb;
  A->srf += wv * (D->couple.eos ? rhob / eb : rhob);
  for (int d = 0; d < D->P.dim; d++) {
    A->su[d] += wv * vb[d];
    A->sth[d] += mb * W * (ab[d] - D->P.gravity[d]);
  }
  if (D->couple.torque) {
    double k = Vb * wendland_grad_factor(D->couple.alphaC, D->couple.inv_hc, q); /* V_b grad_j W_jb = k r */
    A->scr[0] += k * (r[1] * vb[2] - r[2] * vb[1]);
    A->scr[1] += k * (r[2] * vb[0] - r[0] * vb[2]);
    A->scr[2] += k * (r[0] * vb[1] - r[1] * vb[0]);
    for (int d = 0; d < 3; d++) A->sgr[d] += k * r[d];
  }
}

/* Fluid particle b's terms of grain j's sums (nothing when b is outside the support). */
SPHDEM_HD void couple_grain_add(const sphdem_dev *D, const double *xj, int32_t b, couple_grain_acc *A) {
  double r[3];
  double r2 = separation(D, xj, D->x + 3 * b, r); /* r = x_j - x_b */
  if (r2 >= D->couple.support2c) return;
  double q = sqrt(r2) * D->couple.inv_hc;
  couple_grain_add_w(D, r, q, wendland_w(D->couple.alphaC, q), b, A);
}

/* Grain j's forces from its sums (A->sigw: the wall volume sum, used with immersion only). */
SPHDEM_HD void couple_grain_finish(const sphdem_dev *D, int64_t j, const couple_grain_acc *A) {
  const double *vj = D->couple.gv + 3 * j;
  int dim = D->P.dim;
  double sig = A->sig;
  double fpg[3] = {0, 0, 0}, fd[3] = {0, 0, 0}, tq[3] = {0, 0, 0}, imm = 1.0;
  if (D->couple.immersion_s > 0.0) {
    /* keyword immersion: the share of the grain's kernel support outside the walls that holds fluid */
    double room = 1.0 - A->sigw;
    imm = room > 1e-12 ? sig / (room * D->couple.immersion_s) : 1.0;
    if (imm > 1.0) imm = 1.0;
  }
  if (sig > 0.0) {
    double inv = 1.0 / sig, u[3] = {0, 0, 0}, rel[3] = {0, 0, 0}, w2 = 0.0;
    double rj = D->couple.grad[j], V = grain_volume(dim, rj);
    for (int d = 0; d < dim; d++) {
      u[d] = A->su[d] * inv;
      rel[d] = u[d] - vj[d];
      w2 += rel[d] * rel[d];
      fpg[d] = imm * V * A->sth[d] * inv;                                /* eqs 27-29 */
    }
    double K = drag_coefficient(D->couple.drag, D->couple.cmu, A->se * inv, A->srf * inv, 2.0 * rj, sqrt(w2));
    for (int d = 0; d < dim; d++) fd[d] = imm * K * V * rel[d];          /* eq 30 */
    if (D->couple.torque) {
      /* curl u = sum_b V_b grad_j W x (u_b - u_j) = scr - sgr x u */
      const double *scr = A->scr, *sgr = A->sgr;
      double cu[3] = {scr[0] - (sgr[1] * u[2] - sgr[2] * u[1]), scr[1] - (sgr[2] * u[0] - sgr[0] * u[2]),
                      scr[2] - (sgr[0] * u[1] - sgr[1] * u[0])};
      double kt = imm * (dim == 3 ? 6.0 : 4.0) * D->couple.cmu * V;
      const double *om = D->couple.gom + 3 * j;
      if (dim == 3) for (int d = 0; d < 3; d++) tq[d] = kt * (0.5 * cu[d] - om[d]);
      else tq[2] = kt * (0.5 * cu[2] - om[2]);
    }
  }
  D->couple.grain_shepard[j] = sig;
  for (int d = 0; d < 3; d++) {
    D->couple.gfpg[3 * j + d] = fpg[d];
    D->couple.gfd[3 * j + d] = fd[d];
    D->couple.gf[3 * j + d] = fpg[d] + fd[d];                                   /* eq 27 */
    D->couple.gtq[3 * j + d] = tq[d];
  }
}

/* Wall volume sum around grain position xj (keyword immersion), over the SPH cells of the grain's search. */
SPHDEM_HD double couple_grain_wall_sum(const sphdem_dev *D, const double *xj) {
  double sigw = 0.0;
  cell_walk w;
  int64_t cc;
  walk_fluid_around(D, xj, &w);
  while (walk_next(&w, &cc))
    wall_volume_sum_cell(D, xj, cc, D->couple.alphaC, D->couple.inv_hc, D->couple.support2c, &sigw);
  return sigw;
}

/* Many ranks with an exchange: grain j is another rank's; its forces come from its owner. */
SPHDEM_HD int couple_grain_ghost(const sphdem_dev *D, int64_t j) {
  return D->xown && D->couple.gtag[j] > D->couple.ngown;
}

SPHDEM_HD void couple_grain_body(const sphdem_dev *D, int64_t j) {
  if (couple_grain_ghost(D, j)) return;
  const double *xj = D->couple.gx + 3 * j;
  couple_grain_acc A = {0.0, 0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.0};
  if (D->couple.immersion_s > 0.0) A.sigw = couple_grain_wall_sum(D, xj);
  cell_walk w;
  int64_t cc;
  walk_fluid_around(D, xj, &w);
  while (walk_next(&w, &cc))
    for (int32_t b = D->cstart[cc]; b < D->cend[cc]; b++) couple_grain_add(D, xj, b, &A);
  couple_grain_finish(D, j, &A);
}

/* Reaction on fluid particle a (eq 33): f_a = m_a S_a = -V_a sum_j F_j W_aj(hc) / sum_b V_b W_jb(hc).
 * Summed over a, the weights V_a W_aj / sum_b V_b W_jb give exactly 1 per grain: sum_a f_a = -sum_j F_j.
 * (The paper's prefactor m_a/rho_a with S_a an acceleration is read as this force, divided by m_a.) */
/* Grain j's term of eq 33 with the pair's kernel value W. */
SPHDEM_HD void couple_reaction_add_w(const sphdem_dev *D, int32_t j, double W, double *s) {
  if (!(D->couple.grain_shepard[j] > 0.0)) return;
  double k = W / D->couple.grain_shepard[j];
  for (int d = 0; d < D->P.dim; d++) s[d] += k * D->couple.gf[3 * j + d];
}

SPHDEM_HD void couple_reaction_add(const sphdem_dev *D, const double *xa, int32_t j, double *s) {
  double r[3];
  double r2 = separation(D, xa, D->couple.gx + 3 * j, r);
  if (r2 >= D->couple.support2c) return;
  couple_reaction_add_w(D, j, couple_kernel(D, r2), s);
}

SPHDEM_HD void couple_reaction_finish(const sphdem_dev *D, int64_t a, const double *s) {
  double Va = D->mass[a] / D->rhop[a];
  for (int d = 0; d < 3; d++) {
    double f = -Va * s[d];
    D->couple.fr[3 * a + d] = f;
    D->a[3 * a + d] += f / D->mass[a];
  }
}

SPHDEM_HD void couple_reaction_body(const sphdem_dev *D, int64_t a) {
  const double *xa = D->x + 3 * a;
  double s[3] = {0, 0, 0};
  cell_walk w;
  int64_t cc;
  walk_grains_around(D, xa, &w);
  while (walk_next(&w, &cc))
    for (int32_t j = D->couple.gcstart[cc]; j < D->couple.gcend[cc]; j++) couple_reaction_add(D, xa, j, s);
  couple_reaction_finish(D, a, s);
}

#endif
