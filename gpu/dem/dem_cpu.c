/* dem_cpu.c - CPU (OpenMP) backend of the GPU DEM: loops that call the bodies of dem_bodies.h. */
#include <stdlib.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "dem_bodies.h"

#define DEM_TRY(call) do { int rc_ = (call); if (rc_) return rc_; } while (0)

/* the generated loops of the passes (dem_passes.h) */
SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_CPU_LOOP)

/* Stable counting sort of the grains by cell (the same order as the GPU's stable radix sort). */
static int c_cells(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  const int64_t nc = D->ncells + 1; /* the cells, and the one of the SPHDEM_DEM_SKIP grains */
  memset(D->cstart, 0, sizeof(int32_t) * (size_t)nc);
  memset(D->cend, 0, sizeof(int32_t) * (size_t)nc);
  DEM_TRY(m->ops->cell(m)); /* (the sorted order below overwrites sidx) */
  /* cend as counts, then exclusive offsets in cstart */
  for (int64_t i = 0; i < n; i++) D->cend[D->cell[i]]++;
  int32_t acc = 0;
  for (int64_t c = 0; c < nc; c++) {
    D->cstart[c] = acc;
    acc += D->cend[c];
    D->cend[c] = D->cstart[c];
  }
  for (int64_t i = 0; i < n; i++) D->sidx[D->cend[D->cell[i]]++] = (int32_t)i;
  for (int64_t s = 0; s < n; s++) D->cell[s] = dem_grain_cell(D, D->sidx[s]);
  for (int64_t c = 0; c < nc; c++)
    if (D->cstart[c] == D->cend[c]) D->cstart[c] = D->cend[c] = 0;
  return SPHDEM_OK;
}

/* 1 when a loop of this many iterations runs on one thread (no atomics needed) */
static int c_serial(int64_t iters) {
#ifdef _OPENMP
  return iters <= SPHDEM_DEM_OMP_MIN || omp_get_max_threads() == 1;
#else
  (void)iters;
  return 1;
#endif
}

static int c_count(struct sphdem_dem_s *m, int64_t *np) {
  dem_dev *D = &m->D;
  int64_t n = D->n;
  m->cpu_prefilled = 0;
  if (c_serial(n) && D->pcap > 0) {
    /* one thread: count and write in one scan, each slot from the running offset; when the pairs outgrow the
     * arrays (then reallocated) the fill scans again */
    int64_t acc = 0;
    for (int64_t s = 0; s < n; s++) {
      D->off[s] = acc;
      D->cnt[s] = dem_scan_slot(D, s, 1);
      acc += D->cnt[s];
    }
    *np = acc;
    m->cpu_prefilled = acc <= D->pcap;
    return SPHDEM_OK;
  }
  DEM_TRY(m->ops->scan_count(m));
  int64_t acc = 0; /* exclusive prefix sum (Yu 2024 Fig. 2) */
  for (int64_t s = 0; s < n; s++) {
    D->off[s] = acc;
    acc += D->cnt[s];
  }
  *np = acc;
  return SPHDEM_OK;
}

static const uint64_t *g_sort_keys; /* qsort has no context argument; only used under the lock below */
static int cmp_key(const void *a, const void *b) {
  uint64_t ka = g_sort_keys[*(const int32_t *)a], kb = g_sort_keys[*(const int32_t *)b];
  return ka < kb ? -1 : ka > kb;
}

/* perm = the pairs in key order (keys are unique), without a comparison sort of the whole list: the pairs counted
 * into the groups of their grain a's tag in tag order, and each group (a grain's few partners) sorted by key by
 * insertion. The group of a grain: its tag itself when the tags are dense (at most 4 n + 1024; gt = tag), else
 * the rank of its tag among the distinct tags (a radix sort of the 31-bit tags; copies of a grain share one).
 * Returns 0, or 1 when the scratch cannot be had or a group is too long for insertion (the caller then sorts the
 * whole list). */
static int key_order(const dem_dev *D, int64_t n, int64_t np, int32_t *perm) {
  int64_t maxtag = 0;
  for (int64_t i = 0; i < n; i++) maxtag = D->tag[i] > maxtag ? D->tag[i] : maxtag;
  const int dense = maxtag <= 4 * n + 1024;
  const int64_t ng0 = dense ? maxtag + 1 : n;
  int32_t *grp = (int32_t *)malloc(sizeof(int32_t) * (size_t)(ng0 + 1 + (dense ? 0 : 3 * n)));
  if (!grp) return 1;
  int32_t *gt = grp + ng0 + 1; /* not dense: the group of each grain, the grains by tag, scratch */
  int64_t ng = ng0;
  if (!dense) {
    int32_t *ord = gt + n, *tmp = ord + n, cnt[256];
    for (int64_t i = 0; i < n; i++) ord[i] = (int32_t)i;
    for (int sh = 0; sh < 32; sh += 8) { /* LSD radix sort, stable */
      memset(cnt, 0, sizeof cnt);
      for (int64_t i = 0; i < n; i++) cnt[(D->tag[ord[i]] >> sh) & 255]++;
      int32_t acc = 0;
      for (int b = 0; b < 256; b++) { const int32_t c = cnt[b]; cnt[b] = acc; acc += c; }
      for (int64_t i = 0; i < n; i++) tmp[cnt[(D->tag[ord[i]] >> sh) & 255]++] = ord[i];
      memcpy(ord, tmp, sizeof(int32_t) * (size_t)n);
    }
    ng = 0;
    for (int64_t k = 0; k < n; k++) {
      if (k > 0 && D->tag[ord[k]] != D->tag[ord[k - 1]]) ng++;
      gt[ord[k]] = (int32_t)ng;
    }
    if (n > 0) ng++;
  }
  /* pairs counted into the groups of a (grp: offsets), then placed in list order within each group */
  for (int64_t g = 0; g <= ng; g++) grp[g] = 0;
#define SPHDEM_KEY_GROUP(p) (dense ? (int64_t)D->tag[D->pa[p]] : (int64_t)gt[D->pa[p]])
  for (int64_t p = 0; p < np; p++) grp[SPHDEM_KEY_GROUP(p) + 1]++;
  for (int64_t g = 0; g < ng; g++) grp[g + 1] += grp[g];
  for (int64_t p = 0; p < np; p++) perm[grp[SPHDEM_KEY_GROUP(p)]++] = (int32_t)p;
#undef SPHDEM_KEY_GROUP
  /* grp[g] is now the end of group g; each group by key */
  int32_t lo = 0;
  int rc = 0;
  for (int64_t g = 0; g < ng && !rc; g++) {
    const int32_t hi = grp[g];
    if (hi - lo > 512) rc = 1;
    for (int32_t k = lo + 1; k < hi && !rc; k++) {
      const int32_t q = perm[k];
      const uint64_t kq = D->key[q];
      int32_t j = k;
      while (j > lo && D->key[perm[j - 1]] > kq) { perm[j] = perm[j - 1]; j--; }
      perm[j] = q;
    }
    lo = hi;
  }
  free(grp);
  return rc;
}

static int c_fill(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  const int64_t np = D->np, n = D->n;
  if (!m->cpu_prefilled) DEM_TRY(m->ops->scan_fill(m));
  m->cpu_prefilled = 0;
  /* sort the list by key (keys are unique); rlist and rkey serve as scratch */
  int32_t *perm = D->rlist;
  if (key_order(D, n, np, perm)) {
    for (int64_t p = 0; p < np; p++) perm[p] = (int32_t)p;
#pragma omp critical(sphdem_dem_qsort)
    {
      g_sort_keys = D->key;
      qsort(perm, (size_t)np, sizeof(int32_t), cmp_key);
    }
  }
  uint64_t *k2 = (uint64_t *)malloc(sizeof(uint64_t) * (size_t)(np ? np : 1));
  if (!k2) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the pair sort buffer");
  for (int64_t p = 0; p < np; p++) k2[p] = D->key[perm[p]];
  memcpy(D->key, k2, sizeof(uint64_t) * (size_t)np);
  free(k2);
  for (int64_t p = 0; p < np; p++) D->rkey[p] = D->pa[perm[p]];
  memcpy(D->pa, D->rkey, sizeof(int32_t) * (size_t)np);
  for (int64_t p = 0; p < np; p++) D->rkey[p] = D->pb[perm[p]];
  memcpy(D->pb, D->rkey, sizeof(int32_t) * (size_t)np);
  if (!c_serial(np)) return m->ops->carry(m);
  /* one thread: both lists are sorted by key, so one merge walk finds each pair's predecessor */
  const int64_t nold = D->np_old;
  int64_t j = 0;
  for (int64_t p = 0; p < np; p++) {
    const uint64_t k = D->key[p];
    while (j < nold && D->key_old[j] < k) j++;
    dem_carry_from(D, p, j < nold && D->key_old[j] == k ? j : -1);
  }
  return SPHDEM_OK;
}

/* *p has room for need elements of elem bytes, *cap its capacity (a growth keeps no contents: every caller fills
 * the array afresh). Returns 0, or 1 when the room cannot be had (*p and *cap as they were). */
static int c_room(void **p, size_t elem, int64_t need, int64_t *cap) {
  if (need <= *cap && *p) return 0;
  const int64_t c = need + need / 4 + 64;
  void *q = realloc(*p, elem * (size_t)c);
  if (!q) return 1;
  *p = q;
  *cap = c;
  return 0;
}

/* The pairs in the order of their grain b, for the reverse half of the several-thread pass: rlist, rkey and the
 * ranges rstart, rend (ties in pair order: a stable counting sort; the walls, pb < 0, first, which the reverse
 * ranges skip). */
static int c_reverse(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  const int64_t n = D->n, np = D->np;
  memset(D->rstart, 0, sizeof(int32_t) * (size_t)n);
  memset(D->rend, 0, sizeof(int32_t) * (size_t)n);
  /* rend counts, rstart the offsets, both set again by reverse_ranges */
  int64_t nwall = 0;
  for (int64_t p = 0; p < np; p++) {
    const int32_t b = D->pb[p];
    if (b >= 0) D->rend[b]++;
    else nwall++;
  }
  int64_t wk = 0;
  int32_t acc = (int32_t)nwall;
  for (int64_t i = 0; i < n; i++) {
    D->rstart[i] = acc;
    acc += D->rend[i];
  }
  for (int64_t p = 0; p < np; p++) {
    const int32_t b = D->pb[p];
    D->rlist[b >= 0 ? D->rstart[b]++ : wk++] = (int32_t)p;
  }
  memset(D->rstart, 0, sizeof(int32_t) * (size_t)n);
  memset(D->rend, 0, sizeof(int32_t) * (size_t)n);
  for (int64_t k = 0; k < np; k++) D->rkey[k] = D->pb[D->rlist[k]];
  DEM_TRY(m->ops->reverse_ranges(m));
  m->cpu_rev_valid = 1;
  return SPHDEM_OK;
}

static int c_csr(struct sphdem_dem_s *m) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np;
  memset(D->fstart, 0, sizeof(int32_t) * (size_t)n);
  memset(D->fend, 0, sizeof(int32_t) * (size_t)n);
  if (c_serial(np)) { /* one thread: the runs of one tag of a, walked in order */
    for (int64_t p = 0, s = 0; p < np; p++) {
      if ((D->key[p] >> 32) != (D->key[s] >> 32)) s = p;
      const int32_t g = D->pa[s]; /* (copies of one grain share a tag: the run goes to its first pair's copy) */
      if (s == p) D->fstart[g] = (int32_t)p;
      D->fend[g] = (int32_t)(p + 1);
    }
  } else {
    DEM_TRY(m->ops->forward_ranges(m));
  }
  /* one grain a per run of pairs (no copies of one grain sharing a tag): the one-thread pass reads a once per run */
  m->cpu_uniform = 1;
  for (int64_t p = 0; p < np && m->cpu_uniform; p++) {
    const int32_t a = D->pa[p];
    m->cpu_uniform = D->fstart[a] <= p && p < D->fend[a];
  }
  /* copies sharing a tag: each copy's run head, for the one-thread pass */
  D->head = NULL;
  if (!m->cpu_uniform) {
    if (c_room((void **)&m->cpu_head, sizeof(int32_t), n, &m->cap_head))
      return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the run heads (%lld grains)", (long long)n);
    for (int64_t p = 0, s = 0; p < np; p++) {
      if ((D->key[p] >> 32) != (D->key[s] >> 32)) s = p;
      m->cpu_head[D->pa[p]] = D->pa[s];
    }
    D->head = m->cpu_head;
  }
  /* the reverse half's lists: only when the pass that needs them runs (else when it first does) */
  m->cpu_rev_valid = 0;
  if (!sphdem_dem_cpu_serial_pass(m)) DEM_TRY(c_reverse(m));
  /* the gap of each pair now, for the forces to pass over the pairs that cannot touch yet */
  D->gap0 = NULL;
  if (c_room((void **)&m->cpu_gap, sizeof(double), np, &m->cap_gap))
    return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the pair gaps (%lld pairs)", (long long)np);
  for (int64_t p = 0; p < np; p++) m->cpu_gap[p] = dem_pair_gap(D, p);
  D->gap0 = m->cpu_gap;
  return SPHDEM_OK;
}

/* Forward pass of the particle-parallel forces with the contact law of one model inlined. */
static inline __attribute__((always_inline)) int64_t c_forward(const dem_dev *D, int64_t n, double *pfb,
                                                               unsigned char *tf, unsigned char *bt, int known,
                                                               const int model, int serial) {
  int64_t nt = 0;
  if (serial) { /* no call into the OpenMP runtime at all (it costs microseconds per region) */
    /* a local copy of the constants and array pointers: the stores of forces and history through the
     * pointers cannot alias it, so the loop keeps them in registers instead of reloading them per pair */
    const dem_dev Dl = *D;
    for (int64_t i = 0; i < n; i++) nt += dem_particle_forward_model(&Dl, i, pfb, tf, bt, known, model);
  } else {
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : nt)
    for (int64_t i = 0; i < n; i++) nt += dem_particle_forward_model(D, i, pfb, tf, bt, known, model);
  }
  return nt;
}

/* Each variant of the one-thread pass is a function of its own (one copy of the contact law each): inlined into
 * one function, the many copies make it too large for good register allocation (values kept on the stack). A local
 * copy of the constants and array pointers, which the stores of forces and history cannot alias. */
/* an AVX-512 and an AVX2 copy of each beside the baseline one, chosen at load time (gcc, x86-64): the three-operand
 * instructions need fewer register copies, and AVX-512's 32 vector registers keep the law's values out of the stack;
 * no fused multiply-adds (this file is compiled with -ffp-contract=off), so the same roundings and the same bits */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define C_SERIAL_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define C_SERIAL_CLONES
#endif
typedef int64_t (*c_serial_fn)(const dem_dev *D, unsigned char *tf, const int32_t *act, int64_t nact);
#define C_SERIAL_FN(M, U, V, A)                                                                                      \
  static __attribute__((noinline)) C_SERIAL_CLONES int64_t c_serial_##M##_##U##V##A(                                 \
      const dem_dev *D, unsigned char *tf, const int32_t *act, int64_t nact) {                                       \
    const dem_dev Dl = *D;                                                                                           \
    return dem_pairs_serial_model(&Dl, tf, A ? act : NULL, nact, SPHDEM_DEM_##M, U, V);                              \
  }
/* uniform and no virial, uniform with the virial, copies sharing a tag (with the virial); each over all pairs or
 * over a list of them */
#define C_SERIAL_MODEL(M)                                                                                            \
  C_SERIAL_FN(M, 1, 0, 0) C_SERIAL_FN(M, 1, 0, 1) C_SERIAL_FN(M, 1, 1, 0) C_SERIAL_FN(M, 1, 1, 1)                    \
  C_SERIAL_FN(M, 0, 1, 0) C_SERIAL_FN(M, 0, 1, 1)                                                                    \
  static const c_serial_fn c_serial_table_##M[6] = {c_serial_##M##_100, c_serial_##M##_101, c_serial_##M##_110,      \
                                                    c_serial_##M##_111, c_serial_##M##_010, c_serial_##M##_011};
C_SERIAL_MODEL(HOOKE)
C_SERIAL_MODEL(HERTZ)
C_SERIAL_MODEL(HERTZ_MINDLIN)
C_SERIAL_MODEL(GRANULAR)
C_SERIAL_MODEL(HERTZ_LIGGGHTS)

static int64_t c_serial_pairs(const dem_dev *D, unsigned char *tf, const int32_t *act, int64_t nact, int uniform) {
  const c_serial_fn *t;
  switch (D->P.model) {
    case SPHDEM_DEM_HOOKE: t = c_serial_table_HOOKE; break;
    case SPHDEM_DEM_HERTZ: t = c_serial_table_HERTZ; break;
    case SPHDEM_DEM_HERTZ_MINDLIN: t = c_serial_table_HERTZ_MINDLIN; break;
    case SPHDEM_DEM_GRANULAR: t = c_serial_table_GRANULAR; break;
    default: t = c_serial_table_HERTZ_LIGGGHTS; break;
  }
  const int v = !uniform ? 4 : D->want_virial ? 2 : 0;
  return t[v + (act != NULL)](D, tf, act, nact);
}

/* The largest squared move of the n grains at x since the positions xs (a loop the compiler vectorises; the
 * positions are finite: the rebuild check has seen them). */
__attribute__((optimize("finite-math-only", "no-signed-zeros"))) static double c_move2(const double *restrict x,
                                                                                       const double *restrict xs,
                                                                                       int64_t n) {
  double d2max = 0.0;
  for (int64_t i = 0; i < n; i++) {
    const double dx = x[3 * i] - xs[3 * i], dy = x[3 * i + 1] - xs[3 * i + 1], dz = x[3 * i + 2] - xs[3 * i + 2];
    const double d2 = dx * dx + dy * dy + dz * dz;
    d2max = d2 > d2max ? d2 : d2max;
  }
  return d2max;
}

/* The pairs the one-thread pass visits while the list stands (dilute scenes: most pairs of the list are
 * further apart than their grains have moved since the build, and looking at each of them every step costs a
 * load and a hard-to-predict branch). After the first pass over the whole list (which leaves every pair marked
 * in tf), the pass visits only the pairs of m->cpu_act (in increasing order), taken at some evaluation t0 as
 * those whose bound e = gap at the build - move of a since the build - move of b since the build is <= lim,
 * and those marked touching at the last evaluation. At a later evaluation the moves since the build are at most
 * those at t0 plus the largest move M since t0, and the radius growth and the change of the periodic lengths
 * add gap_rest, so a pair left out is apart while 2 M + gap_rest <= lim (and, apart at t0, is marked so in tf);
 * past that, the set is taken again. The moves of each grain, not the largest one: in a gas the fastest grain
 * moves several times as far as most. The margin lim - gap_rest weighs two costs: a pair visited in vain costs
 * about as much as a tested one (its loads of positions and radii), each taking of the set a loop over the
 * grains and one over the pairs. With the bound growing by g per evaluation (twice the fastest grain's move) and
 * the gaps spread evenly over the skin s, a margin L costs per evaluation about the pairs within L of the
 * touching ones plus the set taken every L/g evaluations: least near L = sqrt(2 (c_set / c_pair) g s), c_set /
 * c_pair about 1/4 here: L = sqrt(g s / 2), at least s/128. Returns the pairs to visit, or NULL for all of them
 * (three quarters or more of the list). */
static const int32_t *c_active(struct sphdem_dem_s *m, const unsigned char *tf, int64_t *nact) {
  const dem_dev *D = &m->D;
  const int64_t np = D->np, n = D->n;
  if (m->act_all) return NULL;
  if (m->act_n >= 0 && 2.0 * sqrt(c_move2(D->x, m->cpu_xact, n)) + m->gap_rest <= m->act_lim) {
    *nact = m->act_n;
    return m->cpu_act;
  }
  if (c_room((void **)&m->cpu_act, sizeof(int32_t), np, &m->cap_act) ||
      c_room((void **)&m->cpu_xact, sizeof(double), 4 * n, &m->cap_xact)) { /* no room: every pair (the same forces) */
    m->act_all = 1;
    return NULL;
  }
  /* the bound's growth per evaluation since the whole pass (0 at the build) */
  const double rate = (D->gap_thr - m->act_thr0) / (double)(m->act_calls > 0 ? m->act_calls : 1);
  const double margin = m->act_calls > 0 ? sqrt(0.5 * rate * D->P.skin) : 0.0625 * D->P.skin;
  const double lim = m->gap_rest + fmax(margin, fmax(0.0078125 * D->P.skin, 1e-6 * m->dmax_built));
  /* each grain's move since the build, then the positions now */
  const double *x = D->x, *x0 = m->hx0, *gap = D->gap0;
  double *xs = m->cpu_xact, *mv = xs + 3 * n;
  for (int64_t i = 0; i < n; i++) {
    const double dx = x[3 * i] - x0[3 * i], dy = x[3 * i + 1] - x0[3 * i + 1], dz = x[3 * i + 2] - x0[3 * i + 2];
    mv[i] = sqrt(dx * dx + dy * dy + dz * dz);
  }
  memcpy(xs, x, sizeof(double) * 3 * (size_t)n);
  const int32_t *pa = D->pa, *pb = D->pb;
  int32_t *act = m->cpu_act;
  int64_t k = 0;
  for (int64_t p = 0; p < np; p++) { /* (no branch: the index is written always, kept when the pair is in) */
    const int32_t b = pb[p];
    const double e = gap[p] - mv[pa[p]] - (b >= 0 ? mv[b] : 0.0);
    act[k] = (int32_t)p;
    k += (e <= lim) | (tf[p] != 0);
  }
  if (4 * k >= 3 * np) {
    m->act_all = 1;
    return NULL;
  }
  m->act_lim = lim;
  m->act_n = k;
  *nact = k;
  return act;
}

/* 1 when sphdem_dem_cpu_particle_forces will take the one-thread pass, which adds to f and tq as they are */
int sphdem_dem_cpu_serial_pass(const struct sphdem_dem_s *m) {
  return m->D.P.algo != SPHDEM_DEM_PAIR_PARALLEL && c_serial(m->D.n);
}

/* Heat conduction through the contacts: one loop over the pairs on one thread, the flows added without atomics (an
 * atomic add of a double is a compare-and-swap loop even on one thread; the pass is a small part of a step). */
int sphdem_dem_cpu_heat(struct sphdem_dem_s *m, const double *T, const double *k, const int *mb, int area, double A0,
                        double *q, double *dq) {
  const dem_dev *D = &m->D;
  for (int64_t p = 0; p < D->np; p++) {
    double Q, del[3];
    if (dem_heat_flow(D, p, T, k, mb, area, A0, &Q, del)) dem_heat_add(D, p, Q, del, q, dq, 0);
  }
  return SPHDEM_OK;
}

double sphdem_dem_heat_conductance(double rsq, double ra, double rb, double ka, double kb, int area, double area_value) {
  return dem_heat_conductance(rsq, ra, rb, ka, kb, area, area_value);
}

/* Pair-parallel forces: one thread sums without atomics, several with. */
int sphdem_dem_cpu_pair_forces(struct sphdem_dem_s *m) {
  const dem_dev *D = &m->D;
  const int64_t np = D->np;
  if (c_serial(np)) {
    for (int64_t p = 0; p < np; p++) dem_pair_force_accum(D, p, 0);
  } else {
#pragma omp parallel for schedule(static)
    for (int64_t p = 0; p < np; p++) dem_pair_force_accum(D, p, 1);
  }
  return SPHDEM_OK;
}

/* Particle-parallel forces, each pair evaluated once: forward (pairs as a, F and Tb kept per pair), then
 * reverse; the forward half counts the touching pairs into m->cpu_ntouch. */
int sphdem_dem_cpu_particle_forces(struct sphdem_dem_s *m) {
  /* the history is updated in place (each pair is evaluated once, by its grain a): no copy of the history of
   * the pairs that do not touch, and dem.c does not swap the buffers */
  dem_dev Dm = m->D;
  Dm.hout = Dm.hin;
  Dm.rout = Dm.rin;
  const dem_dev *D = &Dm;
  const int64_t n = D->n, np = D->np;
  int64_t nt = 0;
  int known = m->tf_valid; /* tf marks the pairs of this list as the last call left them */
  if (np > m->cap_pfb) {
    known = 0;
    int64_t cap = np + np / 4 + 64;
    double *b = (double *)realloc(m->cpu_pfb, sizeof(double) * 6 * (size_t)cap);
    if (b) m->cpu_pfb = b;
    unsigned char *t = b ? (unsigned char *)realloc(m->cpu_tf, (size_t)cap) : NULL;
    if (t) m->cpu_tf = t;
    if (!b || !t) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the pair force buffer (%lld pairs)", (long long)np);
    m->cap_pfb = cap;
  }
  if (n > m->cap_bt) { /* all 0 between the passes (the reverse half clears what the forward half set) */
    const int64_t cap = n + n / 4 + 64;
    unsigned char *t = (unsigned char *)calloc((size_t)cap, 1);
    if (!t) return rt_fail(&m->rt, SPHDEM_ERR_ALLOC, "cannot allocate the grain marks (%lld grains)", (long long)n);
    free(m->cpu_bt);
    m->cpu_bt = t;
    m->cap_bt = cap;
  }
  m->hist_in_place = 1;
  double *pfb = m->cpu_pfb;
  unsigned char *tf = m->cpu_tf, *bt = m->cpu_bt;
  const int serial = c_serial(n);
  if (serial && (D->gap0 || !np)) { /* one thread: each pair once in list order, b's share added at once (no reverse pass) */
    if (!known && np) memset(tf, 1, (size_t)np); /* unknown: every pair may have a history to clear */
    if (!m->cpu_adds) {
      memset(D->f, 0, sizeof(double) * 3 * (size_t)n);
      memset(D->tq, 0, sizeof(double) * 3 * (size_t)n);
    }
    const int32_t *act = NULL;
    int64_t nact = 0;
    if (!known) { /* this pass visits every pair; the visited set starts after it */
      m->act_all = 0;
      m->act_n = -1;
      m->act_thr0 = D->gap_thr;
      m->act_calls = 0;
    } else {
      m->act_calls++;
      act = c_active(m, tf, &nact);
    }
    nt = c_serial_pairs(D, tf, act, nact, m->cpu_uniform);
    m->cpu_ntouch = nt;
    m->tf_valid = 1;
    return SPHDEM_OK;
  }
  m->act_all = 1; /* (the visited set of the one-thread pass is taken again after its next whole pass) */
  if (!m->cpu_rev_valid) DEM_TRY(c_reverse(m));
  if (m->cpu_adds) /* (the pass below overwrites f and tq: dem.c asks for it only on one thread) */
    return rt_fail(&m->rt, SPHDEM_ERR_ARG, "DEM forces: the pair gaps are missing for the one-thread pass");
  switch (D->P.model) { /* each model's contact law inlined into a loop of its own */
    case SPHDEM_DEM_HOOKE: nt = c_forward(D, n, pfb, tf, bt, known, SPHDEM_DEM_HOOKE, serial); break;
    case SPHDEM_DEM_HERTZ: nt = c_forward(D, n, pfb, tf, bt, known, SPHDEM_DEM_HERTZ, serial); break;
    case SPHDEM_DEM_HERTZ_MINDLIN: nt = c_forward(D, n, pfb, tf, bt, known, SPHDEM_DEM_HERTZ_MINDLIN, serial); break;
    case SPHDEM_DEM_GRANULAR: nt = c_forward(D, n, pfb, tf, bt, known, SPHDEM_DEM_GRANULAR, serial); break;
    default: nt = c_forward(D, n, pfb, tf, bt, known, SPHDEM_DEM_HERTZ_LIGGGHTS, serial); break;
  }
  if (serial) {
    const dem_dev Dl = *D;
    for (int64_t i = 0; i < n; i++) dem_particle_reverse_body(&Dl, i, pfb, tf, bt);
  } else {
#pragma omp parallel for schedule(dynamic, 64)
    for (int64_t i = 0; i < n; i++) dem_particle_reverse_body(D, i, pfb, tf, bt);
  }
  m->cpu_ntouch = nt;
  m->tf_valid = 1;
  return SPHDEM_OK;
}

static int c_forces(struct sphdem_dem_s *m, int64_t *ntouch) {
  dem_dev *D = &m->D;
  int64_t n = D->n, np = D->np, nt = 0;
  m->hist_in_place = 0;
  if (D->P.algo == SPHDEM_DEM_PAIR_PARALLEL) {
    m->tf_valid = 0;
    memset(D->f, 0, sizeof(double) * 3 * (size_t)n);
    memset(D->tq, 0, sizeof(double) * 3 * (size_t)n);
    DEM_TRY(m->ops->pair_forces(m));
    if (c_serial(np)) {
      for (int64_t p = 0; p < np; p++) nt += dem_touching(D, p);
    } else {
#pragma omp parallel for reduction(+ : nt) schedule(static)
      for (int64_t p = 0; p < np; p++) nt += dem_touching(D, p);
    }
  } else {
    DEM_TRY(m->ops->particle_forces(m));
    nt = m->cpu_ntouch;
  }
  *ntouch = nt;
  return SPHDEM_OK;
}

const dem_ops sphdem_dem_cpu_ops = {
  .name = "cpu", .cells = c_cells, .count = c_count, .fill = c_fill, .csr = c_csr, .forces = c_forces,
  SPHDEM_DEM_PASSES(SPHDEM_DEM_PASS_CPU_ENTRY)
};
