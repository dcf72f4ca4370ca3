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

/* W(q) (eq 5). */
SPHDEM_HD double wendland_w(double alphaD, double q) {
  if (q >= 2.0) return 0.0;
  double t = 1.0 - 0.5 * q, t2 = t * t;
  return alphaD * t2 * t2 * (1.0 + 2.0 * q);
}

/* F(q) such that grad_a W_ab = F * r_ab (r_ab = r_a - r_b): F = dW/dr / r = -5 alpha_D (1-q/2)^3 / h^2. */
SPHDEM_HD double wendland_grad_factor(double alphaD, double inv_h, double q) {
  if (q >= 2.0) return 0.0;
  double t = 1.0 - 0.5 * q;
  return -5.0 * alphaD * t * t * t * inv_h * inv_h;
}

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

/* Pairwise momentum terms shared by fluid-fluid and fluid-wall pairs: pressure (eq 9) with the
 * tensile correction (eq 11) and the viscous term (eq 10 Morris, or Monaghan artificial).
 * pra/prb are P/rho^2 of a and b, ie = 1/(r^2 + 0.01 h^2), vab the velocity difference seen by
 * viscosity. Adds to acc. */
SPHDEM_HD void pair_momentum(const sphdem_dev *D, double mb, double pra, double rhoa, double prb,
                             double rhob, double W, double F, const double *r, double r2, double ie,
                             const double *vab, double *acc) {
  double pterm = pra + prb;
  if (D->P.tensile_eps > 0.0) {
    /* eq 11, with |P| so that the correction is repulsive for negative pressures too */
    double f = W * D->w_dx_inv, fn;
    if (D->tensile_n_is_4) { fn = f * f; fn *= fn; } else fn = pow(f, D->P.tensile_n);
    pterm += D->P.tensile_eps * (fabs(pra) + fabs(prb)) * fn;
  }
  double s = -mb * pterm * F; /* -m_b (...) grad W, grad W = F r */
  if (D->P.visc == SPHDEM_VISC_MORRIS) {
    /* eq 10: m_b (mu_a + mu_b) r.gradW / (rho_a rho_b (r^2 + 0.01 h^2)) v_ab */
    double k = mb * 2.0 * D->P.mu * F * r2 * ie / (rhoa * rhob);
    for (int d = 0; d < 3; d++) acc[d] += k * vab[d];
  } else if (D->P.visc == SPHDEM_VISC_ARTIFICIAL) {
    double vr = 0.0;
    for (int d = 0; d < 3; d++) vr += vab[d] * r[d];
    if (vr < 0.0) {
      double muab = D->h * vr * ie;
      s += mb * D->P.alpha * D->P.c0 * muab * F * 2.0 / (rhoa + rhob); /* -m_b Pi_ab grad W */
    }
  }
  for (int d = 0; d < 3; d++) acc[d] += s * r[d];
}

/* Keyword pressure_form of the coupling: the pair (a, b) in volume form, force on a from b -V_a V_b (P_a + P_b) grad W
 * and continuity rho_a sum_b V_b v_ab.grad W (V = m / rho), is the mass form's pair with P_a/rho_a^2 scaled by
 * *ka = rho_a/rho_b, P_b/rho_b^2 by *kb = rho_b/rho_a and a's continuity term by ka. Both 1 in the mass form (eq 9). */
SPHDEM_HD void pair_form_factors(const sphdem_dev *D, double rhoa, double rhob, double *ka, double *kb) {
  *ka = D->couple.pressure_volume_form ? rhoa / rhob : 1.0;
  *kb = D->couple.pressure_volume_form ? rhob / rhoa : 1.0;
}

/* delta-SPH density diffusion between fluid particles a and b (Molteni & Colagrossi 2009):
 * delta h c0 sum_b psi_ab . grad_a W V_b, psi_ab = 2 (rho_b - rho_a - rho^H_ab) r_ba / (r^2 + 0.01 h^2);
 * returned per unit mass of b (V_b = m_b / rho_b: the caller multiplies by m_b).
 * rho^H_ab is the hydrostatic part of rho_b - rho_a (Fourtakas et al. 2019), linearised in the
 * Tait law: rho^H_ab = -rho0 g.r_ab / c0^2 (relative error O(rho0 g dz / B)). */
SPHDEM_HD double density_diffusion(const sphdem_dev *D, double rhoa, double rhob, double F,
                                   const double *r, double r2, double ie) {
  double drh = rhob - rhoa;
  if (D->P.delta_hydro) {
    double gr = 0.0;
    for (int d = 0; d < D->P.dim; d++) gr += D->P.gravity[d] * r[d];
    drh += D->P.rho0 * gr / (D->P.c0 * D->P.c0);
  }
  return -2.0 * D->P.delta * D->h * D->P.c0 * drh * F * r2 * ie / rhob;
}

/* XSPH (He 2018 eq 12): a moves with v_a + sum_b m_b xsph_weight (v_a - v_b); 0 with xsph off. */
SPHDEM_HD double xsph_weight(const sphdem_dev *D, double rhoa, double rhob, double W) {
  return D->P.xsph_eps > 0.0 ? -D->P.xsph_eps / (0.5 * (rhoa + rhob)) * W : 0.0;
}

/* Accumulators of one fluid particle's rates (the one fluid rate pass, fluid_rates.h). */
typedef struct {
  const double *xa, *va;
  double rhoa, pra, drho, acc[3], u[3];
  double epsa;          /* porosity of a (1 without coupling) */
  /* delta-plus fluid only (D->mp.on; dplus_init in mp_bodies.h): shift velocity, volume, pressure, viscosity,
   * diffusion constants and <grad P>^L of a, its phase */
  double dua[3], ma, Va, Va2, pa, paV, mua, ic2, kdiff;
  const double *ga;
  int pha;
} rates_acc;

/* The record of one fluid pair (a, b), for every fluid model. Plain fluid (fluid_pair_terms): per unit mass
 * of the partner; every term is symmetric or antisymmetric in a and b, so one evaluation serves both: a
 * gains m_b (cont + dda) density rate, m_b A acceleration and m_b U XSPH velocity; b gains m_a (cont + ddb),
 * -m_a A and -m_a U (the CPU's half-list pass). Delta-plus fluid (dplus_pair_terms): a's own rates, weight
 * 1 (its shifting terms are not antisymmetric). */
typedef struct {
  double cont, dda, ddb, A[3], U[3];
} fluid_pair_rec;

/* Continuity (eq 6), delta-SPH, momentum (eqs 9-11) and XSPH (eq 12) of the pair; 0 if out of reach. */
SPHDEM_HD int fluid_pair_terms(const sphdem_dev *D, const double *xa, const double *va, double rhoa,
                               double pra, double epsa, int32_t b, fluid_pair_rec *P) {
  double r[3], vab[3];
  double r2 = separation(D, xa, D->x + 3 * b, r);
  if (r2 >= D->support2 || r2 == 0.0) return 0;
  double q = sqrt(r2) * D->inv_h;
  double W = wendland_w(D->alphaD, q), F = wendland_grad_factor(D->alphaD, D->inv_h, q);
  double rhob = D->rhop[b], vdotr = 0.0, ie = 1.0 / (r2 + D->eta2);
  for (int d = 0; d < 3; d++) { vab[d] = va[d] - D->ve[3 * b + d]; vdotr += vab[d] * r[d]; P->A[d] = 0.0; }
  P->cont = vdotr * F;                                                 /* eq 6 */
  P->dda = P->ddb = 0.0;
  if (D->P.delta > 0.0 && D->couple.eos) {
    /* coupled, superficial density rho = eps rho_f: diffuse the intrinsic density rho_f (the EOS variable),
     * not the porosity structure of rho; each side's rate scaled back by its eps (He 2018 eq 7 context) */
    double epsb = fluid_eps(D, b), dd = density_diffusion(D, rhoa / epsa, rhob / epsb, F, r, r2, ie);
    P->dda = epsa * dd * (rhob / epsb) / rhob;  /* density_diffusion divides by rho_f,b; V_b = m_b / rho_b */
    P->ddb = -epsb * dd * (rhob / epsb) / rhoa;
  } else if (D->P.delta > 0.0) {
    P->dda = density_diffusion(D, rhoa, rhob, F, r, r2, ie);
    P->ddb = -P->dda * rhob / rhoa;
  }
  /* pressure_form volume: the extra continuity part rides on dda/ddb, so one record still serves both sides */
  double ka, kb;
  pair_form_factors(D, rhoa, rhob, &ka, &kb);
  if (D->couple.pressure_volume_form) { P->dda += P->cont * (ka - 1.0); P->ddb += P->cont * (kb - 1.0); }
  pair_momentum(D, 1.0, pra * ka, rhoa, D->pr2[b] * kb, rhob, W, F, r, r2, ie, vab, P->A);
  double k2 = xsph_weight(D, rhoa, rhob, W); /* eq 12 */
  for (int d = 0; d < 3; d++) P->U[d] = k2 * vab[d];
  return 1;
}

/* Monaghan 1994 wall repulsion: D [(r0/r)^12 - (r0/r)^4] r_ab / r^2 within r0. */
SPHDEM_HD void wall_repulsion(const sphdem_dev *D, double rr, double r2, const double *r, double *acc) {
  if (!(D->P.rep_D > 0.0) || rr >= D->P.rep_r0) return;
  double s = D->P.rep_r0 / rr, s2 = s * s, s4 = s2 * s2, s12 = s4 * s4 * s4;
  double k3 = D->P.rep_D * (s12 - s4) / r2;
  for (int d = 0; d < 3; d++) acc[d] += k3 * r[d];
}

/* Wall neighbour w of a, plain fluid: Adami wall state (eqs 13-15) in continuity and momentum, Monaghan
 * repulsion. */
SPHDEM_HD void plain_wall_pair(const sphdem_dev *D, rates_acc *R, int32_t w) {
  double r[3], vv[3];
  double r2 = separation(D, R->xa, D->wx + 3 * w, r);
  if (r2 >= D->support2 || r2 == 0.0) return;
  double rr = sqrt(r2), q = rr * D->inv_h;
  double W = wendland_w(D->alphaD, q), F = wendland_grad_factor(D->alphaD, D->inv_h, q);
  /* wall particles keep their volume V_w = m_w / rho0 (Adami 2012); their density follows eq 15 */
  double mb = D->wmass[w] * D->wrho[w] / D->P.rho0, vdotr = 0.0, rw = D->wrho[w];
  if (D->couple.wall_porosity) { mb *= D->couple.wall_porosity[w]; rw *= D->couple.wall_porosity[w]; } /* coupled: superficial wall density eps_w rho_w */
  for (int d = 0; d < 3; d++) {
    vdotr += (R->va[d] - D->wv[3 * w + d]) * r[d];   /* prescribed wall velocity: no penetration */
    vv[d] = R->va[d] - D->wvx[3 * w + d];            /* eq 13: extrapolated, no slip */
  }
  double ka, kb; /* pressure_form (V_w = mb / rw) */
  pair_form_factors(D, R->rhoa, rw, &ka, &kb);
  R->drho += mb * ka * vdotr * F;
  pair_momentum(D, mb, R->pra * ka, R->rhoa, D->wp[w] / (rw * rw) * kb, rw, W, F, r, r2, 1.0 / (r2 + D->eta2), vv,
                R->acc);
  wall_repulsion(D, rr, r2, r, R->acc);
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

SPHDEM_HD void kick_body(const sphdem_dev *D, int64_t i, double dth) {
  for (int d = 0; d < D->P.dim; d++) D->v[3 * i + d] += dth * D->a[3 * i + d];
  D->rho[i] = isolated_floor(D, i, D->rho[i] + dth * D->drho[i]);
}

SPHDEM_HD void drift_body(const sphdem_dev *D, int64_t i, double dt) {
  for (int d = 0; d < D->P.dim; d++) {
    double x = D->x[3 * i + d] + dt * (D->v[3 * i + d] + D->u[3 * i + d]);
    if (D->P.periodic[d]) {
      double lo = D->P.boxlo[d], L = D->L[d];
      if (x < lo) x += L; else if (x >= lo + L) x -= L;
    }
    D->x[3 * i + d] = x;
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
    D->x[3 * i + d] = x;
    D->v[3 * i + d] = D->rk.v0[3 * i + d] + (mode == 2 ? D->rk.dv[3 * i + d] : cst * kv);
  }
  D->rk.drho[i] += wk * D->drho[i];
  D->rho[i] = D->rk.rho0[i] + (mode == 2 ? D->rk.drho[i] : cst * D->drho[i]);
}

/* ---- reductions ---------------------------------------------------------------------------- */

SPHDEM_HD void red_init(sphdem_red *r) {
  r->v2max = r->a2max = r->rhoerr = r->ke = r->disp2max = 0.0;
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
  r->ke += o->ke;
  for (int d = 0; d < 3; d++) { r->lo[d] = fmin(r->lo[d], o->lo[d]); r->hi[d] = fmax(r->hi[d], o->hi[d]); }
  r->nnan += o->nnan;
  r->nlost += o->nlost;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) r->v2ph[k] = fmax(r->v2ph[k], o->v2ph[k]);
  r->numax = fmax(r->numax, o->numax);
}

/* Adds particle i of the set to r: fluid stats, displacement since the last sort, bounding box. */
SPHDEM_HD void red_body(const sphdem_dev *D, int set, int64_t i, sphdem_red *r) {
  const double *x = set == SPHDEM_SET_FLUID ? D->x + 3 * i : D->wx + 3 * i;
  for (int d = 0; d < D->P.dim; d++) { r->lo[d] = fmin(r->lo[d], x[d]); r->hi[d] = fmax(r->hi[d], x[d]); }
  if (set != SPHDEM_SET_FLUID) return;
  double v2 = 0.0, a2 = 0.0, s2 = 0.0, rr[3];
  if (D->uidx[i] >= D->nown) { /* a ghost copy: its displacement decides a resort, its state is its owner's */
    if (isfinite(x[0] + x[1] + x[2])) r->disp2max = fmax(r->disp2max, separation(D, x, D->x0 + 3 * i, rr));
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
  r->v2max = fmax(r->v2max, v2);
  r->a2max = fmax(r->a2max, a2);
  r->rhoerr = fmax(r->rhoerr, fabs(eos_density(D, i, D->rho[i]) / fluid_rho0(D, i) - 1.0)); /* intrinsic when coupled */
  if (D->mp.on) {
    int k = D->mp.ph[i];
    r->v2ph[k] = fmax(r->v2ph[k], v2);
    if (D->mp.mu_p) r->numax = fmax(r->numax, D->mp.mu_p[i] / D->rho[i]);
  }
  r->disp2max = fmax(r->disp2max, s2);
  r->ke += 0.5 * D->mass[i] * v2;
  r->nnan += bad;
  r->nlost += lost;
  if (bad) r->disp2max = 1e300; /* force a resort attempt to be safe */
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
