/* sph_step.c - the integrators of the fluid context: the velocity-Verlet kick and drift, and the
 * fourth-order Runge-Kutta step (Shi & Huang 2022), which evaluates the rates four times. */
#include "sph_internal.h"

#define TRY(expr) do { int rc_ = (expr); if (rc_ != SPHDEM_OK) return rc_; } while (0)

/* The first half kick of a step and the second alternate on every context, also on one that holds no particle (a
 * rank without fluid): particles that arrive there between the two (exchange, new ghosts) find the phase of the
 * step, and the rates evaluated then predict rho and v by the half step like everywhere else. */
static void toggle_half_kick(sphdem_ctx c, double dth) {
  c->half_kicked = !c->half_kicked;
  c->D.pred_dth = c->half_kicked ? dth : 0.0;
}

int sphdem_kick(sphdem_ctx c, double dth) {
  if (!c) return SPHDEM_ERR_ARG;
  if (c->D.nf == 0) {
    toggle_half_kick(c, dth);
    return SPHDEM_OK;
  }
  if (!c->have_rates) return sphdem_fail(c, SPHDEM_ERR_STATE, "kick before the rates were computed (call sphdem_compute_rates first)");
  double t0 = rt_now();
  TRY(c->ops->kick(c, dth));
  TRY(rt_sync(&c->rt));
  c->timers[SPHDEM_T_INTEGRATE] += rt_now() - t0;
  /* first half kick of a step: the next rates predict rho and v by dth; second one closes the step */
  toggle_half_kick(c, dth);
  return SPHDEM_OK;
}

int sphdem_drift(sphdem_ctx c, double dt) {
  if (!c) return SPHDEM_ERR_ARG;
  if (c->D.nf == 0) return SPHDEM_OK;
  if (!c->have_rates) return sphdem_fail(c, SPHDEM_ERR_STATE, "drift before the rates were computed (call sphdem_compute_rates first)");
  double t0 = rt_now();
  c->edisp_ok = 0; /* the positions move: the next fluid reduction finds their move since the upload */
  TRY(c->ops->drift(c, dt));
  TRY(rt_sync(&c->rt));
  c->timers[SPHDEM_T_INTEGRATE] += rt_now() - t0;
  /* displacement since the last sort decides the next resort (He 2018 §2.4.2) */
  sphdem_red r;
  TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
  if (!(r.disp2max <= 0.25 * c->D.P.skin * c->D.P.skin)) c->need_sort = 1;
  return SPHDEM_OK;
}

/* After a stage moved the particles: resort before the next rate evaluation when needed. */
static int rk_moved(sphdem_ctx c) {
  sphdem_red r;
  TRY(sphdem_timed_reduce(c, SPHDEM_SET_FLUID, &r));
  if (!(r.disp2max <= 0.25 * c->D.P.skin * c->D.P.skin)) c->need_sort = 1;
  return SPHDEM_OK;
}

int sphdem_step_rk4(sphdem_ctx c, double dt) {
  if (!c) return SPHDEM_ERR_ARG;
  sphdem_dev *D = &c->D;
  if (D->couple.on) return sphdem_fail(c, SPHDEM_ERR_STATE, "step_rk4: the Runge-Kutta integrator cannot be used with "
                                                         "the SPH-DEM coupling (use velocity Verlet)");
  if (!(dt > 0)) return sphdem_fail(c, SPHDEM_ERR_ARG, "step_rk4: dt must be > 0 (got %g)", dt);
  if (D->nf == 0 && !c->xfn) return SPHDEM_OK; /* many ranks: the rate evaluations are collective */
  if (D->nf > 0) TRY(sphdem_rk_ensure(c, D->nf));
  c->half_kicked = 0;
  /* stage weights dt/6, dt/3, dt/3, dt/6; the next stage's state at t + dt/2, t + dt/2, t + dt */
  const double wk[4] = {dt / 6.0, dt / 3.0, dt / 3.0, dt / 6.0}, cst[3] = {0.5 * dt, 0.5 * dt, dt};
  /* many ranks: the ghosts take each stage's rates and XSPH / shift velocity from their owners, so their stage
   * states follow their owners' (the same arithmetic on the same values) */
  c->rk_stepping = 1;
  for (int s = 0; s < 4; s++) {
    const int rc = sphdem_compute_rates(c);
    if (rc != SPHDEM_OK) { c->rk_stepping = 0; return rc; }
    if (D->nf == 0) continue;
    double t0 = rt_now();
    c->edisp_ok = 0;
    if (s == 0) TRY(c->ops->rk(c, 0, 0.0, 0.0));
    TRY(c->ops->rk(c, s == 3 ? 2 : 1, wk[s], s < 3 ? cst[s] : 0.0));
    TRY(rt_sync(&c->rt));
    c->timers[SPHDEM_T_INTEGRATE] += rt_now() - t0;
    TRY(rk_moved(c));
  }
  c->rk_stepping = 0;
  return SPHDEM_OK;
}
