/* couple_state.h - the state of the SPH-DEM coupling feature of the fluid context (He 2018 §2.3-2.4): the
 * device part (arrays and constants the passes read, a member of sphdem_dev) and the host part (parameters,
 * capacities, grain bookkeeping, the CPU's pair lists). Not public. */
#ifndef SPHDEM_COUPLE_STATE_H
#define SPHDEM_COUPLE_STATE_H

#include "grains.h"
#include "sphdem.h"

/* Device part; on == 0 and NULL arrays while the coupling is off. Grain arrays are in grain-grid
 * (cell-sorted) order; gtag = upload index + 1. */
typedef struct {
  int on;              /* coupling passes run in compute_rates */
  int eos;             /* eps enters the EOS (superficial density, eqs 6-7) */
  int pressure_volume_form;            /* pressure_form volume: volume form of the pressure and continuity pair terms */
  double immersion_s;  /* keyword immersion S of the coupling (0 = off) */
  int eps_wall_share;  /* eq 26 normalised by the kernel share inside the walls (keyword eps_walls) */
  int drag, torque;    /* sphdem_drag, rotational drag on/off */
  double cmu;          /* fluid viscosity in the drag laws */
  double eps_floor;    /* eps_min */
  double hc, inv_hc, alphaC, support2c; /* coupling kernel (support 2 hc) */
  double *eps;         /* porosity at fluid particles (eq 26, before the floor), device order */
  double *fr;          /* reaction force m_a S_a on fluid particles (eq 33), 3 per particle */
  double *wall_porosity;        /* porosity at wall particles (superficial density only; extrapolated from the fluid) */
  int64_t ng;
  int64_t ngown;       /* grains with gtag <= ngown are owned; the rest are ghost copies (= ng on one rank) */
  double *gx, *gv, *grad, *gom;
  double *grain_shepard;        /* Shepard sum sum_b V_b W_jb at each grain (eqs 28, 33) */
  double *gf, *gfd, *gfpg, *gtq; /* total fluid force, drag part, pressure-gradient/viscous part, torque */
  int64_t *gtag;
  int32_t *gcell, *gcstart, *gcend;
  /* grain ("DEM", level 1) grid: cells >= d_max; the SPH (level 2) grid is the fluid's */
  double gglo[3], gcs[3], gcs_inv[3];
  int gnc[3];
  int64_t gncells;
  int glay[3];         /* grain-grid layers searched around a fluid particle: ceil(2 hc / cell) */
  int flay[3];         /* SPH-grid layers searched around a grain: ceil((2 hc + skin/2) / cell) */
} sphdem_couple_dev;

/* Host part (couple.c, couple_cpu.c). */
typedef struct {
  sphdem_couple_params cp;      /* as set (hc 0 = fluid h) */
  int64_t cap_g, cap_gcells, cap_cf, cap_cw; /* capacities: grains, grain cells, fluid and wall coupling arrays */
  int grains_dirty;             /* uploaded but not yet sorted */
  double gbb_lo[3], gbb_hi[3], gdmax; /* bounding box and largest diameter of the uploaded grains */
  int64_t nforces;              /* grains seen by the last compute_rates */
  int64_t ngown;                /* owned grains of the last set_grains (the rest are ghost copies) */
  double *hgf;                  /* their forces in upload order: f, fdrag, fpg, torque (4 x 3n) */
  int64_t cap_hgf;
  int forces_valid;
  struct sphdem_grains_s *gstore; /* private store of sphdem_set_grains (a shim hands its own store) */
  sphdem_idx_buf gidx_buf;      /* device copy of the index list of sphdem_set_grains_store */
  /* CPU: the fluid-grain pairs of the current coupling step (couple_cpu.c): per fluid particle its grains
   * (cpl_f, CSR cpl_fs), per grain its fluid particles (cpl_g, CSR cpl_gs), the pairs' kernel values in both
   * orders (cpl_fw, cpl_gw), per-thread buffers (grain index and kernel value) */
  int64_t *cpl_fs, *cpl_gs, cap_cplfs, cap_cplgs, cap_cplf, cap_cplg;
  int32_t *cpl_f, *cpl_g;
  double *cpl_fw, *cpl_gw;
  int64_t cap_cplfw, cap_cplgw;
  int32_t **cpl_tb;
  double **cpl_tw;
  int64_t *cpl_tcap, *cpl_tn;
  int cpl_nt, cpl_valid, cpl_err;
} sphdem_couple_host;

#endif
