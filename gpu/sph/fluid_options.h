/* fluid_options.h - the state of the fluid's smaller features, each a member of sphdem_dev (device part) and
 * of the context (host part): the fixed ghost walls with MLS interpolation (ghost.c), the fourth-order
 * Runge-Kutta integrator (rk4.c) and the kernel sums of the keyword isolated (isolated.c). Not public. */
#ifndef SPHDEM_FLUID_OPTIONS_H
#define SPHDEM_FLUID_OPTIONS_H

#include <stdint.h>

/* Fixed ghost walls with MLS interpolation (Shi & Huang §3.4; sphdem_set_wall_mirror): on == 0 while off. */
typedef struct {
  int on;
  double *wxi;         /* interpolation (mirror) point of each wall particle, 3 */
  double *wmu;         /* ghost viscosity (multiphase), from the phase with the larger M11 share */
} sphdem_ghost_dev;

/* Fourth-order Runge-Kutta (sphdem_step_rk4): state at t_n and the weighted sums of the stage rates. */
typedef struct {
  double *x0, *v0, *rho0, *dx, *dv, *drho;
} sphdem_rk_dev;

/* Kernel sums (keyword isolated). */
typedef struct {
  double *ksum;        /* fluid kernel sum of each fluid particle (NULL when off) */
  int ok;              /* ksum is in the current particle order (set by the evaluation, cleared by sorts/uploads) */
} sphdem_iso_dev;

/* Host part of each: the capacity of its arrays. */
typedef struct {
  int64_t cap;
} sphdem_option_host;

#endif
