/* mp_state.h - the state of the delta-plus / multiphase feature of the fluid context (Shi & Huang 2022,
 * mp_bodies.h): the device part (a member of sphdem_dev) and the host part (mp.c). Not public. */
#ifndef SPHDEM_MP_STATE_H
#define SPHDEM_MP_STATE_H

#include "sphdem.h"

/* Device part; on == 0 and NULL arrays while the feature is off. */
typedef struct {
  int on;
  sphdem_mp_params M;
  double Bk[SPHDEM_MAX_PHASES]; /* Tait constant of each phase */
  double ck[SPHDEM_MAX_PHASES]; /* sound speed of each phase */
  double umax_ph[SPHDEM_MAX_PHASES]; /* max |v| per phase (eq 27), reduced before the shifting pass */
  double wvol_inv_rho0;         /* wall volume V_w = m_w * this (1 / rho0) */
  int32_t *ph;         /* phase of each fluid particle (gathered by sorts) */
  double *mu_p;        /* viscosity mu_i at the force time (eqs 22-25) */
  double *gdot;        /* shear rate |D_i| (eq 26) */
  double *Lm;          /* renormalisation matrix L_i (eq 19), 6 per particle: xx yy zz xy xz yz */
  double *gdr;         /* renormalised pressure gradient <grad P>^L (eq 19 on P = c_i^2 delta rho), 3 */
  double *lam;         /* min eigenvalue lambda_i of the same-phase B_i (§3.3) */
  double *dus;         /* shifting velocity du_i (eqs 27-29), 3 */
} sphdem_mp_dev;

/* Host part. */
typedef struct {
  int64_t cap;         /* capacity of the arrays */
  int ready;           /* the viscosity/shift fields of the last compute_rates exist */
} sphdem_mp_host;

#endif
