/* sph_internal.h - core data shared by the context code and both backends (not public). */
#ifndef SPHDEM_INTERNAL_H
#define SPHDEM_INTERNAL_H

#include "grains.h"
#include "hd.h"
#include "runtime.h"
#include "sphdem.h"
#include "sph_passes.h"
#include "couple_state.h"
#include "fluid_options.h"
#include "mp_state.h"


/* Cap on the number of cells of the search grid; beyond it cells grow (still >= 2h + skin). */
#define SPHDEM_MAX_CELLS (1 << 26)

/* The delta-plus fluid (Shi & Huang 2022): eqs 16 and 24 divide by r_ij^2 with no regularisation; (eta h)^2 with eta = 0.01 (Morris et al. 1997)
 * only guards coincident particles. He 2018's 0.01 h^2 (eta = 0.1) under-estimates the viscous term by
 * ~1.5 % independently of the resolution (the two-layer Poiseuille test then stops converging at 1.5 %). */
#define SPHDEM_MP_ETA2 1e-4

/* The parameters the pair terms read (pair_real.h), in each real type: derived once from the parameters
 * (sph_ctx.c, whenever they change), so that no pair converts them. mp_eta2: the delta-plus fluid's (eta h)^2. */
#define SPHDEM_PAIR_CONSTS(R)                                                                                  \
  struct {                                                                                                     \
    R inv_h, alphaD, eta2, mp_eta2, h, w_dx_inv, tensile_eps, tensile_n, mu, alpha, c0, delta, rho0, g[3], xsph_eps, \
        rep_D, rep_r0;                                                                                         \
  }
typedef SPHDEM_PAIR_CONSTS(double) pair_consts;
typedef SPHDEM_PAIR_CONSTS(float) pair_consts_f;

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
  pair_consts K;     /* the pair terms' constants in double (precision double) */
  pair_consts_f Kf;  /* and in float (mixed, single) */
  /* search grid */
  double glo[3], cs[3], cs_inv[3], L[3];
  int nc[3];
  int64_t ncells;
  /* fluid */
  int64_t nf;
  int64_t nown;        /* particles with uidx < nown are owned; the rest are ghost copies of other ranks' (or
                        * periodic images): they enter the pair sums, not the statistics (= nf on one rank) */
  int xown;            /* 1: the passes evaluate owned particles only (sphdem_set_exchange hands the ghosts theirs) */
  int xwall;           /* 1: the wall pass too (owned walls: wtag <= nwown; the plain fluid's Adami walls) */
  int64_t nwown;       /* owned wall particles (device mirror of the context's nwown) */
  double *x, *v, *rho, *mass, *drho, *a, *u, *p, *x0;
  double *xe;          /* positions of the last sphdem_set_fluid (the engine's neighbour build) */
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
  /* the features' device state (couple_state.h, mp_state.h, fluid_options.h): off and NULL arrays while unused */
  sphdem_couple_dev couple; /* SPH-DEM coupling (He 2018 §2.3, couple_bodies.h) */
  sphdem_mp_dev mp;         /* delta-plus / multiphase fluid (Shi & Huang 2022, mp_bodies.h) */
  sphdem_ghost_dev ghost;   /* fixed ghost walls with MLS interpolation */
  sphdem_rk_dev rk;         /* fourth-order Runge-Kutta */
  sphdem_iso_dev iso;       /* kernel sums (keyword isolated) */
  double cmax;              /* largest sound speed (the CFL limit; multiphase: of any phase) */
} sphdem_dev;

/* Reduction record: stats of fluid (or bounding box of walls). */
typedef struct {
  double v2max, a2max, rhoerr, ke, disp2max;
  double edisp2max;               /* owned fluid: largest squared move since sphdem_set_fluid (x - xe) */
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
  /* Moving walls re-uploaded in the same order (sphdem_set_walls): while no wall is more than skin/2 from where
   * it was at the last wall sort, the new values go to the slots of that sort (wperm: slot -> caller index) and
   * the cells and lists of the walls are kept, as the fluid's are between its sorts. */
  int32_t *wperm;               /* device, cap_w; valid when wref_n >= 0 */
  int64_t wref_n;               /* walls at the last wall sort (-1: no reference) */
  double *hwx0, *hwm0;          /* host, caller order: positions and masses at the last wall sort */
  double *hwx1, *hwm1;          /* host, caller order: those of the last upload */
  int64_t cap_hw;
  int walls_caller_order;       /* the device wall arrays are in caller order (a full upload since the last sort) */
  int wref_synced;              /* the last wall sort was part of a fluid sort (sort_all) */
  int64_t nwall_reuse;          /* uploads that kept the wall sort (statistics) */
  int64_t nsorts;
  int have_rates;
  int half_kicked;              /* between the two half kicks of a step */
  int nl_dirty, wl_dirty;       /* neighbour lists must be rebuilt (after a fluid / wall sort) */
  unsigned char *nl_ghost;      /* CPU, many ranks: which slots were ghosts when the half lists were built (they */
  int64_t nl_ghost_cap;         /* leave out pairs of two ghosts); NULL or stale: rebuilt when it differs */
  int nl_xown;
  int cpu_sym;                  /* CPU: fluid pairs once from half lists (1) or gathered like the GPU (0) */
  double *symbuf;               /* CPU symmetric pass: per-thread rate accumulators */
  int64_t symbuf_cap;
  float *f8buf;                 /* CPU float pair loop (precisions mixed, single): 8 floats per fluid particle */
  int64_t f8buf_cap;
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
  sphdem_exchange_fn xfn;       /* many ranks: the owners' values to the ghosts (sphdem_set_exchange) */
  int rk_stepping;              /* inside step_rk4: the rates' exchange carries the XSPH / shift velocity too */
  double xtime;                 /* seconds of all exchanges so far (booked as transfer; the hooks' timers leave it out) */
  void *xuser;
  double *xbuf;                 /* its host staging */
  int64_t xbuf_cap;
  /* many ranks, per set (fluid, walls, coupled grains): the owned rows the exchange function reads
   * (sphdem_set_exchange_rows, fluid and walls; caller indices, nrows < 0: every owned one) and the slot maps of
   * those rows and of the ghosts on the device, valid while the set's slots, count and owned count stay as they
   * were when made (slot_gen counts changes) */
  struct sphdem_xmap {
    int32_t *rows;              /* host, nrows caller indices */
    int64_t nrows, cap_rows;
    int32_t *row_slot, *ghost_slot; /* device: slot of each row, slot of each ghost (caller index n0 + g) */
    int64_t cap_row_slot, cap_ghost_slot, nmapped_rows;
    int64_t n, n0;
    uint64_t gen;
    int valid;
  } xm[3];
  uint64_t slot_gen[3];
  int32_t *xinv;                /* host scratch: caller index -> slot */
  int64_t xinv_cap;
  double *xio;                  /* host: the owned and ghost values handed to the exchange function */
  size_t xio_cap;
  double *xstage;               /* device staging of gathered rows */
  int64_t xstage_cap;
  double edisp2;                /* largest squared move of an owned fluid particle since sphdem_set_fluid */
  int edisp_ok;                 /* edisp2 is that of the current positions */
  void *backend_data;
  /* the features' host state */
  sphdem_couple_host couple;    /* couple.c, couple_cpu.c */
  sphdem_mp_host mp;            /* mp.c */
  sphdem_option_host ghost, rk, iso; /* ghost.c, rk4.c, isolated.c */
};

#ifdef __cplusplus
extern "C" {
#endif
/* Many ranks: the owned values of a fluid field (SPHDEM_XCHG_RATES, _EPS, _ACC) to the ghosts through
 * sphdem_set_exchange's function; collective, nothing without one (exchange.c). The grains' exchange: couple.c. */
int sphdem_exchange_fluid(struct sphdem_ctx_s *c, int what);
/* The plain fluid's wall state (SPHDEM_XCHG_WALL) likewise (exchange.c). */
int sphdem_exchange_walls(struct sphdem_ctx_s *c);
/* The exchange of the device arrays arr[0..narr) (nc[k] values per slot) of a set (SPHDEM_SET_FLUID, _WALL,
 * _GRAIN): the owned rows' values to the exchange function in caller order, the ghosts' values back into their
 * slots; only those rows and the ghosts move between device and host (exchange.c). Collective. */
int sphdem_exchange_set(struct sphdem_ctx_s *c, int what, int set, double *const *arr, const int *nc, int narr,
                        const char *what_name);
/* Host staging of n doubles for the exchanges (exchange.c). */
double *sphdem_xbuf(struct sphdem_ctx_s *c, int64_t n);
/* The slots of a set (SPHDEM_SET_FLUID, _WALL) changed: its exchange maps are made again when next used. */
static inline void sphdem_slots_changed(struct sphdem_ctx_s *c, int set) { c->slot_gen[set]++; }
/* The ghosts' values vals (ncomp per ghost, ghost g at vals[stride g + off ..]) into their slots of the device
 * array dev (ncomp per slot), through the set's ghost map (exchange.c). */
int sphdem_scatter_ghosts(struct sphdem_ctx_s *c, int set, double *dev, int ncomp, const double *vals, int stride,
                          int off);
/* The values of the set's owned rows (sphdem_set_exchange_rows) of the device array dev (ncomp per slot) into host,
 * row with caller index i at host[stride i + off ..] (exchange.c). */
int sphdem_gather_owned_rows(struct sphdem_ctx_s *c, int set, const double *dev, int ncomp, double *host, int stride,
                             int off);
/* The exchange maps' memory (exchange.c). */
void sphdem_free_xmaps(struct sphdem_ctx_s *c);
/* Set the context error message (printf-style); returns code. */
int sphdem_fail(struct sphdem_ctx_s *c, int code, const char *fmt, ...);
/* Device scratch (perm, scratch_d, scratch_i) for sorts of n entries (sph_ctx.c). */
int sphdem_ensure_scratch(struct sphdem_ctx_s *c, int64_t n);
/* Device memory counted in c->rt.bytes (sph_ctx.c); dfree takes the bytes allocated and clears *ptr. */
int sphdem_dalloc(struct sphdem_ctx_s *c, void **ptr, size_t bytes);
void sphdem_dfree(struct sphdem_ctx_s *c, void **ptr, size_t bytes);
/* Derived constants of the parameters (sph_ctx.c). */
void sphdem_rederive(struct sphdem_ctx_s *c);
/* The backend's reduction of a set (SPHDEM_SET_*), timed into SPHDEM_T_REDUCE; the sort scratch freed (sph_ctx.c). */
int sphdem_timed_reduce(struct sphdem_ctx_s *c, int set, sphdem_red *r);
void sphdem_free_scratch(struct sphdem_ctx_s *c);

/* A feature of the fluid context (the SPH-DEM coupling, the delta-plus / multiphase fluid, ghost walls,
 * Runge-Kutta, kernel sums): its device state is a member of sphdem_dev, its host state a member of the
 * context, and the core reaches it only through these hooks, in the order of the table (gpu/sph/features.c).
 * Any hook may be NULL. prepare, prepare_rates and finish run only while `on` says the feature is active; the
 * others always (each checks its own state). A rate evaluation runs: prepare (timed into `timer`), the pressure
 * and wall passes, prepare_rates (timed with the rates), the rates pass, finish (timed into `timer`). */
typedef struct {
  const char *name;
  int (*on)(const struct sphdem_ctx_s *c);
  /* set_fluid made a new fluid set (arrays to be sized to D.nf), or set_walls a new wall set */
  int (*rebuilt)(struct sphdem_ctx_s *c, int set);
  /* a sort permuted the n entries of a set (c->perm, ops->gather): its arrays that carry state follow */
  int (*sorted)(struct sphdem_ctx_s *c, int set, int64_t n);
  int (*prepare)(struct sphdem_ctx_s *c);          /* before the pressure pass */
  int (*prepare_rates)(struct sphdem_ctx_s *c);    /* after the pressure and wall passes, before the rates pass */
  int (*finish)(struct sphdem_ctx_s *c);           /* after the rates pass */
  /* get_fluid: the pressure of the n densities rho (device order, host copy) into p[ui[s]] when the feature
   * owns the EOS (*done = 1); the first feature that does wins, else the fluid's Tait EOS */
  int (*host_pressure)(struct sphdem_ctx_s *c, int64_t n, const double *rho, const int32_t *ui, double *p,
                       int *done);
  void (*release)(struct sphdem_ctx_s *c);         /* free its memory */
  int timer;                                       /* SPHDEM_T_* of prepare and finish */
} sphdem_feature;
extern const sphdem_feature sphdem_feature_couple, sphdem_feature_mp, sphdem_feature_ghost, sphdem_feature_rk,
    sphdem_feature_iso;
extern const sphdem_feature *const sphdem_features[]; /* NULL-terminated, in call order */
/* Runge-Kutta arrays for n fluid particles (fluid_options.c), for the integrator (sph_step.c). */
int sphdem_rk_ensure(struct sphdem_ctx_s *c, int64_t n);
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
