/* dem_internal.h - GPU DEM data shared by the context code (dem.c) and both backends (not public). */
#ifndef SPHDEM_DEM_INTERNAL_H
#define SPHDEM_DEM_INTERNAL_H

#include "hd.h"
#include "runtime.h"
#include "dem_passes.h"

#define SPHDEM_DEM_NHIST 5      /* per pair: tangential displacement xyz, touch flag, largest overlap
                                   (hooke/hysteresis) or twisting angle (granular twisting; 0 otherwise) */
#define SPHDEM_DEM_MAX_CELLS (1 << 24)
#define SPHDEM_DEM_MAX_WALLS 16 /* the walls travel in the kernel parameters: keep dem_dev small */
#define SPHDEM_DEM_MAX_TAG 2147483647LL
/* D->vir: 6 virial doubles, the contact counter (dem_cuda.cu), then the first pair found with coincident
 * centres as ((a + 1) << 32) | b (uint64, 0 = none) */
#define SPHDEM_DEM_VIR_COINCIDENT 7
#define SPHDEM_DEM_VIR_DOUBLES 8

/* LIGGGHTS' material of a pair of materials i, j as its property registry derives it (global_properties:
 * Yeff, Geff, betaeff, coeffRestLog, coeffFrict, coeffRollFrict at [itype][jtype]). */
typedef struct {
  double Yeff, Geff; /* 1/((1 - nu_i^2)/E_i + (1 - nu_j^2)/E_j), 1/(2(2 - nu_i)(1 + nu_i)/E_i + 2(2 - nu_j)(1 + nu_j)/E_j) */
  double betaeff;    /* ln e / sqrt(ln^2 e + pi^2) */
  double lnen;       /* ln e */
  double mu, mu_r;   /* sliding and rolling friction */
  double ced;        /* cohesion energy density (cohesionEnergyDensity) */
  double rvd;        /* rolling viscous damping (coefficientRollingViscousDamping) */
  double kn2kcmax, kn2kc, phif; /* hooke/hysteresis: coefficientMaxElasticStiffness, coefficientAdhesionStiffness,
                                   coefficientPlasticityDepth */
} dem_mat;

/* Everything a pass needs, by value to kernels and by pointer to CPU loops. Grain arrays are in the
 * caller's order; the cell grid sorts only an index array (sidx). */
typedef struct {
  sphdem_dem_params P;
  /* derived constants */
  double cdamp;       /* |ln e| / sqrt(pi^2 + ln^2 e) (Yu eq 11 / He eq 23) */
  int use_en;         /* damping from the restitution coefficient (en > 0) */
  double ct;          /* He eq 21 tangential coefficient */
  double Estar;       /* He eq 21 for one material: E / (2 (1 - nu^2)) */
  double tmax_fac;    /* He eq 22: (2 - nu) / (2 - 2 nu) mu */
  dem_mat mat0;       /* the LIGGGHTS models: the material pair of the params' one material */
  int nmat;           /* 0: every grain is of mat0; else materials in the table mat (sphdem_dem_set_materials) */
  dem_mat *mat;       /* nmat x nmat material pairs (device), grain material index from its flags */
  int ngran;          /* SPHDEM_DEM_GRANULAR: grain types in the table gran (sphdem_dem_set_granular), 0 before */
  sphdem_dem_granular *gran; /* ngran x ngran type-pair coefficients (device), grain type from its flags */
  int gran_rolling;   /* some type pair of gran has a rolling model: the rolling history rin/rout is kept */
  double L[3];
  double halfL[3];    /* L / 2 on periodic axes, HUGE_VAL on the others (the minimum-image test of dem_sep) */
  double halfL2min;   /* the least halfL[d]^2 (HUGE_VAL without a periodic axis): |r|^2 below it needs no image */
  double glo[3], cs_inv[3];
  int nc[3];
  int64_t ncells;
  int nw;
  sphdem_dem_wall walls[SPHDEM_DEM_MAX_WALLS];
  double dt;
  int update, want_virial;
  /* grains */
  int64_t n;
  double *x, *v, *om, *rad, *mass, *f, *tq;
  int32_t *flags;
  int any_frozen;     /* some grain has SPHDEM_DEM_FROZEN (else the law reads no flags for it) */
  uint16_t excl[SPHDEM_DEM_MAX_CLASSES]; /* sphdem_dem_set_exclusions: bit c2 of excl[c1], pairs of classes c1, c2
                         are not kept */
  int any_excl;       /* some pair of classes is excluded */
  int32_t *head;      /* CPU one-thread pass, copies of a grain sharing a tag: per copy, the copy whose run of pairs
                         holds its pairs (the first pair's a); NULL when each run has one grain */
  int ghost_once;     /* a pair of this rank's grain and another rank's (SPHDEM_DEM_GHOST) is kept only when this
                         rank's grain has the lower tag, and its force on the other grain is the engine's to send
                         back (sphdem_dem_set_ghost_once) */
  int64_t *tag;
  /* cell grid: sorted slot -> grain, cell of each sorted slot, cell ranges */
  int32_t *sidx, *cell, *cstart, *cend;
  /* pair list: per-slot counts and offsets, pairs sorted by key, history double-buffered */
  int64_t *cnt, *off;
  int64_t np;
  int64_t pcap;       /* pairs the arrays pa, pb, key hold (the fill writes no further) */
  int32_t *pa, *pb;   /* grain indices; pb = -1 - w for wall w */
  uint64_t *key;      /* (tag_a << 32) | tag_b, walls 0xffffffff - w */
  double *hin, *hout;
  double *rin, *rout; /* ROLL_EPSD2: rolling spring torque per pair (3); GRANULAR rolling sds: the rolling
                         displacement (3); double-buffered like hin/hout; NULL when off */
  int roll_carry;     /* this build carries roll_old (else the rolling torques start from zero) */
  double *roll_old;   /* rolling torques of the previous list, for the carry */
  int carry_touching; /* this build carries the history of touching pairs only (keep_history, build
                         requested by the engine) */
  /* previous list for the history carry */
  int64_t np_old;
  uint64_t *key_old;
  double *hist_old;
  /* CPU particle-parallel: per pair its gap at the last build (dem_pair_gap; NULL: none kept), and the
   * least gap a pair may have had then and touch now: twice the largest displacement and radius growth of a
   * grain since (dem_particle_forward_model skips the pairs above it) */
  double *gap0;
  double gap_thr;
  /* particle-parallel CSR: pairs where the grain is a: [fstart, fend); where it is b: rlist[rstart..rend) */
  int32_t *fstart, *fend, *rstart, *rend, *rlist, *rkey;
  double *vir;        /* 6 virial components, 8 bytes of device counter, the coincident-pair slot (below) */
} dem_dev;

struct sphdem_dem_s;
/* Backend passes (memory operations are in the runtime, m->rt); each returns SPHDEM_OK or a code with the
 * message set. */
typedef struct {
  const char *name;
  /* cells of the grains, sidx stably sorted by cell, cell ranges */
  int (*cells)(struct sphdem_dem_s *m);
  /* count candidate pairs per sorted slot, exclusive scan; *np gets the total */
  int (*count)(struct sphdem_dem_s *m, int64_t *np);
  /* fill pa, pb, key, sort the list by key, carry the history from the previous list */
  int (*fill)(struct sphdem_dem_s *m);
  /* CSR for the particle-parallel pass */
  int (*csr)(struct sphdem_dem_s *m);
  /* contact forces into f, tq (zeroed here), history hin -> hout, virial; touching pairs into *ntouch */
  int (*forces)(struct sphdem_dem_s *m, int64_t *ntouch);
  /* the per-element passes the steps call (dem_passes.h) */
  SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_FIELD)
} dem_ops;

struct sphdem_dem_s {
  dem_dev D;
  sphdem_rt rt;                /* memory and error text (no device byte count is reported for the DEM: frees pass 0) */
  const dem_ops *ops;
  int backend;
  int64_t cap_n, cap_p, cap_pold, cap_cells;
  int need_build;
  int build_requested;         /* sphdem_dem_request_build since the last build */
  int seeded;                  /* key_old/hist_old hold a history given by sphdem_dem_set_history */
  int seed_roll;               /* and roll_old its rolling torques (sphdem_dem_set_history_rolling) */
  int roll_valid;              /* D->rin holds the rolling torques of the current list */
  int64_t cap_roll, cap_rold;  /* capacities (pairs) of rin/rout and roll_old */
  /* pairs added to the history the next build carries over (sphdem_dem_add_history): host arrays sorted by key,
   * merged into key_old/hist_old/roll_old at that build (into the spare arrays mk/mh/mr, then swapped) */
  uint64_t *add_key;
  double *add_hist, *add_roll; /* add_roll: 3 per pair, or zeros where none were given */
  int64_t nadd, cap_add;
  int add_roll_given;
  uint64_t *mk;                /* spare key_old/hist_old/roll_old (host; the CPU backend swaps them in) */
  double *mh, *mr;
  int64_t cap_m, cap_mr;
  int tags_valid;              /* device tag array matches htag */
  int zero_copy;               /* CPU backend: f, tq point at the caller's arrays during sphdem_dem_compute
                                  (x, v, om, rad, mass always at the grain store's device view) */
  struct sphdem_grains_s *gstore; /* private store of sphdem_dem_compute (a shim hands its own store) */
  int64_t nbuilds, ncontacts;
  int has_ghosts;              /* the last grains had SPHDEM_DEM_GHOST or SPHDEM_DEM_IMAGE flags */
  /* host copies for the rebuild decision: positions and radii at the last build, tags */
  double *hx0, *hr0;
  double Lbuilt[3];            /* the box lengths at the last build (a box that changes between builds) */
  int64_t *htag;
  int64_t hcap;
  double dmax_built;
  void *backend_data;
  /* CPU particle-parallel: F and Tb of each pair (6 doubles per pair), see dem_particle_forward_body */
  double *cpu_pfb;
  unsigned char *cpu_tf;       /* and whether each pair touches (1) or not (0), for the reverse half */
  int64_t cap_pfb;
  unsigned char *cpu_bt;       /* per grain: a touching pair as b this evaluation (the reverse half skips the others) */
  int64_t cap_bt;
  double *cpu_gap;             /* D.gap0 of the CPU backend */
  int64_t cap_gap;
  int32_t *cpu_act;            /* the pairs the one-thread pass visits (c_active in dem_cpu.c) */
  int64_t cap_act, act_n;      /* capacity; act_n pairs in it (< 0: not taken yet) */
  double act_lim;              /* cpu_act stands while 2 (largest move since it was taken) + gap_rest <= act_lim */
  double act_thr0;             /* D->gap_thr at the pass over the whole list */
  int64_t act_calls;           /* the evaluations since that pass */
  int act_all;                 /* visit every pair until the next pass over the whole list */
  double *cpu_xact;            /* the positions when cpu_act was taken (3 n), then each grain's move since the
                                  build at that time (n, scratch) */
  int64_t cap_xact;
  double gap_rest;             /* D->gap_thr less the grains' moves: twice the largest radius growth since the
                                  build, and the change of the periodic lengths */
  int32_t *cpu_head;           /* D.head of the CPU backend */
  int64_t cap_head;
  int cpu_rev_valid;           /* rlist, rstart, rend hold the current list's reverse ranges (c_reverse) */
  int hist_in_place;           /* the last forces wrote the new history over the old (hin): no swap */
  int tf_valid;                /* cpu_tf marks the current list's pairs and the history was changed by the CPU
                                  particle-parallel pass only since (cleared by builds and history edits) */
  int64_t cpu_ntouch;          /* touching pairs counted by the CPU particle-parallel pass */
  int cpu_prefilled;           /* the CPU count (one thread) wrote pa, pb, key already: the fill has no scan */
  int cpu_uniform;             /* every run of pairs of one tag has one grain a (set by the CPU builds) */
  const int32_t *flags_zero;   /* D->flags holds flags_zero_n zeros (no flags given) since the last call */
  int64_t flags_zero_n;
  int accumulate;              /* sphdem_dem_set_accumulate: the forces are added to the caller's f, torque */
  int same_tags;               /* sphdem_dem_same_tags: the next call's tags are the last call's (not compared) */
  int cpu_adds;                /* the CPU forces of this call add to D->f, D->tq as they are (else overwrite) */
  double *acc_f;               /* accumulate where the backend overwrites: the forces here, then added */
  /* sphdem_dem_keep_step_history: the history (and rolling history) the last evaluation started from, its
   * update flag; snap_valid while no other evaluation has come since */
  int snap_req, snap_valid, snap_update;
  double *snap_h, *snap_r;
  int64_t cap_snap;
  int64_t cap_acc;
  /* time split of sphdem_dem_compute (SPHDEM_DEM_T_*), calls since the last reset */
  double t[SPHDEM_DEM_NTIMERS];
  int64_t ncalls;
};

#ifdef __cplusplus
extern "C" {
#endif
int sphdem_dem_fail(struct sphdem_dem_s *m, int code, const char *fmt, ...);
extern const dem_ops sphdem_dem_cpu_ops;
int sphdem_dem_cpu_serial_pass(const struct sphdem_dem_s *m);
SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_DECL_CPU)
#ifdef SPHDEM_WITH_CUDA
extern const dem_ops sphdem_dem_cuda_ops;
SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_DECL_CUDA)
#endif
#ifdef __cplusplus
}
#endif

#endif
