/* mp_bodies.h - multiphase delta-plus SPH with Herschel-Bulkley phases (Shi & Huang 2022 §2-§3),
 * written once for the CPU loops and the CUDA kernels. Two passes before the rates pass:
 *   mp_grad_body   renormalisation L_i (eq 19), lambda_i (§3.3), <grad P>^L (eq 19), shear rate
 *                  |D_i| (eq 26) and viscosity mu_i (eqs 22-25);
 *   mp_shift_body  shifting velocity du_i (eqs 27-29), only with shifting on;
 * and the delta-plus pair terms of the one fluid rate pass (fluid_rates.h): continuity (eq 15) with
 * diffusion (eqs 16-18), pressure (eq 20), viscous (eq 24) and shifting terms (eq 3), wall pairs, XSPH. */
#ifndef SPHDEM_MP_BODIES_H
#define SPHDEM_MP_BODIES_H

#include "sph_bodies.h"

/* ---- small symmetric 3x3 algebra (6 entries: xx yy zz xy xz yz) ---------------------------------- */

SPHDEM_HD void sym_add_outer(double *S, double c, const double *r) {
  S[0] += c * r[0] * r[0]; S[1] += c * r[1] * r[1]; S[2] += c * r[2] * r[2];
  S[3] += c * r[0] * r[1]; S[4] += c * r[0] * r[2]; S[5] += c * r[1] * r[2];
}

SPHDEM_HD void sym_mul(const double *S, const double *v, double *out) {
  out[0] = S[0] * v[0] + S[3] * v[1] + S[4] * v[2];
  out[1] = S[3] * v[0] + S[1] * v[1] + S[5] * v[2];
  out[2] = S[4] * v[0] + S[5] * v[1] + S[2] * v[2];
}

SPHDEM_HD double sym_get(const double *S, int i, int j) {
  if (i == j) return S[i];
  int k = i + j; /* (0,1) -> 3, (0,2) -> 4, (1,2) -> 5 */
  return S[k == 1 ? 3 : k == 2 ? 4 : 5];
}

/* Smallest eigenvalue (2D: of the xy block; 3D: trigonometric closed form). */
SPHDEM_HD double sym_min_eig(const double *S, int dim) {
  if (dim == 2) {
    double m = 0.5 * (S[0] + S[1]), d = 0.5 * (S[0] - S[1]);
    return m - sqrt(d * d + S[3] * S[3]);
  }
  double p1 = S[3] * S[3] + S[4] * S[4] + S[5] * S[5];
  double q = (S[0] + S[1] + S[2]) / 3.0;
  if (p1 <= 1e-300) return fmin(S[0], fmin(S[1], S[2]));
  double a = S[0] - q, b = S[1] - q, c = S[2] - q;
  double p2 = a * a + b * b + c * c + 2.0 * p1, p = sqrt(p2 / 6.0);
  /* det((S - q I) / p) / 2 */
  double det = a * (b * c - S[5] * S[5]) - S[3] * (S[3] * c - S[5] * S[4]) + S[4] * (S[3] * S[5] - b * S[4]);
  double rr = det / (2.0 * p * p * p);
  rr = fmax(-1.0, fmin(1.0, rr));
  double phi = acos(rr) / 3.0;
  return q + 2.0 * p * cos(phi + 2.0 * M_PI / 3.0);
}

/* Inverse of S (2D: the xy block, zz = 1); 0 if singular. */
SPHDEM_HD int sym_inverse(const double *S, int dim, double *out) {
  if (dim == 2) {
    double det = S[0] * S[1] - S[3] * S[3];
    if (!(fabs(det) > 1e-300)) return 0;
    out[0] = S[1] / det; out[1] = S[0] / det; out[3] = -S[3] / det;
    out[2] = 1.0; out[4] = out[5] = 0.0;
    return 1;
  }
  double c00 = S[1] * S[2] - S[5] * S[5], c01 = S[4] * S[5] - S[3] * S[2], c02 = S[3] * S[5] - S[4] * S[1];
  double det = S[0] * c00 + S[3] * c01 + S[4] * c02;
  if (!(fabs(det) > 1e-300)) return 0;
  double id = 1.0 / det;
  out[0] = c00 * id; out[3] = c01 * id; out[4] = c02 * id;
  out[1] = (S[0] * S[2] - S[4] * S[4]) * id;
  out[5] = (S[4] * S[3] - S[0] * S[5]) * id;
  out[2] = (S[0] * S[1] - S[3] * S[3]) * id;
  return 1;
}

/* ---- rheology -------------------------------------------------------------------------------------- */

/* Herschel-Bulkley apparent viscosity at shear rate gd with the cut-off of eq 23: below gdot_cut the
 * viscosity is held at its cut-off value (Newtonian phases: K at every rate). */
SPHDEM_HD double hb_viscosity(const sphdem_phase *f, double gd) {
  if (f->tau_y == 0.0 && f->N == 1.0) return f->K;
  double g = gd < f->gdot_cut ? f->gdot_cut : gd;
  if (!(g > 0.0)) return f->tau_y > 0.0 ? 1e300 : (f->N > 1.0 ? 0.0 : 1e300);
  return f->tau_y / g + f->K * pow(g, f->N - 1.0);
}


SPHDEM_HD double wall_volume(const sphdem_dev *D, int64_t w) { return D->wmass[w] * D->mp.wvol_inv_rho0; }

/* ---- fixed ghost walls with MLS interpolation (§3.4, eqs 29-31) -------------------------------------- */

/* Solves the (n x n, n <= 4) symmetric system M a = e1 by Gaussian elimination with partial pivoting;
 * 0 if singular (pivot below 1e-12 of the largest diagonal entry). */
SPHDEM_HD int mls_solve_e1(double *M, int n, double *a) {
  double b[4] = {1, 0, 0, 0}, scale = 0.0;
  for (int i = 0; i < n; i++) scale = fmax(scale, fabs(M[5 * i]));
  if (!(scale > 0.0)) return 0;
  for (int k = 0; k < n; k++) {
    int piv = k;
    for (int i = k + 1; i < n; i++) if (fabs(M[4 * i + k]) > fabs(M[4 * piv + k])) piv = i;
    if (fabs(M[4 * piv + k]) < 1e-12 * scale) return 0;
    if (piv != k) {
      for (int j = 0; j < n; j++) { double t = M[4 * k + j]; M[4 * k + j] = M[4 * piv + j]; M[4 * piv + j] = t; }
      double t = b[k]; b[k] = b[piv]; b[piv] = t;
    }
    for (int i = k + 1; i < n; i++) {
      double f = M[4 * i + k] / M[4 * k + k];
      for (int j = k; j < n; j++) M[4 * i + j] -= f * M[4 * k + j];
      b[i] -= f * b[k];
    }
  }
  for (int i = n - 1; i >= 0; i--) {
    double s = b[i];
    for (int j = i + 1; j < n; j++) s -= M[4 * i + j] * a[j];
    a[i] = s / M[4 * i + i];
  }
  return 1;
}

/* Ghost wall particle w: MLS interpolation of the fluid at its mirror point x_I (eq 30), pressure with
 * the hydrostatic offset (eq 29), no-slip velocity (eq 31 as 2 v_wall - u_I), ghost viscosity of the
 * phase with the larger M11 share (multiphase). */
SPHDEM_HD void mls_wall_state_body(const sphdem_dev *D, int64_t w) {
  const double *xi = D->ghost.wxi + 3 * w, *xw = D->wx + 3 * w;
  int dim = D->P.dim, nb = dim + 1;
  double M[16], m11[SPHDEM_MAX_PHASES], r[3], b[4], a[4] = {1, 0, 0, 0};
  for (int k = 0; k < 16; k++) M[k] = 0.0;
  for (int k = 0; k < SPHDEM_MAX_PHASES; k++) m11[k] = 0.0;
  int32_t cells[27];
  int nn = neighbor_cells(D, cell_of(D, xi), cells);
  for (int k = 0; k < nn; k++)
    for (int32_t f = D->cstart[cells[k]]; f < D->cend[cells[k]]; f++) {
      double r2 = separation(D, D->x + 3 * f, xi, r); /* x_f - x_I */
      if (r2 >= D->support2) continue;
      double WV = wendland_w(D->alphaD, sqrt(r2) * D->inv_h) * D->mass[f] / D->rhop[f];
      b[0] = 1.0;
      for (int d = 0; d < dim; d++) b[1 + d] = r[d];
      for (int i = 0; i < nb; i++) for (int j = 0; j < nb; j++) M[4 * i + j] += b[i] * b[j] * WV;
      if (D->mp.on) m11[D->mp.ph[f]] += WV;
    }
  /* W_MLS(x_f) = (M^-1 e1) . b_f W; where the kernel support at x_I is truncated (free surface: Shepard
   * sum M11 below 0.7) the linear fit extrapolates wildly, so the Shepard interpolation is used there */
  int mls = M[0] >= 0.7 && mls_solve_e1(M, nb, a);
  double s = 0.0, sp = 0.0, su[3] = {0, 0, 0}, sg = 0.0, sgw = 0.0;
  int kph = 0;
  if (D->mp.on) for (int k = 1; k < D->mp.M.nphase; k++) if (m11[k] > m11[kph]) kph = k;
  for (int k = 0; k < nn; k++)
    for (int32_t f = D->cstart[cells[k]]; f < D->cend[cells[k]]; f++) {
      double r2 = separation(D, D->x + 3 * f, xi, r);
      if (r2 >= D->support2) continue;
      double WV = wendland_w(D->alphaD, sqrt(r2) * D->inv_h) * D->mass[f] / D->rhop[f], wm = a[0];
      if (mls) for (int d = 0; d < dim; d++) wm += a[1 + d] * r[d];
      wm *= WV;
      s += wm;
      sp += D->p[f] * wm;
      for (int d = 0; d < 3; d++) su[d] += D->ve[3 * f + d] * wm;
      if (D->mp.on && D->mp.ph[f] == kph) { sg += D->mp.gdot[f] * WV; sgw += WV; }
    }
  if (!mls && s > 0.0) { sp /= s; for (int d = 0; d < 3; d++) su[d] /= s; } /* Shepard fallback */
  const double *vw = D->wv + 3 * w, *aw = D->wa + 3 * w;
  double rhof = D->mp.on ? D->mp.M.phase[kph].rho0 : D->P.rho0, gx = 0.0;
  for (int d = 0; d < dim; d++) gx += (D->P.gravity[d] - aw[d]) * (xw[d] - xi[d]);
  double pw = s != 0.0 ? sp + rhof * gx : 0.0;
  if (D->P.wall_clamp && pw < 0.0) pw = 0.0;
  D->wp[w] = pw;
  D->wrho[w] = tait_density(D, pw);
  for (int d = 0; d < 3; d++) D->wvx[3 * w + d] = s != 0.0 ? 2.0 * vw[d] - su[d] : vw[d];
  if (D->ghost.wmu) D->ghost.wmu[w] = D->mp.on ? hb_viscosity(&D->mp.M.phase[kph], sgw > 0.0 ? sg / sgw : 0.0) : 0.0;
}

/* ---- pass 1: renormalisation, gradients, viscosity ------------------------------------------------ */

/* Adds neighbour j (at r = x_i - x_j, F the kernel-gradient factor, volume V) to the sums of pass 1:
 * B = sum (x_j - x_i) (x) grad_i W V_j, the same-phase Bc, the raw gradients of delta rho and velocity. */
SPHDEM_HD void mp_grad_add(double *Bm, double *Bc, int same, double *gr, double *G, const double *r, double F,
                           double V, double ddr, const double *dv) {
  sym_add_outer(Bm, -F * V, r); /* (x_j - x_i) (x) F r V = -F V r (x) r */
  if (same) sym_add_outer(Bc, -F * V, r);
  for (int d = 0; d < 3; d++) {
    gr[d] += ddr * F * V * r[d];
    for (int e = 0; e < 3; e++) G[3 * d + e] += dv[d] * F * V * r[e];
  }
}

SPHDEM_HD void mp_grad_body(const sphdem_dev *D, int64_t a) {
  const double *xa = D->x + 3 * a, *va = D->ve + 3 * a;
  double Bm[6] = {0, 0, 0, 0, 0, 0}, Bc[6] = {0, 0, 0, 0, 0, 0}, gr[3] = {0, 0, 0}, G[9], r[3], dv[3];
  for (int k = 0; k < 9; k++) G[k] = 0.0;
  double pa = D->p[a];
  int pha = D->mp.ph[a];
  int32_t cells[27];
  int nn = neighbor_cells(D, D->cell[a], cells);
  for (int k = 0; k < nn; k++) {
    for (int32_t b = D->cstart[cells[k]]; b < D->cend[cells[k]]; b++) {
      double r2 = separation(D, xa, D->x + 3 * b, r);
      if (r2 >= D->support2 || r2 == 0.0) continue;
      double F = wendland_grad_factor(D->alphaD, D->inv_h, sqrt(r2) * D->inv_h);
      for (int d = 0; d < 3; d++) dv[d] = D->ve[3 * b + d] - va[d];
      mp_grad_add(Bm, Bc, D->mp.ph[b] == pha, gr, G, r, F, D->mass[b] / D->rhop[b], D->p[b] - pa, dv);
    }
    if (D->nw == 0) continue;
    for (int32_t w = D->wcstart[cells[k]]; w < D->wcend[cells[k]]; w++) {
      double r2 = separation(D, xa, D->wx + 3 * w, r);
      if (r2 >= D->support2 || r2 == 0.0) continue;
      double F = wendland_grad_factor(D->alphaD, D->inv_h, sqrt(r2) * D->inv_h);
      for (int d = 0; d < 3; d++) dv[d] = D->wvx[3 * w + d] - va[d]; /* no-slip ghost velocity (eq 13) */
      mp_grad_add(Bm, Bc, 1, gr, G, r, F, wall_volume(D, w), D->wp[w] - pa, dv);
    }
  }
  int dim = D->P.dim;
  if (dim == 2) { Bm[2] = Bc[2] = 1.0; }
  /* eq 19; where the support is badly truncated (isolated or splashing particles) no renormalisation */
  double L[6] = {1, 1, 1, 0, 0, 0};
  if (sym_min_eig(Bm, dim) > 0.25) sym_inverse(Bm, dim, L);
  double g[3];
  sym_mul(L, gr, g);
  /* velocity gradient G_de = sum (u_j - u_i)_d (L grad W)_e V_j, symmetrised: D = G + G^T (eq 26) */
  double Gr[9], s2 = 0.0;
  for (int d = 0; d < 3; d++)
    for (int e = 0; e < 3; e++) {
      double t = 0.0;
      for (int f = 0; f < 3; f++) t += G[3 * d + f] * sym_get(L, f, e);
      Gr[3 * d + e] = t;
    }
  for (int d = 0; d < dim; d++)
    for (int e = 0; e < dim; e++) { double Dde = Gr[3 * d + e] + Gr[3 * e + d]; s2 += Dde * Dde; }
  double gd = sqrt(0.5 * s2); /* |D| = sqrt(D_ij D_ij / 2): the shear rate of a simple shear */
  double mu = hb_viscosity(&D->mp.M.phase[pha], gd);
  if (D->mp.M.cs_les > 0.0) {
    double l = D->mp.M.cs_les * 2.0 * D->h; /* l_LES = 2h, the Wendland support radius */
    mu += D->rhop[a] * l * l * gd;    /* eq 25 */
  }
  for (int k = 0; k < 6; k++) D->mp.Lm[6 * a + k] = L[k];
  for (int d = 0; d < 3; d++) D->mp.gdr[3 * a + d] = d < dim ? g[d] : 0.0; /* <grad P>^L */
  D->mp.gdot[a] = gd;
  D->mp.mu_p[a] = mu;
  D->mp.lam[a] = D->mp.M.shifting ? sym_min_eig(Bc, dim) : 0.0;
}

/* ---- pass 2: shifting velocity (eqs 27-29) -------------------------------------------------------- */

SPHDEM_HD double shift_weight(const sphdem_dev *D, double W) {
  double f = W * D->w_dx_inv, fn;
  if (D->mp.M.shift_n == 4.0) { fn = f * f; fn *= fn; } else fn = pow(f, D->mp.M.shift_n);
  return 1.0 + D->mp.M.shift_R * fn;
}

SPHDEM_HD void mp_shift_body(const sphdem_dev *D, int64_t a) {
  double *du = D->mp.dus + 3 * a;
  du[0] = du[1] = du[2] = 0.0;
  int pha = D->mp.ph[a];
  double lam = D->mp.lam[a], U = D->mp.umax_ph[pha];
  if (lam < D->mp.M.lam_surface || !(U > 0.0)) return; /* S_I: interface or free surface, no shift */
  const double *xa = D->x + 3 * a;
  double S[3] = {0, 0, 0}, gl[3] = {0, 0, 0}, r[3];
  int32_t cells[27];
  int nn = neighbor_cells(D, D->cell[a], cells);
  for (int k = 0; k < nn; k++) {
    for (int32_t b = D->cstart[cells[k]]; b < D->cend[cells[k]]; b++) {
      if (D->mp.ph[b] != pha) continue; /* chi: same phase only */
      double r2 = separation(D, xa, D->x + 3 * b, r);
      if (r2 >= D->support2 || r2 == 0.0) continue;
      double q = sqrt(r2) * D->inv_h;
      double W = wendland_w(D->alphaD, q), F = wendland_grad_factor(D->alphaD, D->inv_h, q);
      double V = D->mass[b] / D->rhop[b], ws = shift_weight(D, W);
      for (int d = 0; d < 3; d++) { S[d] += ws * F * V * r[d]; gl[d] += (D->mp.lam[b] - lam) * F * V * r[d]; }
    }
    if (D->nw == 0) continue;
    for (int32_t w = D->wcstart[cells[k]]; w < D->wcend[cells[k]]; w++) {
      double r2 = separation(D, xa, D->wx + 3 * w, r);
      if (r2 >= D->support2 || r2 == 0.0) continue;
      double q = sqrt(r2) * D->inv_h;
      double W = wendland_w(D->alphaD, q), F = wendland_grad_factor(D->alphaD, D->inv_h, q);
      double ws = shift_weight(D, W), V = wall_volume(D, w);
      for (int d = 0; d < 3; d++) S[d] += ws * F * V * r[d];
    }
  }
  /* eq 27: away from the local concentration (grad_i W points from i towards j) */
  double s[3], m2 = 0.0;
  for (int d = 0; d < 3; d++) { s[d] = d < D->P.dim ? -U * 2.0 * D->h * S[d] : 0.0; m2 += s[d] * s[d]; }
  double m = sqrt(m2);
  if (m > 0.5 * U) for (int d = 0; d < 3; d++) s[d] *= 0.5 * U / m; /* eq 28 */
  if (lam <= D->mp.M.lam_near) {
    /* S_N: outward normal n = -L grad lambda / |.| (eq 30); no shift component towards the interface */
    double g[3], n2 = 0.0, sn = 0.0;
    sym_mul(D->mp.Lm + 6 * a, gl, g);
    for (int d = 0; d < D->P.dim; d++) n2 += g[d] * g[d];
    if (n2 > 0.0) {
      double inv = -1.0 / sqrt(n2);
      for (int d = 0; d < 3; d++) { g[d] = d < D->P.dim ? g[d] * inv : 0.0; sn += s[d] * g[d]; }
      if (sn >= 0.0) for (int d = 0; d < 3; d++) s[d] -= sn * g[d]; /* eq 29: (I - n n) du* */
    }
  }
  for (int d = 0; d < 3; d++) du[d] = s[d];
}


/* ---- the delta-plus terms of the one fluid rate pass (fluid_rates.h) ----------------------------------- */

/* a's constants of the delta-plus pair terms. Diffusion on delta rho = (P - P0) / c_a^2 (eq 18 with the
 * particle's sound speed): P is continuous across an interface, so is delta rho measured in a's units;
 * delta_d h c_a D_a. */
SPHDEM_HD void dplus_init(const sphdem_dev *D, int64_t a, rates_acc *R) {
  dplus_side *A = &R->A;
  R->pha = D->mp.ph[a];
  R->pa = D->p[a];
  R->mua = D->mp.mu_p[a];
  A->rhoa = R->rhoa;
  A->ma = D->mass[a];
  const double Va = A->ma / R->rhoa, ca = D->mp.ck[R->pha];
  A->ic2 = 1.0 / (ca * ca);
  A->kdiff = D->mp.M.delta * D->h * ca;
  A->paV = R->pa * Va * Va / A->ma;
  A->Va2 = Va * Va;
  for (int d = 0; d < 3; d++) {
    A->va[d] = R->va[d];
    A->dua[d] = D->mp.M.shifting ? D->mp.dus[3 * a + d] : 0.0;
    A->ga[d] = D->mp.gdr[3 * a + d];
  }
  if (pair_in_float(D)) {
    dplus_side_f *B = &R->Af;
    B->rhoa = (float)A->rhoa; B->ma = (float)A->ma; B->Va2 = (float)A->Va2; B->paV = (float)A->paV;
    B->ic2 = (float)A->ic2; B->kdiff = (float)A->kdiff;
    for (int d = 0; d < 3; d++) { B->va[d] = (float)A->va[d]; B->dua[d] = (float)A->dua[d]; B->ga[d] = (float)A->ga[d]; }
  }
}

/* The harmonic mean of two viscosities (eq 24); 0 when both are 0. */
SPHDEM_HD double harmonic_mu(double mua, double mub) { return mua + mub > 0.0 ? 2.0 * mua * mub / (mua + mub) : 0.0; }

/* Fluid pair (a, b), delta-plus (dplus_pair_core of pair_real.h, in the precision's real type); a's rates,
 * weight 1 (fluid_pair_rec). 0 if out of reach. */
SPHDEM_HD int dplus_pair_terms(const sphdem_dev *D, const rates_acc *R, int32_t b, fluid_pair_rec *P) {
  const int shift = D->mp.M.shifting, diff = D->mp.M.diffusion, same = D->mp.ph[b] == R->pha;
  const double *vb = D->ve + 3 * b, *gb = D->mp.gdr + 3 * b;
  if (pair_in_float(D)) {
    float r[3], vab[3], vbf[3], dub[3], gbf[3];
    const float r2 = separation_f(D, R->xa, D->x + 3 * b, r);
    if (r2 < 0.0f) return 0;
    const double rhob = D->rhop[b], mb = D->mass[b], pb = D->p[b], mubar = harmonic_mu(R->mua, D->mp.mu_p[b]);
    for (int d = 0; d < 3; d++) {
      vab[d] = (float)(R->va[d] - vb[d]);
      vbf[d] = (float)vb[d];
      dub[d] = shift ? (float)D->mp.dus[3 * b + d] : 0.0f;
      gbf[d] = (float)gb[d];
    }
    fluid_pair_rec_f Q;
    dplus_pair_core_f(&D->Kf, pair_opts(D), shift, diff, same, &R->Af, r, r2, vab, vbf, dub, gbf, (float)rhob, (float)mb,
                      (float)pb, (float)(pb - R->pa), (float)mubar, &Q);
    pair_rec_from_f(&Q, P);
    return 1;
  }
  double r[3], vab[3], dub[3] = {0, 0, 0};
  const double r2 = separation(D, R->xa, D->x + 3 * b, r);
  if (r2 >= D->support2 || r2 == 0.0) return 0;
  const double rhob = D->rhop[b], mb = D->mass[b], pb = D->p[b], mubar = harmonic_mu(R->mua, D->mp.mu_p[b]);
  for (int d = 0; d < 3; d++) {
    vab[d] = R->va[d] - vb[d];
    if (shift) dub[d] = D->mp.dus[3 * b + d];
  }
  dplus_pair_core(&D->K, pair_opts(D), shift, diff, same, &R->A, r, r2, vab, vb, dub, gb, rhob, mb, pb, pb - R->pa, mubar,
                  P);
  return 1;
}

/* Wall neighbour w of a, delta-plus: the wall's volume m_w / rho0 in continuity, pressure and viscosity
 * (Adami walls take the fluid particle's viscosity, MLS ghosts their own, §3.4, harmonic mean as eq 24),
 * Monaghan repulsion (dplus_wall_core of pair_real.h, in the precision's real type). */
SPHDEM_HD void dplus_wall_pair(const sphdem_dev *D, rates_acc *R, int32_t w) {
  if (pair_in_float(D)) {
    float r[3], vs[3], vv[3], drho = 0.0f, acc[3] = {0.0f, 0.0f, 0.0f};
    const float r2 = separation_f(D, R->xa, D->wx + 3 * w, r);
    if (r2 < 0.0f) return;
    const double Vw = wall_volume(D, w), pw = D->wp[w];
    const double mubar = harmonic_mu(R->mua, D->ghost.on ? D->ghost.wmu[w] : R->mua);
    for (int d = 0; d < 3; d++) {
      vs[d] = (float)(R->va[d] + R->A.dua[d] - D->wv[3 * w + d]); /* prescribed wall velocity */
      vv[d] = (float)(R->va[d] - D->wvx[3 * w + d]);              /* extrapolated (eq 13) */
    }
    dplus_wall_core_f(&D->Kf, pair_opts(D), &R->Af, r, r2, vs, vv, (float)Vw, (float)pw, (float)mubar, &drho, acc);
    R->drho += drho;
    for (int d = 0; d < 3; d++) R->acc[d] += acc[d];
    return;
  }
  double r[3], vs[3], vv[3];
  const double r2 = separation(D, R->xa, D->wx + 3 * w, r);
  if (r2 >= D->support2 || r2 == 0.0) return;
  const double Vw = wall_volume(D, w), pw = D->wp[w];
  const double mubar = harmonic_mu(R->mua, D->ghost.on ? D->ghost.wmu[w] : R->mua);
  for (int d = 0; d < 3; d++) {
    vs[d] = R->va[d] + R->A.dua[d] - D->wv[3 * w + d];
    vv[d] = R->va[d] - D->wvx[3 * w + d];
  }
  dplus_wall_core(&D->K, pair_opts(D), &R->A, r, r2, vs, vv, Vw, pw, mubar, &R->drho, R->acc);
}

#endif
