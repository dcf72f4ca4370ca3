/* couple_cpu.c - CPU backend of the SPH-DEM coupling: the loops of its listed passes (sph_passes.h) and the
 * CPU's own versions of the three passes over fluid-grain pair lists.
 *
 * The three passes of a coupling step visit the same fluid-grain pairs (porosity: fluid -> grains, grain
 * forces: grain -> fluid, reaction: fluid -> grains). On the CPU the porosity pass walks the grain cells once
 * and records each fluid particle's grains within 2 hc (in the walk's order); the list is transposed to each
 * grain's fluid particles (ascending fluid index, the order of the grain pass's cell walk where no cell wraps
 * periodically), and the other two passes read the lists instead of walking cells. The per-pair terms are
 * the shared ones (couple_*_add / _finish), so the sums are those of the cell walks, term for term.
 * The GPU-like gather mode (SPHDEM_CPU_GATHER) walks the cells like the CUDA kernels: the twin self-test
 * (twin_cpu_selftest) compares the two. */
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

/* the cell-walk loops of the listed passes (sph_passes.h): the gather mode, and the fallback when the pair
 * lists could not be built */
SPHDEM_COUPLE_PASSES(SPHDEM_PASS_CPU_LOOP)

void sphdem_cpu_couple_lists_free(struct sphdem_ctx_s *c) {
  free(c->couple.cpl_fs); free(c->couple.cpl_gs); free(c->couple.cpl_f); free(c->couple.cpl_g);
  for (int t = 0; t < c->couple.cpl_nt; t++) free(c->couple.cpl_tb[t]);
  free(c->couple.cpl_tb); free(c->couple.cpl_tcap); free(c->couple.cpl_tn);
  c->couple.cpl_fs = c->couple.cpl_gs = NULL; c->couple.cpl_f = c->couple.cpl_g = NULL;
  c->couple.cpl_tb = NULL; c->couple.cpl_tcap = c->couple.cpl_tn = NULL;
  c->couple.cap_cplfs = c->couple.cap_cplgs = c->couple.cap_cplf = c->couple.cap_cplg = 0;
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
    if (!tn) return sphdem_fail(c, SPHDEM_ERR_ALLOC, "couple: cannot allocate the pair-list buffers");
    for (int t = c->couple.cpl_nt; t < nt; t++) { c->couple.cpl_tb[t] = NULL; c->couple.cpl_tcap[t] = 0; }
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
    int64_t n = 0;
    /* static schedule: each thread takes one contiguous block of a, in thread order */
#pragma omp for schedule(static)
    for (int64_t a = 0; a < nf; a++) {
      const double *xa = D->x + 3 * a;
      double s = 0.0;
      int64_t n0 = n;
      cell_walk w;
      int64_t cc;
      walk_grains_around(D, xa, &w);
      while (walk_next(&w, &cc))
        for (int32_t j = D->couple.gcstart[cc]; j < D->couple.gcend[cc]; j++)
          if (couple_porosity_add(D, xa, j, &s)) {
            if (!err && grow32(&c->couple.cpl_tb[t], &c->couple.cpl_tcap[t], n + 1)) err = 1;
            if (!err) c->couple.cpl_tb[t][n] = j;
            n++;
          }
      couple_porosity_finish(D, a, s);
      fs[a + 1] = n - n0;
    }
    c->couple.cpl_tn[t] = n;
  }
  if (err) return SPHDEM_OK; /* porosity is done; the other passes walk the cells (cpl_valid stays 0) */
  fs[0] = 0;
  for (int64_t a = 0; a < nf; a++) fs[a + 1] += fs[a];
  if (grow32(&c->couple.cpl_f, &c->couple.cap_cplf, fs[nf] + 1) ||
      grow32(&c->couple.cpl_g, &c->couple.cap_cplg, fs[nf] + 1))
    return SPHDEM_OK;
  int64_t off = 0;
  for (int t = 0; t < nt; t++) {
    if (c->couple.cpl_tn[t] > 0) memcpy(c->couple.cpl_f + off, c->couple.cpl_tb[t], 4 * (size_t)c->couple.cpl_tn[t]);
    off += c->couple.cpl_tn[t];
  }
  /* transpose: each grain's fluid particles in ascending fluid index */
  int64_t *gs = c->couple.cpl_gs;
  memset(gs, 0, 8 * (size_t)(ng + 1));
  for (int64_t k = 0; k < fs[nf]; k++) gs[c->couple.cpl_f[k] + 1]++;
  for (int64_t j = 0; j < ng; j++) gs[j + 1] += gs[j];
  for (int64_t a = 0; a < nf; a++)
    for (int64_t k = fs[a]; k < fs[a + 1]; k++) c->couple.cpl_g[gs[c->couple.cpl_f[k]]++] = (int32_t)a;
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
#pragma omp parallel for schedule(dynamic, 16)
  for (int64_t j = 0; j < D->couple.ng; j++) {
    if (couple_grain_ghost(D, j)) continue; /* its owner's forces arrive by the exchange */
    const double *xj = D->couple.gx + 3 * j;
    couple_grain_acc A = {0.0, 0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, 0.0};
    if (D->couple.immersion_s > 0.0) A.sigw = couple_grain_wall_sum(D, xj);
    for (int64_t k = gs[j]; k < gs[j + 1]; k++) couple_grain_add(D, xj, gl[k], &A);
    couple_grain_finish(D, j, &A);
  }
  return SPHDEM_OK;
}

int sphdem_cpu_couple_reaction(struct sphdem_ctx_s *c) {
  const sphdem_dev *D = &c->D;
  if (!c->couple.cpl_valid) return sphdem_cpu_loop_couple_reaction(c);
  const int64_t *fs = c->couple.cpl_fs;
  const int32_t *fl = c->couple.cpl_f;
#pragma omp parallel for schedule(dynamic, 64)
  for (int64_t a = 0; a < D->nf; a++) {
    const double *xa = D->x + 3 * a;
    double s[3] = {0, 0, 0};
    for (int64_t k = fs[a]; k < fs[a + 1]; k++) couple_reaction_add(D, xa, fl[k], s);
    couple_reaction_finish(D, a, s);
  }
  c->couple.cpl_valid = 0; /* one step's pairs */
  return SPHDEM_OK;
}
