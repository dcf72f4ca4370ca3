/* cfd_bodies.h - the gas-grid physics of CFD-DEM (Yu 2024 §2.1-2.4), written once for the CPU loops
 * and the CUDA kernels. Staggered grid: eps, p at cell centres; u_d on the faces normal to axis d. */
#ifndef SPHDEM_CFD_BODIES_H
#define SPHDEM_CFD_BODIES_H

#include <math.h>
#include "cfd_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

SPHDEM_HD void cfd_add(double *p, double v) {
#ifdef __CUDA_ARCH__
  atomicAdd(p, v);
#else
#pragma omp atomic
  *p += v;
#endif
}

/* ---- drag law (eqs 15-17) as K = beta V_p / (1 - eps), so that f = K (u_g - v) -------------------
 * Ergun (eps <= 0.8): beta = 150 (1-eps)^2 mu / (eps d^2) + 1.75 (1-eps) rho |u-v| / d (the paper's eq 15
 * prints both terms over eps d^2; the second is over d, as in Gidaspow 1994 - dimensions require it).
 * Wen-Yu (eps > 0.8): beta = 3/4 C_D eps (1-eps) rho |u-v| / d eps^-2.65, C_D of eq 16 with Re of eq 17.
 * Written without the 1/(1-eps) so that a lone grain (eps -> 1) is exact. */
SPHDEM_HD double cfd_drag_K(int drag, double eps, double slip, double d, double rho, double mu) {
  double Vp = M_PI / 6.0 * d * d * d;
  if (drag == SPHDEM_CFD_DRAG_NONE) return 0.0;
  if (drag == SPHDEM_CFD_DRAG_GIDASPOW && eps <= 0.8)
    return Vp * (150.0 * (1.0 - eps) * mu / (eps * d * d) + 1.75 * rho * slip / d);
  double re = rho * eps * slip * d / mu;
  double f = pow(eps, -1.65);
  if (re < 1000.0) return Vp * 18.0 * mu * (1.0 + 0.15 * pow(re, 0.687)) / (d * d * eps) * f;
  return Vp * 0.75 * 0.44 * rho * slip / d * f;
}

/* ---- indexing ------------------------------------------------------------------------------------ */

/* A level (multigrid level 0 is the grid itself): cells x fastest; faces of axis d from foff[d] on, with
 * (nc[d] + 1) faces along d. */
SPHDEM_HD int64_t lv_cell(const cfd_level *L, const int *c) {
  return (int64_t)c[0] + (int64_t)L->nc[0] * ((int64_t)c[1] + (int64_t)L->nc[1] * c[2]);
}
SPHDEM_HD void lv_decode(const cfd_level *L, int64_t ci, int *c) {
  c[0] = (int)(ci % L->nc[0]);
  c[1] = (int)((ci / L->nc[0]) % L->nc[1]);
  c[2] = (int)(ci / ((int64_t)L->nc[0] * L->nc[1]));
}
SPHDEM_HD int64_t lv_face(const cfd_level *L, int d, const int *ix) {
  int64_t fx = L->nc[0] + (d == 0), fy = L->nc[1] + (d == 1);
  return L->foff[d] + ix[0] + fx * (ix[1] + fy * (int64_t)ix[2]);
}
/* axis and index triple of face f */
SPHDEM_HD int lv_face_decode(const cfd_level *L, int64_t f, int *ix) {
  int d = f >= L->foff[2] ? 2 : (f >= L->foff[1] ? 1 : 0);
  int64_t l = f - L->foff[d];
  int64_t fx = L->nc[0] + (d == 0), fy = L->nc[1] + (d == 1);
  ix[0] = (int)(l % fx);
  ix[1] = (int)((l / fx) % fy);
  ix[2] = (int)(l / (fx * fy));
  return d;
}

SPHDEM_HD int64_t cfd_cellv(const cfd_dev *D, const int *ix) { return lv_cell(&D->G, ix); }
SPHDEM_HD void cfd_cell_decode(const cfd_dev *D, int64_t ci, int *c) { lv_decode(&D->G, ci, c); }
SPHDEM_HD int64_t cfd_face(const cfd_dev *D, int d, const int *ix) { return lv_face(&D->G, d, ix); }
SPHDEM_HD int cfd_face_decode(const cfd_dev *D, int64_t f, int *ix) { return lv_face_decode(&D->G, f, ix); }

/* Many ranks: a local cell this rank owns (not a halo copy) */
SPHDEM_HD int cfd_owned_cell(const cfd_dev *D, int64_t ci) {
  if (!D->split) return 1;
  int c[3];
  cfd_cell_decode(D, ci, c);
  for (int d = 0; d < 3; d++)
    if (c[d] < D->hlo[d] || c[d] >= D->hlo[d] + D->own[d]) return 0;
  return 1;
}
/* a local face this rank owns: the low face of each owned cell, and the high face of an owned cell on the high
 * side of the whole grid (each face of the grid has one owner) */
SPHDEM_HD int cfd_owned_face(const cfd_dev *D, int64_t f) {
  if (!D->split) return 1;
  int c[3];
  int d = cfd_face_decode(D, f, c);
  for (int e = 0; e < 3; e++) {
    int top = D->hlo[e] + D->own[e];
    if (c[e] < D->hlo[e] || c[e] > top) return 0;
    if (c[e] == top && !(e == d && D->g0[e] + top == D->gnc[e])) return 0;
  }
  return 1;
}

SPHDEM_HD double cfd_eps_use(const cfd_dev *D, const double *eps, int64_t c) {
  double e = eps[c];
  return e > D->P.eps_min ? e : D->P.eps_min;
}

/* Voidage at a face of axis d with index ix: mean of the two cells, or the one cell at a boundary. */
SPHDEM_HD double cfd_eps_face(const cfd_dev *D, const double *eps, int d, const int *ix) {
  int c[3] = {ix[0], ix[1], ix[2]};
  if (ix[d] == D->nc[d]) c[d]--;
  double e1 = cfd_eps_use(D, eps, cfd_cellv(D, c));
  if (ix[d] == 0 || ix[d] == D->nc[d]) return e1;
  c[d] = ix[d] - 1;
  return 0.5 * (e1 + cfd_eps_use(D, eps, cfd_cellv(D, c)));
}

/* Superficial inflow velocity (into the box) at a boundary face of side s with index ix. */
SPHDEM_HD double cfd_inlet_u(const cfd_dev *D, int s, const int *ix) {
  int d = s / 2;
  double u = D->P.inlet_u[s];
  int e0 = d == 0 ? 1 : 0, e1 = d == 2 ? 1 : 2;
  double c0 = D->lo[e0] + (ix[e0] + 0.5) * D->h[e0], c1 = D->lo[e1] + (ix[e1] + 0.5) * D->h[e1];
  for (int q = 0; q < D->P.npatch; q++) {
    const sphdem_cfd_patch *pt = &D->P.patch[q];
    if (pt->side == s && c0 >= pt->lo[0] && c0 < pt->hi[0] && c1 >= pt->lo[1] && c1 < pt->hi[1]) u = pt->u;
  }
  return u;
}

/* Cell of a position along axis d (clamped into the grid) and the weight of the upper face. */
SPHDEM_HD int cfd_locate(const cfd_dev *D, int d, double x, double *whi) {
  double s = (x - D->lo[d]) * D->inv_h[d], fs = floor(s);
  /* clamped in double before the cast (a position far outside has no int cell) */
  int c = !(fs > 0.0) ? 0 : fs > (double)(D->nc[d] - 1) ? D->nc[d] - 1 : (int)fs;
  double w = s - c;
  *whi = w < 0.0 ? 0.0 : (w > 1.0 ? 1.0 : w);
  return c;
}

/* Cell holding a position (clamped into the grid). */
SPHDEM_HD int64_t cfd_cell_at(const cfd_dev *D, const double *x) {
  int c[3];
  double w;
  for (int d = 0; d < 3; d++) c[d] = cfd_locate(D, d, x[d], &w);
  return cfd_cellv(D, c);
}

/* Trilinear (cloud-in-cell) weights of the 8 cell centres around x: lower corner i0 and fractions f. A
 * position beyond the outer cell centres gives all its weight to the boundary cell, so a scatter keeps
 * the total and an interpolation takes the boundary value. */
SPHDEM_HD void cfd_cic(const cfd_dev *D, const double *x, int *i0, double *f) {
  for (int d = 0; d < 3; d++) {
    double s = (x[d] - D->lo[d]) * D->inv_h[d] - 0.5, fs = floor(s);
    int c;
    double t;
    /* clamped in double before the cast (a position far outside has no int cell) */
    if (!(fs >= -1.0)) { c = -1; t = 1.0; }
    else if (fs > (double)(D->nc[d] - 1)) { c = D->nc[d] - 1; t = 0.0; }
    else { c = (int)fs; t = s - c; }
    i0[d] = c;
    f[d] = t;
  }
}
/* corner q (bit d: upper along d) of the cloud-in-cell stencil: its cell (clamped) and weight */
SPHDEM_HD double cfd_cic_corner(const cfd_dev *D, const int *i0, const double *f, int q, int *c) {
  double w = 1.0;
  for (int d = 0; d < 3; d++) {
    int up = (q >> d) & 1;
    int cc = i0[d] + up;
    w *= up ? f[d] : 1.0 - f[d];
    c[d] = cc < 0 ? 0 : (cc > D->nc[d] - 1 ? D->nc[d] - 1 : cc);
  }
  return w;
}

/* ---- voidage (eq 3) ------------------------------------------------------------------------------ */

SPHDEM_HD void cfd_k_void_scatter(const cfd_dev *D, int64_t g) {
  const double *x = D->gx + 3 * g;
  double r = D->grad[g];
  double V = 4.0 / 3.0 * M_PI * r * r * r;
  if (D->P.voidage == SPHDEM_CFD_VOID_CENTROID) {
    cfd_add(&D->sol[cfd_cell_at(D, x)], V);
    return;
  }
  /* smooth: the grain's volume to the 8 nearest cell centres with the trilinear weights */
  int i0[3];
  double f[3];
  cfd_cic(D, x, i0, f);
  for (int q = 0; q < 8; q++) {
    int c[3];
    double w = cfd_cic_corner(D, i0, f, q, c);
    if (w > 0.0) cfd_add(&D->sol[cfd_cellv(D, c)], w * V);
  }
}

SPHDEM_HD void cfd_k_void_finish(const cfd_dev *D, int64_t c) { D->eps[c] = 1.0 - D->sol[c] / D->Vc; }

/* Voidage seen by a grain: its cell (centroid) or the trilinear interpolation (smooth). */
SPHDEM_HD double cfd_eps_at(const cfd_dev *D, const double *x) {
  if (D->P.voidage == SPHDEM_CFD_VOID_CENTROID) {
    return cfd_eps_use(D, D->eps, cfd_cell_at(D, x));
  }
  int i0[3];
  double f[3];
  cfd_cic(D, x, i0, f);
  double e = 0.0;
  for (int q = 0; q < 8; q++) {
    int c[3];
    double w = cfd_cic_corner(D, i0, f, q, c);
    e += w * cfd_eps_use(D, D->eps, cfd_cellv(D, c));
  }
  return e;
}

/* The two faces of axis d around a grain (in its cell) and their weights: the interpolation of the
 * gas velocity to the grain and the distribution of its drag on the gas use the same weights. */
SPHDEM_HD void cfd_grain_faces(const cfd_dev *D, const double *x, int d, int64_t *flo, int64_t *fhi,
                               double *wlo, double *whi, int *clo) {
  int ix[3];
  double w[3];
  for (int e = 0; e < 3; e++) ix[e] = cfd_locate(D, e, x[e], &w[e]);
  *clo = ix[d];
  *flo = cfd_face(D, d, ix);
  ix[d]++;
  *fhi = cfd_face(D, d, ix);
  *whi = w[d];
  *wlo = 1.0 - w[d];
}

/* ---- drag coefficients (eqs 14-17), slip from the gas field of the previous step ----------------- */

SPHDEM_HD void cfd_k_drag(const cfd_dev *D, int64_t g) {
  const double *x = D->gx + 3 * g, *v = D->gv + 3 * g;
  int64_t fl[3], fh[3];
  double wl[3], wh[3], slip2 = 0.0;
  for (int d = 0; d < 3; d++) {
    int c;
    cfd_grain_faces(D, x, d, &fl[d], &fh[d], &wl[d], &wh[d], &c);
    double s = wl[d] * D->u[fl[d]] + wh[d] * D->u[fh[d]] - v[d];
    slip2 += s * s;
  }
  double K = cfd_drag_K(D->P.drag, cfd_eps_at(D, x), sqrt(slip2), 2.0 * D->grad[g], D->P.rho_g, D->P.mu_g);
  D->gK[g] = K;
  if (K == 0.0) return;
  for (int d = 0; d < 3; d++) {
    cfd_add(&D->K[fl[d]], wl[d] * K);
    cfd_add(&D->Kv[fl[d]], wl[d] * K * v[d]);
    cfd_add(&D->K[fh[d]], wh[d] * K);
    cfd_add(&D->Kv[fh[d]], wh[d] * K * v[d]);
  }
}

/* ---- momentum predictor (eq 2, model A) ---------------------------------------------------------- */

/* Tangential neighbour of face f (axis d, index ix) one step along e (dir -1/+1), or the ghost value
 * beyond the box side: conv (1) the value convected in from the side (0 from an inlet, else u_f),
 * else the viscous mirror (-u_f at no-slip walls and inlets, u_f at slip walls and outlets). */
SPHDEM_HD double cfd_tang(const cfd_dev *D, int d, const int *ix, int e, int dir, double uf, int conv) {
  int n[3] = {ix[0], ix[1], ix[2]};
  n[e] += dir;
  if (n[e] < 0 || n[e] >= D->nc[e]) {
    int bc = D->P.bc[2 * e + (dir > 0)];
    if (conv) return bc == SPHDEM_CFD_INLET ? 0.0 : uf;
    return (bc == SPHDEM_CFD_NOSLIP || bc == SPHDEM_CFD_INLET) ? -uf : uf;
  }
  return D->u[cfd_face(D, d, n)];
}

/* eps u_e on the e-face of cell c (index triple) on its side s (0 low, 1 high) */
SPHDEM_HD double cfd_flux_e(const cfd_dev *D, const int *c, int e, int s) {
  int f[3] = {c[0], c[1], c[2]};
  f[e] += s;
  return cfd_eps_face(D, D->eps, e, f) * D->u[cfd_face(D, e, f)];
}

SPHDEM_HD void cfd_k_predict(const cfd_dev *D, int64_t f) {
  int ix[3];
  int d = cfd_face_decode(D, f, ix);
  double dt = D->dt, rho = D->P.rho_g;
  if (ix[d] == 0 || ix[d] == D->nc[d]) { /* boundary face */
    int s = 2 * d + (ix[d] == D->nc[d]);
    int bc = D->P.bc[s];
    double sign = (s & 1) ? -1.0 : 1.0;
    D->af[f] = 0.0;
    if (bc == SPHDEM_CFD_INLET) {
      D->us[f] = sign * cfd_inlet_u(D, s, ix) / cfd_eps_face(D, D->eps, d, ix);
      D->cf[f] = 0.0;
    } else if (bc == SPHDEM_CFD_OUTLET) {
      int n[3] = {ix[0], ix[1], ix[2]};
      n[d] += (s & 1) ? -1 : 1;
      D->us[f] = D->u[cfd_face(D, d, n)] + dt * D->P.gravity[d]; /* zero gradient; gravity as inside */
      D->cf[f] = dt / rho;
      D->af[f] = 2.0 * cfd_eps_face(D, D->eps, d, ix) * D->cf[f] * D->inv_h[d] * D->inv_h[d];
    } else {
      D->us[f] = 0.0;
      D->cf[f] = 0.0;
    }
    return;
  }
  double uf = D->u[f];
  double en = cfd_eps_face(D, D->eps, d, ix), eo = cfd_eps_face(D, D->eps_old, d, ix);
  int cP[3] = {ix[0], ix[1], ix[2]}, cN[3] = {ix[0], ix[1], ix[2]};
  cP[d]--;
  /* conservative first-order upwind convection of eps u u over the control volume of the face */
  double conv = 0.0, lap = 0.0;
  for (int e = 0; e < 3; e++) {
    double he = D->h[e];
    if (e == d) {
      int a[3] = {ix[0], ix[1], ix[2]};
      a[d] = ix[d] + 1;
      double uhi = D->u[cfd_face(D, d, a)];
      a[d] = ix[d] - 1;
      double ulo = D->u[cfd_face(D, d, a)];
      double Fhi = cfd_eps_use(D, D->eps, cfd_cellv(D, cN)) * 0.5 * (uf + uhi);
      double Flo = cfd_eps_use(D, D->eps, cfd_cellv(D, cP)) * 0.5 * (ulo + uf);
      conv += (Fhi * (Fhi > 0.0 ? uf : uhi) - Flo * (Flo > 0.0 ? ulo : uf)) / he;
      lap += (uhi - 2.0 * uf + ulo) / (he * he);
    } else {
      double Fhi = 0.5 * (cfd_flux_e(D, cP, e, 1) + cfd_flux_e(D, cN, e, 1));
      double Flo = 0.5 * (cfd_flux_e(D, cP, e, 0) + cfd_flux_e(D, cN, e, 0));
      double chi = cfd_tang(D, d, ix, e, +1, uf, 1), clo = cfd_tang(D, d, ix, e, -1, uf, 1);
      conv += (Fhi * (Fhi > 0.0 ? uf : chi) - Flo * (Flo > 0.0 ? clo : uf)) / he;
      lap += (cfd_tang(D, d, ix, e, +1, uf, 0) - 2.0 * uf + cfd_tang(D, d, ix, e, -1, uf, 0)) / (he * he);
    }
  }
  double Kf = D->K[f] / D->Vc, Kvf = D->Kv[f] / D->Vc;
  double a = en * rho / dt + Kf;
  double rhs = eo * rho * uf / dt - rho * conv + D->P.mu_g * en * lap + rho * en * D->P.gravity[d] + Kvf;
  D->us[f] = rhs / a;
  D->cf[f] = en / a;
  D->af[f] = en * D->cf[f] * D->inv_h[d] * D->inv_h[d];
}

/* ---- pressure equation: sum_f a_f (p_P - p_nb) + a_out p_P = -(div(eps u*) + d eps/dt) ------------
 * a_f = eps_f cf_f / h_d^2 at interior faces, 2 eps_f cf_f / h_d^2 at outlet faces (p = 0 on the face),
 * 0 at walls and inlets (prescribed velocity): af, filled by the predictor. */

/* face of cell c on side s (0 low, 1 high) along d */
SPHDEM_HD int64_t cfd_cell_face(const cfd_dev *D, const int *c, int d, int s) {
  int fi[3] = {c[0], c[1], c[2]};
  fi[d] += s;
  return cfd_face(D, d, fi);
}

SPHDEM_HD int64_t cfd_stride(const cfd_dev *D, int d) {
  return d == 0 ? 1 : (d == 1 ? (int64_t)D->nc[0] : (int64_t)D->nc[0] * D->nc[1]);
}

/* div(eps u) of a face-velocity field at cell ci, plus d eps/dt */
SPHDEM_HD double cfd_div(const cfd_dev *D, const double *u, int64_t ci) {
  int c[3];
  cfd_cell_decode(D, ci, c);
  double div = 0.0;
  for (int d = 0; d < 3; d++) {
    int fi[3] = {c[0], c[1], c[2]};
    double flo = cfd_eps_face(D, D->eps, d, fi) * u[cfd_face(D, d, fi)];
    fi[d]++;
    double fhi = cfd_eps_face(D, D->eps, d, fi) * u[cfd_face(D, d, fi)];
    div += (fhi - flo) * D->inv_h[d];
  }
  if (D->P.ddt_eps && !D->first)
    div += (cfd_eps_use(D, D->eps, ci) - cfd_eps_use(D, D->eps_old, ci)) / D->dt;
  return div;
}

/* Diagonal of A on a level: the sum of the cell's six face coefficients (1 where all are 0). */
SPHDEM_HD double lv_diag(const cfd_level *L, int64_t ci) {
  int c[3];
  lv_decode(L, ci, c);
  double s = 0.0;
  for (int d = 0; d < 3; d++) {
    int fi[3] = {c[0], c[1], c[2]};
    s += L->af[lv_face(L, d, fi)];
    fi[d]++;
    s += L->af[lv_face(L, d, fi)];
  }
  return s > 0.0 ? s : 1.0;
}

SPHDEM_HD void cfd_k_rhs(const cfd_dev *D, int64_t ci) {
  D->b[ci] = -cfd_div(D, D->us, ci);
  D->diag[ci] = lv_diag(&D->G, ci);
}

/* ---- multigrid levels (level 0 = the grid) ------------------------------------------------------ */

/* (A x)[ci] on a level: sum_f a_f (x_P - x_nb), a boundary face (outlet; 0 elsewhere) a_f x_P */
SPHDEM_HD double lv_Ax(const cfd_level *L, const double *x, int64_t ci) {
  int c[3];
  lv_decode(L, ci, c);
  double xp = x[ci], y = 0.0;
  int64_t st = 1;
  for (int d = 0; d < 3; d++) {
    int fi[3] = {c[0], c[1], c[2]};
    double alo = L->af[lv_face(L, d, fi)];
    fi[d]++;
    double ahi = L->af[lv_face(L, d, fi)];
    y += alo * (c[d] > 0 ? xp - x[ci - st] : xp);
    y += ahi * (c[d] < L->nc[d] - 1 ? xp - x[ci + st] : xp);
    st *= L->nc[d];
  }
  return y;
}

SPHDEM_HD void cfd_k_matvec(const cfd_dev *D, int64_t ci) { D->Ad[ci] = lv_Ax(&D->G, D->mvx, ci); }

SPHDEM_HD void cfd_k_mg_af(const cfd_dev *D, int64_t f) {
  const cfd_level *C = &D->L[D->lv], *F = &D->L[D->lv - 1];
  int ic[3];
  int d = lv_face_decode(C, f, ic);
  int base[3], cnt[3];
  for (int e = 0; e < 3; e++) {
    if (e == d) {
      base[e] = ic[e] == C->nc[e] ? F->nc[e] : C->cf[e] * ic[e];
      cnt[e] = 1;
    } else {
      base[e] = C->cf[e] * ic[e];
      cnt[e] = base[e] + C->cf[e] <= F->nc[e] ? C->cf[e] : F->nc[e] - base[e];
    }
  }
  double a = 0.0;
  for (int k = 0; k < cnt[2]; k++)
    for (int j = 0; j < cnt[1]; j++)
      for (int i = 0; i < cnt[0]; i++) {
        int fi[3] = {base[0] + i, base[1] + j, base[2] + k};
        a += F->af[lv_face(F, d, fi)];
      }
  C->af[f] = a;
}

SPHDEM_HD void cfd_k_mg_diag(const cfd_dev *D, int64_t ci) { D->L[D->lv].diag[ci] = lv_diag(&D->L[D->lv], ci); }

SPHDEM_HD void cfd_k_mg_jacobi0(const cfd_dev *D, int64_t ci) {
  const cfd_level *L = &D->L[D->lv];
  L->x[ci] = D->omega * L->r[ci] / L->diag[ci];
}
SPHDEM_HD void cfd_k_mg_resid(const cfd_dev *D, int64_t ci) {
  const cfd_level *L = &D->L[D->lv];
  L->t[ci] = L->r[ci] - lv_Ax(L, L->x, ci);
}
SPHDEM_HD void cfd_k_mg_jacobi(const cfd_dev *D, int64_t ci) {
  const cfd_level *L = &D->L[D->lv];
  L->x[ci] += D->omega * L->t[ci] / L->diag[ci];
}
SPHDEM_HD void cfd_k_mg_restrict(const cfd_dev *D, int64_t ci) {
  const cfd_level *F = &D->L[D->lv], *C = &D->L[D->lv + 1];
  int c[3];
  lv_decode(C, ci, c);
  double s = 0.0;
  for (int k = 0; k < C->cf[2]; k++)
    for (int j = 0; j < C->cf[1]; j++)
      for (int i = 0; i < C->cf[0]; i++) {
        int f[3] = {C->cf[0] * c[0] + i, C->cf[1] * c[1] + j, C->cf[2] * c[2] + k};
        if (f[0] < F->nc[0] && f[1] < F->nc[1] && f[2] < F->nc[2]) s += F->t[lv_cell(F, f)];
      }
  C->r[ci] = s;
}
SPHDEM_HD void cfd_k_mg_prolong(const cfd_dev *D, int64_t ci) {
  const cfd_level *F = &D->L[D->lv], *C = &D->L[D->lv + 1];
  int c[3];
  lv_decode(F, ci, c);
  int p[3] = {c[0] / C->cf[0], c[1] / C->cf[1], c[2] / C->cf[2]};
  F->x[ci] += C->x[lv_cell(C, p)];
}

SPHDEM_HD void cfd_k_pcg_res(const cfd_dev *D, int64_t i) { D->r[i] = D->b[i] - D->Ad[i]; }
SPHDEM_HD void cfd_k_pcg_first(const cfd_dev *D, int64_t i) { D->d[i] = D->z[i]; }

/* Line preconditioner: along each line of cells on axis lax of level 0 (the grid, or the owned block of a
 * decomposed grid), solve the tridiagonal part of A (the full diagonal and the couplings along the line) for x
 * (Thomas algorithm, t the scratch). Tall beds converge in far fewer iterations than with a point-Jacobi
 * preconditioner; the matrix stays symmetric positive definite. */
SPHDEM_HD void cfd_k_precond(const cfd_dev *D, int64_t l) {
  const cfd_level *L = &D->L[0];
  int a = D->lax;
  int e0 = a == 0 ? 1 : 0, e1 = a == 2 ? 1 : 2;
  int c[3];
  c[e0] = (int)(l % L->nc[e0]);
  c[e1] = (int)(l / L->nc[e0]);
  c[a] = 0;
  int64_t st = a == 0 ? 1 : (a == 1 ? (int64_t)L->nc[0] : (int64_t)L->nc[0] * L->nc[1]), c0 = lv_cell(L, c);
  int n = L->nc[a];
  /* forward sweep: lower(k) = -af(low face of k), upper(k) = -af(high face of k) for k < n-1 */
  double prev_cp = 0.0, prev_z = 0.0;
  for (int k = 0; k < n; k++) {
    c[a] = k;
    int64_t ci = c0 + k * st;
    int fi[3] = {c[0], c[1], c[2]};
    double low = k > 0 ? -L->af[lv_face(L, a, fi)] : 0.0;
    fi[a]++;
    double up = k < n - 1 ? -L->af[lv_face(L, a, fi)] : 0.0;
    double den = L->diag[ci] - low * prev_cp;
    prev_cp = up / den;
    prev_z = (L->r[ci] - low * prev_z) / den;
    L->t[ci] = prev_cp;
    L->x[ci] = prev_z;
  }
  for (int k = n - 2; k >= 0; k--) {
    int64_t ci = c0 + k * st;
    L->x[ci] -= L->t[ci] * L->x[ci + st];
  }
}

/* ---- the owned block as level 0 of the preconditioner (decomposed grid) ---------------------------- */
SPHDEM_HD void cfd_k_blk_af(const cfd_dev *D, int64_t f) {
  const cfd_level *L = &D->L[0];
  int c[3];
  int d = lv_face_decode(L, f, c);
  for (int e = 0; e < 3; e++) c[e] += D->hlo[e];
  L->af[f] = D->af[cfd_face(D, d, c)];
}
SPHDEM_HD void cfd_k_blk_r(const cfd_dev *D, int64_t ci) {
  const cfd_level *L = &D->L[0];
  int c[3];
  lv_decode(L, ci, c);
  for (int e = 0; e < 3; e++) c[e] += D->hlo[e];
  L->r[ci] = D->r[cfd_cellv(D, c)];
}
SPHDEM_HD void cfd_k_blk_z(const cfd_dev *D, int64_t ci) {
  const cfd_level *L = &D->L[0];
  int c[3];
  lv_decode(L, ci, c);
  for (int e = 0; e < 3; e++) c[e] += D->hlo[e];
  D->z[cfd_cellv(D, c)] = L->x[ci];
}
SPHDEM_HD void cfd_k_pcg_update(const cfd_dev *D, int64_t i) {
  D->p[i] += D->alpha * D->d[i];
  D->r[i] -= D->alpha * D->Ad[i];
}
SPHDEM_HD void cfd_k_pcg_dir(const cfd_dev *D, int64_t i) { D->d[i] = D->z[i] + D->beta * D->d[i]; }

/* ---- correction and forces on grains ------------------------------------------------------------- */

/* dp/dx_d at a face (boundary: outlet from p = 0 on the face; walls and inlets: the gradient of the
 * nearest interior face, 0 if the axis has one cell). */
SPHDEM_HD double cfd_grad_face(const cfd_dev *D, int d, const int *ix) {
  int n = D->nc[d];
  int a[3] = {ix[0], ix[1], ix[2]}, b[3] = {ix[0], ix[1], ix[2]};
  if (ix[d] == 0 || ix[d] == n) {
    int hi = ix[d] == n;
    int c[3] = {ix[0], ix[1], ix[2]};
    if (hi) c[d]--;
    if (D->P.bc[2 * d + hi] == SPHDEM_CFD_OUTLET) {
      double pP = D->p[cfd_cellv(D, c)];
      return (hi ? -pP : pP) * 2.0 * D->inv_h[d];
    }
    if (n < 2) return 0.0;
    a[d] = hi ? n - 2 : 0;
    b[d] = hi ? n - 1 : 1;
  } else {
    a[d] = ix[d] - 1;
    b[d] = ix[d];
  }
  return (D->p[cfd_cellv(D, b)] - D->p[cfd_cellv(D, a)]) * D->inv_h[d];
}

SPHDEM_HD void cfd_k_correct(const cfd_dev *D, int64_t f) {
  int ix[3];
  int d = cfd_face_decode(D, f, ix);
  if (D->cf[f] == 0.0) {
    D->u[f] = D->us[f];
    return;
  }
  D->u[f] = D->us[f] - D->cf[f] * cfd_grad_face(D, d, ix);
}

SPHDEM_HD int cfd_face_is_boundary(const cfd_dev *D, int64_t f) {
  int ix[3];
  int d = cfd_face_decode(D, f, ix);
  return ix[d] == 0 || ix[d] == D->nc[d];
}

SPHDEM_HD void cfd_k_forces(const cfd_dev *D, int64_t g) {
  const double *x = D->gx + 3 * g, *v = D->gv + 3 * g;
  double K = D->gK[g], r = D->grad[g];
  double V = 4.0 / 3.0 * M_PI * r * r * r;
  for (int d = 0; d < 3; d++) {
    int64_t fl, fh;
    double wl, wh;
    int c;
    cfd_grain_faces(D, x, d, &fl, &fh, &wl, &wh, &c);
    double fb = 0.0;
    if (cfd_face_is_boundary(D, fl)) fb += wl * K * (D->u[fl] - v[d]);
    if (cfd_face_is_boundary(D, fh)) fb += wh * K * (D->u[fh] - v[d]);
    D->gfd[3 * g + d] = K * (wl * D->u[fl] + wh * D->u[fh] - v[d]);
    D->gfb[3 * g + d] = fb;
    double gp = 0.0;
    if (D->P.pressure_force) {
      int il[3], ih[3];
      cfd_face_decode(D, fl, il);
      cfd_face_decode(D, fh, ih);
      gp = wl * cfd_grad_face(D, d, il) + wh * cfd_grad_face(D, d, ih);
    }
    D->gfp[3 * g + d] = -V * gp;
  }
}

/* ---- reductions ------------------------------------------------------------------------------------ */

SPHDEM_HD double cfd_r_rz(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? D->r[i] * D->z[i] : 0.0; }
SPHDEM_HD double cfd_r_dad(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? D->d[i] * D->Ad[i] : 0.0; }
SPHDEM_HD double cfd_r_rr(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? D->r[i] * D->r[i] : 0.0; }
SPHDEM_HD double cfd_r_bb(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? D->b[i] * D->b[i] : 0.0; }
SPHDEM_HD double cfd_r_negeps(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? -D->eps[i] : -1e300; }
SPHDEM_HD double cfd_r_eps(const cfd_dev *D, int64_t i) { return cfd_owned_cell(D, i) ? D->eps[i] : 0.0; }
SPHDEM_HD double cfd_r_u2(const cfd_dev *D, int64_t f) { return cfd_owned_face(D, f) ? D->u[f] * D->u[f] : 0.0; }
SPHDEM_HD double cfd_r_cfl(const cfd_dev *D, int64_t f) {
  int ix[3];
  int d = cfd_face_decode(D, f, ix);
  return cfd_owned_face(D, f) ? fabs(D->u[f]) * D->inv_h[d] : 0.0;
}
SPHDEM_HD double cfd_r_mass(const cfd_dev *D, int64_t ci) {
  return cfd_owned_cell(D, ci) ? fabs(cfd_div(D, D->u, ci)) * D->dt : 0.0;
}
SPHDEM_HD double cfd_fsum(const cfd_dev *D, int64_t f, int axis, int boundary) {
  int ix[3];
  int d = cfd_face_decode(D, f, ix);
  if (d != axis || !cfd_owned_face(D, f)) return 0.0;
  int b = ix[d] == 0 || ix[d] == D->nc[d];
  if (b != boundary) return 0.0;
  double t = D->K[f] * D->u[f] - D->Kv[f];
  return boundary ? t : -t;
}
SPHDEM_HD double cfd_r_fgasx(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 0, 0); }
SPHDEM_HD double cfd_r_fgasy(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 1, 0); }
SPHDEM_HD double cfd_r_fgasz(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 2, 0); }
SPHDEM_HD double cfd_r_fbndx(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 0, 1); }
SPHDEM_HD double cfd_r_fbndy(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 1, 1); }
SPHDEM_HD double cfd_r_fbndz(const cfd_dev *D, int64_t f) { return cfd_fsum(D, f, 2, 1); }
/* flow axis: the axis of the first inlet side (z if none) */
SPHDEM_HD int cfd_flow_axis(const cfd_dev *D) {
  for (int s = 0; s < 6; s++)
    if (D->P.bc[s] == SPHDEM_CFD_INLET) return s / 2;
  return 2;
}
SPHDEM_HD int cfd_flow_low(const cfd_dev *D) {
  for (int s = 0; s < 6; s++)
    if (D->P.bc[s] == SPHDEM_CFD_INLET) return (s & 1) == 0;
  return 1;
}
SPHDEM_HD double cfd_player(const cfd_dev *D, int64_t ci, int first) {
  int c[3];
  cfd_cell_decode(D, ci, c);
  int a = cfd_flow_axis(D);
  int inlet_low = cfd_flow_low(D);
  int want = (first == inlet_low) ? 0 : D->gnc[a] - 1;
  return c[a] + D->g0[a] == want && cfd_owned_cell(D, ci) ? D->p[ci] : 0.0;
}
SPHDEM_HD double cfd_r_pfirst(const cfd_dev *D, int64_t ci) { return cfd_player(D, ci, 1); }
SPHDEM_HD double cfd_r_plast(const cfd_dev *D, int64_t ci) { return cfd_player(D, ci, 0); }

#endif
