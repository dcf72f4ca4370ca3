/* sph_cpu.c - CPU backend of the fluid: the loops of the listed passes (sph_passes.h), the sorts, the
 * reduction, and the CPU's own wall-state and rate passes over neighbour lists. */
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "fluid_rates.h"
#include "sph_internal.h"

#define TRY_CPU(x) do { int rc_ = (x); if (rc_) return rc_; } while (0)

/* Counting sort by cell (stable in the old order), then insertion sort by tag inside each cell:
 * the same (cell, tag) order as the CUDA radix sort of sort_key(). */
static int cpu_sort_perm(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = set_count(D, set);
  const double *x = set_x(D, set);
  const int64_t *tag = set_tag(D, set);
  int32_t *cell = set_cell(D, set);
  int64_t nc = set_ncells(D, set);
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; i++) cell[i] = set_cell_of(D, set, x + 3 * i);
  int64_t *start = (int64_t *)calloc((size_t)nc + 1, sizeof(int64_t));
  if (!start) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the cell count table");
  for (int64_t i = 0; i < n; i++) start[cell[i] + 1]++;
  for (int64_t k = 0; k < nc; k++) start[k + 1] += start[k];
  int32_t *perm = c->perm;
  int32_t *sorted_cell = (int32_t *)c->scratch_i; /* scratch_i has 8 bytes per entry */
  for (int64_t i = 0; i < n; i++) {
    int64_t s = start[cell[i]]++;
    perm[s] = (int32_t)i;
    sorted_cell[s] = cell[i];
  }
  /* start[k] now holds the end of cell k; sort each cell's run by tag */
#pragma omp parallel for schedule(dynamic, 256)
  for (int64_t k = 0; k < nc; k++) {
    int64_t b = k == 0 ? 0 : start[k - 1], e = start[k];
    for (int64_t i = b + 1; i < e; i++) {
      int32_t p = perm[i];
      int64_t t = tag[p], j = i - 1;
      while (j >= b && tag[perm[j]] > t) { perm[j + 1] = perm[j]; j--; }
      perm[j + 1] = p;
    }
  }
  memcpy(cell, sorted_cell, sizeof(int32_t) * (size_t)n);
  free(start);
  return SPHDEM_OK;
}

static int cpu_gather(struct sphdem_ctx_s *c, void *arr, int elem_bytes, int64_t n) {
  int ew = elem_bytes / 4;
  uint32_t *tmp = (uint32_t *)c->scratch_d;
  const uint32_t *src = (const uint32_t *)arr;
  const int32_t *perm = c->perm;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; i++) gather_words_body(tmp, src, perm, ew, i);
  memcpy(arr, tmp, (size_t)elem_bytes * (size_t)n);
  return SPHDEM_OK;
}

static int cpu_cell_ranges(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = set_count(D, set);
  int32_t *cs = set_cstart(D, set), *ce = set_cend(D, set);
  const int32_t *cell = set_cell(D, set);
  memset(cs, 0, sizeof(int32_t) * (size_t)set_ncells(D, set));
  memset(ce, 0, sizeof(int32_t) * (size_t)set_ncells(D, set));
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; i++) cell_range_body(cell, n, i, cs, ce);
  return SPHDEM_OK;
}

/* CSR neighbour lists within 2h + skin, rebuilt after each sort: the rates pass then checks ~3x
 * (2D) to ~6x (3D) fewer candidates than the 3^dim-cell walk. */
static int grow(struct sphdem_ctx_s *c, void **p, int64_t *cap, int64_t n, size_t eb) {
  if (n <= *cap) return SPHDEM_OK;
  int64_t m = n + n / 4 + 16;
  void *q = realloc(*p, (size_t)m * eb);
  if (!q) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate a neighbour list of %lld entries", (long long)m);
  c->rt.bytes += (size_t)(m - *cap) * eb;
  *p = q;
  *cap = m;
  return SPHDEM_OK;
}

static int cpu_build_list(struct sphdem_ctx_s *c, int set) {
  sphdem_dev *D = &c->D;
  int64_t n = D->nf, *st;
  int half = set == 0 && c->cpu_sym && !D->mp.on; /* the delta-plus fluid gathers from full lists */
  if (set == 0) {
    TRY_CPU(grow(c, (void **)&D->nl_start, &c->nls_cap, n + 1, sizeof(int64_t)));
    TRY_CPU(grow(c, (void **)&D->wl_start, &c->wls_cap, n + 1, sizeof(int64_t)));
  }
  st = set == 0 ? D->nl_start : D->wl_start;
  st[0] = 0;
#pragma omp parallel for schedule(static)
  for (int64_t a = 0; a < n; a++) st[a + 1] = D->nw > 0 || set == 0 ? list_body(D, a, set, half, NULL) : 0;
  for (int64_t a = 0; a < n; a++) st[a + 1] += st[a];
  int32_t **lst = set == 0 ? &D->nl : &D->wl;
  int64_t *cap = set == 0 ? &c->nl_cap : &c->wl_cap;
  if (grow(c, (void **)lst, cap, st[n] + 1, sizeof(int32_t))) return SPHDEM_ERR_ALLOC;
  int32_t *l = *lst;
#pragma omp parallel for schedule(static)
  for (int64_t a = 0; a < n; a++)
    if (st[a + 1] > st[a]) list_body(D, a, set, half, l + st[a]);
  if (set == 1 && D->nw > 0) {
    /* wall -> fluid, the transpose: each wall's fluid neighbours in ascending fluid (= cell) order */
    int64_t nw = D->nw, *ws;
    TRY_CPU(grow(c, (void **)&D->wfl_start, &c->wfls_cap, nw + 1, sizeof(int64_t)));
    TRY_CPU(grow(c, (void **)&D->wfl, &c->wfl_cap, st[n] + 1, sizeof(int32_t)));
    ws = D->wfl_start;
    memset(ws, 0, sizeof(int64_t) * (size_t)(nw + 1));
    for (int64_t k = 0; k < st[n]; k++) ws[l[k] + 1]++;
    for (int64_t w = 0; w < nw; w++) ws[w + 1] += ws[w];
    for (int64_t a = 0; a < n; a++)
      for (int64_t k = st[a]; k < st[a + 1]; k++) D->wfl[ws[l[k]]++] = (int32_t)a;
    for (int64_t w = nw; w > 0; w--) ws[w] = ws[w - 1]; /* the fill advanced each start to its end */
    ws[0] = 0;
  }
  return SPHDEM_OK;
}

/* Many ranks: the half lists leave out pairs of two ghosts, so they are rebuilt when a slot's ghost status
 * differs from the build's (an upload in place may swap owned and ghost entries). */
static int cpu_lists_partition(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  if (!D->xown) { if (c->nl_xown) c->nl_dirty = 1; return SPHDEM_OK; }
  if (!c->nl_xown) c->nl_dirty = 1;
  const int64_t cap0 = c->nl_ghost_cap;
  if (grow(c, (void **)&c->nl_ghost, &c->nl_ghost_cap, D->nf + 1, 1)) return SPHDEM_ERR_ALLOC;
  int changed = c->nl_ghost_cap != cap0;
  if (changed) memset(c->nl_ghost, 0, (size_t)c->nl_ghost_cap);
  for (int64_t s = 0; s < D->nf; s++) {
    const unsigned char g = (unsigned char)fluid_ghost(D, s);
    changed |= g != c->nl_ghost[s];
    c->nl_ghost[s] = g;
  }
  if (changed) c->nl_dirty = 1;
  return SPHDEM_OK;
}

static int cpu_ensure_lists(struct sphdem_ctx_s *c) {
  TRY_CPU(cpu_lists_partition(c));
  if (c->nl_dirty) {
    TRY_CPU(cpu_build_list(c, 0));
    c->nl_dirty = 0, c->wl_dirty = 1, c->nl_xown = c->D.xown;
  }
  if (c->wl_dirty) { TRY_CPU(cpu_build_list(c, 1)); c->wl_dirty = 0; }
  return SPHDEM_OK;
}

/* Wall state: from the wall -> fluid lists (the cell walk checked ~6x more candidates in 3D; the wall pass
 * cost as much as the fluid rates in the settling tank); MLS walls, multiphase runs and the GPU-like gather
 * mode (SPHDEM_CPU_GATHER, the twin self-test's second side) walk the cells. */
int sphdem_cpu_wall_state(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  if (D->ghost.on || D->mp.on || !c->cpu_sym) return sphdem_cpu_loop_wall_state(c);
  TRY_CPU(cpu_ensure_lists(c));
#pragma omp parallel for schedule(static)
  for (int64_t w = 0; w < D->nw; w++) {
    if (wall_ghost(D, w)) continue; /* its owner's state arrives by the exchange */
    const double *xw = D->wx + 3 * w;
    wall_state_acc A = {0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.0};
    for (int64_t k = D->wfl_start[w]; k < D->wfl_start[w + 1]; k++) wall_state_add(D, xw, D->wfl[k], &A);
    wall_state_finish(D, w, &A);
  }
  return SPHDEM_OK;
}

/* The float pair loop of the precisions mixed and single (sph_cpu_float.c): the AVX2 + FMA build where the CPU
 * has both (and the compiler could build it), else the baseline one; SPHDEM_CPU_FLOAT=generic forces the latter. */
typedef void (*pairs_float_fn)(const sphdem_dev *D, const float *F8, int64_t a, double *B, double *sums);
void sphdem_cpu_pairs_float_generic(const sphdem_dev *D, const float *F8, int64_t a, double *B, double *sums);
#ifdef SPHDEM_CPU_FLOAT_AVX2
void sphdem_cpu_pairs_float_avx2(const sphdem_dev *D, const float *F8, int64_t a, double *B, double *sums);
#endif

static pairs_float_fn cpu_pairs_float(void) {
  const char *e = getenv("SPHDEM_CPU_FLOAT");
  if (e && !strcmp(e, "generic")) return sphdem_cpu_pairs_float_generic;
#ifdef SPHDEM_CPU_FLOAT_AVX2
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return sphdem_cpu_pairs_float_avx2;
#endif
  return sphdem_cpu_pairs_float_generic;
}

/* Name of the float pair loop the precisions mixed and single use on this CPU ("avx2" or "generic"). */
const char *sphdem_cpu_float_isa(void) {
#ifdef SPHDEM_CPU_FLOAT_AVX2
  if (cpu_pairs_float() == sphdem_cpu_pairs_float_avx2) return "avx2";
#endif
  return "generic";
}

/* Fluid pairs evaluated once from the half lists: a's share is summed in registers, b's share goes
 * to the thread's own accumulator array; then each particle adds the thread arrays (in thread
 * order, static schedule: deterministic for a given thread count) and its wall neighbours. */
static int cpu_rates_sym(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  int64_t n = D->nf;
  const pairs_float_fn pairs_float = pair_in_float(D) ? cpu_pairs_float() : NULL;
  int nt = 1;
#ifdef _OPENMP
  nt = omp_get_max_threads();
#endif
  TRY_CPU(grow(c, (void **)&c->symbuf, &c->symbuf_cap, (int64_t)nt * n * 7, sizeof(double)));
  double *buf = c->symbuf;
  float *F8 = NULL;
  if (pairs_float) {
    /* each particle's float record for the float pair loop: velocity at the force time, rho, P/rho^2, mass, eps */
    TRY_CPU(grow(c, (void **)&c->f8buf, &c->f8buf_cap, 8 * n, sizeof(float)));
    F8 = c->f8buf;
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; i++) {
      float *f = F8 + 8 * (size_t)i;
      f[0] = (float)D->ve[3 * i]; f[1] = (float)D->ve[3 * i + 1]; f[2] = (float)D->ve[3 * i + 2];
      f[3] = (float)D->rhop[i]; f[4] = (float)D->pr2[i]; f[5] = (float)D->mass[i]; f[6] = (float)fluid_eps(D, i);
      f[7] = 0.0f;
    }
  }
#pragma omp parallel num_threads(nt)
  {
    int t = 0;
#ifdef _OPENMP
    t = omp_get_thread_num();
#endif
    const pair_consts K = D->K;  /* the double pairs' constants and terms, once per thread (a local copy: the */
    const sphdem_pair_opts O = pair_opts(D); /* stores to B cannot alias it) */
    double *B = buf + (size_t)t * (size_t)n * 7;
    memset(B, 0, sizeof(double) * 7 * (size_t)n);
#pragma omp barrier
    if (pairs_float) {
      /* mixed, single: the float pair loop (sph_cpu_float.c); a's sums straight into its own row */
#pragma omp for schedule(static)
      for (int64_t a = 0; a < n; a++) pairs_float(D, F8, a, B, B + 7 * (size_t)a);
    } else {
#pragma omp for schedule(static)
    for (int64_t a = 0; a < n; a++) {
      const double *xa = D->x + 3 * a, *va = D->ve + 3 * a;
      double rhoa = D->rhop[a], pra = D->pr2[a], ma = D->mass[a], da = 0.0, aa[3] = {0, 0, 0}, ua[3] = {0, 0, 0};
      double epsa = fluid_eps(D, a);
      for (int64_t k = D->nl_start[a]; k < D->nl_start[a + 1]; k++) { /* (two ghosts: not in the half list) */
        int32_t b = D->nl[k];
        fluid_pair_rec P;
        if (!fluid_pair_terms_double(D, &K, O, xa, va, rhoa, pra, epsa, b, &P)) continue;
        double mb = D->mass[b], *Bb = B + 7 * (size_t)b;
        da += mb * (P.cont + P.dda);
        Bb[0] += ma * (P.cont + P.ddb);
        for (int d = 0; d < 3; d++) {
          aa[d] += mb * P.A[d]; ua[d] += mb * P.U[d];
          Bb[1 + d] -= ma * P.A[d]; Bb[4 + d] -= ma * P.U[d];
        }
      }
      double *Ba = B + 7 * (size_t)a;
      Ba[0] += da;
      for (int d = 0; d < 3; d++) { Ba[1 + d] += aa[d]; Ba[4 + d] += ua[d]; }
    }
    }
#pragma omp for schedule(static)
    for (int64_t a = 0; a < n; a++) {
      if (fluid_ghost(D, a)) continue; /* its owner's rates arrive by the exchange */
      rates_acc R;
      rates_init(D, a, &R);
      for (int s = 0; s < nt; s++) {
        const double *Bs = buf + ((size_t)s * (size_t)n + (size_t)a) * 7;
        R.drho += Bs[0];
        for (int d = 0; d < 3; d++) { R.acc[d] += Bs[1 + d]; R.u[d] += Bs[4 + d]; }
      }
      rates_walls(D, a, &R, NULL, 0);
      rates_store(D, a, &R);
    }
  }
  return SPHDEM_OK;
}

/* Rates: the symmetric half-list pass for the plain fluid; the delta-plus fluid and the GPU-like gather mode
 * run the generated loop (rates_body over the full lists). */
int sphdem_cpu_rates(struct sphdem_ctx_s *c) {
  TRY_CPU(cpu_ensure_lists(c));
  if (c->cpu_sym && !c->D.mp.on) return cpu_rates_sym(c);
  return sphdem_cpu_loop_rates(c);
}

static int cpu_reduce(struct sphdem_ctx_s *c, int set, sphdem_red *out) {
  const sphdem_dev *D = &c->D;
  int64_t n = set == SPHDEM_SET_FLUID ? D->nf : D->nw;
  red_init(out);
#pragma omp parallel
  {
    sphdem_red r;
    red_init(&r);
#pragma omp for schedule(static) nowait
    for (int64_t i = 0; i < n; i++) red_body(D, set, i, &r);
#pragma omp critical
    red_combine(out, &r);
  }
  return SPHDEM_OK;
}

/* the loops of the listed passes (sph_passes.h) */
SPHDEM_FLUID_PASSES(SPHDEM_PASS_CPU_LOOP)

const sphdem_ops sphdem_cpu_ops = {
  .name = "cpu",
  .sort_perm = cpu_sort_perm,
  .gather = cpu_gather,
  .cell_ranges = cpu_cell_ranges,
  .reduce = cpu_reduce,
  SPHDEM_FLUID_PASSES(SPHDEM_PASS_CPU_ENTRY)
  SPHDEM_COUPLE_PASSES(SPHDEM_PASS_CPU_ENTRY)
};
