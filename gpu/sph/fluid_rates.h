/* fluid_rates.h - the one fluid rate pass, for every fluid model, written once for the CPU loops and the
 * CUDA kernels. Each fluid particle gathers its rates (density rate, acceleration, XSPH and shift
 * velocity) from its fluid neighbours (one pair record, fluid_pair_rec) and its wall neighbours. The fluid
 * model is a switch per pass, not per term: the plain fluid of He 2018 (sph_bodies.h: continuity, Morris or
 * artificial viscosity, delta-SPH, tensile, XSPH, the coupled superficial density) or the delta-plus
 * fluid of Shi & Huang 2022 (mp_bodies.h: shifting, diffusion of (P - P0)/c0^2, eq 24 viscosity, phases).
 * The CPU's half-list pass (sph_cpu.c, cpu_rates_sym) evaluates the plain fluid's pairs once for both
 * sides with the same fluid_pair_terms and adds the walls with rates_walls. */
#ifndef SPHDEM_FLUID_RATES_H
#define SPHDEM_FLUID_RATES_H

#include "mp_bodies.h"

SPHDEM_HD void rates_init(const sphdem_dev *D, int64_t a, rates_acc *R) {
  R->xa = D->x + 3 * a; R->va = D->ve + 3 * a;
  R->rhoa = D->rhop[a]; R->pra = D->pr2[a]; R->drho = 0.0; R->epsa = fluid_eps(D, a);
  for (int d = 0; d < 3; d++) { R->acc[d] = d < D->P.dim ? D->P.gravity[d] : 0.0; R->u[d] = 0.0; }
  if (D->mp.on) dplus_init(D, a, R);
}

/* Fluid neighbour b of a, gathered into a's rates: the record of the pair times its weight (the partner's
 * mass for the plain fluid, 1 for the delta-plus fluid). */
SPHDEM_HD void rates_fluid_pair(const sphdem_dev *D, rates_acc *R, int32_t b) {
  fluid_pair_rec P;
  double w;
  if (D->mp.on) {
    if (!dplus_pair_terms(D, R, b, &P)) return;
    w = 1.0;
  } else {
    if (!fluid_pair_terms(D, R->xa, R->va, R->rhoa, R->pra, R->epsa, b, &P)) return;
    w = D->mass[b];
  }
  R->drho += w * (P.cont + P.dda);
  for (int d = 0; d < 3; d++) { R->acc[d] += w * P.A[d]; R->u[d] += w * P.U[d]; }
}

SPHDEM_HD void rates_wall_pair(const sphdem_dev *D, rates_acc *R, int32_t w) {
  if (D->mp.on) dplus_wall_pair(D, R, w);
  else plain_wall_pair(D, R, w);
}

/* Wall neighbours of a, from the wall list (CPU) or the cell walk. */
SPHDEM_HD void rates_walls(const sphdem_dev *D, int64_t a, rates_acc *R, const int32_t *cells, int nn) {
  if (D->nw == 0) return;
  if (D->wl_start) {
    for (int64_t k = D->wl_start[a]; k < D->wl_start[a + 1]; k++) rates_wall_pair(D, R, D->wl[k]);
  } else {
    for (int k = 0; k < nn; k++)
      for (int32_t w = D->wcstart[cells[k]]; w < D->wcend[cells[k]]; w++) rates_wall_pair(D, R, w);
  }
}

/* a's rates; the delta-plus fluid moves with v + XSPH + its shift velocity. */
SPHDEM_HD void rates_store(const sphdem_dev *D, int64_t a, const rates_acc *R) {
  D->drho[a] = state_round(D, R->drho);
  for (int d = 0; d < 3; d++) {
    D->a[3 * a + d] = state_round(D, R->acc[d]);
    D->u[3 * a + d] = state_round(D, D->mp.on ? R->u[d] + R->A.dua[d] : R->u[d]);
  }
}

/* Rates of fluid particle a, gathered from all its neighbours. Neighbours come from the full CSR lists when
 * they exist (CPU) or from the cell walk; both visit fluid then wall neighbours in the same cell order, so
 * the sums are identical. */
SPHDEM_HD void rates_body(const sphdem_dev *D, int64_t a) {
  if (fluid_ghost(D, a)) return; /* its owner's rates arrive by the exchange */
  rates_acc R;
  rates_init(D, a, &R);
  int32_t cells[27];
  int nn = 0;
  if (D->nl_start) {
    for (int64_t k = D->nl_start[a]; k < D->nl_start[a + 1]; k++) rates_fluid_pair(D, &R, D->nl[k]);
  } else {
    nn = neighbor_cells(D, D->cell[a], cells);
    for (int k = 0; k < nn; k++)
      for (int32_t b = D->cstart[cells[k]]; b < D->cend[cells[k]]; b++) rates_fluid_pair(D, &R, b);
  }
  rates_walls(D, a, &R, cells, nn);
  rates_store(D, a, &R);
}

#endif
