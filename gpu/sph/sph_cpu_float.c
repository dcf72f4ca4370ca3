/* sph_cpu_float.c - the CPU backend's half-list fluid pairs in float (precisions mixed and single): the
 * neighbours of fluid particle a in blocks of SPHDEM_FBLK are gathered into float arrays (structure of arrays:
 * separation, velocity difference, density, P/rho^2, porosity, mass; all but the separation from the float record
 * of each particle, F8, filled once per rate pass by sph_cpu.c), their pair terms are evaluated in one SIMD
 * loop by the shared float body (fluid_pair_core_f, pair_real.h), and a's sums and the partners' shares are then
 * accumulated in double. Built twice: for the baseline instruction set (sphdem_cpu_pairs_float_generic) and,
 * where the compiler can, for AVX2 + FMA (sph_cpu_float_avx2.c); sph_cpu.c picks one at run time. */
#include "fluid_rates.h"

#ifndef SPHDEM_FLOAT_ISA
#define SPHDEM_FLOAT_ISA generic
#endif
#define SPHDEM_FCAT2(a, b) a##_##b
#define SPHDEM_FCAT(a, b) SPHDEM_FCAT2(a, b)

#define SPHDEM_FBLK 16

/* The pairs (a, b) of a's half list: a's density rate, acceleration and XSPH velocity are added to sums[0..7)
 * (drho, a[3], u[3]), b's shares (m_a times the record, fluid_pair_rec) to the accumulator row B + 7 b. */
static inline __attribute__((always_inline)) void pairs_float(const sphdem_dev *D, const sphdem_pair_opts O,
                                                              const float *F8, int64_t a, double *B, double *sums) {
  const double *xa = D->x + 3 * a;
  const float rhoa = (float)D->rhop[a], pra = (float)D->pr2[a], epsa = (float)fluid_eps(D, a);
  const double ma = D->mass[a];
  const int single = D->P.precision == SPHDEM_PREC_SINGLE;
  const int periodic = D->P.periodic[0] || D->P.periodic[1] || (D->P.dim == 3 && D->P.periodic[2]);
  const float support2 = (float)D->support2;
  const int64_t k0 = D->nl_start[a], k1 = D->nl_start[a + 1];
  const pair_consts_f K = D->Kf;
  const float xaf[3] = {(float)xa[0], (float)xa[1], (float)xa[2]};
  const float vaf[3] = {F8[8 * (size_t)a], F8[8 * (size_t)a + 1], F8[8 * (size_t)a + 2]};
  /* the lanes past a block's end keep finite values (masked by j < m) */
  float rx[SPHDEM_FBLK], ry[SPHDEM_FBLK], rz[SPHDEM_FBLK], vx[SPHDEM_FBLK], vy[SPHDEM_FBLK], vz[SPHDEM_FBLK];
  float rb[SPHDEM_FBLK], pb[SPHDEM_FBLK], eb[SPHDEM_FBLK], mf[SPHDEM_FBLK];
  for (int j = 0; j < SPHDEM_FBLK; j++) {
    rx[j] = ry[j] = rz[j] = vx[j] = vy[j] = vz[j] = pb[j] = mf[j] = 0.0f;
    rb[j] = rhoa; eb[j] = 1.0f;
  }
  double sa[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  for (int64_t kb = k0; kb < k1; kb += SPHDEM_FBLK) {
    const int m = k1 - kb < SPHDEM_FBLK ? (int)(k1 - kb) : SPHDEM_FBLK;
    const int32_t *nb = D->nl + kb;
    if (periodic) {
      for (int j = 0; j < m; j++) {
        float r[3];
        if (separation_f(D, xa, D->x + 3 * nb[j], r) < 0.0f) r[0] = r[1] = r[2] = 0.0f; /* out of reach: masked */
        rx[j] = r[0]; ry[j] = r[1]; rz[j] = r[2];
      }
    }
    for (int j = 0; j < m; j++) {
      const int32_t b = nb[j];
      const double *xb = D->x + 3 * b;
      const float *fb = F8 + 8 * (size_t)b; /* b's float record: v (force time), rho, P/rho^2, m, eps */
      if (!periodic && single) {
        rx[j] = xaf[0] - (float)xb[0]; ry[j] = xaf[1] - (float)xb[1]; rz[j] = xaf[2] - (float)xb[2];
      } else if (!periodic) {
        rx[j] = (float)(xa[0] - xb[0]); ry[j] = (float)(xa[1] - xb[1]); rz[j] = (float)(xa[2] - xb[2]);
      }
      vx[j] = vaf[0] - fb[0]; vy[j] = vaf[1] - fb[1]; vz[j] = vaf[2] - fb[2];
      rb[j] = fb[3]; pb[j] = fb[4]; mf[j] = fb[5]; eb[j] = fb[6];
    }
    if (D->P.dim == 2) for (int j = 0; j < m; j++) rz[j] = 0.0f; /* (z kept at its input value in 2D) */
    /* the pair terms, vectorised by the compiler across the block (-O3; not omp simd, whose per-lane copies of
     * the small arrays block it); a's block sums in float, then in double */
    float ob[SPHDEM_FBLK], oA[3][SPHDEM_FBLK], oU[3][SPHDEM_FBLK];
    float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f, s4 = 0.0f, s5 = 0.0f, s6 = 0.0f;
    for (int j = 0; j < SPHDEM_FBLK; j++) {
      const float r[3] = {rx[j], ry[j], rz[j]}, vab[3] = {vx[j], vy[j], vz[j]};
      const float r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
      const float in = j < m && r2 < support2 && r2 > 0.0f ? 1.0f : 0.0f; /* in the block, in reach, apart */
      fluid_pair_rec_f P;
      fluid_pair_core_f(&K, O, r, r2, vab, rhoa, pra, epsa, rb[j], pb[j], eb[j], &P);
      ob[j] = in * (P.cont + P.ddb);
      SPHDEM_FOR3(d, oA[d][j] = in * P.A[d]; oU[d][j] = in * P.U[d];)
      const float mb = in * mf[j]; /* a's share: m_b times the record */
      s0 += mb * (P.cont + P.dda);
      s1 += mb * P.A[0]; s2 += mb * P.A[1]; s3 += mb * P.A[2];
      s4 += mb * P.U[0]; s5 += mb * P.U[1]; s6 += mb * P.U[2];
    }
    sa[0] += s0; sa[1] += s1; sa[2] += s2; sa[3] += s3; sa[4] += s4; sa[5] += s5; sa[6] += s6;
    /* the partners' shares, in double */
    for (int j = 0; j < m; j++) {
      double *Bb = B + 7 * (size_t)nb[j];
      Bb[0] += ma * ob[j];
      SPHDEM_FOR3(d, Bb[1 + d] -= ma * oA[d][j]; Bb[4 + d] -= ma * oU[d][j];)
    }
  }
  for (int k = 0; k < 7; k++) sums[k] += sa[k];
}

/* The variants: viscosity (3) x tensile correction with n = 4 (2) x density diffusion (3) x XSPH (2), each with
 * its terms as constants; the hydrostatic diffusion and the volume form stay run-time switches (selects). Any
 * other tensile exponent: the general loop (one branch per pair). */
#define SPHDEM_FV(visc_, tens_, delta_, xsph_)                                                             \
  case ((visc_) * 12 + (tens_) * 6 + (delta_) * 2 + (xsph_)): {                                              \
    sphdem_pair_opts K = O;                                                                                  \
    K.visc = (visc_); K.tensile = (tens_); K.tensile4 = 1; K.delta = (delta_); K.xsph = (xsph_);             \
    pairs_float(D, K, F8, a, B, sums);                                                                           \
    return;                                                                                                  \
  }
#define SPHDEM_FV_X(v, t, d) SPHDEM_FV(v, t, d, 0) SPHDEM_FV(v, t, d, 1)
#define SPHDEM_FV_D(v, t) SPHDEM_FV_X(v, t, 0) SPHDEM_FV_X(v, t, 1) SPHDEM_FV_X(v, t, 2)
#define SPHDEM_FV_T(v) SPHDEM_FV_D(v, 0) SPHDEM_FV_D(v, 1)

void SPHDEM_FCAT(sphdem_cpu_pairs_float, SPHDEM_FLOAT_ISA)(const sphdem_dev *D, const float *F8, int64_t a, double *B,
                                                          double *sums) {
  const sphdem_pair_opts O = pair_opts(D);
  if (O.tensile && !O.tensile4) { pairs_float(D, O, F8, a, B, sums); return; }
  switch (O.visc * 12 + O.tensile * 6 + O.delta * 2 + O.xsph) {
    SPHDEM_FV_T(SPHDEM_VISC_NONE)
    SPHDEM_FV_T(SPHDEM_VISC_MORRIS)
    SPHDEM_FV_T(SPHDEM_VISC_ARTIFICIAL)
    default: pairs_float(D, O, F8, a, B, sums); return;
  }
}
