/* sph_bodies.h - the SPH physics of He 2018 §2.1, written once for the CPU loops and CUDA kernels. */
#ifndef SPHDEM_SPH_BODIES_H
#define SPHDEM_SPH_BODIES_H

#include <math.h>
#include "sph_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- kernel --------------------------------------------------------------------------- */

/* Wendland C2 normalisation alpha_D for W = alpha_D (1 - q/2)^4 (1 + 2q), 0 <= q <= 2 (eq 5).
 * 2D: 7/(4 pi h^2); 3D: 21/(16 pi h^3). (The paper prints 7/(8 pi h^3) for 3D, which does not
 * integrate to one; the unit test checks both normalisations numerically.) */
SPHDEM_HD double wendland_alpha(int dim, double h) {
  return dim == 2 ? 7.0 / (4.0 * M_PI * h * h) : 21.0 / (16.0 * M_PI * h * h * h);
}

/* The terms of a pair that are on (pair_real.h reads them here, not in the parameters, so that a caller can
 * pass them as constants): tensile correction (tensile4: n = 4), viscosity (sphdem_visc), density diffusion
 * (0 off, 1 plain, 2 of the coupled fluid's intrinsic density), its hydrostatic part, the coupling's volume
 * pressure form, XSPH, porous wall particles (coupled), the Monaghan wall repulsion. */
typedef struct {
  int tensile, tensile4, visc, delta, hydro, vol, xsph, porous_walls, rep;
} sphdem_pair_opts;

SPHDEM_HD sphdem_pair_opts pair_opts(const sphdem_dev *D) {
  sphdem_pair_opts O;
  O.tensile = D->P.tensile_eps > 0.0;
  O.tensile4 = D->tensile_n_is_4;
  O.visc = D->P.visc;
  O.delta = D->P.delta > 0.0 ? (D->couple.eos ? 2 : 1) : 0;
  O.hydro = D->P.delta_hydro;
  O.vol = D->couple.pressure_volume_form;
  O.xsph = D->P.xsph_eps > 0.0;
  O.porous_walls = D->couple.wall_porosity != NULL;
  O.rep = D->P.rep_D > 0.0;
  return O;
}

#ifdef __CUDACC__
#define SPHDEM_RINLINE __host__ __device__ static __forceinline__
#else
#define SPHDEM_RINLINE static inline __attribute__((always_inline))
#endif

/* The three components of a vector statement, written out (the float pair loop vectorises across pairs only
 * when no inner loop is left in its body). */
#define SPHDEM_FOR3(d, ...) \
  { const int d = 0; __VA_ARGS__ } { const int d = 1; __VA_ARGS__ } { const int d = 2; __VA_ARGS__ }

/* The pair arithmetic in double (the names as written) and in float (suffix _f, precisions mixed and single). */
#define SPHDEM_REAL double
#define SPHDEM_RNAME(name) name
#define SPHDEM_RSQRT sqrt
#define SPHDEM_RFABS fabs
#define SPHDEM_RPOW pow
#define SPHDEM_RFLOAT 0
#include "pair_real.h"
#define SPHDEM_REAL float
#define SPHDEM_RNAME(name) name##_f
#define SPHDEM_RSQRT sqrtf
#define SPHDEM_RFABS fabsf
#define SPHDEM_RPOW powf
#define SPHDEM_RFLOAT 1
#include "pair_real.h"

/* ---- equation of state ----------------------------------------------------------------- */

/* Tait pressure P = B ((rho/rho0)^gamma - 1) (eq 7 with epsilon = 1). */
SPHDEM_HD double tait_pressure(const sphdem_dev *D, double rho) {
  double r = rho / D->P.rho0, rg;
  if (D->gamma_is_7) { double r3 = r * r * r; rg = r3 * r3 * r; }
  else rg = pow(r, D->P.gamma);
  return D->B * (rg - 1.0);
}

/* Tait inverted, rho = rho0 (P/B + 1)^(1/gamma) (eq 15); the base is kept positive. */
SPHDEM_HD double tait_density(const sphdem_dev *D, double p) {
  double base = p / D->B + 1.0;
  if (base < 1e-3) base = 1e-3;
  return D->P.rho0 * pow(base, 1.0 / D->P.gamma);
}

/* Many ranks with an exchange (sphdem_set_exchange): fluid particle i is another rank's, its rates and
 * coupling sums come from its owner, so the passes skip it. */
SPHDEM_HD int fluid_ghost(const sphdem_dev *D, int64_t i) { return D->xown && D->uidx[i] >= D->nown; }
/* The same for wall particle w: its state comes from its owner (plain fluid, Adami walls). */
SPHDEM_HD int wall_ghost(const sphdem_dev *D, int64_t w) { return D->xwall && D->wtag[w] > D->nwown; }

/* Porosity used in the fluid equations: eq 26 floored at eps_min (1 while the coupling is off). */
SPHDEM_HD double fluid_eps(const sphdem_dev *D, int64_t i) {
  return D->couple.eps ? fmax(D->couple.eps[i], D->couple.eps_floor) : 1.0;
}

/* Density that enters the EOS: rho itself, or the intrinsic density rho_bar / eps when rho is the
 * superficial density of the coupled fluid (He 2018 eq 7: P = B ((rho_bar / (eps rho0))^gamma - 1)). */
SPHDEM_HD double eos_density(const sphdem_dev *D, int64_t i, double rho) {
  return D->couple.eos ? rho / fluid_eps(D, i) : rho;
}

/* Multiphase equation of state of phase k (Shi & Huang 2022 eq 4, or Tait with the phase's rho0),
 * plus the background pressure P0. */
SPHDEM_HD double mp_pressure_k(const sphdem_dev *D, int k, double rho) {
  double r0 = D->mp.M.phase[k].rho0;
  if (D->mp.M.eos == SPHDEM_EOS_LINEAR) return D->mp.ck[k] * D->mp.ck[k] * (rho - r0) + D->mp.M.p0;
  double r = rho / r0, rg;
  if (D->gamma_is_7) { double r3 = r * r * r; rg = r3 * r3 * r; }
  else rg = pow(r, D->P.gamma);
  return D->mp.Bk[k] * (rg - 1.0) + D->mp.M.p0;
}

/* Pressure of fluid particle i at density rho: the phase's EOS (multiphase) or Tait (eq 7). */
SPHDEM_HD double fluid_pressure(const sphdem_dev *D, int64_t i, double rho) {
  if (D->mp.on) return mp_pressure_k(D, D->mp.ph[i], rho);
  return tait_pressure(D, eos_density(D, i, rho));
}

/* Reference density of fluid particle i. */
SPHDEM_HD double fluid_rho0(const sphdem_dev *D, int64_t i) {
  return D->mp.on ? D->mp.M.phase[D->mp.ph[i]].rho0 : D->P.rho0;
}

/* ---- search grid ------------------------------------------------------------------------ */

/* Cell coordinate on one axis of a grid (origin lo, 1/cell inv, n cells): wrapped on periodic axes,
 * clamped otherwise. */
SPHDEM_HD int axis_coord(double x, double lo, double inv, int n, int periodic) {
  /* clamped in double before the cast: a position far outside (or not finite) has no int cell */
  double s = floor((x - lo) * inv);
  if (!(s > -1e9)) s = -1e9;
  if (s > 1e9) s = 1e9;
  int c = (int)s;
  if (periodic) { c %= n; if (c < 0) c += n; }
  else { if (c < 0) c = 0; if (c >= n) c = n - 1; }
  return c;
}

SPHDEM_HD int grid_coord(const sphdem_dev *D, int d, double x) {
  return axis_coord(x, D->glo[d], D->cs_inv[d], D->nc[d], D->P.periodic[d]);
}

/* Coordinate on the grain (DEM, level 1) grid of the coupling. */
SPHDEM_HD int grain_grid_coord(const sphdem_dev *D, int d, double x) {
  return axis_coord(x, D->couple.gglo[d], D->couple.gcs_inv[d], D->couple.gnc[d], D->P.periodic[d]);
}

SPHDEM_HD int32_t grain_cell_of(const sphdem_dev *D, const double *x) {
  int cx = grain_grid_coord(D, 0, x[0]), cy = grain_grid_coord(D, 1, x[1]);
  int cz = D->P.dim == 3 ? grain_grid_coord(D, 2, x[2]) : 0;
  return (int32_t)(((int64_t)cz * D->couple.gnc[1] + cy) * D->couple.gnc[0] + cx);
}

SPHDEM_HD int32_t cell_of(const sphdem_dev *D, const double *x) {
  int cx = grid_coord(D, 0, x[0]), cy = grid_coord(D, 1, x[1]);
  int cz = D->P.dim == 3 ? grid_coord(D, 2, x[2]) : 0;
  return (int32_t)(((int64_t)cz * D->nc[1] + cy) * D->nc[0] + cx);
}

/* Cells adjacent to cell c (itself included), periodic wrap where set; returns the count. */
SPHDEM_HD int neighbor_cells(const sphdem_dev *D, int32_t c, int32_t *out) {
  int nx = D->nc[0], ny = D->nc[1], nz = D->nc[2];
  int cx = c % nx, cy = (c / nx) % ny, cz = c / (nx * ny);
  int kz = D->P.dim == 3 ? 1 : 0, n = 0;
  for (int dz = -kz; dz <= kz; dz++) {
    int z = cz + dz;
    if (z < 0 || z >= nz) { if (!D->P.periodic[2] || D->P.dim != 3) continue; z = (z + nz) % nz; }
    for (int dy = -1; dy <= 1; dy++) {
      int y = cy + dy;
      if (y < 0 || y >= ny) { if (!D->P.periodic[1]) continue; y = (y + ny) % ny; }
      for (int dx = -1; dx <= 1; dx++) {
        int x = cx + dx;
        if (x < 0 || x >= nx) { if (!D->P.periodic[0]) continue; x = (x + nx) % nx; }
        out[n++] = (int32_t)(((int64_t)z * ny + y) * nx + x);
      }
    }
  }
  return n;
}

/* Particle sets (fluid, wall, grain) as the sorts see them. */
SPHDEM_HD int64_t set_count(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->nf : set == SPHDEM_SET_WALL ? D->nw : D->couple.ng;
}
SPHDEM_HD const double *set_x(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->x : set == SPHDEM_SET_WALL ? D->wx : D->couple.gx;
}
SPHDEM_HD const int64_t *set_tag(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->tag : set == SPHDEM_SET_WALL ? D->wtag : D->couple.gtag;
}
SPHDEM_HD int32_t *set_cell(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->cell : set == SPHDEM_SET_WALL ? D->wcell : D->couple.gcell;
}
SPHDEM_HD int32_t *set_cstart(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->cstart : set == SPHDEM_SET_WALL ? D->wcstart : D->couple.gcstart;
}
SPHDEM_HD int32_t *set_cend(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_FLUID ? D->cend : set == SPHDEM_SET_WALL ? D->wcend : D->couple.gcend;
}
SPHDEM_HD int64_t set_ncells(const sphdem_dev *D, int set) {
  return set == SPHDEM_SET_GRAIN ? D->couple.gncells : D->ncells;
}
SPHDEM_HD int32_t set_cell_of(const sphdem_dev *D, int set, const double *x) {
  return set == SPHDEM_SET_GRAIN ? grain_cell_of(D, x) : cell_of(D, x);
}

/* r_ab = x_a - x_b with the minimum image on periodic axes; returns |r_ab|^2. */
SPHDEM_HD double separation(const sphdem_dev *D, const double *xa, const double *xb, double *r) {
  double r2 = 0.0;
  for (int d = 0; d < 3; d++) {
    if (d >= D->P.dim) { r[d] = 0.0; continue; }
    double s = xa[d] - xb[d];
    if (D->P.periodic[d]) s -= D->L[d] * rint(s / D->L[d]);
    r[d] = s;
    r2 += s * s;
  }
  return r2;
}

/* ---- per-particle passes ------------------------------------------------------------------ */

/* Velocity Verlet with one force evaluation: rho and v are at the half step when the rates are
 * computed, x at the full step; predict rho and v to the full step (as LAMMPS' vest) so that the
 * pressure does not lag the positions (a lag that makes still water unstable at CFL 0.2). */
/* Keyword isolated: a particle whose kernel sum is below the threshold keeps its EOS density at or above the
 * reference (superficial density: eps rho0), so it never pulls on its few neighbours. A floor only: compression
 * and its release are left alone. Applied where the density changes: predict, kick. */
SPHDEM_HD double isolated_floor(const sphdem_dev *D, int64_t i, double rho) {
  if (!D->iso.ok || !(D->iso.ksum[i] < D->P.isolated)) return rho;
  double rmin = fluid_rho0(D, i) * (D->couple.eos ? fluid_eps(D, i) : 1.0);
  return rho < rmin ? rmin : rho;
}

SPHDEM_HD void predict_body(const sphdem_dev *D, int64_t i) {
  D->rho[i] = isolated_floor(D, i, D->rho[i]);
  double rp = isolated_floor(D, i, D->rho[i] + D->pred_dth * D->drho[i]);
  D->rhop[i] = rp;
  D->p[i] = fluid_pressure(D, i, rp);
  D->pr2[i] = D->p[i] / (rp * rp);
  for (int d = 0; d < 3; d++) D->ve[3 * i + d] = D->v[3 * i + d] + D->pred_dth * D->a[3 * i + d];
}

/* Adds V_w W(x - x_w) of the wall particles of SPH cell c to *s (V_w = m_w / rho0, Adami), with the kernel of
 * normalisation alpha, 1/h inv_h and support^2 support2 (the fluid's or the coupling's). */
SPHDEM_HD void wall_volume_sum_cell(const sphdem_dev *D, const double *x, int64_t c, double alpha, double inv_h,
                                    double support2, double *s) {
  double r[3];
  if (D->nw == 0) return;
  for (int32_t w = D->wcstart[c]; w < D->wcend[c]; w++) {
    double r2 = separation(D, x, D->wx + 3 * w, r);
    if (r2 < support2) *s += D->wmass[w] / D->P.rho0 * wendland_w(alpha, sqrt(r2) * inv_h);
  }
}

/* Kernel sum of fluid particle i, sum_b V_b W_ib over the fluid (V_b = m_b / rho_b, i itself included) and the
 * wall particles (V_w = m_w / rho0, Adami): ~1 inside the fluid and beside walls, ~0.6 at a flat free surface,
 * less for drops and thin jets (keyword isolated). */
SPHDEM_HD void ksum_body(const sphdem_dev *D, int64_t i) {
  const double *xi = D->x + 3 * i;
  double s = 0.0, r[3];
  int32_t cells[27];
  int nn = neighbor_cells(D, D->cell[i], cells);
  for (int k = 0; k < nn; k++)
    for (int32_t b = D->cstart[cells[k]]; b < D->cend[cells[k]]; b++) {
      double r2 = separation(D, xi, D->x + 3 * b, r);
      if (r2 < D->support2) s += D->mass[b] / D->rho[b] * wendland_w(D->alphaD, sqrt(r2) * D->inv_h);
    }
  for (int k = 0; k < nn; k++) wall_volume_sum_cell(D, xi, cells[k], D->alphaD, D->inv_h, D->support2, &s);
  D->iso.ksum[i] = s;
}

/* Adami generalized wall condition at wall particle w (eqs 13-15): sums over the fluid particles f within
 * the support (wall_state_add, one per f), then the wall's extrapolated state (wall_state_finish).
 * wall_state_body walks the 3^dim SPH cells around w; the CPU backend feeds the same sums from a
 * wall -> fluid list (sph_cpu.c), in the same order where no cell wraps periodically. */
typedef struct { double sw, spw, srr[3], sv[3], se; } wall_state_acc;

SPHDEM_HD void wall_state_add(const sphdem_dev *D, const double *xw, int32_t f, wall_state_acc *A) {
  double r[3];
  double r2 = separation(D, xw, D->x + 3 * f, r); /* r_wf = r_w - r_f */
  if (r2 >= D->support2) return;
  double W = wendland_w(D->alphaD, sqrt(r2) * D->inv_h);
  A->sw += W;
  A->spw += D->p[f] * W;
  /* coupled: the intrinsic density carries the hydrostatic gradient (eos_density is rho when uncoupled) */
  double rf = eos_density(D, f, D->rho[f]);
  for (int d = 0; d < 3; d++) { A->srr[d] += rf * r[d] * W; A->sv[d] += D->v[3 * f + d] * W; }
  if (D->couple.wall_porosity) A->se += fluid_eps(D, f) * W;
}

SPHDEM_HD void wall_state_finish(const sphdem_dev *D, int64_t w, const wall_state_acc *A) {
  double sw = A->sw;
  /* coupled, superficial density: the wall particle carries the porosity of the fluid beside it (extrapolated
   * like eqs 13-14), so that fluid-wall pairs see the same mixture as fluid-fluid pairs */
  if (D->couple.wall_porosity) D->couple.wall_porosity[w] = sw > 0.0 ? A->se / sw : 1.0;
  const double *vw = D->wv + 3 * w, *aw = D->wa + 3 * w;
  double pw = 0.0;
  if (sw > 0.0) {
    double ga = 0.0;
    for (int d = 0; d < D->P.dim; d++) ga += (D->P.gravity[d] - aw[d]) * A->srr[d];
    pw = (A->spw + ga) / sw;                                         /* eq 14 */
    if (D->P.wall_clamp && pw < 0.0) pw = 0.0;
    for (int d = 0; d < 3; d++) D->wvx[3 * w + d] = 2.0 * vw[d] - A->sv[d] / sw; /* eq 13 */
  } else {
    for (int d = 0; d < 3; d++) D->wvx[3 * w + d] = vw[d];
  }
  D->wp[w] = pw;
  D->wrho[w] = tait_density(D, pw);                                  /* eq 15 */
}

SPHDEM_HD void wall_state_body(const sphdem_dev *D, int64_t w) {
  if (wall_ghost(D, w)) return; /* its owner's state arrives by the exchange */
  const double *xw = D->wx + 3 * w;
  wall_state_acc A = {0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.0};
  int32_t cells[27];
  int nn = neighbor_cells(D, D->wcell[w], cells);
  for (int k = 0; k < nn; k++)
    for (int32_t f = D->cstart[cells[k]]; f < D->cend[cells[k]]; f++) wall_state_add(D, xw, f, &A);
  wall_state_finish(D, w, &A);
}

/* Accumulators of one fluid particle's rates (the one fluid rate pass, fluid_rates.h). */
typedef struct {
  const double *xa, *va;
  double rhoa, pra, drho, acc[3], u[3];
  double epsa;          /* porosity of a (1 without coupling) */
  /* delta-plus fluid only (D->mp.on; dplus_init in mp_bodies.h): a's side of the pair terms in double and, in the
   * precisions mixed and single, in float (pair_real.h); its pressure, viscosity and phase */
  dplus_side A;
  dplus_side_f Af;
  double pa, mua;
  int pha;
} rates_acc;

/* The precision (sphdem_params.precision) decides how a pair is evaluated: in double, or the pair terms in float (pair_real.h, suffix _f) from the double separation (mixed) or from float positions (single);
 * the sums stay double. */
SPHDEM_HD int pair_in_float(const sphdem_dev *D) { return D->P.precision != SPHDEM_PREC_DOUBLE; }

/* The separation r_ab = x_a - x_b in float (minimum image on periodic axes) of the two positions rounded to
 * float (precision single) or of their double difference (mixed); returns |r_ab|^2 in float, or -1 when the
 * pair is out of reach (r >= 2h) or coincident. */
SPHDEM_HD float separation_f(const sphdem_dev *D, const double *xa, const double *xb, float *r) {
  if (D->P.precision == SPHDEM_PREC_SINGLE) {
    float r2 = 0.0f;
    for (int d = 0; d < 3; d++) {
      if (d >= D->P.dim) { r[d] = 0.0f; continue; }
      float s = (float)xa[d] - (float)xb[d];
      if (D->P.periodic[d]) { float L = (float)D->L[d]; s -= L * rintf(s / L); }
      r[d] = s;
      r2 += s * s;
    }
    return r2 >= (float)D->support2 || r2 == 0.0f ? -1.0f : r2;
  }
  double rd[3], r2 = separation(D, xa, xb, rd);
  if (r2 >= D->support2 || r2 == 0.0) return -1.0f;
  for (int d = 0; d < 3; d++) r[d] = (float)rd[d];
  return (float)r2;
}

/* Plain-fluid pair (a, b): continuity (eq 6), delta-SPH, momentum (eqs 9-11) and XSPH (eq 12) per unit mass of
 * the partner (fluid_pair_core of pair_real.h); 0 if out of reach. In double, and in float (the precisions
 * mixed and single; fluid_pair_terms picks by the precision). */
SPHDEM_RINLINE int fluid_pair_terms_double(const sphdem_dev *D, const pair_consts *K, sphdem_pair_opts O,
                                           const double *xa, const double *va, double rhoa, double pra, double epsa,
                                           int32_t b, fluid_pair_rec *P) {
  double r[3], vab[3];
  const double r2 = separation(D, xa, D->x + 3 * b, r);
  if (r2 >= D->support2 || r2 == 0.0) return 0;
  for (int d = 0; d < 3; d++) vab[d] = va[d] - D->ve[3 * b + d];
  const double epsb = O.delta == 2 ? fluid_eps(D, b) : 1.0;
  fluid_pair_core(K, O, r, r2, vab, rhoa, pra, epsa, D->rhop[b], D->pr2[b], epsb, P);
  return 1;
}

/* A pair record evaluated in float, into the record the double sums read. */
SPHDEM_HD void pair_rec_from_f(const fluid_pair_rec_f *Q, fluid_pair_rec *P) {
  P->cont = Q->cont; P->dda = Q->dda; P->ddb = Q->ddb;
  for (int d = 0; d < 3; d++) { P->A[d] = Q->A[d]; P->U[d] = Q->U[d]; }
}

SPHDEM_HD int fluid_pair_terms_float(const sphdem_dev *D, const double *xa, const double *va, double rhoa,
                                     double pra, double epsa, int32_t b, fluid_pair_rec *P) {
  float r[3], vab[3];
  const float r2 = separation_f(D, xa, D->x + 3 * b, r);
  if (r2 < 0.0f) return 0;
  for (int d = 0; d < 3; d++) vab[d] = (float)(va[d] - D->ve[3 * b + d]);
  const double epsb = D->P.delta > 0.0 && D->couple.eos ? fluid_eps(D, b) : 1.0;
  fluid_pair_rec_f Q;
  fluid_pair_core_f(&D->Kf, pair_opts(D), r, r2, vab, (float)rhoa, (float)pra, (float)epsa, (float)D->rhop[b], (float)D->pr2[b],
                    (float)epsb, &Q);
  pair_rec_from_f(&Q, P);
  return 1;
}

SPHDEM_HD int fluid_pair_terms(const sphdem_dev *D, const double *xa, const double *va, double rhoa,
                               double pra, double epsa, int32_t b, fluid_pair_rec *P) {
  if (pair_in_float(D)) return fluid_pair_terms_float(D, xa, va, rhoa, pra, epsa, b, P);
  return fluid_pair_terms_double(D, &D->K, pair_opts(D), xa, va, rhoa, pra, epsa, b, P);
}

/* Wall neighbour w of a, plain fluid: Adami wall state (eqs 13-15) in continuity and momentum, Monaghan
 * repulsion (wall_pair_core of pair_real.h, in the precision's real type). */
SPHDEM_RINLINE void plain_wall_pair(const sphdem_dev *D, rates_acc *R, int32_t w) {
  const double ew = D->couple.wall_porosity ? D->couple.wall_porosity[w] : 1.0;
  if (pair_in_float(D)) {
    float r[3], vw[3], vv[3], drho = 0.0f, acc[3] = {0.0f, 0.0f, 0.0f};
    const float r2 = separation_f(D, R->xa, D->wx + 3 * w, r);
    if (r2 < 0.0f) return;
    for (int d = 0; d < 3; d++) {
      vw[d] = (float)(R->va[d] - D->wv[3 * w + d]);
      vv[d] = (float)(R->va[d] - D->wvx[3 * w + d]);
    }
    wall_pair_core_f(&D->Kf, pair_opts(D), r, r2, vw, vv, (float)R->rhoa, (float)R->pra, (float)D->wmass[w], (float)D->wrho[w],
                     (float)D->wp[w], (float)ew, &drho, acc);
    R->drho += drho;
    for (int d = 0; d < 3; d++) R->acc[d] += acc[d];
    return;
  }
  double r[3], vw[3], vv[3];
  const double r2 = separation(D, R->xa, D->wx + 3 * w, r);
  if (r2 >= D->support2 || r2 == 0.0) return;
  for (int d = 0; d < 3; d++) {
    vw[d] = R->va[d] - D->wv[3 * w + d];   /* prescribed wall velocity: no penetration */
    vv[d] = R->va[d] - D->wvx[3 * w + d];  /* eq 13: extrapolated, no slip */
  }
  wall_pair_core(&D->K, pair_opts(D), r, r2, vw, vv, R->rhoa, R->pra, D->wmass[w], D->wrho[w], D->wp[w], ew, &R->drho, R->acc);
}

/* Kernel interpolation at probe point k (He 2018 eq 4, Shepard-normalised). */
SPHDEM_HD void probe_body(const sphdem_dev *D, const double *pts, double *out, int64_t k) {
  const double *xp = pts + 3 * k;
  double s = 0.0, sp = 0.0, sr = 0.0, sv[3] = {0, 0, 0}, r[3];
  int32_t cells[27];
  int nn = neighbor_cells(D, cell_of(D, xp), cells);
  for (int c = 0; c < nn; c++)
    for (int32_t b = D->cstart[cells[c]]; b < D->cend[cells[c]]; b++) {
      double r2 = separation(D, xp, D->x + 3 * b, r);
      if (r2 >= D->support2) continue;
      double rho = D->rho[b], w = D->mass[b] / rho * wendland_w(D->alphaD, sqrt(r2) * D->inv_h);
      s += w;
      sp += w * fluid_pressure(D, b, rho);
      sr += w * rho;
      for (int d = 0; d < 3; d++) sv[d] += w * D->v[3 * b + d];
    }
  double *o = out + SPHDEM_NPROBE * k, inv = s > 0.0 ? 1.0 / s : 0.0;
  o[0] = sp * inv; o[1] = sr * inv;
  for (int d = 0; d < 3; d++) o[2 + d] = sv[d] * inv;
  o[5] = s;
}

/* Neighbour-list build (CPU backend): candidates within 2h + skin of fluid particle a in the
 * fluid (set 0) or wall (set 1) cells, in cell-walk order; half: fluid neighbours b > a only (each
 * pair once, for the symmetric CPU pass). out NULL: count only. */
SPHDEM_HD int32_t list_body(const sphdem_dev *D, int64_t a, int set, int half, int32_t *out) {
  const double *xa = D->x + 3 * a, *xs = set == 0 ? D->x : D->wx;
  const int32_t *cs = set == 0 ? D->cstart : D->wcstart, *ce = set == 0 ? D->cend : D->wcend;
  double rc = 2.0 * D->h + D->P.skin, rc2 = rc * rc, r[3];
  int32_t cells[27], n = 0;
  const int gha = fluid_ghost(D, a);
  int nn = neighbor_cells(D, D->cell[a], cells);
  for (int k = 0; k < nn; k++)
    for (int32_t b = cs[cells[k]]; b < ce[cells[k]]; b++) {
      if (set == 0 && (half ? b <= a : b == a)) continue;
      if (set == 0 && half && gha && fluid_ghost(D, b)) continue; /* two ghosts: neither side is this rank's */
      if (separation(D, xa, xs + 3 * b, r) >= rc2) continue;
      if (out) out[n] = b;
      n++;
    }
  return n;
}

/* Precision single: the state (x, v, rho) and its rates are kept at float precision, rounded after each update
 * (the arrays stay double); the other precisions keep them in double. */
SPHDEM_HD double state_round(const sphdem_dev *D, double v) {
  return D->P.precision == SPHDEM_PREC_SINGLE ? (double)(float)v : v;
}

SPHDEM_HD void kick_body(const sphdem_dev *D, int64_t i, double dth) {
  for (int d = 0; d < D->P.dim; d++) D->v[3 * i + d] = state_round(D, D->v[3 * i + d] + dth * D->a[3 * i + d]);
  D->rho[i] = state_round(D, isolated_floor(D, i, D->rho[i] + dth * D->drho[i]));
}

SPHDEM_HD void drift_body(const sphdem_dev *D, int64_t i, double dt) {
  for (int d = 0; d < D->P.dim; d++) {
    double x = D->x[3 * i + d] + dt * (D->v[3 * i + d] + D->u[3 * i + d]);
    if (D->P.periodic[d]) {
      double lo = D->P.boxlo[d], L = D->L[d];
      if (x < lo) x += L; else if (x >= lo + L) x -= L;
    }
    D->x[3 * i + d] = state_round(D, x);
  }
}

/* Fourth-order Runge-Kutta (Shi & Huang 2022 §3.5) on (x, v, rho) with the rates dx/dt = v + u
 * (XSPH / shifting), dv/dt = a, drho/dt = drho. mode 0: save the state at t_n, clear the sums. mode 1:
 * add wk times the rates of the current stage to the sums and move the state to state_n + cst * rates
 * (the next stage's state). mode 2: add wk times the rates, state = state_n + sums (the step's end). */
SPHDEM_HD void rk_stage_body(const sphdem_dev *D, int64_t i, int mode, double wk, double cst) {
  if (mode == 0) {
    for (int d = 0; d < 3; d++) {
      D->rk.x0[3 * i + d] = D->x[3 * i + d]; D->rk.v0[3 * i + d] = D->v[3 * i + d];
      D->rk.dx[3 * i + d] = D->rk.dv[3 * i + d] = 0.0;
    }
    D->rk.rho0[i] = D->rho[i];
    D->rk.drho[i] = 0.0;
    return;
  }
  for (int d = 0; d < D->P.dim; d++) {
    double kx = D->v[3 * i + d] + D->u[3 * i + d], kv = D->a[3 * i + d];
    D->rk.dx[3 * i + d] += wk * kx;
    D->rk.dv[3 * i + d] += wk * kv;
    double x = D->rk.x0[3 * i + d] + (mode == 2 ? D->rk.dx[3 * i + d] : cst * kx);
    if (D->P.periodic[d]) {
      double lo = D->P.boxlo[d], L = D->L[d];
      if (x < lo) x += L; else if (x >= lo + L) x -= L;
    }
    D->x[3 * i + d] = state_round(D, x);
    D->v[3 * i + d] = state_round(D, D->rk.v0[3 * i + d] + (mode == 2 ? D->rk.dv[3 * i + d] : cst * kv));
  }
  D->rk.drho[i] += wk * D->drho[i];
  D->rho[i] = state_round(D, D->rk.rho0[i] + (mode == 2 ? D->rk.drho[i] : cst * D->drho[i]));
}

/* ---- reductions ---------------------------------------------------------------------------- */

SPHDEM_HD void red_init(sphdem_red *r) {
  r->v2max = r->a2max = r->rhoerr = r->ke = r->disp2max = r->edisp2max = 0.0;
  for (int d = 0; d < 3; d++) { r->lo[d] = 1e300; r->hi[d] = -1e300; }
  r->nnan = r->nlost = 0;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) r->v2ph[k] = 0.0;
  r->numax = 0.0;
}

SPHDEM_HD void red_combine(sphdem_red *r, const sphdem_red *o) {
  r->v2max = fmax(r->v2max, o->v2max);
  r->a2max = fmax(r->a2max, o->a2max);
  r->rhoerr = fmax(r->rhoerr, o->rhoerr);
  r->disp2max = fmax(r->disp2max, o->disp2max);
  r->edisp2max = fmax(r->edisp2max, o->edisp2max);
  r->ke += o->ke;
  for (int d = 0; d < 3; d++) { r->lo[d] = fmin(r->lo[d], o->lo[d]); r->hi[d] = fmax(r->hi[d], o->hi[d]); }
  r->nnan += o->nnan;
  r->nlost += o->nlost;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) r->v2ph[k] = fmax(r->v2ph[k], o->v2ph[k]);
  r->numax = fmax(r->numax, o->numax);
}

/* max and min of the reductions as fmax / fmin for a NaN in b (a is kept), inline on the CPU too (libm's fmax is a
 * call; the reduction runs over every particle each step) */
SPHDEM_HD double red_max(double a, double b) { return b > a ? b : a; }
SPHDEM_HD double red_min(double a, double b) { return b < a ? b : a; }

/* Adds particle i of the set to r: fluid stats, displacement since the last sort, bounding box. */
SPHDEM_HD void red_body(const sphdem_dev *D, int set, int64_t i, sphdem_red *r) {
  const double *x = set == SPHDEM_SET_FLUID ? D->x + 3 * i : D->wx + 3 * i;
  for (int d = 0; d < D->P.dim; d++) { r->lo[d] = red_min(r->lo[d], x[d]); r->hi[d] = red_max(r->hi[d], x[d]); }
  if (set != SPHDEM_SET_FLUID) return;
  double v2 = 0.0, a2 = 0.0, s2 = 0.0, rr[3];
  if (D->uidx[i] >= D->nown) { /* a ghost copy: its displacement decides a resort, its state is its owner's */
    if (isfinite(x[0] + x[1] + x[2])) r->disp2max = red_max(r->disp2max, separation(D, x, D->x0 + 3 * i, rr));
    else r->disp2max = 1e300;
    return;
  }
  int bad = !isfinite(D->rho[i]), lost = 0;
  for (int d = 0; d < D->P.dim; d++) {
    double vd = D->v[3 * i + d], ad = D->a[3 * i + d];
    v2 += vd * vd; a2 += ad * ad;
    if (!isfinite(x[d]) || !isfinite(vd)) bad = 1;
    if (!D->P.periodic[d] && (x[d] < D->P.boxlo[d] || x[d] > D->P.boxhi[d])) lost = 1;
  }
  s2 = separation(D, x, D->x0 + 3 * i, rr);
  r->v2max = red_max(r->v2max, v2);
  r->a2max = red_max(r->a2max, a2);
  r->rhoerr = red_max(r->rhoerr, fabs(eos_density(D, i, D->rho[i]) / fluid_rho0(D, i) - 1.0)); /* intrinsic when coupled */
  if (D->mp.on) {
    int k = D->mp.ph[i];
    r->v2ph[k] = red_max(r->v2ph[k], v2);
    if (D->mp.mu_p) r->numax = red_max(r->numax, D->mp.mu_p[i] / D->rho[i]);
  }
  r->disp2max = red_max(r->disp2max, s2);
  double e2 = 0.0; /* no minimum image: a particle wrapped through a periodic boundary has moved by the period, as the
                    * engine, whose ghosts are images made at the build, counts it */
  for (int d = 0; d < D->P.dim; d++) e2 += (x[d] - D->xe[3 * i + d]) * (x[d] - D->xe[3 * i + d]);
  r->edisp2max = red_max(r->edisp2max, e2);
  r->ke += 0.5 * D->mass[i] * v2;
  r->nnan += bad;
  r->nlost += lost;
  if (bad) r->disp2max = r->edisp2max = 1e300; /* force a resort attempt (and a neighbour build) to be safe */
}

/* Cell-range tables from a cell-sorted cell array (cstart/cend zeroed beforehand). */
SPHDEM_HD void cell_range_body(const int32_t *cell, int64_t n, int64_t i, int32_t *cstart, int32_t *cend) {
  int32_t c = cell[i];
  if (i == 0 || cell[i - 1] != c) cstart[c] = (int32_t)i;
  if (i == n - 1 || cell[i + 1] != c) cend[c] = (int32_t)(i + 1);
}

/* Gather of 32-bit words: dst element i = src element perm[i] (elements of ew words). */
SPHDEM_HD void gather_words_body(uint32_t *dst, const uint32_t *src, const int32_t *perm, int ew, int64_t i) {
  const uint32_t *s = src + (int64_t)perm[i] * ew;
  for (int k = 0; k < ew; k++) dst[i * ew + k] = s[k];
}

/* Sort key: cell-major, tag-minor, so the device order does not depend on the upload order. */
SPHDEM_HD uint64_t sort_key(int32_t cell, int64_t tag) {
  return ((uint64_t)(uint32_t)cell << 36) | ((uint64_t)tag & ((1ull << 36) - 1));
}

#endif
