/* couple_cpu.c - CPU backend of the SPH-DEM coupling: the loops of its listed passes (sph_passes.h) and the
 * CPU's own versions of the three passes over fluid-grain pair lists.
 *
 * The three passes of a coupling step visit the same fluid-grain pairs (porosity: fluid -> grains, grain
 * forces: grain -> fluid, reaction: fluid -> grains). On the CPU the porosity pass walks the grain cells once
 * and records each fluid particle's grains within 2 hc with the pair's kernel value W (in the walk's order);
 * the list is transposed to each grain's fluid particles (ascending fluid index, the order of the grain pass's
 * cell walk where no cell wraps periodically), and the other two passes read the lists and the kernel values
 * instead of walking cells and evaluating the kernel again. The walk skips the cells that lie wholly beyond
 * 2 hc of the fluid particle on the axes that are not periodic (about a third of the box of a 5^3-cell walk);
 * it visits the others in the order of walk_grains_around, so the pairs and their order are those of the cell
 * walk. The per-pair terms are the shared ones (couple_*_add_w / _finish, with W from couple_kernel), so the
 * sums are those of the cell walks, term for term.
 * The GPU-like gather mode (SPHDEM_CPU_GATHER) walks the cells like the CUDA kernels: the twin self-test
 * (twin_cpu_selftest) compares the two. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "couple_bodies.h"
#include "sph_internal.h"

static int grow64(int64_t **p, int64_t *cap, int64_t n) {
  if (n <= *cap) return 0;
  int64_t m = n + n / 4 + 16;
  int64_t *q = (int64_t *)realloc(*p, 8 * (size_t)m);
  if (!q) return 1;
  *p = q; *cap = m;
  return 0;
}

static int grow32(int32_t **p, int64_t *cap, int64_t n) {
  if (n <= *cap) return 0;
  int64_t m = n + n / 4 + 16;
  int32_t *q = (int32_t *)realloc(*p, 4 * (size_t)m);
  if (!q) return 1;
  *p = q; *cap = m;
  return 0;
}

/* Per-thread pair buffer: grain indices and kernel values, one capacity. */
static int grow_pairs(int32_t **pj, double **pw, int64_t *cap, int64_t n) {
  if (n <= *cap) return 0;
  int64_t m = n + n / 4 + 16;
  int32_t *q = (int32_t *)realloc(*pj, 4 * (size_t)m);
  if (!q) return 1;
  *pj = q;
  double *w = (double *)realloc(*pw, 8 * (size_t)m);
  if (!w) return 1;
  *pw = w;
  *cap = m;
  return 0;
}

static int growd(double **p, int64_t *cap, int64_t n) {
  if (n <= *cap) return 0;
  int64_t m = n + n / 4 + 16;
  double *q = (double *)realloc(*p, 8 * (size_t)m);
  if (!q) return 1;
  *p = q; *cap = m;
  return 0;
}

/* Distance from x to cell i of a grain-grid axis (lower edge lo, cell size cs, n cells), 0 inside; the edge
 * cells extend outward without bound (positions beyond the grid are binned into them). Shortened by a margin
 * far above the rounding of the binning, so that a skipped cell never holds a grain within reach. */
static inline double grain_cell_gap(double x, double lo, double cs, int n, int i) {
  double b0 = lo + i * cs, b1 = b0 + cs, g = 0.0;
  if (i > 0 && x < b0) g = b0 - x;
  else if (i < n - 1 && x > b1) g = x - b1;
  g -= 1e-9 * (cs + fabs(lo) + fabs(x));
  return g > 0.0 ? g * g : 0.0;
}

/* Thread t's pair buffer (grain index, kernel value) and its fill n: grain j appended when within 2 hc of xa,
 * its porosity term added to *s. */
typedef struct {
  int32_t **pj;
  double **pw;
  int64_t *cap, n;
  int err;
} pair_sink;

static inline void porosity_cell(const sphdem_dev *D, const double *xa, int64_t cc, double *s, pair_sink *k) {
  double r[3];
  for (int32_t j = D->couple.gcstart[cc]; j < D->couple.gcend[cc]; j++) {
    double r2 = separation(D, xa, D->couple.gx + 3 * j, r);
    if (r2 >= D->couple.support2c) continue;
    double W = couple_kernel(D, r2);
    couple_porosity_add_w(D, j, W, s);
    if (!k->err && grow_pairs(k->pj, k->pw, k->cap, k->n + 1)) k->err = 1;
    if (!k->err) { (*k->pj)[k->n] = j; (*k->pw)[k->n] = W; }
    k->n++;
  }
}

/* A grid as the culled walk sees it: cell lower edge, size, its inverse, counts per axis. */
typedef struct {
  const double *lo, *cs, *inv;
  const int *n;
} grid_view;

/* The box of cells of L layers around the cell of x (the cells of walk_init on a grid without periodic axes, in
 * its order: x fastest), without the cells wholly at or beyond distance sqrt(reach2) of x; calls cell(cc) for
 * the others. For grids with no periodic axis (the callers take walk_init otherwise). */
#define CULLED_BOX_FOR(D, G, L, X, REACH2, CC, BODY)                                                            \
  do {                                                                                                        \
    const int dim_ = (D)->P.dim;                                                                              \
    int b0_[3] = {0, 0, 0}, b1_[3] = {0, 0, 0};                                                               \
    for (int d_ = 0; d_ < dim_; d_++) {                                                                       \
      int c_ = axis_coord((X)[d_], (G).lo[d_], (G).inv[d_], (G).n[d_], 0);                                    \
      b0_[d_] = c_ - (L)[d_] < 0 ? 0 : c_ - (L)[d_];                                                          \
      b1_[d_] = c_ + (L)[d_] > (G).n[d_] - 1 ? (G).n[d_] - 1 : c_ + (L)[d_];                                  \
    }                                                                                                         \
    for (int z_ = b0_[2]; z_ <= b1_[2]; z_++) {                                                               \
      double gz_ = dim_ == 3 ? grain_cell_gap((X)[2], (G).lo[2], (G).cs[2], (G).n[2], z_) : 0.0;             \
      if (gz_ >= (REACH2)) continue;                                                                          \
      for (int y_ = b0_[1]; y_ <= b1_[1]; y_++) {                                                             \
        double gyz_ = gz_ + grain_cell_gap((X)[1], (G).lo[1], (G).cs[1], (G).n[1], y_);                      \
        if (gyz_ >= (REACH2)) continue;                                                                       \
        int64_t row_ = ((int64_t)z_ * (G).n[1] + y_) * (G).n[0];                                              \
        for (int x_ = b0_[0]; x_ <= b1_[0]; x_++)                                                             \
          if (gyz_ + grain_cell_gap((X)[0], (G).lo[0], (G).cs[0], (G).n[0], x_) < (REACH2)) {                 \
            int64_t CC = row_ + x_;                                                                           \
            BODY;                                                                                             \
          }                                                                                                   \
      }                                                                                                       \
    }                                                                                                         \
  } while (0)

static inline int any_periodic(const sphdem_dev *D) {
  int p = 0;
  for (int d = 0; d < D->P.dim; d++) p |= D->P.periodic[d];
  return p;
}

/* porosity_cell where no axis is periodic: the separation of separation() without its periodic branches (the
 * same operations in the same order, so the same r2), the buffer grown once per cell. */
static inline void porosity_cell_open(const sphdem_dev *D, const double *xa, int64_t cc, double *s, pair_sink *k) {
  const int32_t j0 = D->couple.gcstart[cc], j1 = D->couple.gcend[cc];
  if (j1 <= j0) return;
  if (!k->err && grow_pairs(k->pj, k->pw, k->cap, k->n + (j1 - j0))) k->err = 1;
  int32_t *pj = k->err ? NULL : *k->pj;
  double *pw = k->err ? NULL : *k->pw;
  const double *gx = D->couple.gx, R2 = D->couple.support2c, x0 = xa[0], x1 = xa[1], x2 = xa[2];
  const int three = D->P.dim == 3;
  int64_t n = k->n;
  double acc = *s;
  for (int32_t j = j0; j < j1; j++) {
    double s0 = x0 - gx[3 * j], s1 = x1 - gx[3 * j + 1], r2 = s0 * s0 + s1 * s1;
    if (three) { double s2 = x2 - gx[3 * j + 2]; r2 += s2 * s2; }
    if (r2 >= R2) continue;
    double W = couple_kernel(D, r2);
    couple_porosity_add_w(D, j, W, &acc);
    if (pj) { pj[n] = j; pw[n] = W; }
    n++;
  }
  k->n = n;
  *s = acc;
}

/* Fluid particle a's grains within 2 hc (porosity sum and pairs): the cells of walk_grains_around in its order,
 * without those wholly beyond 2 hc where no axis is periodic (periodic grids take the plain walk). Grains are
 * binned at every upload, so their cells hold them exactly. */
static inline double porosity_pairs(const sphdem_dev *D, const double *xa, pair_sink *k) {
  double s = 0.0;
  if (any_periodic(D)) {
    cell_walk w;
    int64_t cc;
    walk_grains_around(D, xa, &w);
    while (walk_next(&w, &cc)) porosity_cell(D, xa, cc, &s, k);
    return s;
  }
  grid_view g = {D->couple.gglo, D->couple.gcs, D->couple.gcs_inv, D->couple.gnc};
  CULLED_BOX_FOR(D, g, D->couple.glay, xa, D->couple.support2c, cc, porosity_cell_open(D, xa, cc, &s, k));
  return s;
}

/* The wall volume sum around grain position xj (keyword immersion, couple_grain_wall_sum): the cells of
 * walk_fluid_around in its order, without those wholly beyond 2 hc + skin/2 (the wall particles moved at most
 * skin/2 since they were binned) where no axis is periodic. */
static inline double grain_wall_sum(const sphdem_dev *D, const double *xj) {
  if (any_periodic(D)) return couple_grain_wall_sum(D, xj);
  double sigw = 0.0, reach = 2.0 * D->couple.hc + 0.5 * D->P.skin;
  grid_view g = {D->glo, D->cs, D->cs_inv, D->nc};
  CULLED_BOX_FOR(D, g, D->couple.flay, xj, reach * reach, cc,
                 wall_volume_sum_cell(D, xj, cc, D->couple.alphaC, D->couple.inv_hc, D->couple.support2c, &sigw));
  return sigw;
}

/* the cell-walk loops of the listed passes (sph_passes.h): the gather mode, and the fallback when the pair
 * lists could not be built */
SPHDEM_COUPLE_PASSES(SPHDEM_PASS_CPU_LOOP)

void sphdem_cpu_couple_lists_free(struct sphdem_ctx_s *c) {
  free(c->couple.cpl_fs); free(c->couple.cpl_gs); free(c->couple.cpl_f); free(c->couple.cpl_g);
  free(c->couple.cpl_fw); free(c->couple.cpl_gw);
  for (int t = 0; t < c->couple.cpl_nt; t++) { free(c->couple.cpl_tb[t]); free(c->couple.cpl_tw[t]); }
  free(c->couple.cpl_tb); free(c->couple.cpl_tw); free(c->couple.cpl_tcap); free(c->couple.cpl_tn);
  c->couple.cpl_fs = c->couple.cpl_gs = NULL; c->couple.cpl_f = c->couple.cpl_g = NULL;
  c->couple.cpl_fw = c->couple.cpl_gw = NULL;
  c->couple.cpl_tb = NULL; c->couple.cpl_tw = NULL; c->couple.cpl_tcap = c->couple.cpl_tn = NULL;
  c->couple.cap_cplfs = c->couple.cap_cplgs = c->couple.cap_cplf = c->couple.cap_cplg = 0;
  c->couple.cap_cplfw = c->couple.cap_cplgw = 0;
  c->couple.cpl_nt = 0; c->couple.cpl_valid = 0;
}

int sphdem_cpu_couple_porosity(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  int64_t nf = D->nf, ng = D->couple.ng;
  int nt = 1;
#ifdef _OPENMP
  nt = omp_get_max_threads();
#endif
  c->couple.cpl_valid = 0;
  if (!c->cpu_sym) return sphdem_cpu_loop_couple_porosity(c);
  if (nt > c->couple.cpl_nt) {
    int32_t **tb = (int32_t **)realloc(c->couple.cpl_tb, sizeof(int32_t *) * (size_t)nt);
    if (tb) c->couple.cpl_tb = tb;
    int64_t *tc = tb ? (int64_t *)realloc(c->couple.cpl_tcap, 8 * (size_t)nt) : NULL;
    if (tc) c->couple.cpl_tcap = tc;
    int64_t *tn = tc ? (int64_t *)realloc(c->couple.cpl_tn, 8 * (size_t)nt) : NULL;
    if (tn) c->couple.cpl_tn = tn;
    double **tw = tn ? (double **)realloc(c->couple.cpl_tw, sizeof(double *) * (size_t)nt) : NULL;
    if (tw) c->couple.cpl_tw = tw;
    if (!tw) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate the pair-list buffers");
    for (int t = c->couple.cpl_nt; t < nt; t++) {
      c->couple.cpl_tb[t] = NULL; c->couple.cpl_tw[t] = NULL; c->couple.cpl_tcap[t] = 0;
    }
    c->couple.cpl_nt = nt;
  }
  if (grow64(&c->couple.cpl_fs, &c->couple.cap_cplfs, nf + 1) ||
      grow64(&c->couple.cpl_gs, &c->couple.cap_cplgs, ng + 1))
    return sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate the pair-list starts");
  int64_t *fs = c->couple.cpl_fs;
  int err = 0;
#pragma omp parallel num_threads(nt) reduction(| : err)
  {
    int t = 0;
#ifdef _OPENMP
    t = omp_get_thread_num();
#endif
    pair_sink k = {&c->couple.cpl_tb[t], &c->couple.cpl_tw[t], &c->couple.cpl_tcap[t], 0, 0};
    /* static schedule: each thread takes one contiguous block of a, in thread order */
#pragma omp for schedule(static)
    for (int64_t a = 0; a < nf; a++) {
      int64_t n0 = k.n;
      couple_porosity_finish(D, a, porosity_pairs(D, D->x + 3 * a, &k));
      fs[a + 1] = k.n - n0;
    }
    c->couple.cpl_tn[t] = k.n;
    err |= k.err;
  }
  if (err) return SPHDEM_OK; /* porosity is done; the other passes walk the cells (cpl_valid stays 0) */
  fs[0] = 0;
  for (int64_t a = 0; a < nf; a++) fs[a + 1] += fs[a];
  if (grow32(&c->couple.cpl_f, &c->couple.cap_cplf, fs[nf] + 1) ||
      grow32(&c->couple.cpl_g, &c->couple.cap_cplg, fs[nf] + 1) ||
      growd(&c->couple.cpl_fw, &c->couple.cap_cplfw, fs[nf] + 1) ||
      growd(&c->couple.cpl_gw, &c->couple.cap_cplgw, fs[nf] + 1))
    return SPHDEM_OK;
  int64_t off = 0;
  for (int t = 0; t < nt; t++) {
    if (c->couple.cpl_tn[t] > 0) {
      memcpy(c->couple.cpl_f + off, c->couple.cpl_tb[t], 4 * (size_t)c->couple.cpl_tn[t]);
      memcpy(c->couple.cpl_fw + off, c->couple.cpl_tw[t], 8 * (size_t)c->couple.cpl_tn[t]);
    }
    off += c->couple.cpl_tn[t];
  }
  /* transpose: each grain's fluid particles in ascending fluid index, with the kernel values */
  int64_t *gs = c->couple.cpl_gs;
  const int32_t *fl = c->couple.cpl_f;
  const double *fw = c->couple.cpl_fw;
  memset(gs, 0, 8 * (size_t)(ng + 1));
  for (int64_t k = 0; k < fs[nf]; k++) gs[fl[k] + 1]++;
  for (int64_t j = 0; j < ng; j++) gs[j + 1] += gs[j];
  for (int64_t a = 0; a < nf; a++)
    for (int64_t k = fs[a]; k < fs[a + 1]; k++) {
      int64_t m = gs[fl[k]]++;
      c->couple.cpl_g[m] = (int32_t)a;
      c->couple.cpl_gw[m] = fw[k];
    }
  for (int64_t j = ng; j > 0; j--) gs[j] = gs[j - 1]; /* the fill advanced each start to its end */
  gs[0] = 0;
  c->couple.cpl_valid = 1;
  return SPHDEM_OK;
}

int sphdem_cpu_couple_grains(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  if (!c->couple.cpl_valid) return sphdem_cpu_loop_couple_grains(c);
  const int64_t *gs = c->couple.cpl_gs;
  const int32_t *gl = c->couple.cpl_g;
  const double *gw = c->couple.cpl_gw;
#pragma omp parallel for schedule(dynamic, 16)
  for (int64_t j = 0; j < D->couple.ng; j++) {
    if (couple_grain_ghost(D, j)) continue; /* its owner's forces arrive by the exchange */
    const double *xj = D->couple.gx + 3 * j;
    couple_grain_acc A = {0.0, 0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.0};
    if (D->couple.immersion_s > 0.0) A.sigw = grain_wall_sum(D, xj);
    if (D->couple.torque) /* the torque needs the pair's separation: evaluated again */
      for (int64_t k = gs[j]; k < gs[j + 1]; k++) couple_grain_add(D, xj, gl[k], &A);
    else
      for (int64_t k = gs[j]; k < gs[j + 1]; k++) couple_grain_add_w(D, NULL, 0.0, gw[k], gl[k], &A);
    couple_grain_finish(D, j, &A);
  }
  return SPHDEM_OK;
}

int sphdem_cpu_couple_reaction(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  if (!c->couple.cpl_valid) return sphdem_cpu_loop_couple_reaction(c);
  const int64_t *fs = c->couple.cpl_fs;
  const int32_t *fl = c->couple.cpl_f;
  const double *fw = c->couple.cpl_fw;
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t a = 0; a < D->nf; a++) {
    double s[3] = {0, 0, 0};
    for (int64_t k = fs[a]; k < fs[a + 1]; k++) couple_reaction_add_w(D, fl[k], fw[k], s);
    couple_reaction_finish(D, a, s);
  }
  c->couple.cpl_valid = 0; /* one step's pairs */
  return SPHDEM_OK;
}
