/* cfd_internal.h - gas grid (CFD-DEM) data shared by the context code (cfd.c) and both backends. */
#ifndef SPHDEM_CFD_INTERNAL_H
#define SPHDEM_CFD_INTERNAL_H

#include "grains.h"
#include "hd.h"
#include "runtime.h"

#define SPHDEM_CFD_MAX_CELLS (1LL << 26)

#define SPHDEM_CFD_MAX_LEVELS 12

/* halo width in cells where a subdomain meets another rank's: the grain stencils (a grain up to one cell
 * beyond its subdomain, its trilinear corners and the pressure gradient at its faces) reach two cells out */
#define CFD_HALO 2

/* largest global coarse level of a decomposed grid's preconditioner: aggregates, and the flops of its banded
 * Cholesky factorization (n bw^2, once per gas step) */
#define CFD_GC_MAX 2048
#define CFD_GC_FLOPS 1e7

/* One level of the multigrid preconditioner. Level 0 is the grid itself (its arrays alias the solver's:
 * af, diag, r in, x = z out, t = lcp scratch); level l+1 aggregates cf[d] (1 or 2) cells per axis of level l,
 * its face coefficients are the sums of the fine ones across the coarse face (Galerkin, P piecewise constant). */
typedef struct {
  int nc[3], cf[3];
  int64_t ncell, foff[4];
  double *af, *diag, *r, *x, *t;
} cfd_level;

/* Everything a pass needs, by value to kernels and by pointer to CPU loops. Cells and faces are indexed
 * as level 0 of the multigrid hierarchy (L[0]: cells x fastest, faces of axis d from L[0].foff[d] on). */
typedef struct {
  sphdem_cfd_params P;
  /* Many ranks (decomposed grid): this rank stores the cells it owns plus a halo of CFD_HALO cells on every
   * side where another rank's cells are, as a local grid of nc cells starting at global cell g0 (lo is its
   * corner). hlo/own: the owned block's first local index and its size per axis. gnc, gncell: the whole grid.
   * split: 0 where the local grid is the owned block (one rank, or the whole grid replicated). */
  int nc[3], gnc[3], g0[3], hlo[3], own[3], split;
  int64_t ncell, nface, gncell;
  double lo[3], h[3], inv_h[3], Vc;
  double dt;            /* gas step in progress */
  int first;            /* eps_old not yet valid: d eps/dt taken as 0 */
  double alpha, beta;   /* conjugate-gradient scalars of the pass in progress */
  /* cells */
  double *sol;          /* solid volume in each cell (voidage scatter) */
  double *eps, *eps_old, *p;
  double *b, *r, *z, *d, *Ad, *diag; /* pressure solve */
  double *lcp;          /* line preconditioner: Thomas-algorithm scratch */
  int lax;              /* line axis: the axis with the most cells */
  int64_t nlines;       /* ncell / nc[lax] */
  int nlev, lv;         /* multigrid levels; the level a pass works on */
  double omega;         /* Jacobi damping of the smoother */
  cfd_level G;          /* the local grid's indexing (cells and faces of nc) */
  /* the preconditioner's levels: level 0 is the owned block (the grid itself, aliased, where split is 0; else
   * copies, so that the preconditioner is block Jacobi over the ranks: each block solved with the couplings to
   * the other blocks dropped from the matrix, their coefficients kept on the diagonal) */
  cfd_level L[SPHDEM_CFD_MAX_LEVELS];
  const double *mvx;    /* matvec input (p or d); output Ad */
  /* faces */
  double *u, *us, *cf;  /* velocity, predicted velocity, pressure-correction coefficient */
  double *af;           /* pressure-equation coefficient of the face (eps_f cf / h^2; outlet 2x; walls 0) */
  double *K, *Kv;       /* sum over grains of w K_i and w K_i v_d (drag, N s/m and N) */
  /* grains */
  int64_t n;
  double *gx, *gv, *grad, *gK, *gfd, *gfp, *gfb;
} cfd_dev;

/* Loops of the gas step (cfd_bodies.h defines cfd_k_<name>(const cfd_dev *, int64_t i)); the
 * backends generate one parallel loop or kernel per entry. */
#define SPHDEM_CFD_KERNELS(X)                                                                        \
  X(void_scatter) /* per grain: solid volume to cells (centroid or trilinear) */                     \
  X(void_finish)  /* per cell: eps = 1 - solid volume / cell volume */                           \
  X(drag)         /* per grain: K_i from the old gas field, scattered to faces as K, Kv */           \
  X(predict)      /* per face: u* with implicit drag, correction coefficient cf */                   \
  X(rhs)          /* per cell: b = -(div(eps u*) + d eps/dt), diagonal of A */                       \
  X(matvec)       /* per cell: Ad = A mvx */                                                          \
  X(pcg_res)      /* per cell: r = b - Ad */                                                          \
  X(precond)      /* per line along lax of level 0: x = M^-1 r, M the tridiagonal part of A on the line */ \
  X(blk_af)       /* per face of level 0 (split): its coefficient from the grid */                     \
  X(blk_r)        /* per cell of level 0 (split): r from the grid */                                   \
  X(blk_z)        /* per cell of level 0 (split): z of the grid from x */                               \
  X(mg_af)        /* per face of level lv >= 1: sum of the level lv-1 faces across it */             \
  X(mg_diag)      /* per cell of level lv: diagonal */                                                \
  X(mg_jacobi0)   /* per cell of level lv: x = omega r / diag */                                      \
  X(mg_resid)     /* per cell of level lv: t = r - A x */                                             \
  X(mg_jacobi)    /* per cell of level lv: x += omega t / diag */                                     \
  X(mg_restrict)  /* per cell of level lv+1: r = sum of the level lv residuals t of its cells */       \
  X(mg_prolong)   /* per cell of level lv: x += x of its level lv+1 cell */                            \
  X(pcg_first)    /* per cell: d = z */                                                               \
  X(pcg_update)   /* per cell: p += alpha d, r -= alpha Ad */                                         \
  X(pcg_dir)      /* per cell: d = z + beta d */                                                      \
  X(correct)      /* per face: u = u* - cf grad p */                                                  \
  X(forces)       /* per grain: drag, its boundary-face share, pressure-gradient force */

/* Reductions (cfd_r_<name>(const cfd_dev *, int64_t i) returns the term); op 0 sum, 1 max. */
#define SPHDEM_CFD_REDUCTIONS(X)                                                                     \
  X(rz, 0) X(dad, 0) X(rr, 0) X(bb, 0)                                                               \
  X(negeps, 1)    /* -eps (min voidage) */                                                           \
  X(eps, 0)       /* sum of voidage */                                                               \
  X(u2, 1)        /* |u_f|^2 */                                                                       \
  X(cfl, 1)       /* |u_f| / h_d */                                                                   \
  X(mass, 1)      /* |div(eps u) + d eps/dt| * dt */                                                  \
  X(fgasx, 0) X(fgasy, 0) X(fgasz, 0)    /* -(K u - Kv) over interior faces of axis d */              \
  X(fbndx, 0) X(fbndy, 0) X(fbndz, 0)    /* K u - Kv over boundary faces of axis d */                 \
  X(pfirst, 0) X(plast, 0)               /* pressure summed over the first / last layer (flow axis) */

enum {
#define SPHDEM_CFD_KID_(name) CFD_K_##name,
  SPHDEM_CFD_KERNELS(SPHDEM_CFD_KID_)
#undef SPHDEM_CFD_KID_
  CFD_NKERNELS
};
enum {
#define SPHDEM_CFD_RID_(name, op) CFD_R_##name,
  SPHDEM_CFD_REDUCTIONS(SPHDEM_CFD_RID_)
#undef SPHDEM_CFD_RID_
  CFD_NREDUCTIONS
};

/* Backend passes (memory operations are in the runtime, m->rt). */
struct sphdem_cfd_s;
typedef struct {
  const char *name;
  /* run loop kid over [0, n) */
  int (*run)(struct sphdem_cfd_s *m, int kid, int64_t n);
  /* reduction rid over [0, n) into *out (sum or max as its table entry says) */
  int (*reduce)(struct sphdem_cfd_s *m, int rid, int64_t n, double *out);
  /* free backend_data (may be NULL) */
  void (*release)(struct sphdem_cfd_s *m);
} cfd_ops;

struct sphdem_cfd_s {
  cfd_dev D;
  sphdem_rt rt; /* memory, device bytes held, error text */
  const cfd_ops *ops;
  int backend;
  int64_t cap_n;
  /* grains: D->gx, gv, grad point at the grain store's device view, or at these copies of the grains an
   * index list picks (cap_sel grains) */
  double *sel_x, *sel_v, *sel_rad;
  int64_t cap_sel;
  sphdem_idx_buf sel_idx;
  struct sphdem_grains_s *gstore; /* private store of sphdem_cfd_step (a shim hands its own store) */
  double timers[SPHDEM_CFD_NTIMERS];
  sphdem_cfd_stats st;
  void *backend_data;
  /* many ranks (rt.comm), replicated grid: host copy of the per-cell and per-face sums combined over the ranks,
   * and a flag */
  double *hred;
  int64_t nhred;
  /* decomposed grid (sphdem_cfd_set_subdomain): owned global cells [slo, shi) per axis; host buffers of the halo
   * exchange; bytes sent and exchanges made so far */
  int decomp, slo[3], shi[3];
  double *hsend, *hrecv;
  int64_t nhx;
  /* decomposed grid: the halo messages' cell offsets within an item (cells, or the faces of one axis), in message
   * order, on the device, made when first used for the local layout: [kind + 1][axis][dir > 0][layers ==
   * CFD_HALO][reverse][0 sent, 1 received]; device staging of one message, and zeros for the deposits sent */
  struct cfd_halo_list { int32_t *idx; int64_t n; int made; } hl[4][3][2][2][2][2];
  double *hstage, *hzero;
  int64_t nhstage, nhzero;
  /* decomposed grid: the preconditioner's global coarse level, the same on every rank: the whole grid in
   * aggregates of gc_b[d] cells per axis (gc_n of them, at most CFD_GC_MAX), its Galerkin matrix factored
   * (banded Cholesky, gc_L: gc_n rows of the gc_bw + 1 entries left of and on the diagonal), the coarse vectors;
   * gc_ok 0 where the factorization failed this gas step */
  int gc_b[3], gc_nc[3], gc_ok;
  int64_t gc_n, gc_bw;
  double *gc_L, *gc_v, *gc_w, *gc_host;
  double xbytes;
  long xcalls;
};

#ifdef __cplusplus
extern "C" {
#endif
int sphdem_cfd_fail(struct sphdem_cfd_s *m, int code, const char *fmt, ...);
extern const cfd_ops sphdem_cfd_cpu_ops;
#ifdef SPHDEM_WITH_CUDA
extern const cfd_ops sphdem_cfd_cuda_ops;
#endif
#ifdef __cplusplus
}
#endif

#endif
