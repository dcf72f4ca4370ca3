/* dem_bodies.h - the DEM physics and contact search, written once for the CPU loops and CUDA kernels
 * (Yu 2024 §2.2-2.3, He 2018 §2.2). */
#ifndef SPHDEM_DEM_BODIES_H
#define SPHDEM_DEM_BODIES_H

#include <math.h>
#include <string.h>
#include "dem_internal.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* A body inlined into its caller even when large (the contact law specialised per model). */
#ifdef __CUDACC__
#define DEM_HD_INLINE __host__ __device__ static __forceinline__
#else
#define DEM_HD_INLINE static inline __attribute__((always_inline))
#endif

/* Atomic add: CUDA atomicAdd on the device, an OpenMP atomic on the host. */
/* Pair virial (xx yy zz xy xz yz) of the force Fa on a with the separation del = x_a - x_b. */
SPHDEM_HD void dem_pair_virial(const double *del, const double *Fa, double *vir) {
  vir[0] = del[0] * Fa[0];
  vir[1] = del[1] * Fa[1];
  vir[2] = del[2] * Fa[2];
  vir[3] = del[0] * Fa[1];
  vir[4] = del[0] * Fa[2];
  vir[5] = del[1] * Fa[2];
}

/* The area of the circle where two overlapping spheres of radii ra, rb at distance r intersect: pi a^2 with
 * a^2 = -(r - ra - rb)(r + ra - rb)(r - ra + rb)(r + ra + rb) / (4 r^2) (LIGGGHTS' contact area of cohesion sjkr and
 * of fix heat/gran/conduction) */
SPHDEM_HD double dem_lens_area(double r, double ra, double rb) {
  return -M_PI / 4 * ((r - ra - rb) * (r + ra - rb) * (r - ra + rb) * (r + ra + rb)) / (r * r);
}

SPHDEM_HD void dem_add(double *p, double v) {
#ifdef __CUDA_ARCH__
  atomicAdd(p, v);
#else
#pragma omp atomic
  *p += v;
#endif
}

/* ---- cell grid of size d_max + skin (He 2018 §2.4.1 level 1; Yu 2024 Fig. 1) ----------------------- */

SPHDEM_HD int dem_grid_coord(const dem_dev *D, int d, double x) {
  int n = D->nc[d];
  double s = (x - D->glo[d]) * D->cs_inv[d];
  int c;
  if (D->P.periodic[d]) {
    s -= n * floor(s / n);           /* wrap into [0, n) */
    c = s > 0.0 ? (s < (double)n ? (int)s : n - 1) : 0; /* (rounding far out of the box, or not finite) */
  } else {
    if (!(s > 0.0)) s = 0.0;         /* clamping keeps neighbours within one cell of each other */
    c = s >= (double)n ? n - 1 : (int)s;
  }
  return c;
}

SPHDEM_HD int32_t dem_cell_of(const dem_dev *D, const double *x) {
  int cx = dem_grid_coord(D, 0, x[0]), cy = dem_grid_coord(D, 1, x[1]), cz = dem_grid_coord(D, 2, x[2]);
  return (int32_t)(((int64_t)cz * D->nc[1] + cy) * D->nc[0] + cx);
}

/* The cell of grain i: a SPHDEM_DEM_SKIP grain goes to the extra cell ncells, after every other, which no
 * grain's neighbourhood holds. */
SPHDEM_HD int32_t dem_grain_cell(const dem_dev *D, int64_t i) {
  return (D->flags[i] & SPHDEM_DEM_SKIP) ? (int32_t)D->ncells : dem_cell_of(D, D->x + 3 * i);
}

/* Cell of grain i, and the unsorted slot order (the sort by cell permutes sidx). */
SPHDEM_HD void dem_cell_body(const dem_dev *D, int64_t i) {
  D->cell[i] = dem_grain_cell(D, i);
  D->sidx[i] = (int32_t)i;
}

/* Distinct wrapped coordinates c-1, c, c+1 along axis d (fewer when the axis has < 3 cells). */
SPHDEM_HD int dem_axis_neighbors(const dem_dev *D, int d, int c, int out[3]) {
  int n = D->nc[d], k = 0;
  if (n >= 3) { /* the three are distinct: no duplicate to drop */
    if (c > 0) out[k++] = c - 1;
    else if (D->P.periodic[d]) out[k++] = n - 1;
    out[k++] = c;
    if (c < n - 1) out[k++] = c + 1;
    else if (D->P.periodic[d]) out[k++] = 0;
    return k;
  }
  for (int o = -1; o <= 1; o++) {
    int x = c + o;
    if (x < 0 || x >= n) {
      if (!D->P.periodic[d]) continue;
      x = (x + n) % n;
    }
    int dup = 0;
    for (int q = 0; q < k; q++) dup |= out[q] == x;
    if (!dup) out[k++] = x;
  }
  return k;
}

/* The (up to 27) distinct cells adjacent to cell c, itself included. */
SPHDEM_HD int dem_neighbor_cells(const dem_dev *D, int32_t c, int32_t *out) {
  int nx = D->nc[0], ny = D->nc[1];
  int cx = c % nx, cy = (c / nx) % ny, cz = c / (nx * ny);
  int ax[3], ay[3], az[3];
  int kx = dem_axis_neighbors(D, 0, cx, ax), ky = dem_axis_neighbors(D, 1, cy, ay),
      kz = dem_axis_neighbors(D, 2, cz, az), n = 0;
  for (int z = 0; z < kz; z++)
    for (int y = 0; y < ky; y++) {
      const int64_t row = ((int64_t)az[z] * ny + ay[y]) * nx;
      for (int x = 0; x < kx; x++) out[n++] = (int32_t)(row + ax[x]);
    }
  return n;
}

/* r = xa - xb with the minimum image on periodic axes; returns |r|^2. */
SPHDEM_HD double dem_sep(const dem_dev *D, const double *xa, const double *xb, double *r) {
  double s[3] = {xa[0] - xb[0], xa[1] - xb[1], xa[2] - xb[2]};
  double rsq = s[0] * s[0] + s[1] * s[1] + s[2] * s[2]; /* (0 + s0^2) + ... as before: the same bits */
  /* |s|^2 < min (L/2)^2: every |s_d| < L_d/2 (the rounded squares are monotone and rsq is no less than any of
   * them), so rint(s_d/L_d) is 0 and s stays as it is: one compare for most pairs. Else the axes of |s_d| >= L_d/2
   * (halfL is L/2 on periodic axes, HUGE_VAL on the others) take the image, and |r|^2 is taken again. */
  if (!(rsq < D->halfL2min) &&
      !((fabs(s[0]) < D->halfL[0]) & (fabs(s[1]) < D->halfL[1]) & (fabs(s[2]) < D->halfL[2]))) {
    for (int d = 0; d < 3; d++)
      if (!(fabs(s[d]) < D->halfL[d]) && D->P.periodic[d]) s[d] -= D->L[d] * rint(s[d] / D->L[d]);
    rsq = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
  }
  for (int d = 0; d < 3; d++) r[d] = s[d];
  return rsq;
}

/* keep_history: which periodic image of b touches a, as the touch flag of the history stores it
 * (2 + code; 1 = not recorded, 0 = no history). The engine's list holds each image of a grain as its own
 * pair with its own history; the core keys pairs by tags, so a kept history belongs to the image it was
 * made with. Positions are continuous between the engine's builds, so the shift is well defined there. */
SPHDEM_HD double dem_image_flag(const dem_dev *D, const double *xa, const double *xb) {
  double code = 0.0, w = 1.0;
  for (int d = 0; d < 3; d++, w *= 64.0) {
    double n = 0.0, s = xa[d] - xb[d];
    if (D->P.periodic[d] && !(fabs(s) < 0.5 * D->L[d])) n = rint(s / D->L[d]);
    code += (n + 32.0) * w;
  }
  return 2.0 + code;
}

/* Signed distance of x from wall w along its normal. */
SPHDEM_HD double dem_wall_dist(const dem_dev *D, int w, const double *x) {
  const sphdem_dem_wall *W = &D->walls[w];
  return (x[0] - W->point[0]) * W->normal[0] + (x[1] - W->point[1]) * W->normal[1] +
         (x[2] - W->point[2]) * W->normal[2];
}

SPHDEM_HD uint64_t dem_key(int64_t ta, uint32_t tb) { return ((uint64_t)ta << 32) | (uint64_t)tb; }
SPHDEM_HD uint32_t dem_wall_code(int w) { return 0xffffffffu - (uint32_t)w; }

/* Yu 2024 §2.3 collision detection for sorted slot s: candidates j in the adjacent cells with a later
 * slot (each pair once) closer than r_i + r_j + skin, then the walls closer than r_i + skin. With
 * write = 0 it only counts; with write = 1 it stores the pairs from off[s] on (up to the capacity pcap of
 * the pair arrays), the grain of lower tag first. Returns the count. The slots are sorted by cell, so a
 * cell of lower index than s's holds earlier slots only: it is skipped, and s's own cell is read from
 * s + 1 on. */
/* Grains of other MPI ranks (SPHDEM_DEM_GHOST) and periodic images of this rank's grains
 * (SPHDEM_DEM_IMAGE) take part only in pairs with a grain of this rank; a pair with an image is kept once,
 * as the image of the grain of higher tag (its twin, the image of the other grain, is dropped). A pair with
 * another rank's grain is kept on both ranks, or (ghost_once) on the rank of its grain of lower tag only. A pair
 * whose classes are excluded (sphdem_dem_set_exclusions) is never kept. */
SPHDEM_HD int dem_pair_kept(const dem_dev *D, int32_t i, int32_t j) {
  if (D->any_excl) { /* pairs the engine excludes (sphdem_dem_set_exclusions) */
    const int ci = (D->flags[i] & SPHDEM_DEM_CLASS_MASK) >> SPHDEM_DEM_CLASS_SHIFT;
    const int cj = (D->flags[j] & SPHDEM_DEM_CLASS_MASK) >> SPHDEM_DEM_CLASS_SHIFT;
    if ((D->excl[ci] >> cj) & 1) return 0;
  }
  const int32_t away = SPHDEM_DEM_GHOST | SPHDEM_DEM_IMAGE, fi = D->flags[i] & away, fj = D->flags[j] & away;
  if (!fi && !fj) return 1;
  if (fi && fj) return 0;
  if (fi & SPHDEM_DEM_IMAGE) return D->tag[j] < D->tag[i];
  if (fj & SPHDEM_DEM_IMAGE) return D->tag[i] < D->tag[j];
  return !D->ghost_once || (fi ? D->tag[j] < D->tag[i] : D->tag[i] < D->tag[j]);
}

/* A pair evaluated on two ranks (one grain a SPHDEM_DEM_GHOST) counts half in the virial of each. */
SPHDEM_HD void dem_pair_virial_shared(const dem_dev *D, int32_t a, int32_t b, double *vir) {
  if (!D->ghost_once && ((D->flags[a] | D->flags[b]) & SPHDEM_DEM_GHOST))
    for (int d = 0; d < 6; d++) vir[d] *= 0.5;
}

/* The counters (touching contacts, candidate pairs) take a pair on the rank that owns its grain of lower
 * tag (a), so that their sums over the ranks count each pair once. */
SPHDEM_HD int dem_pair_counted(const dem_dev *D, int32_t a) { return !(D->flags[a] & SPHDEM_DEM_GHOST); }

SPHDEM_HD int64_t dem_scan_slot(const dem_dev *D, int64_t s, int write) {
  int32_t i = D->sidx[s];
  const double *xi = D->x + 3 * (int64_t)i;
  double ri = D->rad[i], r[3];
  int64_t k = 0, o = write ? D->off[s] : 0;
  int32_t cells[27];
  const int32_t cs = D->cell[s];
  if (cs == D->ncells) return 0; /* SPHDEM_DEM_SKIP */
  int nn = dem_neighbor_cells(D, cs, cells);
  for (int q = 0; q < nn; q++) {
    int32_t c = cells[q];
    if (c < cs) continue;
    for (int32_t t = c == cs ? (int32_t)s + 1 : D->cstart[c]; t < D->cend[c]; t++) {
      int32_t j = D->sidx[t];
      double cut = ri + D->rad[j] + D->P.skin;
      if (dem_sep(D, xi, D->x + 3 * (int64_t)j, r) >= cut * cut) continue;
      if (!dem_pair_kept(D, i, j)) continue;
      if (write && o + k < D->pcap) {
        int64_t p = o + k;
        int lo = D->tag[i] < D->tag[j];
        D->pa[p] = lo ? i : j;
        D->pb[p] = lo ? j : i;
        D->key[p] = lo ? dem_key(D->tag[i], (uint32_t)D->tag[j]) : dem_key(D->tag[j], (uint32_t)D->tag[i]);
      }
      k++;
    }
  }
  const int own = !(D->flags[i] & (SPHDEM_DEM_GHOST | SPHDEM_DEM_IMAGE)); /* walls: this rank's grains */
  for (int w = 0; w < D->nw && own; w++) {
    if (dem_wall_dist(D, w, xi) >= ri + D->P.skin) continue;
    if (write && o + k < D->pcap) {
      int64_t p = o + k;
      D->pa[p] = i;
      D->pb[p] = -1 - w;
      D->key[p] = dem_key(D->tag[i], dem_wall_code(w));
    }
    k++;
  }
  return k;
}
SPHDEM_HD void dem_count_body(const dem_dev *D, int64_t s) { D->cnt[s] = dem_scan_slot(D, s, 0); }

/* ---- contact laws ------------------------------------------------------------------------------------ */

/* The LIGGGHTS material pair of grains a and b (b < 0: a wall, taken as of a's material): the params'
 * one material, or the table entry of the two grains' materials (flags >> SPHDEM_DEM_MATERIAL_SHIFT). */
SPHDEM_HD const dem_mat *dem_pair_material(const dem_dev *D, int32_t a, int32_t b) {
  if (D->nmat == 0) return &D->mat0;
  const int ia = D->flags[a] >> SPHDEM_DEM_MATERIAL_SHIFT, ib = b >= 0 ? D->flags[b] >> SPHDEM_DEM_MATERIAL_SHIFT : ia;
  return &D->mat[(int64_t)ia * D->nmat + ib];
}

/* LIGGGHTS' granular models "hertz|hooke|hooke/hysteresis tangential history [rolling_friction ...]
 * [cohesion ...]" (hooke and hooke/hysteresis below; surface model default:
 * lever arms r - delta/2), term by term, with the material pair of the two grains (dem_pair_material,
 * LIGGGHTS' [itype][jtype] values): k_n = 4/3 Y* sqrt(R* delta),
 * k_t = 8 G* sqrt(R* delta), gamma = -2 sqrt(5/6) beta sqrt(S m_eff) with S_n = 2 Y* sqrt(R* delta),
 * S_t = k_t; the tangential spring is capped at mu |F_n| (without damping when sliding); the
 * constant rolling torque mu_r k_n delta R* opposes the relative rotation, its normal part removed. */
DEM_HD_INLINE void dem_contact_liggghts(const dem_dev *D, int64_t p, int wall, const double *del, double r, double rinv,
                                    double ra, double rb, double radsum, double meff, double *Fa, double *Ta,
                                    double *Tb, double *hout) {
  const int32_t a = D->pa[p], b = D->pb[p];
  const double *va = D->v + 3 * (int64_t)a, *wa = D->om + 3 * (int64_t)a;
  const double *hin = D->hin + SPHDEM_DEM_NHIST * p;
  const double zero[3] = {0.0, 0.0, 0.0};
  const double *vb = wall ? zero : D->v + 3 * (int64_t)b, *wb = wall ? zero : D->om + 3 * (int64_t)b;
  const dem_mat *M = dem_pair_material(D, a, b);
  const double en[3] = {del[0] * rinv, del[1] * rinv, del[2] * rinv};
  const double vr1 = va[0] - vb[0], vr2 = va[1] - vb[1], vr3 = va[2] - vb[2];
  const double vn = vr1 * en[0] + vr2 * en[1] + vr3 * en[2];
  const double vt1 = vr1 - vn * en[0], vt2 = vr2 - vn * en[1], vt3 = vr3 - vn * en[2];
  const double deltan = radsum - r;
  double wr1, wr2, wr3, cri, crj = 0.0;
  if (wall) {
    cri = ra - 0.5 * deltan;
    wr1 = cri * wa[0] * rinv;
    wr2 = cri * wa[1] * rinv;
    wr3 = cri * wa[2] * rinv;
  } else {
    cri = ra - 0.5 * deltan;
    crj = rb - 0.5 * deltan;
    wr1 = (cri * wa[0] + crj * wb[0]) * rinv;
    wr2 = (cri * wa[1] + crj * wb[1]) * rinv;
    wr3 = (cri * wa[2] + crj * wb[2]) * rinv;
  }
  const double vtr1 = vt1 - (del[2] * wr2 - del[1] * wr3);
  const double vtr2 = vt2 - (del[0] * wr3 - del[2] * wr1);
  const double vtr3 = vt3 - (del[1] * wr1 - del[0] * wr2);
  /* with keep_history a history kept from a contact through another periodic image is not this
   * contact's (the engine's list has the images as separate pairs): it starts from zero */
  double flag = 1.0;
  int other_image = 0;
  if (D->P.keep_history) {
    flag = wall ? 2.0 : dem_image_flag(D, D->x + 3 * (int64_t)a, D->x + 3 * (int64_t)b);
    other_image = hin[3] <= -2.0 && -hin[3] != flag;
  }
  /* normal */
  const double reff = wall ? ra : (ra * rb / (ra + rb));
  double kn, kt, gamman, gammat, Fn, deltamax = 0.0;
  const int hysteresis = D->P.model == SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS;
  if (D->P.model == SPHDEM_DEM_HOOKE_LIGGGHTS || hysteresis) {
    /* LIGGGHTS model hooke: stiffness from Y* and the characteristic velocity, damping from e */
    const double sqrtval = sqrt(reff), V = D->P.charvel;
    kn = 16. / 15. * sqrtval * M->Yeff * pow(15. * meff * V * V / (16. * sqrtval * M->Yeff), 0.2);
    kt = D->P.kt_to_kn && !hysteresis ? kn * 0.285714286 : kn; /* the 2/7 as LIGGGHTS writes it */
    const double pl = M_PI / M->lnen;
    gamman = sqrt(4. * meff * kn / (1. + pl * pl));
    gammat = D->P.no_tangential_damping ? 0.0 : gamman; /* tangential_damping off */
  } else {
    const double sqrtval = sqrt(reff * deltan);
    const double Sn = 2. * M->Yeff * sqrtval, St = 8. * M->Geff * sqrtval;
    kn = 4. / 3. * M->Yeff * sqrtval;
    kt = St;
    const double sqrtFiveOverSix = 0.91287092917527685576161630466800355658790782499663875;
    gamman = -2. * sqrtFiveOverSix * M->betaeff * sqrt(Sn * meff);
    /* tangential_damping off: gamma_t = 0 */
    gammat = D->P.no_tangential_damping ? 0.0 : -2. * sqrtFiveOverSix * M->betaeff * sqrt(St * meff);
  }
  if (hysteresis) {
    /* LIGGGHTS model hooke/hysteresis (normal_model_hooke_hysteresis.h; Walton & Braun 1986 in the form of
     * Luding 2008): loading on k_n; unloading and reloading on k_2 = k_n + (k_2,max - k_n) delta_max /
     * delta_lim from F = k_2 (delta - delta_max) + k_n delta_max, with delta_max the largest overlap (kept per
     * pair, as LIGGGHTS raises it also while the history is not advanced) and delta_lim = k_2,max / (k_2,max -
     * k_n) 2 phi_F R*, beyond which k_2 = k_2,max; the force is not below the adhesive branch -k_c delta,
     * where delta_max is moved so that the unloading line meets it. No force limit (limitForce is ignored). */
    const double k2Max = kn * M->kn2kcmax, kc = kn * M->kn2kc;
    deltamax = other_image ? 0.0 : hin[4];
    if (deltan > deltamax) deltamax = deltan;
    const double deltaMaxLim = (k2Max / (k2Max - kn)) * M->phif * 2 * reff;
    double fHys;
    int adhesive = 0;
    if (deltamax >= deltaMaxLim) { /* beyond the plastic limit: k_2,max */
      const double fTmp = k2Max * (deltan - deltaMaxLim) + kn * deltaMaxLim;
      if (fTmp >= -kc * deltan) fHys = fTmp;
      else fHys = -kc * deltan, adhesive = 1;
    } else {
      const double k2 = kn + (k2Max - kn) * deltamax / deltaMaxLim;
      const double fTmp = k2 * (deltan - deltamax) + kn * deltamax;
      if (fTmp >= kn * deltan) fHys = kn * deltan; /* loading */
      else if (fTmp > -kc * deltan) fHys = fTmp;   /* unloading, reloading */
      else fHys = -kc * deltan, adhesive = 1;
    }
    if (adhesive && D->update)
      deltamax = 0.5 * (deltan + sqrt(deltan * deltan + 4 * ((kn + kc) * deltan * deltaMaxLim / (k2Max - kn))));
    Fn = fHys + -gamman * vn;
  } else {
    Fn = -gamman * vn + kn * deltan;
    if (D->P.limit_damping && Fn < 0.0) Fn = 0.0;
  }
  for (int d = 0; d < 3; d++) Fa[d] = Fn * en[d];
  /* cohesion sjkr / sjkr2 (LIGGGHTS cohesion_model_sjkr.h, sjkr2.h; tangential_reduce off: the friction
   * limit keeps F_n): F = -k A along the normal, added before the tangential force as LIGGGHTS does */
  if (D->P.cohesion) {
    double Acont;
    if (D->P.cohesion == SPHDEM_DEM_COH_SJKR)
      Acont = wall ? (ra * ra - r * r) * M_PI : dem_lens_area(r, ra, rb);
    else
      Acont = wall ? M_PI * 2. * ra * (ra - r) : M_PI * 2. * (2. * ra * rb / (ra + rb)) * (ra + rb - r);
    const double Fn_coh = -M->ced * Acont;
    for (int d = 0; d < 3; d++) Fa[d] += Fn_coh * en[d];
  }
  /* tangential history */
  double shear[3] = {hin[0], hin[1], hin[2]};
  if (other_image) shear[0] = shear[1] = shear[2] = 0.0;
  if (D->update) {
    shear[0] += vtr1 * D->dt;
    shear[1] += vtr2 * D->dt;
    shear[2] += vtr3 * D->dt;
    const double rsht = shear[0] * en[0] + shear[1] * en[1] + shear[2] * en[2];
    shear[0] -= rsht * en[0];
    shear[1] -= rsht * en[1];
    shear[2] -= rsht * en[2];
  }
  const double shrmag = sqrt(shear[0] * shear[0] + shear[1] * shear[1] + shear[2] * shear[2]);
  double Ft1 = -(kt * shear[0]), Ft2 = -(kt * shear[1]), Ft3 = -(kt * shear[2]);
  const double Ft_shear = kt * shrmag, Ft_friction = M->mu * fabs(Fn);
  if (Ft_shear > Ft_friction) {
    if (shrmag != 0.0) {
      const double ratio = Ft_friction / Ft_shear;
      Ft1 *= ratio;
      Ft2 *= ratio;
      Ft3 *= ratio;
      if (D->update) {
        shear[0] = -Ft1 / kt;
        shear[1] = -Ft2 / kt;
        shear[2] = -Ft3 / kt;
      }
    } else {
      Ft1 = Ft2 = Ft3 = 0.0;
    }
  } else {
    Ft1 -= (gammat * vtr1);
    Ft2 -= (gammat * vtr2);
    Ft3 -= (gammat * vtr3);
  }
  const double tor1 = en[1] * Ft3 - en[2] * Ft2, tor2 = en[2] * Ft1 - en[0] * Ft3, tor3 = en[0] * Ft2 - en[1] * Ft1;
  Ta[0] = -cri * tor1;
  Ta[1] = -cri * tor2;
  Ta[2] = -cri * tor3;
  Tb[0] = -crj * tor1;
  Tb[1] = -crj * tor2;
  Tb[2] = -crj * tor3;
  Fa[0] += Ft1;
  Fa[1] += Ft2;
  Fa[2] += Ft3;
  /* rolling friction epsd2 (LIGGGHTS rolling_model_epsd2.h, torsionTorque off): a spring torque on the
   * tangential part of the relative rotation, k_r = k_t R*^2, added to the pair's previous torque and
   * capped at mu_r R* |F_n| */
  /* epsd (rolling_model_epsd.h, 3D): k_r = 2.25 k_n mu_r^2 R*^2, and below the cap a dashpot on the same
   * rotation, not kept in the history */
  if (D->P.mu_r > 0.0 && D->P.rolling_model != SPHDEM_DEM_ROLL_CDT) {
    const int epsd = D->P.rolling_model == SPHDEM_DEM_ROLL_EPSD;
    double wr[3];
    if (wall) {
      wr[0] = wr1, wr[1] = wr2, wr[2] = wr3;
    } else {
      for (int d = 0; d < 3; d++) wr[d] = wa[d] - wb[d];
    }
    const double wr_dot_delta = wr[0] * en[0] + wr[1] * en[1] + wr[2] * en[2];
    double wr_tot[3], rt[3];
    for (int d = 0; d < 3; d++) wr_tot[d] = wr[d] - en[d] * wr_dot_delta;
    const double kr = epsd ? 2.25 * kn * M->mu_r * M->mu_r * reff * reff : kt * reff * reff, s = D->dt * kr;
    const double *rold = D->rin + 3 * p;
    for (int d = 0; d < 3; d++) rt[d] = (other_image ? 0.0 : rold[d]) + wr_tot[d] * s;
    const double rtmag = sqrt(rt[0] * rt[0] + rt[1] * rt[1] + rt[2] * rt[2]);
    const double rtmax = fabs(Fn) * reff * M->mu_r;
    const int capped = rtmag > rtmax;
    if (capped) {
      const double factor = rtmax / rtmag;
      for (int d = 0; d < 3; d++) rt[d] *= factor;
    }
    if (hout) {
      double *rnew = D->rout + 3 * p;
      for (int d = 0; d < 3; d++) rnew[d] = D->update ? rt[d] : (other_image ? 0.0 : rold[d]);
    }
    if (epsd && !capped) {
      double r_inertia;
      const double mi = D->mass[a];
      if (wall) {
        r_inertia = 1.4 * mi * reff * reff;
      } else {
        const double mj = D->mass[b], ri_red = mi * ra * ra, rj_red = mj * rb * rb;
        r_inertia = 1.4 * ri_red * rj_red / (ri_red + rj_red);
      }
      const double r_coef = M->rvd * 2 * sqrt(r_inertia * kr);
      for (int d = 0; d < 3; d++) rt[d] += r_coef * wr_tot[d];
    }
    for (int d = 0; d < 3; d++) {
      Ta[d] -= rt[d];
      Tb[d] += rt[d];
    }
  } else if (D->P.mu_r > 0.0) { /* rolling friction, constant directional torque (cdt) */
    const double rmu = M->mu_r;
    double rt[3] = {0.0, 0.0, 0.0};
    if (wall) {
      const double wrmag = sqrt(wr1 * wr1 + wr2 * wr2 + wr3 * wr3);
      if (wrmag > 0.) {
        const double F = deltan * kn;
        rt[0] = rmu * F * wr1 / wrmag * reff;
        rt[1] = rmu * F * wr2 / wrmag * reff;
        rt[2] = rmu * F * wr3 / wrmag * reff;
      }
    } else {
      const double w[3] = {wa[0] - wb[0], wa[1] - wb[1], wa[2] - wb[2]};
      const double wmag = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      if (wmag > 0.) {
        const double sc = rmu * kn * deltan * reff / wmag;
        rt[0] = w[0] * sc;
        rt[1] = w[1] * sc;
        rt[2] = w[2] * sc;
      }
    }
    const double rtn = rt[0] * en[0] + rt[1] * en[1] + rt[2] * en[2];
    const double rn[3] = {en[0] * rtn, en[1] * rtn, en[2] * rtn};
    for (int d = 0; d < 3; d++) {
      rt[d] = rt[d] - rn[d];
      Ta[d] -= rt[d];
      Tb[d] += rt[d];
    }
  }
  if (hout) {
    hout[0] = shear[0];
    hout[1] = shear[1];
    hout[2] = shear[2];
    hout[3] = flag;
    hout[4] = deltamax;
  }
}

/* ---- LAMMPS pair_style granular (29 Sep 2021): one body per sub-model, composed per type pair ---------
 * The registry: gran_normal (hooke, hertz, hertz/material, dmt), gran_damping (velocity, mass_velocity,
 * viscoelastic, tsuji), gran_tangential (linear_nohistory, linear_history, mindlin), gran_rolling (sds),
 * gran_twisting (marshall, sds); dem_contact_granular calls the ones of the pair's types (D->gran), and a
 * rolling or twisting model that is off is not evaluated. Symbols as in the LAMMPS documentation:
 * delta overlap, R* = r_a r_b / (r_a + r_b), a = sqrt(R* delta), n the unit normal from b to a. */

#define SPHDEM_GRAN_EPSILON 1e-10 /* below EPSILON F_crit the history is already in the tangent plane */

/* Normal elastic force F_ne and the stiffness factor k_nfac (F_ne = k_nfac delta, dmt less the pull-off):
 * hooke k_n delta; hertz, hertz/material k_n a delta; dmt k_n a delta - 4 pi w R*. */
DEM_HD_INLINE double gran_normal(const sphdem_dem_granular *C, double delta, double a, double reff, double *knfac) {
  double k = C->kn;
  if (C->normal != SPHDEM_GRAN_HOOKE) k *= a;
  *knfac = k;
  double F = k * delta;
  if (C->normal == SPHDEM_GRAN_DMT) F -= 4.0 * M_PI * C->cohesion * reff;
  return F;
}

/* The normal damping prefactor eta_n = eta_n0 x {1, m*, a m*, sqrt(m* k_nfac)} (velocity, mass_velocity,
 * viscoelastic, tsuji; tsuji's eta_n0 is alpha(e), set when the coefficients were read). */
DEM_HD_INLINE double gran_damping(const sphdem_dem_granular *C, double meff, double a, double knfac) {
  double d;
  switch (C->damping) {
    case SPHDEM_GRAN_DAMP_VELOCITY: d = 1.0; break;
    case SPHDEM_GRAN_DAMP_MASS_VELOCITY: d = meff; break;
    case SPHDEM_GRAN_DAMP_VISCOELASTIC: d = a * meff; break;
    default: d = sqrt(meff * knfac); break;
  }
  return C->damp * d;
}

/* A history vector h (3) brought back into the tangent plane of n, keeping its length, when its normal part
 * matters (|h.n| k > EPSILON F_crit), then advanced by rate dt. */
DEM_HD_INLINE void gran_history_advance(double *h, const double *n, double k, double fcrit, const double *rate, double dt) {
  const double hn = h[0] * n[0] + h[1] * n[1] + h[2] * n[2];
  if (fabs(hn) * k > SPHDEM_GRAN_EPSILON * fcrit) {
    const double mag = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (int d = 0; d < 3; d++) h[d] -= hn * n[d];
    const double prj = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    const double s = prj > 0.0 ? mag / prj : 0.0;
    for (int d = 0; d < 3; d++) h[d] *= s;
  }
  for (int d = 0; d < 3; d++) h[d] += rate[d] * dt;
}

/* A spring-dashpot F = -k h - eta v capped at F_crit: beyond it the spring is set so that spring and dashpot
 * give the capped force (a zero spring: no force). Used by the tangential and the rolling history. */
DEM_HD_INLINE void gran_spring_capped(double *h, double k, double eta, const double *v, double fcrit, double *F) {
  for (int d = 0; d < 3; d++) F[d] = -k * h[d] - eta * v[d];
  const double fm = sqrt(F[0] * F[0] + F[1] * F[1] + F[2] * F[2]);
  if (fm > fcrit) {
    const double hm = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    if (hm != 0.0) {
      for (int d = 0; d < 3; d++) h[d] = -1.0 / k * (fcrit * F[d] / fm + eta * v[d]);
      for (int d = 0; d < 3; d++) F[d] *= fcrit / fm;
    } else {
      F[0] = F[1] = F[2] = 0.0;
    }
  }
}

/* Tangential force fs from the relative tangential velocity vtr at the contact: linear_nohistory a dashpot
 * eta_t |v_t| capped at F_scrit; linear_history and mindlin (k_t a) a spring on the accumulated displacement h
 * (kept in the history) with a dashpot, capped. Returns k_t as used (for marshall's twisting). */
DEM_HD_INLINE double gran_tangential(const sphdem_dem_granular *C, int update, double dt, const double *n, const double *vtr,
                                 double a, double damp_t, double fscrit, double *h, double *fs) {
  if (C->tangential == SPHDEM_GRAN_TANG_LINEAR_NOHISTORY) {
    const double vrel = sqrt(vtr[0] * vtr[0] + vtr[1] * vtr[1] + vtr[2] * vtr[2]);
    const double fsm = damp_t * vrel;
    const double Ft = vrel != 0.0 ? (fsm < fscrit ? fsm : fscrit) / vrel : 0.0;
    for (int d = 0; d < 3; d++) fs[d] = -Ft * vtr[d];
    return C->kt;
  }
  double kt = C->kt;
  if (C->tangential == SPHDEM_GRAN_TANG_MINDLIN) kt *= a;
  if (update) gran_history_advance(h, n, kt, fscrit, vtr, dt);
  gran_spring_capped(h, kt, damp_t, vtr, fscrit, fs);
  return kt;
}

/* Rolling resistance sds: the rolling velocity v_roll = R* (w_rel x n) (Wang 2015 eq 31) accumulated in hr
 * drives a spring-dashpot capped at mu_roll F_ncrit; torque on a R* (n x F_r), on b the opposite. */
DEM_HD_INLINE void gran_rolling(const sphdem_dem_granular *C, int update, double dt, const double *n, const double *wrel,
                            double reff, double fncrit, double *hr, double *Tr) {
  const double vrl[3] = {reff * (wrel[1] * n[2] - wrel[2] * n[1]), reff * (wrel[2] * n[0] - wrel[0] * n[2]),
                         reff * (wrel[0] * n[1] - wrel[1] * n[0])};
  const double frcrit = C->mu_r * fncrit;
  if (update) gran_history_advance(hr, n, C->kr, frcrit, vrl, dt);
  double fr[3];
  gran_spring_capped(hr, C->kr, C->damp_r, vrl, frcrit, fr);
  Tr[0] = reff * (n[1] * fr[2] - n[2] * fr[1]);
  Tr[1] = reff * (n[2] * fr[0] - n[0] * fr[2]);
  Tr[2] = reff * (n[0] * fr[1] - n[1] * fr[0]);
}

/* Twisting: the twist rate w_rel.n accumulated in *ht drives M_t = -k ht - eta w_t, capped at mu F_ncrit
 * (Marshall 2009 eqs 29-34); marshall takes k = k_t a^2/2, eta = eta_t a^2/2, mu = 2/3 a mu_s. Returns M_t
 * (the torque on a is M_t n). */
DEM_HD_INLINE double gran_twisting(const sphdem_dem_granular *C, int update, double dt, const double *n, const double *wrel,
                               double a, double kt, double damp_t, double fncrit, double *ht) {
  const double wt = wrel[0] * n[0] + wrel[1] * n[1] + wrel[2] * n[2];
  double k, eta, mu;
  if (C->twisting == SPHDEM_GRAN_TWIST_MARSHALL) {
    k = 0.5 * kt * a * a;
    eta = 0.5 * damp_t * a * a;
    mu = 2.0 / 3.0 * a * C->mu;
  } else {
    k = C->ktw, eta = C->damp_tw, mu = C->mu_tw;
  }
  if (update) *ht += wt * dt;
  double M = -k * *ht - eta * wt;
  const double sgn = (wt > 0) - (wt < 0), mcrit = mu * fncrit;
  if (fabs(M) > mcrit) {
    *ht = 1.0 / k * (mcrit * sgn - eta * wt);
    M = -mcrit * sgn;
  }
  return M;
}

/* The contact of an overlapping pair under pair_style granular: the sub-models of the pair's types.
 * Fa force on a (b: -Fa); Ta, Tb torques; hout the history (tangential xyz, touch flag, twist; rolling in
 * D->rout). A wall (b < 0) is a flat partner at rest with R* = r_a. */
DEM_HD_INLINE void dem_contact_granular(const dem_dev *D, int64_t p, int wall, const double *del, double r, double ra,
                                    double rb, double radsum, double meff, double *Fa, double *Ta, double *Tb,
                                    double *hout) {
  const int32_t a_ = D->pa[p], b_ = D->pb[p];
  const int ta = D->flags[a_] >> SPHDEM_DEM_MATERIAL_SHIFT, tb = wall ? ta : D->flags[b_] >> SPHDEM_DEM_MATERIAL_SHIFT;
  const sphdem_dem_granular *C = &D->gran[(int64_t)ta * D->ngran + tb];
  const double zero[3] = {0.0, 0.0, 0.0};
  const double *va = D->v + 3 * (int64_t)a_, *wa = D->om + 3 * (int64_t)a_;
  const double *vb = wall ? zero : D->v + 3 * (int64_t)b_, *wb = wall ? zero : D->om + 3 * (int64_t)b_;
  const double *hin = D->hin + SPHDEM_DEM_NHIST * p;
  const double rinv = 1.0 / r;
  const double n[3] = {del[0] * rinv, del[1] * rinv, del[2] * rinv};
  const double vr[3] = {va[0] - vb[0], va[1] - vb[1], va[2] - vb[2]};
  const double vnnr = vr[0] * n[0] + vr[1] * n[1] + vr[2] * n[2];
  const double reff = wall ? ra : ra * rb / radsum;
  const double delta = radsum - r;
  const double a = sqrt(delta * reff);
  /* normal: elastic, damping, the limit */
  double knfac;
  const double Fne = gran_normal(C, delta, a, reff, &knfac);
  const double damp_n = gran_damping(C, meff, a, knfac);
  double Fntot = Fne - damp_n * vnnr;
  if (C->limit_damping && Fntot < 0.0) Fntot = 0.0;
  /* the critical normal force of the friction limits: |F_ntot|; dmt: |F_ne| (the stock 2021 code adds twice a
   * pull-off force made of a cohesion it sets only for jkr pairs: 0 in a run without jkr, as measured) */
  const double Fncrit = C->normal == SPHDEM_GRAN_DMT ? fabs(Fne) : fabs(Fntot);
  /* relative tangential velocity at the contact point: v_t - n x (r_a w_a + r_b w_b) */
  double vtr[3];
  {
    const double vn[3] = {n[0] * vnnr, n[1] * vnnr, n[2] * vnnr};
    const double wr[3] = {ra * wa[0] + rb * wb[0], ra * wa[1] + rb * wb[1], ra * wa[2] + rb * wb[2]};
    vtr[0] = (vr[0] - vn[0]) - (n[2] * wr[1] - n[1] * wr[2]);
    vtr[1] = (vr[1] - vn[1]) - (n[0] * wr[2] - n[2] * wr[0]);
    vtr[2] = (vr[2] - vn[2]) - (n[1] * wr[0] - n[0] * wr[1]);
  }
  double h[3] = {hin[0], hin[1], hin[2]}, fs[3];
  const double damp_t = C->damp_t * damp_n;
  const double kt = gran_tangential(C, D->update, D->dt, n, vtr, a, damp_t, C->mu * Fncrit, h, fs);
  for (int d = 0; d < 3; d++) Fa[d] = n[d] * Fntot + fs[d];
  const double tor[3] = {n[1] * fs[2] - n[2] * fs[1], n[2] * fs[0] - n[0] * fs[2], n[0] * fs[1] - n[1] * fs[0]};
  const double ca = ra - 0.5 * delta, cb = rb - 0.5 * delta;
  for (int d = 0; d < 3; d++) {
    Ta[d] = -ca * tor[d];
    Tb[d] = -cb * tor[d];
  }
  double twist = hin[4];
  if (C->rolling != SPHDEM_GRAN_ROLL_NONE || C->twisting != SPHDEM_GRAN_TWIST_NONE) {
    const double wrel[3] = {wa[0] - wb[0], wa[1] - wb[1], wa[2] - wb[2]};
    if (C->twisting != SPHDEM_GRAN_TWIST_NONE) {
      const double M = gran_twisting(C, D->update, D->dt, n, wrel, a, kt, damp_t, Fncrit, &twist);
      for (int d = 0; d < 3; d++) {
        Ta[d] += M * n[d];
        Tb[d] -= M * n[d];
      }
    }
    if (C->rolling != SPHDEM_GRAN_ROLL_NONE) {
      const double *ro = D->rin + 3 * p;
      double hr[3] = {ro[0], ro[1], ro[2]}, Tr[3];
      gran_rolling(C, D->update, D->dt, n, wrel, reff, Fncrit, hr, Tr);
      for (int d = 0; d < 3; d++) {
        Ta[d] += Tr[d];
        Tb[d] -= Tr[d];
      }
      if (hout)
        for (int d = 0; d < 3; d++) D->rout[3 * p + d] = hr[d];
    }
  }
  if (hout) {
    if (D->rin && C->rolling == SPHDEM_GRAN_ROLL_NONE)
      for (int d = 0; d < 3; d++) D->rout[3 * p + d] = 0.0;
    hout[0] = h[0];
    hout[1] = h[1];
    hout[2] = h[2];
    hout[3] = 1.0;
    hout[4] = twist;
  }
}

/* Force and torques of pair p. Fa: force on a (b gets -Fa); Ta, Tb torques on a and b; hout (NULL: not
 * written) the updated history; vir the pair virial r_ab Fa (xx yy zz xy xz yz). Returns 1 if touching.
 * Geometry, relative velocities and the tangential history (accumulated v_t dt, then projected on the
 * tangent plane, Yu eq 13) are common; the three laws differ in the normal and tangential forces. */
/* Grains a and b with coincident centres: no contact normal exists. The first such pair found is kept in
 * the slot after the contact counter (dem.c reports it by tag); the pair then counts as not touching. */
SPHDEM_HD void dem_flag_coincident(const dem_dev *D, int32_t a, int32_t b) {
  unsigned long long code = ((unsigned long long)(uint32_t)(a + 1) << 32) | (uint32_t)b;
  unsigned long long *slot = (unsigned long long *)(D->vir + SPHDEM_DEM_VIR_COINCIDENT);
#ifdef __CUDA_ARCH__
  atomicCAS(slot, 0ull, code);
#else
  __atomic_store_n(slot, code, __ATOMIC_RELAXED); /* any one of the pairs will do */
#endif
}

/* Geometry of pair p of grain a (at xa, radius ra): del = x_a - x_b (minimum image; for a wall the distance
 * along its normal), |del|^2, the partner's radius (0 for a wall) and r_a + r_b. Returns 1 if the grains
 * overlap. */
/* The same for a grain partner b (>= 0), with rsq and radsum always written. */
DEM_HD_INLINE int dem_grain_overlap(const dem_dev *D, const int32_t a, const int32_t b, const double *xa, const double ra,
                                    double *del, double *rsq_, double *radsum_) {
  const double rsq = dem_sep(D, xa, D->x + 3 * (int64_t)b, del), radsum = ra + D->rad[b];
  *rsq_ = rsq;
  *radsum_ = radsum;
  if (!(rsq < radsum * radsum)) return 0; /* most candidate pairs of a loose packing: out first */
  if (rsq <= 1e-24 * radsum * radsum) { /* centres within 1e-12 of the contact distance: r = 0 */
    dem_flag_coincident(D, a, b);
    return 0;
  }
  return 1;
}

DEM_HD_INLINE int dem_contact_geom_a(const dem_dev *D, int64_t p, const int32_t a, const double *xa, const double ra,
                                     double *del, double *rsq_, double *rb_, double *radsum_) {
  const int32_t b = D->pb[p];
  double rsq, rb, radsum;
  if (b >= 0) {
    if (!dem_grain_overlap(D, a, b, xa, ra, del, &rsq, &radsum)) return 0;
    rb = D->rad[b];
  } else {
    const int w = -1 - b;
    const double dist = dem_wall_dist(D, w, xa);
    for (int d = 0; d < 3; d++) del[d] = dist * D->walls[w].normal[d];
    rsq = dist * dist;
    rb = 0.0;
    radsum = ra;
    if (dist <= 0.0) rsq = radsum * radsum; /* centre behind the plane: no contact */
  }
  *rsq_ = rsq;
  *rb_ = rb;
  *radsum_ = radsum;
  return rsq < radsum * radsum;
}

/* The same with grain a read from the pair. */
DEM_HD_INLINE int dem_contact_geom(const dem_dev *D, int64_t p, double *del, double *rsq_, double *rb_,
                                   double *radsum_) {
  const int32_t a = D->pa[p];
  return dem_contact_geom_a(D, p, a, D->x + 3 * (int64_t)a, D->rad[a], del, rsq_, rb_, radsum_);
}

/* History carried across a rebuild (and any reordering): look the pair's key up in the previous,
 * key-sorted list; a new pair starts from zero. At a build the engine asked for with keep_history
 * (carry_touching; LIGGGHTS' granular list build copies the history of a partner only if the two
 * overlap at that moment) a pair that does not touch starts from zero too; the core's own rebuilds
 * (a grain moved skin/2) carry every history, as the engine's list would have kept it. */
/* pair p from pair found of the previous list (-1: none) */
SPHDEM_HD void dem_carry_from(const dem_dev *D, int64_t p, int64_t found) {
  if (found >= 0 && D->carry_touching) {
    double del[3], rsq, rb, radsum;
    if (!dem_contact_geom(D, p, del, &rsq, &rb, &radsum)) found = -1;
  }
  double *h = D->hin + SPHDEM_DEM_NHIST * p;
  for (int q = 0; q < SPHDEM_DEM_NHIST; q++) h[q] = found >= 0 ? D->hist_old[SPHDEM_DEM_NHIST * found + q] : 0.0;
  if (D->rin)
    for (int q = 0; q < 3; q++) D->rin[3 * p + q] = found >= 0 && D->roll_carry ? D->roll_old[3 * found + q] : 0.0;
  if (found >= 0 && D->carry_touching) h[3] = 1.0; /* the engine wraps positions at its builds: image not recorded */
}

/* pair p's key looked up in the previous list by bisection */
SPHDEM_HD void dem_carry_body(const dem_dev *D, int64_t p) {
  uint64_t k = D->key[p];
  int64_t lo = 0, hi = D->np_old - 1, found = -1;
  while (lo <= hi) {
    int64_t mid = lo + (hi - lo) / 2;
    uint64_t km = D->key_old[mid];
    if (km == k) { found = mid; break; }
    if (km < k) lo = mid + 1; else hi = mid - 1;
  }
  dem_carry_from(D, p, found);
}

/* The quantities of an overlapping pair that its separation and radii alone give: |r|, 1/|r|, 1/|r|^2 and the factor
 * of the LAMMPS Hertz law, sqrt(delta r_a r_b / (r_a + r_b)) (a wall: sqrt(delta r_a); 1 for the other laws). The
 * law below takes them from here; the one-thread pass takes them for a block of pairs in a loop of its own before
 * the law (the square roots and divisions of different pairs independent of each other, so they overlap instead
 * of heading each pair's chain of dependent operations), with the same operations, so the same bits. */
DEM_HD_INLINE void dem_pair_roots(const double rsq, const double ra, const double rb, const double radsum,
                                  const int wall, const int model, double *r_, double *rinv_, double *rsqinv_,
                                  double *poly_) {
  const double r = sqrt(rsq), delta = radsum - r;
  *r_ = r;
  *rinv_ = 1.0 / r;
  *rsqinv_ = 1.0 / rsq;
  *poly_ = model != SPHDEM_DEM_HERTZ ? 1.0 : wall ? sqrt(delta * ra) : sqrt(delta * ra * rb / radsum);
}

/* The force part of dem_contact for an overlapping pair, its geometry from dem_contact_geom; wall: b < 0 (fixed at
 * compile time by dem_contact_model). pre: r, 1/r, 1/r^2 and the Hertz factor of dem_pair_roots, or NULL to take
 * them here. */
DEM_HD_INLINE int dem_contact_model_w(const dem_dev *D, int64_t p, const int32_t a, const int32_t b, const double ra,
                                      const double *del, const double rsq, const double rb, const double radsum,
                                      double *Fa, double *Ta, double *Tb, double *hout, double *vir, const double *pre,
                                      const int model, const int wall) {
  const double *va = D->v + 3 * (int64_t)a, *wa = D->om + 3 * (int64_t)a;
  const double *hin = D->hin + SPHDEM_DEM_NHIST * p;
  double meff, vr[3], wr[3], wrel[3], r, rinv, rsqinv, hpoly;
  if (pre) r = pre[0], rinv = pre[1], rsqinv = pre[2], hpoly = pre[3];
  else dem_pair_roots(rsq, ra, rb, radsum, wall, model, &r, &rinv, &rsqinv, &hpoly);
  const double ma = D->mass[a];
  if (!wall) {
    const double *vb = D->v + 3 * (int64_t)b, *wb = D->om + 3 * (int64_t)b;
    const double mb = D->mass[b];
    for (int d = 0; d < 3; d++) {
      vr[d] = va[d] - vb[d];
      wr[d] = (ra * wa[d] + rb * wb[d]) * rinv;
      wrel[d] = wa[d] - wb[d];
    }
    meff = ma * mb / (ma + mb);
    if (D->any_frozen) {
      if (D->flags[a] & SPHDEM_DEM_FROZEN) meff = mb;
      if (D->flags[b] & SPHDEM_DEM_FROZEN) meff = ma;
    }
  } else {
    for (int d = 0; d < 3; d++) {
      vr[d] = va[d];
      wr[d] = ra * wa[d] * rinv;
      wrel[d] = wa[d];
    }
    meff = ma;
  }
  if (model == SPHDEM_DEM_GRANULAR) {
    dem_contact_granular(D, p, wall, del, r, ra, rb, radsum, meff, Fa, Ta, Tb, hout);
    if (D->want_virial) {
      if (!wall) dem_pair_virial(del, Fa, vir), dem_pair_virial_shared(D, a, b, vir);
      else for (int d = 0; d < 6; d++) vir[d] = 0.0;
    }
    return 1;
  }
  if (model == SPHDEM_DEM_HERTZ_LIGGGHTS) {
    dem_contact_liggghts(D, p, wall, del, r, rinv, ra, rb, radsum, meff, Fa, Ta, Tb, hout);
    if (D->want_virial) {
      if (!wall) dem_pair_virial(del, Fa, vir), dem_pair_virial_shared(D, a, b, vir);
      else for (int d = 0; d < 6; d++) vir[d] = 0.0;
    }
    return 1;
  }
  const double delta = radsum - r;
  /* normal and tangential relative velocity at the contact point */
  const double vnnr = vr[0] * del[0] + vr[1] * del[1] + vr[2] * del[2];
  double vt[3], vtr[3];
  for (int d = 0; d < 3; d++) vt[d] = vr[d] - del[d] * vnnr * rsqinv;
  vtr[0] = vt[0] - (del[2] * wr[1] - del[1] * wr[2]);
  vtr[1] = vt[1] - (del[0] * wr[2] - del[2] * wr[0]);
  vtr[2] = vt[2] - (del[1] * wr[0] - del[0] * wr[1]);
  /* tangential displacement: accumulate (eq 13), then rotate onto the current tangent plane */
  double s[3] = {hin[0], hin[1], hin[2]};
  if (D->update) {
    double h = D->dt;
    /* Yu eq 12: a new contact has been touching for delta / |v_n| of the step, not the whole step */
    if (D->P.first_contact && hin[3] == 0.0 && vnnr < 0.0) {
      const double tin = delta * r / -vnnr; /* |v_n| = -vnnr / r */
      if (tin < h) h = tin;
    }
    for (int d = 0; d < 3; d++) s[d] += vtr[d] * h;
  }
  /* |s| before the projection: only whether it is zero matters (sqrt(x) != 0 exactly when x != 0) */
  const double shrmag2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
  const double rsht = (s[0] * del[0] + s[1] * del[1] + s[2] * del[2]) * rsqinv;
  if (D->update)
    for (int d = 0; d < 3; d++) s[d] -= rsht * del[d];

  double ccel, fs[3], fn_el;
  const double mu = D->P.mu;
  if (model != SPHDEM_DEM_HERTZ_MINDLIN) {
    /* Yu eqs 7-8 / LAMMPS gran/hooke|hertz/history: F_n = k_n delta - eta_n v_n, F_t = -(k_t d_t + eta_t v_t)
     * capped at mu |F_n|; eta = m_eff gamma, or from e by eq 11 (eta = 2 sqrt(k m_eff) |ln e|/sqrt(pi^2 + ln^2 e)) */
    const double kn = D->P.kn, kt = D->P.kt;
    double gn = D->P.gamman, gt = D->P.gammat;
    if (D->use_en) {
      gn = 2.0 * sqrt(kn / meff) * D->cdamp;
      gt = 2.0 * sqrt(kt / meff) * D->cdamp;
    }
    const double damp = meff * gn * vnnr * rsqinv;
    const double poly = hpoly;
    ccel = (kn * delta * rinv - damp) * poly;
    if (D->P.limit_damping && ccel < 0.0) ccel = 0.0;
    fn_el = kn * delta * poly;
    for (int d = 0; d < 3; d++) fs[d] = -poly * (kt * s[d] + meff * gt * vtr[d]);
    const double fsm = sqrt(fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]);
    const double fn = mu * fabs(ccel * r);
    if (fsm > fn) {
      if (shrmag2 != 0.0) {
        /* sliding: the spring is shortened so that spring + dashpot equal the Coulomb limit */
        const double fnfs = fn / fsm, mgkt = kt > 0.0 ? meff * gt / kt : 0.0;
        for (int d = 0; d < 3; d++) {
          s[d] = fnfs * (s[d] + mgkt * vtr[d]) - mgkt * vtr[d];
          fs[d] *= fnfs;
        }
      } else {
        fs[0] = fs[1] = fs[2] = 0.0;
      }
    }
  } else {
    /* He 2018: Hertz normal (eq 18) with damping (eq 20, c_n from e by eq 23), R* and E* (eqs 20-21) */
    const double reff = wall ? ra : ra * rb / radsum;
    const double sq = sqrt(reff * delta);
    fn_el = 4.0 / 3.0 * D->Estar * sq * delta;
    const double vn = vnnr * rinv; /* > 0 separating */
    double fn_tot = fn_el - D->cdamp * sqrt(8.0 * meff * D->Estar * sq) * vn;
    if (D->P.limit_damping && fn_tot < 0.0) fn_tot = 0.0;
    ccel = fn_tot * rinv;
    fs[0] = fs[1] = fs[2] = 0.0;
    const double tmax = D->tmax_fac * delta; /* eq 22 */
    if (mu > 0.0 && tmax > 0.0) {
      double sm = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
      if (sm > tmax) { /* full sliding: the displacement stays at delta_t,max */
        for (int d = 0; d < 3; d++) s[d] *= tmax / sm;
        sm = tmax;
      }
      const double ratio = sm / tmax, rest = 1.0 - ratio;
      /* Mindlin-Deresiewicz (eq 19) */
      const double fel = sm > 0.0 ? mu * fn_el * (1.0 - rest * sqrt(rest)) / sm : 0.0;
      /* eq 21, written as c_t sqrt(4 m* k_t) with k_t = 3/2 mu |F_n| sqrt(1 - d/dmax)/dmax (the printed E*
       * factor would make the coefficient dimensionally inconsistent) */
      const double eta_t = D->ct * sqrt(6.0 * mu * meff * fn_el * sqrt(rest) / tmax);
      for (int d = 0; d < 3; d++) fs[d] = -fel * s[d] - eta_t * vtr[d];
      const double fsm = sqrt(fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]), fmax = mu * fabs(fn_tot);
      if (fsm > fmax)
        for (int d = 0; d < 3; d++) fs[d] *= fmax / fsm;
    } else {
      s[0] = s[1] = s[2] = 0.0;
    }
  }
  for (int d = 0; d < 3; d++) Fa[d] = del[d] * ccel + fs[d];
  /* torque of the tangential force (He eq 24) */
  double tor[3];
  tor[0] = rinv * (del[1] * fs[2] - del[2] * fs[1]);
  tor[1] = rinv * (del[2] * fs[0] - del[0] * fs[2]);
  tor[2] = rinv * (del[0] * fs[1] - del[1] * fs[0]);
  for (int d = 0; d < 3; d++) {
    Ta[d] = -ra * tor[d];
    Tb[d] = -rb * tor[d];
  }
  /* constant-torque rolling friction against the relative rotation (He eq 25) */
  if (D->P.mu_r > 0.0) {
    const double wm = sqrt(wrel[0] * wrel[0] + wrel[1] * wrel[1] + wrel[2] * wrel[2]);
    if (wm > 0.0) {
      const double tr = D->P.mu_r * fn_el / wm;
      for (int d = 0; d < 3; d++) {
        Ta[d] -= tr * ra * wrel[d];
        Tb[d] += tr * rb * wrel[d];
      }
    }
  }
  if (D->want_virial) {
    if (!wall) dem_pair_virial(del, Fa, vir), dem_pair_virial_shared(D, D->pa[p], D->pb[p], vir);
    else for (int d = 0; d < 6; d++) vir[d] = 0.0;
  }
  if (hout) {
    hout[0] = s[0];
    hout[1] = s[1];
    hout[2] = s[2];
    hout[3] = 1.0;
    hout[4] = 0.0;
  }
  return 1;
}

/* The force part of dem_contact for an overlapping pair, its geometry from dem_contact_geom: the body above
 * compiled for a grain partner and for a wall apart (no branch on the partner inside the law). */
DEM_HD_INLINE int dem_contact_model_pre(const dem_dev *D, int64_t p, const int32_t a, const int32_t b, const double ra,
                                        const double *del, const double rsq, const double rb, const double radsum,
                                        double *Fa, double *Ta, double *Tb, double *hout, double *vir,
                                        const double *pre, const int model) {
  if (b < 0) return dem_contact_model_w(D, p, a, b, ra, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, NULL, model, 1);
  return dem_contact_model_w(D, p, a, b, ra, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, pre, model, 0);
}
DEM_HD_INLINE int dem_contact_model_ab(const dem_dev *D, int64_t p, const int32_t a, const int32_t b, const double ra,
                                       const double *del, const double rsq, const double rb, const double radsum,
                                       double *Fa, double *Ta, double *Tb, double *hout, double *vir, const int model) {
  return dem_contact_model_pre(D, p, a, b, ra, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, NULL, model);
}
DEM_HD_INLINE int dem_contact_model(const dem_dev *D, int64_t p, const double *del, const double rsq,
                                    const double rb, const double radsum, double *Fa, double *Ta, double *Tb,
                                    double *hout, double *vir, const int model) {
  const int32_t a = D->pa[p];
  return dem_contact_model_ab(D, p, a, D->pb[p], D->rad[a], del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, model);
}

/* The contact law of D->P.model for an overlapping pair, each model compiled with it fixed. */
SPHDEM_HD int dem_contact_touching(const dem_dev *D, int64_t p, const double *del, double rsq, double rb,
                                   double radsum, double *Fa, double *Ta, double *Tb, double *hout, double *vir) {
  switch (D->P.model) {
    case SPHDEM_DEM_HOOKE:
      return dem_contact_model(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, SPHDEM_DEM_HOOKE);
    case SPHDEM_DEM_HERTZ:
      return dem_contact_model(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, SPHDEM_DEM_HERTZ);
    case SPHDEM_DEM_HERTZ_MINDLIN:
      return dem_contact_model(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, SPHDEM_DEM_HERTZ_MINDLIN);
    case SPHDEM_DEM_GRANULAR:
      return dem_contact_model(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, SPHDEM_DEM_GRANULAR);
    default:
      return dem_contact_model(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir, SPHDEM_DEM_HERTZ_LIGGGHTS);
  }
}

/* History of a pair that does not touch: the touch flag cleared, the tangential displacement zeroed
 * (LAMMPS: "unset non-touching neighbors") or, with keep_history, kept as it was (LIGGGHTS with
 * contactDistanceFactor 1 resets it only in surfacesClose, r < contactDistanceFactor (r_a + r_b), an
 * empty band: the history stays until the next list build, dem_carry_body). */
/* the bits of x (0 for +0.0 only) */
SPHDEM_HD uint64_t dem_bits(double x) {
  uint64_t u;
  memcpy(&u, &x, sizeof u);
  return u;
}

SPHDEM_HD void dem_separated_history(const dem_dev *D, int64_t p, double *hout) {
  const double *hin = D->hin + SPHDEM_DEM_NHIST * p;
  const int keep = D->P.keep_history;
  if (hout == hin) { /* in place (the CPU's forward pass): only what changes is written, the same bits */
    if (keep) {
      if (hin[3] > 0.0) hout[3] = -hin[3];
      return; /* the rest, and the rolling torque, stay */
    }
    if (dem_bits(hin[0]) | dem_bits(hin[1]) | dem_bits(hin[2]) | dem_bits(hin[3]) | dem_bits(hin[4]))
      for (int q = 0; q < SPHDEM_DEM_NHIST; q++) hout[q] = 0.0;
    if (D->rin) {
      double *r = D->rin + 3 * p;
      if (dem_bits(r[0]) | dem_bits(r[1]) | dem_bits(r[2])) r[0] = r[1] = r[2] = 0.0;
    }
    return;
  }
  for (int q = 0; q < 3; q++) hout[q] = keep ? hin[q] : 0.0;
  hout[3] = keep && hin[3] > 0.0 ? -hin[3] : keep ? hin[3] : 0.0; /* < 0: not touching, image kept */
  hout[4] = keep ? hin[4] : 0.0; /* hooke/hysteresis: the largest overlap, kept alike */
  if (D->rin) /* epsd2's rolling torque: the same rule (LIGGGHTS resets it in surfacesClose, as the shear) */
    for (int q = 0; q < 3; q++) D->rout[3 * p + q] = keep ? D->rin[3 * p + q] : 0.0;
}

/* Contact of pair p: 0 (and the history of dem_separated_history in hout) when the grains do not overlap; else the law of
 * D->P.model. The overlap test is inlined into the loops (most candidate pairs of a loose packing do not
 * touch); vir is written only when D->want_virial; Fa, Ta, Tb, vir only when the pair touches. */
DEM_HD_INLINE int dem_contact(const dem_dev *D, int64_t p, double *Fa, double *Ta, double *Tb, double *hout,
                              double *vir) {
  double del[3], rsq, rb, radsum;
  if (!dem_contact_geom(D, p, del, &rsq, &rb, &radsum)) {
    if (hout) dem_separated_history(D, p, hout);
    return 0;
  }
  return dem_contact_touching(D, p, del, rsq, rb, radsum, Fa, Ta, Tb, hout, vir);
}

/* Collision-pair parallel pass (Yu 2024 §2.3, Fig. 3): one thread per pair, the force added to a and
 * subtracted from b atomically; atomic = 0 (a CPU loop on one thread) adds in the same order without
 * the atomic instructions. */
SPHDEM_HD void dem_pair_force_accum(const dem_dev *D, int64_t p, int atomic) {
  double F[3], Ta[3], Tb[3], vir[6];
  if (!dem_contact(D, p, F, Ta, Tb, D->hout + SPHDEM_DEM_NHIST * p, vir)) return;
  const int64_t a = D->pa[p], b = D->pb[p];
  if (!atomic) {
    for (int d = 0; d < 3; d++) {
      D->f[3 * a + d] += F[d];
      D->tq[3 * a + d] += Ta[d];
    }
    if (b >= 0)
      for (int d = 0; d < 3; d++) {
        D->f[3 * b + d] += -F[d];
        D->tq[3 * b + d] += Tb[d];
      }
    if (D->want_virial)
      for (int d = 0; d < 6; d++) D->vir[d] += vir[d];
    return;
  }
  for (int d = 0; d < 3; d++) {
    dem_add(&D->f[3 * a + d], F[d]);
    dem_add(&D->tq[3 * a + d], Ta[d]);
  }
  if (b >= 0)
    for (int d = 0; d < 3; d++) {
      dem_add(&D->f[3 * b + d], -F[d]);
      dem_add(&D->tq[3 * b + d], Tb[d]);
    }
  if (D->want_virial)
    for (int d = 0; d < 6; d++) dem_add(&D->vir[d], vir[d]);
}
SPHDEM_HD void dem_pair_force_body(const dem_dev *D, int64_t p) { dem_pair_force_accum(D, p, 1); }

/* Pair p evaluated again for output (sphdem_dem_contacts): the law as the step evaluated it, with the grains as
 * they are now, the history read and written only to D->hout (scratch; D->update 0, as the stock styles'
 * evaluation for compute pair/gran/local). rec[(1 + SPHDEM_DEM_CONTACT_DOUBLES) p]: 1 when the two grains touch (0
 * when not, and for a wall), then the force on a, the torques on a and on b, and x_a - x_b as the law took it
 * (the minimum image along the periodic axes the context treats so). */
SPHDEM_HD void dem_contact_record_body(const dem_dev *D, int64_t p, double *rec) {
  double F[3], Ta[3], Tb[3], vir[6], del[3], rsq, rb, radsum, *r = rec + (1 + SPHDEM_DEM_CONTACT_DOUBLES) * p;
  r[0] = 0.0;
  if (D->pb[p] < 0) return;
  if (!dem_contact_geom(D, p, del, &rsq, &rb, &radsum)) {
    dem_separated_history(D, p, D->hout + SPHDEM_DEM_NHIST * p);
    return;
  }
  dem_contact_touching(D, p, del, rsq, rb, radsum, F, Ta, Tb, D->hout + SPHDEM_DEM_NHIST * p, vir);
  r[0] = 1.0;
  for (int d = 0; d < 3; d++) {
    r[1 + d] = F[d];
    r[4 + d] = Ta[d];
    r[7 + d] = Tb[d];
    r[10 + d] = del[d];
  }
}

/* Heat conduction through contact p (sphdem_dem_heat; the contact conductance of LIGGGHTS' fix heat/gran/conduction,
 * after Chaudhuri et al. 2006, with uniform temperature within each grain): where the two grains of
 * the pair touch, the contact area A (area SPHDEM_DEM_HEAT_AREA_OVERLAP: the circle where the two spheres
 * intersect, pi a^2 with a^2 = -(r - ra - rb)(r + ra - rb)(r - ra + rb)(r + ra + rb) / (4 r^2), or the smaller
 * grain's cross-section where it lies within the other (r <= |ra - rb|); PROJECTION: the
 * larger grain's cross-section; CONSTANT: A0), the conductance h = 4 ka kb / (ka + kb) sqrt(A) (the harmonic mean
 * of the two conductivities; 0 where one is 0) and the heat flow Q = h (T_b - T_a) into a, out of b. q gets +Q at
 * a and -Q at b; dq (3 per grain, may be NULL) gets Q (x_a - x_b) / 2 at both. Walls take no part, nor a pair
 * of two grains with member 0 (member NULL: every grain is one). */
/* dem_heat_flow: 1 when pair p conducts, with the flow Q into a and del = x_a - x_b; dem_heat_add adds it to the
 * sums (atomically in dem_heat_body, the CUDA kernel's; plainly in the CPU backend's one-thread loop). */
/* dem_heat_conductance: h of a contact of two touching grains (the flow into a is (T_b - T_a) h), from |x_a - x_b|^2,
 * the radii, the conductivities and the kind of contact area (its value A0 for SPHDEM_DEM_HEAT_AREA_CONSTANT) */
SPHDEM_HD double dem_heat_conductance(double rsq, double ra, double rb, double ka, double kb, int area, double A0) {
  double A = A0;
  if (area == SPHDEM_DEM_HEAT_AREA_OVERLAP) /* a grain within the other (no such circle): the smaller's section */
    A = rsq > (ra - rb) * (ra - rb) ? dem_lens_area(sqrt(rsq), ra, rb) : M_PI * (ra < rb ? ra * ra : rb * rb);
  else if (area == SPHDEM_DEM_HEAT_AREA_PROJECTION)
    A = M_PI * (ra > rb ? ra * ra : rb * rb);
  const double ks = ka + kb;
  return (ka > 0.0 && kb > 0.0) ? 4.0 * ka * kb / ks * sqrt(A) : 0.0;
}
SPHDEM_HD int dem_heat_flow(const dem_dev *D, int64_t p, const double *T, const double *k, const int *member, int area,
                            double A0, double *Q_, double *del) {
  const int32_t a = D->pa[p], b = D->pb[p];
  double rsq, rb, radsum;
  if (b < 0 || (member && !member[a] && !member[b]) || !dem_contact_geom(D, p, del, &rsq, &rb, &radsum)) return 0;
  *Q_ = (T[b] - T[a]) * dem_heat_conductance(rsq, D->rad[a], rb, k[a], k[b], area, A0);
  return 1;
}
/* the flow Q of pair p (del = x_a - x_b) added to the sums: atomic adds (threads sharing the sums) or plain */
DEM_HD_INLINE void dem_heat_add(const dem_dev *D, int64_t p, double Q, const double *del, double *q, double *dq,
                                const int atomic) {
  const int32_t a = D->pa[p], b = D->pb[p];
  if (!atomic) {
    q[a] += Q;
    q[b] -= Q;
    if (dq)
      for (int d = 0; d < 3; d++) {
        dq[3 * a + d] += 0.5 * Q * del[d];
        dq[3 * b + d] += 0.5 * Q * del[d];
      }
    return;
  }
  dem_add(&q[a], Q);
  dem_add(&q[b], -Q);
  if (dq)
    for (int d = 0; d < 3; d++) {
      dem_add(&dq[3 * a + d], 0.5 * Q * del[d]);
      dem_add(&dq[3 * b + d], 0.5 * Q * del[d]);
    }
}
SPHDEM_HD void dem_heat_body(const dem_dev *D, int64_t p, const double *T, const double *k, const int *member,
                             int area, double A0, double *q, double *dq) {
  double Q, del[3];
  if (dem_heat_flow(D, p, T, k, member, area, A0, &Q, del)) dem_heat_add(D, p, Q, del, q, dq, 1);
}

/* The sums of grain i: its force and torque, and its share of the virial (atomic, nonzero terms only). */
SPHDEM_HD void dem_store_grain(const dem_dev *D, int64_t i, const double *f, const double *t, const double *vs) {
  for (int d = 0; d < 3; d++) {
    D->f[3 * i + d] = f[d];
    D->tq[3 * i + d] = t[d];
  }
  if (D->want_virial)
    for (int d = 0; d < 6; d++)
      if (vs[d] != 0.0) dem_add(&D->vir[d], vs[d]);
}

/* Particle-parallel pass: grain i sums its own pairs (as a, then as b) without atomics; both partners
 * evaluate the same pair with the same operands, so the forces are exactly opposite. Only a writes the
 * history and counts the virial. */
SPHDEM_HD void dem_particle_force_body(const dem_dev *D, int64_t i) {
  double F[3], Ta[3], Tb[3], vir[6], f[3] = {0, 0, 0}, t[3] = {0, 0, 0}, vs[6] = {0, 0, 0, 0, 0, 0};
  for (int64_t p = D->fstart[i]; p < D->fend[i]; p++) {
    if (!dem_contact(D, p, F, Ta, Tb, D->hout + SPHDEM_DEM_NHIST * p, vir)) continue;
    for (int d = 0; d < 3; d++) { f[d] += F[d]; t[d] += Ta[d]; }
    if (D->want_virial)
      for (int d = 0; d < 6; d++) vs[d] += vir[d];
  }
  for (int64_t k = D->rstart[i]; k < D->rend[i]; k++) {
    if (!dem_contact(D, D->rlist[k], F, Ta, Tb, 0, vir)) continue;
    for (int d = 0; d < 3; d++) { f[d] -= F[d]; t[d] += Tb[d]; }
  }
  dem_store_grain(D, i, f, t, vs);
}

/* The gap of pair p at a build: its distance less r_a + r_b (a wall: the distance less r_a, -HUGE_VAL behind the
 * plane), less 1e-6 (r_a + r_b), far more than the rounding of the distances. While no grain has moved by more
 * than delta nor grown by more than dr since, a pair of gap > 2 (delta + dr) does not touch. */
SPHDEM_HD double dem_pair_gap(const dem_dev *D, int64_t p) {
  const int32_t a = D->pa[p], b = D->pb[p];
  const double ra = D->rad[a];
  if (b >= 0) {
    double del[3];
    const double radsum = ra + D->rad[b];
    const double r = sqrt(dem_sep(D, D->x + 3 * (int64_t)a, D->x + 3 * (int64_t)b, del));
    return r - radsum - 1e-6 * radsum;
  }
  const double dist = dem_wall_dist(D, -1 - b, D->x + 3 * (int64_t)a);
  return dist > 0.0 ? dist - ra - 1e-6 * ra : -HUGE_VAL;
}

/* The particle-parallel pass in two halves that evaluate each pair once (the CPU loops; the same
 * additions in the same order as dem_particle_force_body, so the same bits). Forward: grain i sums
 * its pairs as a into f, tq, keeps F and Tb of each touching pair in pfb (6 per pair) and marks the pair
 * in tf (1 touching, 0 not) and its grain b in bt; returns the touching pairs. Reverse (after every forward):
 * grain i adds -F and Tb of its touching pairs as b. Each pair is evaluated by one grain only, so the history may be updated in
 * place (D->hout == D->hin, D->rout == D->rin). known: tf holds the marks of the previous evaluation of this
 * list and the history was not changed since, so a pair marked 0 has the history of a separated pair already
 * (dem_separated_history would change nothing: it is not read). With D->gap0 the pairs whose gap at the build
 * exceeds D->gap_thr are not touching without a look at their grains (dem_pair_gap). dem_particle_forward_model
 * has the contact law inlined for a model fixed at compile time. */
/* One pair of the particle-parallel passes, its grain a at xa with radius ra: 0 when it does not touch (its
 * history that of a separated pair, unless known says it is already), else the law of model into F, Ta, Tb
 * (and vir with D->want_virial) and the history in place. tf[p] marks the pair touching (1) or not (0), stored
 * after the law's loads (a byte store may alias anything); *b_ the partner of a touching pair. gaps (D->gap0 is
 * set): the pairs whose gap at the build exceeds D->gap_thr are apart without a look at their grains. */
DEM_HD_INLINE int dem_pair_step(const dem_dev *D, int64_t p, const int32_t a, const double *xa, const double ra,
                                unsigned char *tf, const int known, const int gaps, int32_t *b_, double *F, double *Ta,
                                double *Tb, double *vir, const int model) {
  double *hout = D->hout + SPHDEM_DEM_NHIST * p;
  if (!(gaps && D->gap0[p] > D->gap_thr)) {
    double del[3], rsq, rb, radsum;
    const int32_t b = D->pb[p];
    if (dem_contact_geom_a(D, p, a, xa, ra, del, &rsq, &rb, &radsum)) {
      dem_contact_model_ab(D, p, a, b, ra, del, rsq, rb, radsum, F, Ta, Tb, hout, vir, model);
      *b_ = b;
      tf[p] = 1;
      return 1;
    }
  }
  if (!known || tf[p]) { /* apart now, touching at the last evaluation (or unknown) */
    dem_separated_history(D, p, hout);
    tf[p] = 0;
  }
  return 0;
}

DEM_HD_INLINE int64_t dem_particle_forward_model(const dem_dev *D, int64_t i, double *pfb, unsigned char *tf,
                                                 unsigned char *bt, const int known, const int model) {
  double F[3], Ta[3], Tb[3], vir[6] = {0, 0, 0, 0, 0, 0}, f[3] = {0, 0, 0}, t[3] = {0, 0, 0}, vs[6] = {0, 0, 0, 0, 0, 0};
  int64_t nt = 0;
  const int counted = dem_pair_counted(D, (int32_t)i);
  for (int64_t p = D->fstart[i]; p < D->fend[i]; p++) {
    const int32_t a = D->pa[p]; /* (i itself, or a copy of it sharing its tag) */
    int32_t b;
    if (!dem_pair_step(D, p, a, D->x + 3 * (int64_t)a, D->rad[a], tf, known, D->gap0 != NULL, &b, F, Ta, Tb, vir,
                       model))
      continue;
    if (b >= 0) { /* grain b has a touching pair for the reverse half (any thread may set it: the same 1) */
#ifdef __CUDA_ARCH__
      bt[b] = 1;
#else
      __atomic_store_n(&bt[b], (unsigned char)1, __ATOMIC_RELAXED);
#endif
    }
    nt += counted;
    for (int d = 0; d < 3; d++) { f[d] += F[d]; t[d] += Ta[d]; }
    if (D->want_virial)
      for (int d = 0; d < 6; d++) vs[d] += vir[d];
    double *o = pfb + 6 * p;
    for (int d = 0; d < 3; d++) { o[d] = F[d]; o[3 + d] = Tb[d]; }
  }
  dem_store_grain(D, i, f, t, vs);
  return nt;
}

/* The first pair of pair p's run (the pairs whose grain a has p's tag), by bisection of the key-sorted list. */
SPHDEM_HD int64_t dem_run_start(const dem_dev *D, int64_t p) {
  const uint64_t ta = D->key[p] >> 32;
  int64_t lo = 0, hi = p;
  while (lo < hi) {
    const int64_t mid = lo + (hi - lo) / 2;
    if ((D->key[mid] >> 32) < ta) lo = mid + 1; else hi = mid;
  }
  return lo;
}

/* The pairs the one-thread pass takes in one block: their overlap test, then the square roots of the touching ones,
 * then the law (kept in L1: 10 doubles a pair and 4 for the roots) */
#define DEM_PAIR_BLOCK 128

/* The same pairs on one thread, each evaluated once, in list order (by the tags of a, then of b: the order
 * does not depend on the order of the grains): the force of each run of touching pairs of one grain a summed and
 * added to a at the run's end, -F and Tb added to grain b at once; f and tq hold what is there already (zero, or
 * the caller's forces to add to). No pair force buffer and no reverse pass.
 * The visited pairs go in blocks of DEM_PAIR_BLOCK, each in four loops:
 *  - the overlap test of each pair in a slot of its own, nothing carried from one pair to the next, so that the
 *    chains of loads (pair, grains, positions) of many pairs overlap; the uncommon cases (walls, separations that
 *    may need a periodic image, coincident centres) marked for the general test;
 *  - the general test of those, and the list of the touching slots, without a branch on the outcome (touching or
 *    not changes from pair to pair in a bed, and a branch on it is mispredicted often);
 *  - the square roots and divisions that the separation and radii give (dem_pair_roots) for the block's touching
 *    pairs: independent iterations, vectorized, where in the law each would head a chain of dependent operations;
 *  - the law of those pairs.
 * tf marks every pair as the last evaluation left it (set all to 1 when unknown), D->gap0 is set (the CPU builds).
 * act (not NULL): only its nact pairs, in increasing order; every other pair is apart and marked so in tf (its
 * gap at the build exceeds what its grains can have moved since the marks were made: c_active in dem_cpu.c), so
 * it adds nothing and its history is that of a separated pair already. The touching pairs are the same and are added in the same order, so the
 * forces are the same bits with and without act, and whatever the block size.
 * uniform: every pair of a run has the same grain a (no copies of one grain sharing a tag); else D->head gives
 * each copy its run's head. virial: D->want_virial, fixed at compile time. Returns the touching pairs counted
 * (dem_pair_counted). */
DEM_HD_INLINE int64_t dem_pairs_serial_model(const dem_dev *D, unsigned char *tf, const int32_t *act,
                                             const int64_t nact, const int model, const int uniform,
                                             const int virial) {
  const int64_t nk = act ? nact : D->np;
  /* the arrays in locals: byte stores to tf may alias anything */
  const int32_t *pa = D->pa, *pb = D->pb;
  const double *x = D->x, *rad = D->rad, *gap0 = D->gap0, thr = D->gap_thr;
  int64_t nt = 0;
  int32_t g = -1; /* the grain of the current run */
  int counted = 0;
  double f[3] = {0, 0, 0}, t[3] = {0, 0, 0}, vs[6] = {0, 0, 0, 0, 0, 0};
  double F[3] = {0, 0, 0}, Ta[3] = {0, 0, 0}, Tb[3] = {0, 0, 0}, vir[6] = {0, 0, 0, 0, 0, 0};
  const double halfL2min = D->halfL2min;
  int32_t bp[DEM_PAIR_BLOCK], kid[DEM_PAIR_BLOCK];
  unsigned char bc[DEM_PAIR_BLOCK];
  double bd[6][DEM_PAIR_BLOCK], cr[3][DEM_PAIR_BLOCK], pre[4][DEM_PAIR_BLOCK]; /* separation, |r|^2, r_a, r_b; the
                                                                                  touching ones' |r|^2, r_a, r_b; roots */
  for (int64_t k0 = 0; k0 < nk; k0 += DEM_PAIR_BLOCK) {
    const int nm = (int)(nk - k0 < DEM_PAIR_BLOCK ? nk - k0 : DEM_PAIR_BLOCK);
    /* 1: every pair's test in its own slot, nothing carried from one pair to the next (the loads of many pairs
     * overlap). bc: 1 touching, 0 not, 2 to be taken by the general test below (a wall; a separation that may
     * need a periodic image; centres within 1e-12 of the contact distance) */
    for (int j = 0; j < nm; j++) {
      const int64_t p = act ? act[k0 + j] : k0 + j;
      const int32_t a = pa[p], b = pb[p], c = b >= 0 ? b : a;
      const double *xa = x + 3 * (int64_t)a, *xb = x + 3 * (int64_t)c;
      const double ra = rad[a], rb = rad[c];
      const double s0 = xa[0] - xb[0], s1 = xa[1] - xb[1], s2 = xa[2] - xb[2];
      const double rsq = s0 * s0 + s1 * s1 + s2 * s2; /* (dem_sep's sum: the same bits) */
      const double radsum = ra + rb, r2 = radsum * radsum;
      const int near = !(gap0[p] > thr), slow = (b < 0) | !(rsq < halfL2min) | (rsq <= 1e-24 * r2);
      bp[j] = (int32_t)p;
      bd[0][j] = s0, bd[1][j] = s1, bd[2][j] = s2, bd[3][j] = rsq, bd[4][j] = ra, bd[5][j] = rb;
      bc[j] = (unsigned char)(near * (slow ? 2 : rsq < r2));
    }
    /* 2: the general test of the slots marked 2 (dem_contact_geom_a), the touching
     * slots listed in kid without a branch on the outcome, and the history of the pairs apart now that touched
     * at the last evaluation (or unknown) cleared */
    int nb = 0;
    for (int j = 0; j < nm; j++) {
      const int64_t p = bp[j];
      int touch = bc[j];
      if (touch == 2) { /* the geometry of the other passes (only a touching pair's values are read below) */
        const int32_t a = pa[p];
        double del[3], radsum;
        touch = dem_contact_geom_a(D, p, a, x + 3 * (int64_t)a, rad[a], del, &bd[3][j], &bd[5][j], &radsum);
        bd[0][j] = del[0], bd[1][j] = del[1], bd[2][j] = del[2];
      }
      kid[nb] = j; /* (with the roots' three inputs side by side for the vectorized loop) */
      cr[0][nb] = bd[3][j], cr[1][nb] = bd[4][j], cr[2][nb] = bd[5][j];
      nb += touch;
      if (!touch && tf[p]) {
        dem_separated_history(D, p, D->hout + SPHDEM_DEM_NHIST * p);
        tf[p] = 0;
      }
    }
    for (int j = 0; j < nb; j++) /* (a wall's roots are taken again by the law: the grain form here) */
      dem_pair_roots(cr[0][j], cr[1][j], cr[2][j], cr[1][j] + cr[2][j], 0, model, &pre[0][j], &pre[1][j], &pre[2][j],
                     &pre[3][j]);
    for (int j = 0; j < nb; j++) {
      const int q = kid[j];
      const int64_t p = bp[q];
      const int32_t a = pa[p], b = pb[p];
      const int32_t h = uniform ? a : D->head[a]; /* (copies sharing a tag: the run's head copy) */
      if (h != g) { /* a new run of touching pairs: the last one's sum to its grain */
        if (g >= 0) {
          double *fg = D->f + 3 * (int64_t)g, *tg = D->tq + 3 * (int64_t)g;
          for (int d = 0; d < 3; d++) { fg[d] += f[d]; tg[d] += t[d]; }
          if (virial)
            for (int d = 0; d < 6; d++) D->vir[d] += vs[d];
        }
        g = h;
        counted = dem_pair_counted(D, g);
        for (int d = 0; d < 3; d++) f[d] = t[d] = 0.0;
        for (int d = 0; d < 6; d++) vs[d] = 0.0;
      }
      const double ra = bd[4][q], rb = bd[5][q], del[3] = {bd[0][q], bd[1][q], bd[2][q]};
      const double roots[4] = {pre[0][j], pre[1][j], pre[2][j], pre[3][j]};
      dem_contact_model_pre(D, p, a, b, ra, del, bd[3][q], rb, b >= 0 ? ra + rb : ra, F, Ta, Tb,
                            D->hout + SPHDEM_DEM_NHIST * p, vir, roots, model);
      tf[p] = 1; /* (after the law's loads: a byte store may alias anything) */
      if (b >= 0) {
        double *fb = D->f + 3 * (int64_t)b, *tb = D->tq + 3 * (int64_t)b;
        for (int d = 0; d < 3; d++) { fb[d] -= F[d]; tb[d] += Tb[d]; }
      }
      for (int d = 0; d < 3; d++) { f[d] += F[d]; t[d] += Ta[d]; }
      if (virial)
        for (int d = 0; d < 6; d++) vs[d] += vir[d];
      nt += counted;
    }
  }
  if (g >= 0) {
    double *fg = D->f + 3 * (int64_t)g, *tg = D->tq + 3 * (int64_t)g;
    for (int d = 0; d < 3; d++) { fg[d] += f[d]; tg[d] += t[d]; }
    if (virial)
      for (int d = 0; d < 6; d++) D->vir[d] += vs[d];
  }
  return nt;
}

SPHDEM_HD int64_t dem_particle_forward_body(const dem_dev *D, int64_t i, double *pfb, unsigned char *tf,
                                            unsigned char *bt) {
  return dem_particle_forward_model(D, i, pfb, tf, bt, 0, D->P.model);
}

/* bt[i]: the forward half found a touching pair of grain i as b (cleared here for the next evaluation) */
SPHDEM_HD void dem_particle_reverse_body(const dem_dev *D, int64_t i, const double *pfb, const unsigned char *tf,
                                         unsigned char *bt) {
  if (!bt[i]) return;
  bt[i] = 0;
  double f[3] = {D->f[3 * i], D->f[3 * i + 1], D->f[3 * i + 2]}, t[3] = {D->tq[3 * i], D->tq[3 * i + 1], D->tq[3 * i + 2]};
  for (int64_t k = D->rstart[i]; k < D->rend[i]; k++) {
    const int64_t p = D->rlist[k];
    if (!tf[p]) continue; /* not touching */
    const double *o = pfb + 6 * p;
    for (int d = 0; d < 3; d++) { f[d] -= o[d]; t[d] += o[3 + d]; }
  }
  for (int d = 0; d < 3; d++) {
    D->f[3 * i + d] = f[d];
    D->tq[3 * i + d] = t[d];
  }
}

/* Touching pairs are the ones with the touch flag > 0 in the new history (< 0: kept, not touching). */
SPHDEM_HD int dem_touching(const dem_dev *D, int64_t p) {
  return D->hout[SPHDEM_DEM_NHIST * p + 3] > 0.0 && dem_pair_counted(D, D->pa[p]);
}

/* Cell range tables from the cell of each sorted slot. */
SPHDEM_HD void dem_cell_range_body(const int32_t *cell, int64_t n, int64_t s, int32_t *cs, int32_t *ce) {
  int32_t c = cell[s];
  if (s == 0 || cell[s - 1] != c) cs[c] = (int32_t)s;
  if (s == n - 1 || cell[s + 1] != c) ce[c] = (int32_t)(s + 1);
}

/* Forward ranges of the particle-parallel pass: the pairs of a grain as a are one run of the key-sorted
 * list (the keys begin with its tag). Several copies of another rank's grain (SPHDEM_DEM_GHOST periodic
 * images) share a tag: their pairs make one run, given to the copy of its first pair (the force on the copies
 * is dropped; each pair's history and F are still written once, for the reverse pass of its grain b). */
SPHDEM_HD void dem_forward_range_body(const dem_dev *D, int64_t p) {
  const int64_t np = D->np;
  const uint64_t ta = D->key[p] >> 32;
  const int first = p == 0 || (D->key[p - 1] >> 32) != ta, last = p == np - 1 || (D->key[p + 1] >> 32) != ta;
  if (!first && !last) return;
  const int32_t g = D->pa[dem_run_start(D, p)];
  if (first) D->fstart[g] = (int32_t)p;
  if (last) D->fend[g] = (int32_t)(p + 1);
}

/* CSR ranges of a pair array sorted by grain index g[] (the pb copy for the reverse). */
SPHDEM_HD void dem_range_body(const int32_t *g, int64_t n, int64_t k, int32_t *st, int32_t *en) {
  int32_t c = g[k];
  if (c < 0) return;
  if (k == 0 || g[k - 1] != c) st[c] = (int32_t)k;
  if (k == n - 1 || g[k + 1] != c) en[c] = (int32_t)(k + 1);
}

#endif
