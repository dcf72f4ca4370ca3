/* sph_internal.h - core data shared by the context code and both backends (not public). */
#ifndef SPHDEM_INTERNAL_H
#define SPHDEM_INTERNAL_H

#include "grains.h"
#include "runtime.h"
#include "sphdem.h"
#include "sph_passes.h"

#ifdef __CUDACC__
#define SPHDEM_HD __host__ __device__ static inline
#else
#define SPHDEM_HD static inline
#endif

/* Cap on the number of cells of the search grid; beyond it cells grow (still >= 2h + skin). */
#define SPHDEM_MAX_CELLS (1 << 26)

/* Everything a pass needs, passed by value to kernels and by pointer to CPU loops.
 * Arrays are in device (cell-sorted) order; vectors are interleaved xyz. */
typedef struct {
  sphdem_params P;
  /* derived constants */
  double B;          /* Tait pressure constant (eq 8 form: c0^2 rho0 / gamma) */
  double alphaD;     /* Wendland normalisation (eq 5) for the dimension */
  double h, inv_h, support2, eta2; /* eta2 = 0.01 h^2 */
  double w_dx_inv;   /* 1 / W(dx) for eq 11 */
  int gamma_is_7, tensile_n_is_4;
  /* search grid */
  double glo[3], cs[3], cs_inv[3], L[3];
  int nc[3];
  int64_t ncells;
  /* fluid */
  int64_t nf;
  int64_t nown;        /* particles with uidx < nown are owned; the rest are ghost copies of other ranks' (or
                        * periodic images): they enter the pair sums, not the statistics (= nf on one rank) */
  double *x, *v, *rho, *mass, *drho, *a, *u, *p, *x0;
  double *rhop, *ve;   /* density and velocity predicted to the force time (velocity Verlet) */
  double *pr2;         /* P / rho^2 at the force time */
  double pred_dth;     /* half step used by the prediction; 0 when state is at a full step */
  int64_t *tag;
  int32_t *uidx, *cell, *cstart, *cend;
  /* walls (dummy particles, Adami) */
  int64_t nw;
  double *wx, *wv, *wa, *wmass, *wp, *wrho, *wvx;
  int64_t *wtag;
  int32_t *wcell, *wcstart, *wcend;
  /* optional CSR neighbour lists (CPU backend): fluid-fluid and fluid-wall */
  int64_t *nl_start, *wl_start;
  int32_t *nl, *wl;
  int64_t *wfl_start;  /* wall -> fluid: the fluid-wall list transposed (CPU wall-state pass) */
  int32_t *wfl;
  /* SPH-DEM coupling (He 2018 §2.3, couple_bodies.h); couple == 0 and NULL arrays while it is off */
  int couple;          /* coupling passes run in compute_rates */
  int couple_eos;      /* eps enters the EOS (superficial density, eqs 6-7) */
  int pressure_volume_form;            /* coupled, pressure_form volume: volume form of the pressure and continuity pair terms */
  double immersion_s;         /* keyword immersion S of the coupling (0 = off) */
  int eps_wall_share;      /* eq 26 normalised by the kernel share inside the walls (keyword eps_walls) */
  int drag, torque;    /* sphdem_drag, rotational drag on/off */
  double cmu;          /* fluid viscosity in the drag laws */
  double eps_floor;    /* eps_min */
  double hc, inv_hc, alphaC, support2c; /* coupling kernel (support 2 hc) */
  double *eps;         /* porosity at fluid particles (eq 26, before the floor), device order */
  double *fr;          /* reaction force m_a S_a on fluid particles (eq 33), 3 per particle */
  double *wall_porosity;        /* porosity at wall particles (superficial density only; extrapolated from the fluid) */
  /* grains, in grain-grid (cell-sorted) order; gtag = upload index + 1 */
  int64_t ng;
  double *gx, *gv, *grad, *gom;
  double *grain_shepard;        /* Shepard sum sum_b V_b W_jb at each grain (eqs 28, 33) */
  double *gf, *gfd, *gfpg, *gtq; /* total fluid force, drag part, pressure-gradient/viscous part, torque */
  int64_t *gtag;
  int32_t *gcell, *gcstart, *gcend;
  /* grain ("DEM", level 1) grid: cells >= d_max; SPH (level 2) grid is the one above */
  double gglo[3], gcs[3], gcs_inv[3];
  int gnc[3];
  int64_t gncells;
  int glay[3];         /* grain-grid layers searched around a fluid particle: ceil(2 hc / cell) */
  int flay[3];         /* SPH-grid layers searched around a grain: ceil((2 hc + skin/2) / cell) */
  /* multiphase delta-plus SPH (Shi & Huang 2022, mp_bodies.h); mp == 0 and NULL arrays while it is off */
  int mp;
  sphdem_mp_params M;
  double Bk[SPHDEM_MAX_PHASES]; /* Tait constant of each phase */
  double ck[SPHDEM_MAX_PHASES]; /* sound speed of each phase */
  double cmax;                  /* largest sound speed (the CFL limit) */
  double umax_ph[SPHDEM_MAX_PHASES]; /* max |v| per phase (eq 27), reduced before the shifting pass */
  double wvol_inv_rho0;         /* wall volume V_w = m_w * this (1 / rho0) */
  int32_t *ph;         /* phase of each fluid particle (gathered by sorts) */
  double *mu_p;        /* viscosity mu_i at the force time (eqs 22-25) */
  double *gdot;        /* shear rate |D_i| (eq 26) */
  double *Lm;          /* renormalisation matrix L_i (eq 19), 6 per particle: xx yy zz xy xz yz */
  double *gdr;         /* renormalised pressure gradient <grad P>^L (eq 19 on P = c_i^2 delta rho), 3 */
  double *lam;         /* min eigenvalue lambda_i of the same-phase B_i (§3.3) */
  double *dus;         /* shifting velocity du_i (eqs 27-29), 3 */
  /* fixed ghost walls with MLS interpolation (Shi & Huang §3.4; sphdem_set_wall_mirror): wmls == 0 while off */
  int wmls;
  double *wxi;         /* interpolation (mirror) point of each wall particle, 3 */
  double *wmu;         /* ghost viscosity (multiphase), from the phase with the larger M11 share */
  /* fourth-order Runge-Kutta (sphdem_step_rk4): state at t_n and the weighted sums of the stage rates */
  double *rk_x0, *rk_v0, *rk_rho0, *rk_dx, *rk_dv, *rk_drho;
  double *ksum;        /* fluid kernel sum of each fluid particle (keyword isolated; NULL when off) */
  int ks_ok;           /* ksum is in the current particle order (set by the evaluation, cleared by sorts/uploads) */
} sphdem_dev;

/* Reduction record: stats of fluid (or bounding box of walls). */
typedef struct {
  double v2max, a2max, rhoerr, ke, disp2max;
  double lo[3], hi[3];
  int64_t nnan, nlost;
  double v2ph[SPHDEM_MAX_PHASES]; /* multiphase: max |v|^2 per phase */
  double numax;                   /* multiphase: max mu_i / rho_i */
} sphdem_red;

/* Which arrays a sort permutes. */
enum { SPHDEM_SET_FLUID = 0, SPHDEM_SET_WALL = 1, SPHDEM_SET_GRAIN = 2 };

/* Backend passes (memory operations are in the runtime, c->rt). Each returns SPHDEM_OK or an error code
 * (message set in ctx). The per-element passes come from the lists of sph_passes.h, one entry each. */
struct sphdem_ctx_s;
typedef struct {
  const char *name;
  /* cell of each particle of the set, then c->perm (new slot -> old slot) ordering by (cell, tag);
   * leaves the cell array permuted (sorted) */
  int (*sort_perm)(struct sphdem_ctx_s *c, int set);
  /* arr[i] = arr[perm[i]] for n elements of elem_bytes (multiple of 4), through scratch */
  int (*gather)(struct sphdem_ctx_s *c, void *arr, int elem_bytes, int64_t n);
  /* cell start/end tables of the set from its sorted cell array */
  int (*cell_ranges)(struct sphdem_ctx_s *c, int set);
  int (*reduce)(struct sphdem_ctx_s *c, int set, sphdem_red *out);
  /* ksum, pressure, wall_state, mp_grad, mp_shift, rates, kick, drift, rk, probe; couple_porosity,
   * couple_grains, couple_reaction */
  SPHDEM_FLUID_PASSES(SPHDEM_PASS_FIELD)
  SPHDEM_COUPLE_PASSES(SPHDEM_PASS_FIELD)
} sphdem_ops;

struct sphdem_ctx_s {
  sphdem_dev D;
  sphdem_rt rt;                 /* memory, device bytes held, error text */
  int64_t nwown;                /* owned wall particles (the rest of the last set_walls are ghost copies) */
  const sphdem_ops *ops;
  int backend;                  /* SPHDEM_DEVICE_CPU / _GPU */
  char note[600];
  int64_t cap_f, cap_w;         /* allocated capacities */
  int64_t cap_cells;
  int need_sort, need_wall_sort;
  int64_t nsorts;
  int have_rates;
  int half_kicked;              /* between the two half kicks of a step */
  int nl_dirty, wl_dirty;       /* neighbour lists must be rebuilt (after a fluid / wall sort) */
  int cpu_sym;                  /* CPU: fluid pairs once from half lists (1) or gathered like the GPU (0) */
  double *symbuf;               /* CPU symmetric pass: per-thread rate accumulators */
  int64_t symbuf_cap;
  int64_t nl_cap, wl_cap, nls_cap, wls_cap, wfl_cap, wfls_cap;
  double timers[SPHDEM_NTIMERS];
  /* scratch device buffers used by sorts/gathers (capacity max(cap_f, cap_w)) */
  int64_t cap_scratch;
  int32_t *perm;
  double *scratch_d;            /* 3 * cap doubles */
  int64_t *scratch_i;           /* cap int64 (keys on the GPU, tags on the CPU) */
  /* host staging (in the caller's order / device order) */
  int64_t cap_host;
  double *hbuf;                 /* 3 * cap */
  int64_t *htag;                /* device-order tags mirror */
  int32_t *huidx;
  int host_tags_valid;
  int64_t *hmap;                /* tag -> caller index scratch */
  int64_t hmap_len;
  void *backend_data;
  /* SPH-DEM coupling (couple.c) */
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
   * (cpl_f, CSR cpl_fs), per grain its fluid particles (cpl_g, CSR cpl_gs), per-thread buffers */
  int64_t *cpl_fs, *cpl_gs, cap_cplfs, cap_cplgs, cap_cplf, cap_cplg;
  int32_t *cpl_f, *cpl_g;
  int32_t **cpl_tb;
  int64_t *cpl_tcap, *cpl_tn;
  int cpl_nt, cpl_valid, cpl_err;
  /* multiphase (mp.c) */
  int64_t cap_mp;               /* capacity of the multiphase arrays */
  int mp_ready;                 /* the viscosity/shift fields of the last compute_rates exist */
  int64_t cap_rk;               /* capacity of the Runge-Kutta arrays */
  int64_t cap_ks;               /* capacity of the kernel-sum array (keyword isolated) */
  int64_t cap_wm;               /* capacity of the ghost-wall arrays */
};

#ifdef __cplusplus
extern "C" {
#endif
/* Set the context error message (printf-style); returns code. */
int sphdem_fail(struct sphdem_ctx_s *c, int code, const char *fmt, ...);
/* Device scratch (perm, scratch_d, scratch_i) for sorts of n entries (sph.c). */
int sphdem_ensure_scratch(struct sphdem_ctx_s *c, int64_t n);
/* Device memory counted in c->rt.bytes (sph.c); dfree takes the bytes allocated and clears *ptr. */
int sphdem_dalloc(struct sphdem_ctx_s *c, void **ptr, size_t bytes);
void sphdem_dfree(struct sphdem_ctx_s *c, void **ptr, size_t bytes);
/* Derived constants again after a parameter change (sph.c). */
void sphdem_rederive(struct sphdem_ctx_s *c);
/* A feature of the fluid context (the SPH-DEM coupling, the delta-plus / multiphase fluid): the core calls
 * its hooks at fixed points and knows nothing else of it. Each hook may be NULL and runs only while `on`
 * says the feature is active; the table of features is gpu/sph/features.c. Order of a rate evaluation:
 * before_pressure (timed into `timer`), pressure and wall passes, before_rates (timed with the rates),
 * rates pass, after_rates (timed into `timer`). */
typedef struct {
  const char *name;
  int (*on)(const struct sphdem_ctx_s *c);
  int (*fluid_rebuilt)(struct sphdem_ctx_s *c);   /* set_fluid made a new fluid set: arrays sized to D.nf */
  int (*before_pressure)(struct sphdem_ctx_s *c);
  int (*before_rates)(struct sphdem_ctx_s *c);
  int (*after_rates)(struct sphdem_ctx_s *c);
  void (*release)(struct sphdem_ctx_s *c);        /* free its memory (also when on() is false) */
  int timer;                                      /* SPHDEM_T_* of before_pressure and after_rates */
} sphdem_feature;
extern const sphdem_feature sphdem_feature_couple, sphdem_feature_mp;
extern const sphdem_feature *const sphdem_features[]; /* NULL-terminated, in call order */
/* CPU passes: the generated loops (sph_cpu.c, couple_cpu.c) and the CPU's own versions (cpu "own") */
SPHDEM_FLUID_PASSES(SPHDEM_PASS_DECL_CPU)
SPHDEM_COUPLE_PASSES(SPHDEM_PASS_DECL_CPU)
void sphdem_cpu_couple_lists_free(struct sphdem_ctx_s *c);

extern const sphdem_ops sphdem_cpu_ops;
#ifdef SPHDEM_WITH_CUDA
extern const sphdem_ops sphdem_cuda_ops;
/* CUDA launchers of the passes (sph_cuda.cu, couple_cuda.cu) */
SPHDEM_FLUID_PASSES(SPHDEM_PASS_DECL_CUDA)
SPHDEM_COUPLE_PASSES(SPHDEM_PASS_DECL_CUDA)
int sphdem_cuda_init(struct sphdem_ctx_s *c);
void sphdem_cuda_fini(struct sphdem_ctx_s *c);
#endif
#ifdef __cplusplus
}
#endif

#endif
