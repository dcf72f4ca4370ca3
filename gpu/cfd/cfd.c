/* cfd.c - the gas-grid context of CFD-DEM: parameters, allocation, the gas step (voidage, drag, predictor,
 * preconditioned conjugate-gradient pressure solve, correction, grain forces), statistics, fields and restart
 * state; on many ranks the grid decomposed into blocks with halo exchange (or replicated). The loops are in
 * cfd_bodies.h, run by a backend. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cfd_bodies.h"

SPHDEM_RT_FAIL_FN(sphdem_cfd_fail, struct sphdem_cfd_s)

double sphdem_cfd_drag_coef(int drag, double eps, double slip, double d, double rho_g, double mu_g) {
  return cfd_drag_K(drag, eps, slip, d, rho_g, mu_g);
}

void sphdem_cfd_params_default(sphdem_cfd_params *p) {
  memset(p, 0, sizeof *p);
  for (int d = 0; d < 3; d++) {
    p->nc[d] = 1;
    p->boxhi[d] = 1.0;
  }
  p->rho_g = 1.2;
  p->mu_g = 1.8e-5;
  p->gravity[2] = -9.81;
  for (int s = 0; s < 6; s++) p->bc[s] = SPHDEM_CFD_NOSLIP;
  p->voidage = SPHDEM_CFD_VOID_CENTROID;
  p->drag = SPHDEM_CFD_DRAG_GIDASPOW;
  p->eps_min = 0.2;
  p->ddt_eps = 1;
  p->pressure_force = 1;
  p->solver = SPHDEM_CFD_SOLVER_MG;
  p->tol = 1e-10;
  p->maxiter = 2000;
  p->cfl_max = 1.0;
}

static const char *const SIDE[6] = {"xlo", "xhi", "ylo", "yhi", "zlo", "zhi"};

#define BAD(...) do { if (msg && msglen) snprintf(msg, msglen, __VA_ARGS__); return SPHDEM_ERR_ARG; } while (0)

int sphdem_cfd_params_check(const sphdem_cfd_params *p, char *msg, size_t msglen) {
  if (!p) BAD("params: NULL");
  double nc = 1.0; /* in double: three axes of up to 2^31 cells overflow int64 */
  for (int d = 0; d < 3; d++) {
    if (p->nc[d] < 1) BAD("nc[%d]: cells per axis must be >= 1 (got %d)", d, p->nc[d]);
    nc *= p->nc[d];
    if (!(p->boxhi[d] > p->boxlo[d]) || !isfinite(p->boxlo[d]) || !isfinite(p->boxhi[d]))
      BAD("box: axis %d needs finite hi > lo (got %g, %g)", d, p->boxlo[d], p->boxhi[d]);
    if (!isfinite(p->gravity[d])) BAD("gravity: component %d is not finite", d);
  }
  if (nc > (double)SPHDEM_CFD_MAX_CELLS)
    BAD("nc: %d x %d x %d = %.0f cells exceed the limit of %lld cells", p->nc[0], p->nc[1], p->nc[2], nc,
        SPHDEM_CFD_MAX_CELLS);
  if (!(p->rho_g > 0.0) || !isfinite(p->rho_g)) BAD("rho: gas density must be > 0 (got %g)", p->rho_g);
  if (!(p->mu_g > 0.0) || !isfinite(p->mu_g)) BAD("mu: gas viscosity must be > 0 (got %g)", p->mu_g);
  int nout = 0;
  for (int s = 0; s < 6; s++) {
    if (p->bc[s] < SPHDEM_CFD_NOSLIP || p->bc[s] > SPHDEM_CFD_OUTLET)
      BAD("bc %s: %d is not a boundary type (noslip, slip, inlet, outlet)", SIDE[s], p->bc[s]);
    if (p->bc[s] == SPHDEM_CFD_OUTLET) nout++;
    if (!isfinite(p->inlet_u[s])) BAD("bc %s: inlet velocity is not finite", SIDE[s]);
  }
  if (nout == 0)
    BAD("bc: at least one side must be a pressure outlet (bc SIDE outlet): a closed box has no pressure level");
  if (p->npatch < 0 || p->npatch > SPHDEM_CFD_MAX_PATCH)
    BAD("patch: %d patches, allowed 0 to %d", p->npatch, SPHDEM_CFD_MAX_PATCH);
  for (int q = 0; q < p->npatch; q++) {
    const sphdem_cfd_patch *pt = &p->patch[q];
    if (pt->side < 0 || pt->side > 5) BAD("patch %d: side %d is not 0-5 (xlo xhi ylo yhi zlo zhi)", q + 1, pt->side);
    if (p->bc[pt->side] != SPHDEM_CFD_INLET)
      BAD("patch %d: side %s is not an inlet (give bc %s inlet U first)", q + 1, SIDE[pt->side], SIDE[pt->side]);
    if (!(pt->hi[0] > pt->lo[0]) || !(pt->hi[1] > pt->lo[1]))
      BAD("patch %d: the rectangle needs hi > lo on both axes", q + 1);
    if (!isfinite(pt->u)) BAD("patch %d: velocity is not finite", q + 1);
  }
  if (p->voidage != SPHDEM_CFD_VOID_CENTROID && p->voidage != SPHDEM_CFD_VOID_SMOOTH)
    BAD("voidage: %d is not centroid (0) or smooth (1)", p->voidage);
  if (p->drag < SPHDEM_CFD_DRAG_GIDASPOW || p->drag > SPHDEM_CFD_DRAG_NONE)
    BAD("drag: %d is not gidaspow (0), wenyu (1) or none (2)", p->drag);
  if (!(p->eps_min > 0.0 && p->eps_min < 1.0)) BAD("eps_min: must be in (0, 1) (got %g)", p->eps_min);
  if (p->ddt_eps != 0 && p->ddt_eps != 1) BAD("ddt_eps: must be 0 or 1");
  if (p->pressure_force != 0 && p->pressure_force != 1) BAD("pressure_force: must be 0 or 1");
  if (p->solver != SPHDEM_CFD_SOLVER_MG && p->solver != SPHDEM_CFD_SOLVER_LINE)
    BAD("solver: %d is not mg (0) or line (1)", p->solver);
  if (!(p->tol > 0.0 && p->tol < 1.0)) BAD("tol: relative residual must be in (0, 1) (got %g)", p->tol);
  if (p->maxiter < 1) BAD("maxiter: must be >= 1 (got %d)", p->maxiter);
  if (!(p->cfl_max > 0.0)) BAD("cfl: must be > 0 (got %g)", p->cfl_max);
  return SPHDEM_OK;
}

/* The local grid of the owned global cells [slo, shi) per axis (the whole grid: 0, nc), with a halo of CFD_HALO
 * cells on each side where the grid goes on (another rank's cells), and the preconditioner's levels over the
 * owned block. */
static void derive(cfd_dev *D, const sphdem_cfd_params *p, const int *slo, const int *shi) {
  D->P = *p;
  D->Vc = 1.0;
  D->split = 0;
  for (int d = 0; d < 3; d++) {
    int hl = slo[d] > 0 ? CFD_HALO : 0, hh = shi[d] < p->nc[d] ? CFD_HALO : 0;
    D->gnc[d] = p->nc[d];
    D->own[d] = shi[d] - slo[d];
    D->hlo[d] = hl;
    D->nc[d] = D->own[d] + hl + hh;
    D->g0[d] = slo[d] - hl;
    D->h[d] = (p->boxhi[d] - p->boxlo[d]) / p->nc[d];
    D->lo[d] = D->g0[d] ? p->boxlo[d] + D->g0[d] * D->h[d] : p->boxlo[d];
    D->inv_h[d] = 1.0 / D->h[d];
    D->Vc *= D->h[d];
    if (hl || hh) D->split = 1;
  }
  D->gncell = (int64_t)p->nc[0] * p->nc[1] * p->nc[2];
  cfd_level *G = &D->G;
  for (int d = 0; d < 3; d++) {
    G->nc[d] = D->nc[d];
    G->cf[d] = 1;
  }
  G->ncell = (int64_t)G->nc[0] * G->nc[1] * G->nc[2];
  G->foff[0] = 0;
  G->foff[1] = ((int64_t)G->nc[0] + 1) * G->nc[1] * G->nc[2];
  G->foff[2] = G->foff[1] + (int64_t)G->nc[0] * ((int64_t)G->nc[1] + 1) * G->nc[2];
  G->foff[3] = G->foff[2] + (int64_t)G->nc[0] * G->nc[1] * ((int64_t)G->nc[2] + 1);
  D->ncell = G->ncell;
  D->nface = G->foff[3];
  D->lax = 2;
  if (p->nc[0] > p->nc[D->lax]) D->lax = 0;
  if (p->nc[1] > p->nc[D->lax]) D->lax = 1;
  /* multigrid levels over the owned block: halve every axis that has more than one cell, down to a few dozen
   * cells */
  D->omega = 0.8;
  D->nlev = 1;
  for (int d = 0; d < 3; d++) {
    D->L[0].nc[d] = D->own[d];
    D->L[0].cf[d] = 1;
  }
  for (;;) {
    cfd_level *F = &D->L[D->nlev - 1];
    F->ncell = (int64_t)F->nc[0] * F->nc[1] * F->nc[2];
    F->foff[0] = 0;
    F->foff[1] = ((int64_t)F->nc[0] + 1) * F->nc[1] * F->nc[2];
    F->foff[2] = F->foff[1] + (int64_t)F->nc[0] * ((int64_t)F->nc[1] + 1) * F->nc[2];
    F->foff[3] = F->foff[2] + (int64_t)F->nc[0] * F->nc[1] * ((int64_t)F->nc[2] + 1);
    if (F->ncell <= 32 || D->nlev == SPHDEM_CFD_MAX_LEVELS) break;
    if (F->nc[0] == 1 && F->nc[1] == 1 && F->nc[2] == 1) break;
    cfd_level *C = &D->L[D->nlev++];
    for (int d = 0; d < 3; d++) {
      C->cf[d] = F->nc[d] > 1 ? 2 : 1;
      C->nc[d] = (F->nc[d] + C->cf[d] - 1) / C->cf[d];
    }
  }
  D->nlines = D->L[0].ncell / D->L[0].nc[D->lax];
}

#define CELL_ARRAYS(X) X(sol) X(eps) X(eps_old) X(p) X(b) X(r) X(z) X(d) X(Ad) X(diag) X(lcp)
#define FACE_ARRAYS(X) X(u) X(us) X(cf) X(af) X(K) X(Kv)
#define GRAIN3_ARRAYS(X) X(gfd) X(gfp) X(gfb)
#define GRAIN1_ARRAYS(X) X(gK)

/* n zeroed doubles on the device */
static int dalloc(struct sphdem_cfd_s *m, double **ptr, int64_t n) {
  void *q = NULL;
  int rc = rt_alloc(&m->rt, &q, sizeof(double) * (size_t)n);
  if (rc) return rc;
  *ptr = (double *)q;
  return rt_zero(&m->rt, q, sizeof(double) * (size_t)(n > 0 ? n : 1));
}

static void free_grains(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
#define F3_(a) rt_free(&m->rt, (void **)&D->a, 3 * sizeof(double) * (size_t)m->cap_n);
#define F1_(a) rt_free(&m->rt, (void **)&D->a, sizeof(double) * (size_t)m->cap_n);
  GRAIN3_ARRAYS(F3_)
  GRAIN1_ARRAYS(F1_)
#undef F3_
#undef F1_
  m->cap_n = 0;
}

static int step_store(struct sphdem_cfd_s *m, double dt, struct sphdem_grains_s *g, int n, const int32_t *idx,
                      int bad_input, double *fdrag, double *fpg);

/* the copies of the grains an index list picks */
static void free_selection(struct sphdem_cfd_s *m) {
  rt_free(&m->rt, (void **)&m->sel_x, 3 * sizeof(double) * (size_t)m->cap_sel);
  rt_free(&m->rt, (void **)&m->sel_v, 3 * sizeof(double) * (size_t)m->cap_sel);
  rt_free(&m->rt, (void **)&m->sel_rad, sizeof(double) * (size_t)m->cap_sel);
  sphdem_idx_free(&m->rt, &m->sel_idx);
  m->cap_sel = 0;
}

/* D->gx, gv, grad for the grains of the view (store g, n, idx) */
static int bind_grains(struct sphdem_cfd_s *m, struct sphdem_grains_s *g, int64_t n, const int32_t *idx) {
  cfd_dev *D = &m->D;
  int rc = sphdem_grains_device(g, &m->rt);
  if (rc || !idx) {
    D->gx = g->dx, D->gv = g->dv, D->grad = g->drad;
    return rc;
  }
  if (n > m->cap_sel) {
    const int64_t cap = n + n / 4 + 16;
    rt_free(&m->rt, (void **)&m->sel_x, 3 * sizeof(double) * (size_t)m->cap_sel);
    rt_free(&m->rt, (void **)&m->sel_v, 3 * sizeof(double) * (size_t)m->cap_sel);
    rt_free(&m->rt, (void **)&m->sel_rad, sizeof(double) * (size_t)m->cap_sel);
    m->cap_sel = 0;
    if ((rc = dalloc(m, &m->sel_x, 3 * cap)) || (rc = dalloc(m, &m->sel_v, 3 * cap)) ||
        (rc = dalloc(m, &m->sel_rad, cap)))
      return rc;
    m->cap_sel = cap;
  }
  const int32_t *id = NULL;
  if ((rc = sphdem_idx_upload(&m->rt, &m->sel_idx, idx, n, &id)) ||
      (rc = sphdem_grains_copy(&m->rt, m->sel_x, g->dx, id, n, 3)) ||
      (rc = sphdem_grains_copy(&m->rt, m->sel_v, g->dv, id, n, 3)) ||
      (rc = sphdem_grains_copy(&m->rt, m->sel_rad, g->drad, id, n, 1)))
    return rc;
  D->gx = m->sel_x, D->gv = m->sel_v, D->grad = m->sel_rad;
  return SPHDEM_OK;
}

static int grow_grains(struct sphdem_cfd_s *m, int64_t n) {
  if (n <= m->cap_n) return SPHDEM_OK;
  int64_t cap = n + n / 4 + 16;
  if (m->cap_n) free_grains(m);
  cfd_dev *D = &m->D;
  int rc;
#define A3_(a) if ((rc = dalloc(m, &D->a, 3 * cap))) return rc;
#define A1_(a) if ((rc = dalloc(m, &D->a, cap))) return rc;
  GRAIN3_ARRAYS(A3_)
  GRAIN1_ARRAYS(A1_)
#undef A3_
#undef A1_
  m->cap_n = cap;
  return SPHDEM_OK;
}

/* ---- many ranks ------------------------------------------------------------------------------------
 * Decomposed (sphdem_cfd_set_subdomain; what the engine shims use): each rank holds its block of cells and a
 * halo, deposits its own grains, sends the halo deposits to their owners and takes the owners' sums back, and
 * the pressure solve's dot products are summed over the ranks (halo_pass, dreduce below).
 * Replicated (no subdomain set): every rank holds all cells and faces and deposits its own grains only. The
 * deposits (solid volume per cell; drag sums K, Kv per face) are added over the ranks, after which every
 * rank advances the same gas equations from the same inputs, so the fields stay identical without halo
 * exchange. Either way a failure seen on some ranks before or between the deposits is agreed on by every
 * rank, so none waits in a reduction the others left: every rank then returns the code and message of the
 * lowest failing rank. */

/* buf[0..n) combined over the ranks, in slices whose count fits the callback's int */
static int comm_reduce(struct sphdem_cfd_s *m, double *buf, int64_t n, int op) {
  const int64_t slice = (int64_t)1 << 28;
  for (int64_t o = 0; o < n; o += slice) {
    int64_t k = n - o < slice ? n - o : slice;
    int rc = sphdem_rt_allreduce(&m->rt, buf + o, (int)k, op);
    if (rc) return rc;
  }
  return SPHDEM_OK;
}

/* Collective, on the failure path only: the code and message of the lowest rank with bad_rc != 0 become
 * every rank's. Returns that code. */
static int comm_agree(struct sphdem_cfd_s *m, int bad_rc) {
  const int nr = rt_nranks(&m->rt), me = m->rt.comm.rank;
  enum { NMSG = (int)sizeof m->rt.err };
  double who = bad_rc ? (double)me : (double)nr;
  if (comm_reduce(m, &who, 1, SPHDEM_RED_MIN)) return SPHDEM_ERR_STATE;
  const int first = (int)who;
  if (first >= nr) return SPHDEM_OK;
  double *b = (double *)calloc(NMSG + 1, sizeof(double));
  if (!b) return sphdem_cfd_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate the failure message of rank %d", first);
  if (me == first) {
    b[0] = bad_rc;
    for (int k = 0; k < NMSG - 1 && m->rt.err[k]; k++) b[1 + k] = (unsigned char)m->rt.err[k];
  }
  int rc = comm_reduce(m, b, NMSG + 1, SPHDEM_RED_SUM);
  if (rc) {
    free(b);
    return rc;
  }
  char text[NMSG];
  int k = 0;
  for (; k < NMSG - 1 && b[1 + k] > 0.0; k++) text[k] = (char)(int)b[1 + k];
  text[k] = 0;
  int code = (int)b[0];
  free(b);
  if (me == first) return code; /* its own message stays */
  return sphdem_cfd_fail(m, code ? code : SPHDEM_ERR_STATE, "rank %d: %s", first, text);
}

/* The deposits of every rank added together: a[0..na) and b[0..nb) (device arrays, b may be NULL), copied to
 * the host, combined with one reduction, copied back. bad_rc != 0: this rank failed before (its arrays are not
 * read); the flag travels with the sums and every rank then returns the failure (comm_agree). One rank: nothing
 * to do. */
static int deposit_sum(struct sphdem_cfd_s *m, double *a, int64_t na, double *b, int64_t nb, int bad_rc) {
  if (rt_nranks(&m->rt) == 1) return bad_rc;
  int64_t n = na + nb;
  if (!m->hred || m->nhred < n + 1)
    return comm_agree(m, bad_rc ? bad_rc : sphdem_cfd_fail(m, SPHDEM_ERR_STATE, "internal: no reduction buffer"));
  double *h = m->hred;
  int rc = bad_rc;
  if (!rc) rc = rt_d2h(&m->rt, h, a, sizeof(double) * (size_t)na);
  if (!rc && nb) rc = rt_d2h(&m->rt, h + na, b, sizeof(double) * (size_t)nb);
  if (rc) memset(h, 0, sizeof(double) * (size_t)n);
  h[n] = rc ? 1.0 : 0.0;
  int rr = comm_reduce(m, h, n + 1, SPHDEM_RED_SUM);
  if (rr) return rr;
  if (h[n] > 0.0) return comm_agree(m, rc);
  if ((rc = rt_h2d(&m->rt, a, h, sizeof(double) * (size_t)na))) return rc;
  if (nb && (rc = rt_h2d(&m->rt, b, h + na, sizeof(double) * (size_t)nb))) return rc;
  return SPHDEM_OK;
}

/* ---- decomposed grid: halo exchange with the face neighbours ------------------------------------------
 * An item is a cell array (kind -1) or the faces of one axis of a face array (kind 0-2, base at that axis'
 * first face); faces of axis d are laid out as cells with one more layer along d, face i the low face of cell
 * i. Per axis (forward 0, 1, 2; reverse 2, 1, 0) two messages: the layers next to each neighbour. Along the
 * other axes a message spans the whole local range for the axes exchanged before it (forward) and the owned
 * range for the others, so edge and corner halo cells arrive in two or three hops. Forward: the owners' values
 * replace the halo copies. Reverse: the halo values (deposits of this rank's grains) are sent, added into the
 * owners' cells and zeroed here. */
typedef struct {
  double *a;
  int kind;
} cfd_item;

static int alloc_grid(struct sphdem_cfd_s *m);
static void free_grid(struct sphdem_cfd_s *m);
static int gc_alloc(struct sphdem_cfd_s *m);

/* local index range [r0, r1) of item kind along axis e in a message along axis d */
static void xrange(const cfd_dev *D, int kind, int e, int d, int *r0, int *r1) {
  const int n = D->nc[e] + (kind == e), hh = D->nc[e] - D->hlo[e] - D->own[e];
  if (e < d) { *r0 = 0; *r1 = n; }
  else { *r0 = D->hlo[e]; *r1 = n - hh; }
}

/* The cells of the layers [l0, l0 + nl) along d of an item of kind kind, as offsets within the item in message
 * order (z, y, x), into out (NULL: the count only). */
static int64_t layer_cells(const cfd_dev *D, int kind, int d, int l0, int nl, int32_t *out) {
  int r0[3], r1[3], n[3];
  for (int e = 0; e < 3; e++) {
    n[e] = D->nc[e] + (kind == e);
    if (e == d) { r0[e] = l0; r1[e] = l0 + nl; }
    else xrange(D, kind, e, d, &r0[e], &r1[e]);
  }
  int64_t k = 0;
  for (int z = r0[2]; z < r1[2]; z++)
    for (int y = r0[1]; y < r1[1]; y++)
      for (int x = r0[0]; x < r1[0]; x++, k++)
        if (out) out[k] = (int32_t)(x + (int64_t)n[0] * (y + (int64_t)n[1] * z));
  return k;
}

/* The first layer sent (recv 0) or received (recv 1) along d towards / from the neighbour at dir. */
static int halo_layer0(const cfd_dev *D, int d, int dir, int H, int reverse, int recv) {
  const int hl = D->hlo[d], top = D->hlo[d] + D->own[d];
  if (!reverse) return recv ? (dir > 0 ? hl - H : top) : (dir > 0 ? top - H : hl);
  return recv ? (dir > 0 ? hl : top - H) : (dir > 0 ? top : 0);
}

/* The device index list of one message part (made on first use for this layout). */
static int halo_list(struct sphdem_cfd_s *m, int kind, int d, int dir, int H, int reverse, int recv,
                     struct cfd_halo_list **out) {
  struct cfd_halo_list *L = &m->hl[kind + 1][d][dir > 0][H == CFD_HALO][reverse][recv];
  *out = L;
  if (L->made) return SPHDEM_OK;
  const int l0 = halo_layer0(&m->D, d, dir, H, reverse, recv);
  const int64_t n = layer_cells(&m->D, kind, d, l0, H, NULL);
  int32_t *h = (int32_t *)malloc(sizeof(int32_t) * (size_t)(n > 0 ? n : 1));
  if (!h) return sphdem_cfd_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate a halo index list of %lld cells", (long long)n);
  layer_cells(&m->D, kind, d, l0, H, h);
  int rc = rt_alloc(&m->rt, (void **)&L->idx, sizeof(int32_t) * (size_t)(n > 0 ? n : 1));
  if (!rc) rc = rt_h2d(&m->rt, L->idx, h, sizeof(int32_t) * (size_t)n);
  free(h);
  if (rc) return rc;
  L->n = n;
  L->made = 1;
  return SPHDEM_OK;
}

static void free_halo_lists(struct sphdem_cfd_s *m) {
  struct cfd_halo_list *L = &m->hl[0][0][0][0][0][0];
  const size_t nl = sizeof m->hl / sizeof m->hl[0][0][0][0][0][0];
  for (size_t k = 0; k < nl; k++) {
    rt_free(&m->rt, (void **)&L[k].idx, sizeof(int32_t) * (size_t)(L[k].n > 0 ? L[k].n : 1));
    L[k].n = 0, L[k].made = 0;
  }
  rt_free(&m->rt, (void **)&m->hstage, sizeof(double) * (size_t)m->nhstage);
  rt_free(&m->rt, (void **)&m->hzero, sizeof(double) * (size_t)m->nhzero);
  m->nhstage = m->nhzero = 0;
}

/* The halo exchange of the items: per axis and direction the layers are gathered from the device arrays into one
 * message (only they cross to the host on a GPU), sent, and the received layers scattered into the arrays
 * (forward: assigned; reverse: added, the sent deposits zeroed). The CPU backend runs the same gathers and
 * scatters on host memory. */
static int halo_pass(struct sphdem_cfd_s *m, int ni, const cfd_item *items, int reverse, int layers) {
  cfd_dev *D = &m->D;
  if (!m->decomp || !D->split) return SPHDEM_OK;
  if (!m->rt.comm.exchange)
    return sphdem_cfd_fail(m, SPHDEM_ERR_STATE, "decomposed gas grid without a halo-exchange callback");
  int rc = SPHDEM_OK;
  /* the largest message: CFD_HALO layers along any axis; the largest part of one */
  int64_t big = 0, part = 0;
  for (int d = 0; d < 3; d++) {
    int64_t sz = 0;
    for (int it = 0; it < ni; it++) {
      const int64_t t = layer_cells(D, items[it].kind, d, 0, CFD_HALO, NULL);
      sz += t;
      if (t > part) part = t;
    }
    if (sz > big) big = sz;
  }
  if (m->nhx < big) {
    free(m->hsend);
    free(m->hrecv);
    m->hsend = (double *)malloc(sizeof(double) * (size_t)big);
    m->hrecv = (double *)malloc(sizeof(double) * (size_t)big);
    m->nhx = m->hsend && m->hrecv ? big : 0;
    if (!m->nhx) return sphdem_cfd_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate the halo buffers");
  }
  if (m->nhstage < big) {
    rt_free(&m->rt, (void **)&m->hstage, sizeof(double) * (size_t)m->nhstage);
    m->nhstage = 0;
    if ((rc = rt_alloc(&m->rt, (void **)&m->hstage, sizeof(double) * (size_t)big))) return rc;
    m->nhstage = big;
  }
  if (reverse && m->nhzero < part) {
    rt_free(&m->rt, (void **)&m->hzero, sizeof(double) * (size_t)m->nhzero);
    m->nhzero = 0;
    if ((rc = rt_alloc(&m->rt, (void **)&m->hzero, sizeof(double) * (size_t)part)) ||
        (rc = rt_zero(&m->rt, m->hzero, sizeof(double) * (size_t)part)))
      return rc;
    m->nhzero = part;
  }
  for (int s = 0; s < 3 && !rc; s++) {
    const int d = reverse ? 2 - s : s;
    const int H = layers, hl = D->hlo[d], top = D->hlo[d] + D->own[d], hh = D->nc[d] - top;
    for (int dir = 1; dir >= -1 && !rc; dir -= 2) {
      /* the layers sent to the neighbour at dir and those received from the one opposite */
      const int snd = dir > 0 ? hh > 0 : hl > 0, rcv = dir > 0 ? hl > 0 : hh > 0;
      struct cfd_halo_list *L;
      int64_t ns = 0, nr = 0;
      for (int it = 0; snd && it < ni && !rc; it++)
        if (!(rc = halo_list(m, items[it].kind, d, dir, H, reverse, 0, &L))) {
          rc = rt_gather(&m->rt, m->hstage + ns, items[it].a, L->idx, L->n, 1);
          ns += L->n;
        }
      if (!rc && snd) rc = rt_d2h(&m->rt, m->hsend, m->hstage, sizeof(double) * (size_t)ns);
      /* the deposits sent are the owner's now: zeros over the sent layers */
      for (int it = 0; reverse && snd && it < ni && !rc; it++)
        if (!(rc = halo_list(m, items[it].kind, d, dir, H, reverse, 0, &L)))
          rc = rt_scatter(&m->rt, items[it].a, m->hzero, L->idx, L->n, 1);
      for (int it = 0; rcv && it < ni && !rc; it++)
        if (!(rc = halo_list(m, items[it].kind, d, dir, H, reverse, 1, &L))) nr += L->n;
      if (rc) break;
      if (m->rt.comm.exchange(m->rt.comm.user, d, dir, m->hsend, (int)ns, m->hrecv, (int)nr) != 0) {
        rc = sphdem_cfd_fail(m, SPHDEM_ERR_STATE, "the halo exchange along axis %d with the neighbour rank failed", d);
        break;
      }
      if (rcv) rc = rt_h2d(&m->rt, m->hstage, m->hrecv, sizeof(double) * (size_t)nr);
      int64_t off = 0;
      for (int it = 0; rcv && it < ni && !rc; it++)
        if (!(rc = halo_list(m, items[it].kind, d, dir, H, reverse, 1, &L))) {
          rc = reverse ? rt_scatter_add(&m->rt, items[it].a, m->hstage + off, L->idx, L->n, 1)
                       : rt_scatter(&m->rt, items[it].a, m->hstage + off, L->idx, L->n, 1);
          off += L->n;
        }
      m->xbytes += 8.0 * (double)ns;
    }
  }
  m->xcalls++;
  return rc;
}

/* the faces of a face array as three items */
static int face_items(const cfd_dev *D, double *a, cfd_item *out) {
  for (int d = 0; d < 3; d++) {
    out[d].a = a + D->G.foff[d];
    out[d].kind = d;
  }
  return 3;
}

/* layers: CFD_HALO, or 1 for an operand of the matrix (its 7-point stencil reaches one cell) */
static int halo_cells(struct sphdem_cfd_s *m, double *a, int reverse, int layers) {
  cfd_item it = {a, -1};
  return halo_pass(m, 1, &it, reverse, layers);
}

static int halo_faces(struct sphdem_cfd_s *m, double *a, double *b, int reverse) {
  cfd_item it[6];
  int n = face_items(&m->D, a, it);
  if (b) n += face_items(&m->D, b, it + n);
  return halo_pass(m, n, it, reverse, CFD_HALO);
}

/* sums (op SPHDEM_RED_SUM) or maxima over the ranks of a decomposed grid; nothing to do otherwise */
static int dreduce(struct sphdem_cfd_s *m, double *v, int n, int op) {
  if (!m->decomp || rt_nranks(&m->rt) == 1) return SPHDEM_OK;
  return comm_reduce(m, v, n, op);
}

int sphdem_cfd_set_subdomain(sphdem_cfd c, const int lo[3], const int hi[3]) {
  if (!c || !lo || !hi) return SPHDEM_ERR_ARG;
  cfd_dev *D = &c->D;
  static const char AX[3] = {'x', 'y', 'z'};
  for (int d = 0; d < 3; d++) {
    if (lo[d] < 0 || hi[d] > D->gnc[d] || hi[d] <= lo[d])
      return sphdem_cfd_fail(c, SPHDEM_ERR_ARG,
                             "subdomain: gas cells [%d, %d) along %c are not a part of the grid's %d cells (each rank "
                             "needs at least one cell centre in its subdomain along every axis: fewer ranks along %c, "
                             "more cells, or a gas box that spans the subdomains)",
                             lo[d], hi[d], AX[d], D->gnc[d], AX[d]);
    if ((lo[d] > 0 || hi[d] < D->gnc[d]) && hi[d] - lo[d] < CFD_HALO)
      return sphdem_cfd_fail(c, SPHDEM_ERR_ARG,
                             "subdomain: %d gas cell(s) along %c (cells %d to %d of %d) is thinner than the gas "
                             "stencil, which needs %d cells per subdomain along a cut axis: fewer ranks along %c, "
                             "or more cells",
                             hi[d] - lo[d], AX[d], lo[d], hi[d] - 1, D->gnc[d], CFD_HALO, AX[d]);
  }
  free_grid(c);
  derive(D, &D->P, lo, hi);
  c->decomp = 1;
  for (int d = 0; d < 3; d++) {
    c->slo[d] = lo[d];
    c->shi[d] = hi[d];
  }
  int rc = alloc_grid(c);
  if (!rc && D->split) rc = gc_alloc(c);
  if (rc) return rc;
  free(c->hred);
  c->hred = NULL;
  c->nhred = 0;
  return SPHDEM_OK;
}

int64_t sphdem_cfd_local_cells(sphdem_cfd c) { return c ? c->D.ncell : 0; }

void sphdem_cfd_halo_traffic(sphdem_cfd c, double *bytes, long *calls) {
  if (bytes) *bytes = c ? c->xbytes : 0.0;
  if (calls) *calls = c ? c->xcalls : 0;
}

/* the cell and face arrays of the local grid and the preconditioner's levels; the gas at rest, all void */
static int alloc_grid(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  int rc = SPHDEM_OK;
#define AC_(a) if (!rc) rc = dalloc(m, &D->a, D->ncell);
#define AF_(a) if (!rc) rc = dalloc(m, &D->a, D->nface);
  CELL_ARRAYS(AC_)
  FACE_ARRAYS(AF_)
#undef AC_
#undef AF_
  if (rc) return rc;
  D->G.af = D->af;
  D->G.diag = D->diag;
  D->G.r = D->r;
  D->G.x = D->z;
  D->G.t = D->lcp;
  if (!D->split) D->L[0] = D->G; /* level 0 is the grid itself */
  for (int l = D->split ? 0 : 1; l < D->nlev && !rc; l++) {
    cfd_level *L = &D->L[l];
    rc = dalloc(m, &L->af, L->foff[3]);
    if (!rc) rc = dalloc(m, &L->diag, L->ncell);
    if (!rc) rc = dalloc(m, &L->r, L->ncell);
    if (!rc) rc = dalloc(m, &L->x, L->ncell);
    if (!rc) rc = dalloc(m, &L->t, L->ncell);
  }
  if (rc) return rc;
  double *one = (double *)malloc(sizeof(double) * (size_t)D->ncell);
  if (!one) return sphdem_cfd_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate %lld host doubles", (long long)D->ncell);
  for (int64_t i = 0; i < D->ncell; i++) one[i] = 1.0;
  rc = rt_h2d(&m->rt, D->eps, one, sizeof(double) * (size_t)D->ncell);
  if (!rc) rc = rt_h2d(&m->rt, D->eps_old, one, sizeof(double) * (size_t)D->ncell);
  free(one);
  D->first = 1;
  return rc;
}

/* (with their sizes, so that the device bytes held stay right when a subdomain replaces the whole grid) */
static void free_grid(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  free_halo_lists(m); /* they follow the local layout */
#define FC_(a) rt_free(&m->rt, (void **)&D->a, sizeof(double) * (size_t)D->ncell);
#define FF_(a) rt_free(&m->rt, (void **)&D->a, sizeof(double) * (size_t)D->nface);
  CELL_ARRAYS(FC_)
  FACE_ARRAYS(FF_)
#undef FC_
#undef FF_
  for (int l = D->split ? 0 : 1; l < D->nlev; l++) {
    cfd_level *L = &D->L[l];
    rt_free(&m->rt, (void **)&L->af, sizeof(double) * (size_t)L->foff[3]);
    void **lv[] = {(void **)&L->diag, (void **)&L->r, (void **)&L->x, (void **)&L->t};
    for (int k = 0; k < 4; k++) rt_free(&m->rt, lv[k], sizeof(double) * (size_t)L->ncell);
  }
  memset(D->L, 0, sizeof D->L);
}

int sphdem_cfd_create(sphdem_cfd *out, const sphdem_cfd_params *p, sphdem_device dev, char *msg, size_t msglen) {
  if (!out) BAD("out: NULL");
  *out = NULL;
  int rc = sphdem_cfd_params_check(p, msg, msglen);
  if (rc) return rc;
  struct sphdem_cfd_s *m = (struct sphdem_cfd_s *)calloc(1, sizeof *m);
  if (!m) BAD("cannot allocate the gas-grid context");
  const cfd_ops *ops = &sphdem_cfd_cpu_ops;
  m->backend = SPHDEM_DEVICE_CPU;
  sphdem_rt_init(&m->rt, SPHDEM_DEVICE_CPU);
  if (dev == SPHDEM_DEVICE_GPU || dev == SPHDEM_DEVICE_AUTO) {
#ifdef SPHDEM_WITH_CUDA
    if (sphdem_gpu_available()) {
      ops = &sphdem_cfd_cuda_ops;
      m->backend = SPHDEM_DEVICE_GPU;
      sphdem_rt_init(&m->rt, SPHDEM_DEVICE_GPU);
    }
#endif
    if (dev == SPHDEM_DEVICE_GPU && m->backend != SPHDEM_DEVICE_GPU) {
      free(m);
      if (msg && msglen)
        snprintf(msg, msglen, "device gpu: no usable GPU (CUDA backend %s)",
#ifdef SPHDEM_WITH_CUDA
                 "built, but no device found"
#else
                 "not built"
#endif
        );
      return SPHDEM_ERR_NO_GPU;
    }
  }
  m->ops = ops;
  const int zero[3] = {0, 0, 0};
  derive(&m->D, p, zero, p->nc);
  rc = alloc_grid(m);
  if (rc) {
    if (msg && msglen) snprintf(msg, msglen, "%s", m->rt.err);
    sphdem_cfd_destroy(&m);
    return rc;
  }
  cfd_dev *D = &m->D;
  m->st.eps_min = m->st.eps_mean = 1.0;
  m->st.flow_axis = cfd_flow_axis(D);
  *out = m;
  return SPHDEM_OK;
}

int sphdem_cfd_destroy(sphdem_cfd *c) {
  if (!c || !*c) return SPHDEM_OK;
  struct sphdem_cfd_s *m = *c;
  cfd_dev *D = &m->D;
  free_grid(m);
#define F_(a) rt_free(&m->rt, (void **)&D->a, 0);
  GRAIN3_ARRAYS(F_)
  GRAIN1_ARRAYS(F_)
#undef F_
  free_selection(m);
  sphdem_grains_destroy(&m->gstore);
  if (m->ops->release) m->ops->release(m);
  free(m->hred);
  free(m->hsend);
  free(m->hrecv);
  free(m->gc_L);
  free(m->gc_v);
  free(m->gc_w);
  free(m->gc_host);
  free(m);
  *c = NULL;
  return SPHDEM_OK;
}

const char *sphdem_cfd_last_error(sphdem_cfd c) { return c ? c->rt.err : "no gas-grid context"; }
int sphdem_cfd_backend(sphdem_cfd c) { return c ? c->backend : SPHDEM_DEVICE_CPU; }
size_t sphdem_cfd_device_bytes(sphdem_cfd c) { return c ? c->rt.bytes : 0; }

int sphdem_cfd_set_params(sphdem_cfd c, const sphdem_cfd_params *p) {
  if (!c) return SPHDEM_ERR_ARG;
  int rc = sphdem_cfd_params_check(p, c->rt.err, sizeof c->rt.err);
  if (rc) return rc;
  for (int d = 0; d < 3; d++)
    if (p->nc[d] != c->D.P.nc[d] || p->boxlo[d] != c->D.P.boxlo[d] || p->boxhi[d] != c->D.P.boxhi[d])
      return sphdem_cfd_fail(c, SPHDEM_ERR_ARG, "nc, box: the grid cannot change after creation");
  c->D.P = *p;
  c->st.flow_axis = cfd_flow_axis(&c->D);
  return SPHDEM_OK;
}

int sphdem_cfd_get_params(sphdem_cfd c, sphdem_cfd_params *p) {
  if (!c || !p) return SPHDEM_ERR_ARG;
  *p = c->D.P;
  return SPHDEM_OK;
}

/* ---- the global coarse level of a decomposed grid -------------------------------------------------------
 * Block Jacobi alone loses the coarse correction across the cuts (the iterations grow with the ranks). The
 * preconditioner of a decomposed grid is therefore M^-1 = B^-1 + P A_c^-1 P^T: B the block V-cycles (or lines),
 * P piecewise constant on aggregates of the whole grid (at most CFD_GC_MAX, and a factorization of at most
 * CFD_GC_FLOPS), A_c = P^T A P. Each rank adds the
 * coefficients of the faces it owns into A_c's faces, one allreduce makes them every rank's, and every rank
 * factors the same small matrix; each application restricts its owned residual (one allreduce of gc_n values),
 * solves and adds the correction to its own cells. Both terms are symmetric positive (semi)definite, so CG keeps
 * its guarantees. */

static int64_t gc_agg(const struct sphdem_cfd_s *m, const int *g) {
  return (int64_t)(g[0] / m->gc_b[0]) +
         (int64_t)m->gc_nc[0] * ((g[1] / m->gc_b[1]) + (int64_t)m->gc_nc[1] * (g[2] / m->gc_b[2]));
}

/* host view of device array a (n doubles): the array itself on the CPU backend, else a copy in buf */
static double *host_view(struct sphdem_cfd_s *m, double *a, int64_t n, double *buf, int *rc) {
  if (m->backend == SPHDEM_DEVICE_CPU) return a;
  *rc = rt_d2h(&m->rt, buf, a, sizeof(double) * (size_t)n);
  return buf;
}

static int gc_alloc(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  for (int d = 0; d < 3; d++) {
    m->gc_b[d] = 1;
    m->gc_nc[d] = D->gnc[d];
  }
  for (;;) {
    m->gc_n = (int64_t)m->gc_nc[0] * m->gc_nc[1] * m->gc_nc[2];
    m->gc_bw = (int64_t)m->gc_nc[0] * m->gc_nc[1];
    if (m->gc_n <= CFD_GC_MAX && (double)m->gc_n * (double)m->gc_bw * (double)m->gc_bw <= CFD_GC_FLOPS) break;
    int a = 0;
    for (int d = 1; d < 3; d++)
      if (m->gc_nc[d] > m->gc_nc[a]) a = d;
    m->gc_b[a] *= 2;
    m->gc_nc[a] = (D->gnc[a] + m->gc_b[a] - 1) / m->gc_b[a];
  }
  const int64_t n = m->gc_n, hostn = m->backend == SPHDEM_DEVICE_CPU ? 0 : D->nface + D->ncell;
  free(m->gc_L);
  free(m->gc_v);
  free(m->gc_w);
  free(m->gc_host);
  m->gc_L = (double *)malloc(sizeof(double) * (size_t)(n * (m->gc_bw + 1)));
  m->gc_v = (double *)malloc(sizeof(double) * (size_t)(4 * n));
  m->gc_w = (double *)malloc(sizeof(double) * (size_t)n);
  m->gc_host = hostn ? (double *)malloc(sizeof(double) * (size_t)hostn) : NULL;
  if (!m->gc_L || !m->gc_v || !m->gc_w || (hostn && !m->gc_host))
    return sphdem_cfd_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate the coarse level of %lld cells", (long long)n);
  return SPHDEM_OK;
}

/* A_c from the face coefficients of this gas step, factored */
static int gc_setup(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  const int64_t n = m->gc_n;
  int rc = SPHDEM_OK;
  const double *af = host_view(m, D->af, D->nface, m->gc_host, &rc);
  if (rc) return rc;
  /* per coarse cell: the couplings to its upper neighbour along x, y, z and its boundary (outlet) diagonal */
  double *c = m->gc_v;
  memset(c, 0, sizeof(double) * (size_t)(4 * n));
  for (int64_t f = 0; f < D->nface; f++) {
    if (af[f] == 0.0 || !cfd_owned_face(D, f)) continue;
    int ix[3];
    const int d = cfd_face_decode(D, f, ix);
    int g[3];
    for (int e = 0; e < 3; e++) g[e] = ix[e] + D->g0[e];
    if (g[d] == 0 || g[d] == D->gnc[d]) { /* a boundary face: the diagonal of its cell's aggregate */
      if (g[d] == D->gnc[d]) g[d]--;
      c[3 * n + gc_agg(m, g)] += af[f];
      continue;
    }
    const int64_t up = gc_agg(m, g);
    g[d]--;
    if (gc_agg(m, g) != up) c[3 * up + d] += af[f]; /* between two aggregates: the upper one keeps it */
  }
  if ((rc = comm_reduce(m, c, 4 * n, SPHDEM_RED_SUM))) return rc;
  /* A_c's lower band (aggregates x fastest: the couplings lie within bw of the diagonal), then its Cholesky
   * factor in place; entry (i, k), i - bw <= k <= i, at i W + k - i + bw */
  const int64_t bw = m->gc_bw, W = bw + 1;
  double *B = m->gc_L;
#define GC_AT(i, k) B[(i) * W + (k) - (i) + bw]
  memset(B, 0, sizeof(double) * (size_t)(n * W));
  for (int64_t I = 0; I < n; I++) {
    GC_AT(I, I) += c[3 * n + I];
    int ci[3] = {(int)(I % m->gc_nc[0]), (int)((I / m->gc_nc[0]) % m->gc_nc[1]),
                 (int)(I / ((int64_t)m->gc_nc[0] * m->gc_nc[1]))};
    for (int d = 0; d < 3; d++) {
      const double a = c[3 * I + d];
      if (a == 0.0 || ci[d] == 0) continue;
      const int64_t J = I - (d == 0 ? 1 : d == 1 ? (int64_t)m->gc_nc[0] : (int64_t)m->gc_nc[0] * m->gc_nc[1]);
      GC_AT(I, I) += a;
      GC_AT(J, J) += a;
      GC_AT(I, J) -= a;
    }
  }
  for (int64_t I = 0; I < n; I++)
    if (GC_AT(I, I) == 0.0) GC_AT(I, I) = 1.0; /* an aggregate without couplings (walls all round) */
  m->gc_ok = 1;
  for (int64_t j = 0; j < n && m->gc_ok; j++) {
    double s = GC_AT(j, j);
    for (int64_t k = j > bw ? j - bw : 0; k < j; k++) s -= GC_AT(j, k) * GC_AT(j, k);
    if (!(s > 0.0)) {
      m->gc_ok = 0; /* not positive definite to round-off: no coarse correction this step (same on every rank) */
      break;
    }
    const double ljj = sqrt(s);
    GC_AT(j, j) = ljj;
    for (int64_t i = j + 1; i < n && i <= j + bw; i++) {
      double t = GC_AT(i, j);
      for (int64_t k = i > bw ? i - bw : 0; k < j; k++) t -= GC_AT(i, k) * GC_AT(j, k);
      GC_AT(i, j) = t / ljj;
    }
  }
#undef GC_AT
  return SPHDEM_OK;
}

/* z += P A_c^-1 P^T r over this rank's cells */
static int gc_apply(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  if (!m->gc_ok) return SPHDEM_OK;
  const int64_t n = m->gc_n;
  int rc = SPHDEM_OK;
  double *hr = host_view(m, D->r, D->ncell, m->gc_host, &rc);
  if (rc) return rc;
  double *v = m->gc_w;
  memset(v, 0, sizeof(double) * (size_t)n);
  for (int64_t ci = 0; ci < D->ncell; ci++) {
    if (!cfd_owned_cell(D, ci)) continue;
    int g[3];
    cfd_cell_decode(D, ci, g);
    for (int e = 0; e < 3; e++) g[e] += D->g0[e];
    v[gc_agg(m, g)] += hr[ci];
  }
  if ((rc = comm_reduce(m, v, n, SPHDEM_RED_SUM))) return rc;
  const double *B = m->gc_L;
  const int64_t bw = m->gc_bw, W = bw + 1;
#define GC_AT(i, k) B[(i) * W + (k) - (i) + bw]
  for (int64_t i = 0; i < n; i++) { /* L y = v */
    double t = v[i];
    for (int64_t k = i > bw ? i - bw : 0; k < i; k++) t -= GC_AT(i, k) * v[k];
    v[i] = t / GC_AT(i, i);
  }
  for (int64_t i = n - 1; i >= 0; i--) { /* L^T x = y */
    double t = v[i];
    for (int64_t k = i + 1; k < n && k <= i + bw; k++) t -= GC_AT(k, i) * v[k];
    v[i] = t / GC_AT(i, i);
  }
#undef GC_AT
  double *hz = host_view(m, D->z, D->ncell, m->gc_host, &rc);
  if (rc) return rc;
  for (int64_t ci = 0; ci < D->ncell; ci++) {
    if (!cfd_owned_cell(D, ci)) continue;
    int g[3];
    cfd_cell_decode(D, ci, g);
    for (int e = 0; e < 3; e++) g[e] += D->g0[e];
    hz[ci] += v[gc_agg(m, g)];
  }
  if (m->backend != SPHDEM_DEVICE_CPU) rc = rt_h2d(&m->rt, D->z, hz, sizeof(double) * (size_t)D->ncell);
  return rc;
}

/* Multigrid V-cycle z = M^-1 r from level l: damped Jacobi (2 sweeps before and after, the first from
 * zero), residual restricted by summation, coarse correction prolonged by injection; on the coarsest
 * level a fixed number of sweeps. The same smoothing before and after keeps M symmetric for CG. */
static int mg_vcycle(struct sphdem_cfd_s *m, int l) {
  cfd_dev *D = &m->D;
  const cfd_ops *o = m->ops;
  int64_t n = D->L[l].ncell;
  int rc, nsw = 2;
  if (l == D->nlev - 1) {
    int mx = D->L[l].nc[0];
    if (D->L[l].nc[1] > mx) mx = D->L[l].nc[1];
    if (D->L[l].nc[2] > mx) mx = D->L[l].nc[2];
    nsw = 4 * mx + 4;
  }
  D->lv = l;
  if ((rc = o->run(m, CFD_K_mg_jacobi0, n))) return rc;
  for (int s = 1; s < nsw; s++)
    if ((rc = o->run(m, CFD_K_mg_resid, n)) || (rc = o->run(m, CFD_K_mg_jacobi, n))) return rc;
  if (l == D->nlev - 1) return SPHDEM_OK;
  if ((rc = o->run(m, CFD_K_mg_resid, n)) || (rc = o->run(m, CFD_K_mg_restrict, D->L[l + 1].ncell))) return rc;
  if ((rc = mg_vcycle(m, l + 1))) return rc;
  D->lv = l;
  if ((rc = o->run(m, CFD_K_mg_prolong, n))) return rc;
  for (int s = 0; s < nsw; s++)
    if ((rc = o->run(m, CFD_K_mg_resid, n)) || (rc = o->run(m, CFD_K_mg_jacobi, n))) return rc;
  return SPHDEM_OK;
}

/* z = M^-1 r with the chosen preconditioner */
static int precondition(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  int rc;
  if (D->split && (rc = m->ops->run(m, CFD_K_blk_r, D->L[0].ncell))) return rc;
  if (D->P.solver == SPHDEM_CFD_SOLVER_LINE) rc = m->ops->run(m, CFD_K_precond, D->nlines);
  else rc = mg_vcycle(m, 0);
  if (!rc && D->split) rc = m->ops->run(m, CFD_K_blk_z, D->L[0].ncell);
  if (!rc && D->split && m->gc_n) rc = gc_apply(m);
  return rc;
}

/* coarse-level operators of the step (the fine face coefficients change every step) */
static int mg_setup(struct sphdem_cfd_s *m) {
  cfd_dev *D = &m->D;
  int rc;
  if (D->split) { /* level 0: the owned block's coefficients (the faces to other blocks on the diagonal only) */
    D->lv = 0;
    if ((rc = m->ops->run(m, CFD_K_blk_af, D->L[0].foff[3])) || (rc = m->ops->run(m, CFD_K_mg_diag, D->L[0].ncell)))
      return rc;
    if (m->gc_n && (rc = gc_setup(m))) return rc;
  }
  if (D->P.solver != SPHDEM_CFD_SOLVER_MG) return SPHDEM_OK;
  for (int l = 1; l < D->nlev; l++) {
    D->lv = l;
    if ((rc = m->ops->run(m, CFD_K_mg_af, D->L[l].foff[3])) || (rc = m->ops->run(m, CFD_K_mg_diag, D->L[l].ncell)))
      return rc;
  }
  return SPHDEM_OK;
}

/* Conjugate gradients with a multigrid or line preconditioner, warm-started from the last pressure. */
static int pressure_solve(struct sphdem_cfd_s *m, int *iters, double *res) {
  cfd_dev *D = &m->D;
  const cfd_ops *o = m->ops;
  int64_t n = D->ncell;
  double bb, rr, rz, dad;
  int rc;
  *iters = 0;
  if ((rc = o->reduce(m, CFD_R_bb, n, &bb)) || (rc = dreduce(m, &bb, 1, SPHDEM_RED_SUM))) return rc;
  if (!(bb > 0.0)) { /* nothing drives the flow: p = 0 solves it */
    *res = 0.0;
    return rt_zero(&m->rt, D->p, sizeof(double) * (size_t)n);
  }
  double bn = sqrt(bb);
  D->mvx = D->p;
  if ((rc = mg_setup(m))) return rc;
  if ((rc = halo_cells(m, D->p, 0, 1)) || (rc = o->run(m, CFD_K_matvec, n)) || (rc = o->run(m, CFD_K_pcg_res, n)) ||
      (rc = precondition(m)) || (rc = o->run(m, CFD_K_pcg_first, n)))
    return rc;
  if ((rc = o->reduce(m, CFD_R_rr, n, &rr)) || (rc = o->reduce(m, CFD_R_rz, n, &rz))) return rc;
  if (m->decomp) {
    double v[2] = {rr, rz};
    if ((rc = dreduce(m, v, 2, SPHDEM_RED_SUM))) return rc;
    rr = v[0];
    rz = v[1];
  }
  D->mvx = D->d;
  int it = 0;
  while (sqrt(rr) > D->P.tol * bn) {
    if (it >= D->P.maxiter) {
      *iters = it;
      *res = sqrt(rr) / bn;
      return sphdem_cfd_fail(m, SPHDEM_ERR_UNSTABLE,
                             "pressure solve did not reach tol %g in maxiter %d iterations (relative residual "
                             "%.3g); likely cause: a gas step too large for the drag (raise maxiter or tol, or "
                             "lower every), or a field already broken",
                             D->P.tol, D->P.maxiter, *res);
    }
    if ((rc = halo_cells(m, D->d, 0, 1)) || (rc = o->run(m, CFD_K_matvec, n))) return rc;
    if ((rc = o->reduce(m, CFD_R_dad, n, &dad)) || (rc = dreduce(m, &dad, 1, SPHDEM_RED_SUM))) return rc;
    if (!(dad > 0.0)) break; /* converged to round-off */
    D->alpha = rz / dad;
    if ((rc = o->run(m, CFD_K_pcg_update, n)) || (rc = precondition(m))) return rc;
    double rz_new;
    if ((rc = o->reduce(m, CFD_R_rr, n, &rr)) || (rc = o->reduce(m, CFD_R_rz, n, &rz_new))) return rc;
    if (m->decomp) {
      double v[2] = {rr, rz_new};
      if ((rc = dreduce(m, v, 2, SPHDEM_RED_SUM))) return rc;
      rr = v[0];
      rz_new = v[1];
    }
    D->beta = rz_new / rz;
    rz = rz_new;
    if ((rc = o->run(m, CFD_K_pcg_dir, n))) return rc;
    it++;
  }
  *iters = it;
  *res = sqrt(rr) / bn;
  return halo_cells(m, D->p, 0, CFD_HALO); /* the pressure gradient at the faces next to the halo */
}

int sphdem_cfd_step(sphdem_cfd c, double dt, int n, const double *x, const double *v, const double *radius,
                    double *fdrag, double *fpg) {
  if (!c) return SPHDEM_ERR_ARG;
  /* a bad count or pointer is refused by sphdem_cfd_step_store (after every rank agreed on it) */
  const int bad = n < 0 || (n > 0 && (!x || !v || !radius));
  int rc = sphdem_grains_put_private(&c->gstore, &c->rt, c->backend, bad ? 0 : n, x, v, NULL, radius, NULL);
  if (rc) return rc;
  return step_store(c, dt, c->gstore, n, NULL, bad, fdrag, fpg);
}

int sphdem_cfd_step_store(sphdem_cfd c, double dt, sphdem_grain_store g, int n, const int32_t *idx, double *fdrag,
                          double *fpg) {
  if (!c) return SPHDEM_ERR_ARG;
  return step_store(c, dt, g, n, idx, 0, fdrag, fpg);
}

static int step_store(struct sphdem_cfd_s *m, double dt, struct sphdem_grains_s *g, int n, const int32_t *idx,
                      int bad_input, double *fdrag, double *fpg) {
  struct sphdem_cfd_s *c = m;
  cfd_dev *D = &m->D;
  const cfd_ops *o = m->ops;
  /* a rank whose own input is bad still takes part in the first deposit sum (with its failure flag), so that
   * every rank stops at the same point */
  int rc = SPHDEM_OK;
  if (!(dt > 0.0) || !isfinite(dt)) rc = sphdem_cfd_fail(c, SPHDEM_ERR_ARG, "dt: gas step must be > 0 (got %g)", dt);
  else if (bad_input) rc = sphdem_cfd_fail(c, SPHDEM_ERR_ARG, "grains: n = %d with a NULL x, v or radius", n);
  else rc = sphdem_grains_check(g, &m->rt, m->backend, n, idx, "cfd_step");
  const double *x = g ? g->hx : NULL, *radius = g ? g->hrad : NULL;
  for (int i = 0; !rc && i < n; i++) {
    const int64_t s = sphdem_grains_at(idx, i);
    if (!(radius[s] > 0.0) || !isfinite(x[3 * s]) || !isfinite(x[3 * s + 1]) || !isfinite(x[3 * s + 2]))
      rc = sphdem_cfd_fail(c, SPHDEM_ERR_NAN, "grain %d: radius %g or position not valid", i, radius[s]);
  }
  /* decomposed grid: a grain's stencil (its cell, the neighbours of its trilinear corners and of its faces) must
   * lie in this rank's cells and halo: at most one cell beyond the owned ones */
  for (int i = 0; !rc && m->decomp && D->split && i < n; i++) {
    const int64_t s = sphdem_grains_at(idx, i);
    for (int d = 0; d < 3 && !rc; d++) {
      double w, sx = floor((x[3 * s + d] - D->P.boxlo[d]) * D->inv_h[d]);
      int gc = !(sx > 0.0) ? 0 : sx > (double)(D->gnc[d] - 1) ? D->gnc[d] - 1 : (int)sx;
      (void)w;
      int cl = gc - D->g0[d], hh = D->nc[d] - D->hlo[d] - D->own[d];
      if ((D->hlo[d] && cl < 1) || (hh && cl > D->nc[d] - 2))
        rc = sphdem_cfd_fail(c, SPHDEM_ERR_ARG,
                             "grain %d at %g along %c lies in gas cell %d, more than one cell beyond this rank's "
                             "cells %d to %d: a grain may leave its subdomain by at most one gas cell between "
                             "re-neighborings (the neighbor skin must be smaller than a gas cell)",
                             i, x[3 * s + d], "xyz"[d], gc, m->slo[d], m->shi[d] - 1);
    }
  }
  if (rc) n = 0; /* the failing rank deposits nothing */
  if (m->decomp && rt_nranks(&m->rt) > 1) { /* every rank stops here together when one failed */
    double flag = rc ? 1.0 : 0.0;
    int rr = comm_reduce(m, &flag, 1, SPHDEM_RED_MAX);
    if (rr) return rr;
    if (flag > 0.0) return comm_agree(m, rc);
  }
  double t0 = rt_now();
  if (!rc) rc = grow_grains(m, n);
  if (!rc) {
    D->n = n;
    D->dt = dt;
  }
  if (!rc && n) rc = bind_grains(m, g, n, idx);
  double t1 = rt_now();
  m->timers[SPHDEM_CFD_T_TRANSFER] += t1 - t0;
  /* voidage: the previous one becomes eps_old; the solid volume of this rank's grains, summed over the ranks */
  if (!rc) rc = rt_d2d(&m->rt, D->eps_old, D->eps, sizeof(double) * (size_t)D->ncell);
  if (!rc) rc = rt_zero(&m->rt, D->sol, sizeof(double) * (size_t)D->ncell);
  if (!rc && n) rc = o->run(m, CFD_K_void_scatter, n);
  if (m->decomp) { /* halo deposits to their owners, then the owners' sums to the halo copies */
    if (rc || (rc = halo_cells(m, D->sol, 1, CFD_HALO)) || (rc = halo_cells(m, D->sol, 0, CFD_HALO))) return rc;
  } else if ((rc = deposit_sum(m, D->sol, D->ncell, NULL, 0, rc))) {
    return rc;
  }
  if ((rc = o->run(m, CFD_K_void_finish, D->ncell))) return rc;
  /* drag coefficients of this rank's grains to the faces, summed over the ranks */
  rc = rt_zero(&m->rt, D->K, sizeof(double) * (size_t)D->nface);
  if (!rc) rc = rt_zero(&m->rt, D->Kv, sizeof(double) * (size_t)D->nface);
  if (!rc && n) rc = o->run(m, CFD_K_drag, n);
  if (m->decomp) {
    if (rc || (rc = halo_faces(m, D->K, D->Kv, 1)) || (rc = halo_faces(m, D->K, D->Kv, 0))) return rc;
  } else if ((rc = deposit_sum(m, D->K, D->nface, D->Kv, D->nface, rc))) {
    return rc;
  }
  double t2 = rt_now();
  m->timers[SPHDEM_CFD_T_COUPLE] += t2 - t1;
  if ((rc = o->run(m, CFD_K_predict, D->nface))) return rc;
  if ((rc = o->run(m, CFD_K_rhs, D->ncell))) return rc;
  double t3 = rt_now();
  m->timers[SPHDEM_CFD_T_PREDICT] += t3 - t2;
  int iters = 0;
  double res = 0.0;
  rc = pressure_solve(m, &iters, &res);
  m->st.iters = iters;
  m->st.residual = res;
  double t4 = rt_now();
  m->timers[SPHDEM_CFD_T_SOLVE] += t4 - t3;
  if (rc) return rc;
  if ((rc = o->run(m, CFD_K_correct, D->nface))) return rc;
  if ((rc = halo_faces(m, D->u, NULL, 0))) return rc;
  if (n && (rc = o->run(m, CFD_K_forces, n))) return rc;
  double t5 = rt_now();
  m->timers[SPHDEM_CFD_T_CORRECT] += t5 - t4;
  /* statistics of the new field */
  double u2, cfl, mass, negeps, epssum, fg[3], fb[3], pf, pl;
  if ((rc = o->reduce(m, CFD_R_u2, D->nface, &u2)) || (rc = o->reduce(m, CFD_R_cfl, D->nface, &cfl)) ||
      (rc = o->reduce(m, CFD_R_mass, D->ncell, &mass)) || (rc = o->reduce(m, CFD_R_negeps, D->ncell, &negeps)) ||
      (rc = o->reduce(m, CFD_R_eps, D->ncell, &epssum)) ||
      (rc = o->reduce(m, CFD_R_fgasx, D->nface, &fg[0])) || (rc = o->reduce(m, CFD_R_fgasy, D->nface, &fg[1])) ||
      (rc = o->reduce(m, CFD_R_fgasz, D->nface, &fg[2])) || (rc = o->reduce(m, CFD_R_fbndx, D->nface, &fb[0])) ||
      (rc = o->reduce(m, CFD_R_fbndy, D->nface, &fb[1])) || (rc = o->reduce(m, CFD_R_fbndz, D->nface, &fb[2])) ||
      (rc = o->reduce(m, CFD_R_pfirst, D->ncell, &pf)) || (rc = o->reduce(m, CFD_R_plast, D->ncell, &pl)))
    return rc;
  if (m->decomp) { /* the statistics over every rank's cells and faces */
    double sv[9] = {epssum, fg[0], fg[1], fg[2], fb[0], fb[1], fb[2], pf, pl}, mv[4] = {u2, cfl, mass, negeps};
    if ((rc = dreduce(m, sv, 9, SPHDEM_RED_SUM)) || (rc = dreduce(m, mv, 4, SPHDEM_RED_MAX))) return rc;
    epssum = sv[0];
    for (int d = 0; d < 3; d++) {
      fg[d] = sv[1 + d];
      fb[d] = sv[4 + d];
    }
    pf = sv[7];
    pl = sv[8];
    u2 = mv[0];
    cfl = mv[1];
    mass = mv[2];
    negeps = mv[3];
  }
  double t6 = rt_now();
  m->timers[SPHDEM_CFD_T_CORRECT] += t6 - t5;
  sphdem_cfd_stats *S = &m->st;
  S->nsteps++;
  S->umax = sqrt(u2);
  S->cfl = cfl * dt;
  S->mass_err = mass;
  S->eps_min = -negeps;
  S->eps_mean = epssum / (double)D->gncell;
  int a = cfd_flow_axis(D);
  double layer = (double)D->gncell / D->gnc[a];
  S->flow_axis = a;
  S->dp = (pf - pl) / layer;
  for (int d = 0; d < 3; d++) {
    S->f_gas[d] = fg[d];
    S->f_bound[d] = fb[d];
    S->f_grains[d] = S->f_pg[d] = 0.0;
  }
  D->first = 0;
  /* the forces back to the caller; their sums (global values) over every rank's grains */
  double fsum[7] = {0, 0, 0, 0, 0, 0, 0};
  rc = SPHDEM_OK;
  if (n) {
    /* scratch only for an array not asked for */
    double *hb = NULL;
    if (!fdrag || !fpg) {
      hb = (double *)malloc(sizeof(double) * 3 * (size_t)n * 2);
      if (!hb) rc = sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate %d grain forces", n);
    }
    double *hfd = fdrag ? fdrag : hb, *hfp = fpg ? fpg : hb + 3 * (size_t)n;
    if (!rc && !(rc = rt_d2h(&m->rt, hfd, D->gfd, sizeof(double) * 3 * (size_t)n)) &&
        !(rc = rt_d2h(&m->rt, hfp, D->gfp, sizeof(double) * 3 * (size_t)n)))
      for (int i = 0; i < n; i++)
        for (int d = 0; d < 3; d++) {
          fsum[d] += hfd[3 * i + d];
          fsum[3 + d] += hfp[3 * i + d];
        }
    free(hb);
  }
  if (rt_nranks(&m->rt) > 1) {
    fsum[6] = rc ? 1.0 : 0.0;
    int rr = comm_reduce(m, fsum, 7, SPHDEM_RED_SUM);
    if (rr) return rr;
    if (fsum[6] > 0.0) return comm_agree(m, rc);
  } else if (rc) {
    return rc;
  }
  for (int d = 0; d < 3; d++) {
    S->f_grains[d] = fsum[d];
    S->f_pg[d] = fsum[3 + d];
  }
  m->timers[SPHDEM_CFD_T_TRANSFER] += rt_now() - t6;
  if (!isfinite(S->umax) || !isfinite(S->dp))
    return sphdem_cfd_fail(c, SPHDEM_ERR_NAN,
                           "gas field is not finite after step %lld; likely cause: a gas step far beyond the "
                           "CFL limit or a grain with an invalid velocity",
                           (long long)S->nsteps);
  double vlim = 0.0;
  for (int d = 0; d < 3; d++) vlim += 2.0 * D->inv_h[d] * D->inv_h[d];
  vlim *= dt * D->P.mu_g / D->P.rho_g;
  if (vlim > 1.0)
    return sphdem_cfd_fail(c, SPHDEM_ERR_UNSTABLE,
                           "gas step %.3g s exceeds the explicit viscous limit %.3g s (nu sum 2/h^2 dt <= 1): lower "
                           "the gas step (every, timestep) or use coarser cells",
                           dt, dt / vlim);
  if (S->cfl > D->P.cfl_max)
    return sphdem_cfd_fail(c, SPHDEM_ERR_UNSTABLE,
                           "gas CFL %.3g exceeds cfl %.3g (max |u| %.3g m/s, gas step %.3g s): lower the gas step "
                           "(every, timestep) or use coarser cells",
                           S->cfl, D->P.cfl_max, S->umax, dt);
  return SPHDEM_OK;
}

int sphdem_cfd_stats_get(sphdem_cfd c, sphdem_cfd_stats *s) {
  if (!c || !s) return SPHDEM_ERR_ARG;
  *s = c->st;
  return SPHDEM_OK;
}

static int fields_local(sphdem_cfd c, double *eps, double *p, double *u) {
  if (!c) return SPHDEM_ERR_ARG;
  cfd_dev *D = &c->D;
  size_t nb = sizeof(double) * (size_t)D->ncell;
  int rc;
  if (eps) {
    /* the raw voidage before the floor */
    double *sol = (double *)malloc(nb);
    if (!sol) return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the field copy");
    rc = rt_d2h(&c->rt, sol, D->eps, nb);
    if (!rc) memcpy(eps, sol, nb);
    free(sol);
    if (rc) return rc;
  }
  if (p && (rc = rt_d2h(&c->rt, p, D->p, nb))) return rc;
  if (u) {
    double *uf = (double *)malloc(sizeof(double) * (size_t)D->nface);
    if (!uf) return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the field copy");
    if ((rc = rt_d2h(&c->rt, uf, D->u, sizeof(double) * (size_t)D->nface))) {
      free(uf);
      return rc;
    }
    for (int k = 0; k < D->nc[2]; k++)
      for (int j = 0; j < D->nc[1]; j++)
        for (int i = 0; i < D->nc[0]; i++) {
          int ix[3] = {i, j, k};
          int64_t ci = cfd_cellv(D, ix);
          for (int d = 0; d < 3; d++) {
            int a[3] = {i, j, k};
            double lo = uf[cfd_face(D, d, a)];
            a[d]++;
            u[3 * ci + d] = 0.5 * (lo + uf[cfd_face(D, d, a)]);
          }
        }
    free(uf);
  }
  return SPHDEM_OK;
}


static int state_local_get(sphdem_cfd c, double *state) {
  if (!c || !state) return SPHDEM_ERR_ARG;
  cfd_dev *D = &c->D;
  int rc;
  if ((rc = rt_d2h(&c->rt, state, D->u, sizeof(double) * (size_t)D->nface))) return rc;
  if ((rc = rt_d2h(&c->rt, state + D->nface, D->p, sizeof(double) * (size_t)D->ncell))) return rc;
  return rt_d2h(&c->rt, state + D->nface + D->ncell, D->eps, sizeof(double) * (size_t)D->ncell);
}

static int state_local_set(sphdem_cfd c, const double *state) {
  if (!c || !state) return SPHDEM_ERR_ARG;
  cfd_dev *D = &c->D;
  int rc;
  if ((rc = rt_h2d(&c->rt, D->u, state, sizeof(double) * (size_t)D->nface))) return rc;
  if ((rc = rt_h2d(&c->rt, D->p, state + D->nface, sizeof(double) * (size_t)D->ncell))) return rc;
  if ((rc = rt_h2d(&c->rt, D->eps, state + D->nface + D->ncell, sizeof(double) * (size_t)D->ncell))) return rc;
  D->first = 0;
  return SPHDEM_OK;
}

/* ---- whole-grid fields and state of a decomposed grid: each rank's owned cells and faces placed in the
 * whole grid's layout, the rest zero, added over the ranks (collective; every rank gets the whole grid) ------ */

/* the whole grid's faces before axis d, and its face of axis d at global index triple g */
static int64_t gface(const cfd_dev *D, int d, const int *g) {
  int64_t off = 0;
  for (int e = 0; e < d; e++)
    off += (int64_t)(D->gnc[0] + (e == 0)) * (D->gnc[1] + (e == 1)) * (D->gnc[2] + (e == 2));
  int64_t fx = D->gnc[0] + (d == 0), fy = D->gnc[1] + (d == 1);
  return off + g[0] + fx * (g[1] + fy * (int64_t)g[2]);
}
static int64_t gcell(const cfd_dev *D, const int *g) {
  return g[0] + (int64_t)D->gnc[0] * (g[1] + (int64_t)D->gnc[1] * g[2]);
}
static int64_t gnface(const cfd_dev *D) {
  int gg[3] = {0, 0, D->gnc[2] + 1}; /* one past the last face of axis z */
  return gface(D, 2, gg);
}

/* the local grid's u (nface), p, eps (ncell) as host copies in one buffer */
static double *host_copy(struct sphdem_cfd_s *c) {
  cfd_dev *D = &c->D;
  double *h = (double *)malloc(sizeof(double) * (size_t)(D->nface + 2 * D->ncell));
  if (!h) {
    sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the field copy");
    return NULL;
  }
  if (state_local_get(c, h)) {
    free(h);
    return NULL;
  }
  return h;
}

int64_t sphdem_cfd_state_size(sphdem_cfd c) {
  if (!c) return 0;
  if (!c->decomp) return c->D.nface + 2 * c->D.ncell;
  return gnface(&c->D) + 2 * c->D.gncell;
}

/* owned cells of the local grid: local index triple l, global g */
#define FOR_OWNED_CELLS(D, l, g)                                                                      \
  for (int l##z = D->hlo[2]; l##z < D->hlo[2] + D->own[2]; l##z++)                                    \
    for (int l##y = D->hlo[1]; l##y < D->hlo[1] + D->own[1]; l##y++)                                  \
      for (int l##x = D->hlo[0]; l##x < D->hlo[0] + D->own[0]; l##x++)                                \
        for (int l[3] = {l##x, l##y, l##z}, g[3] = {l##x + D->g0[0], l##y + D->g0[1], l##z + D->g0[2]}, \
                 once_ = 1; once_; once_ = 0)

int sphdem_cfd_get_state(sphdem_cfd c, double *state) {
  if (!c || !state) return SPHDEM_ERR_ARG;
  if (!c->decomp) return state_local_get(c, state);
  cfd_dev *D = &c->D;
  const int64_t gnf = gnface(D), ns = gnf + 2 * D->gncell;
  double *h = host_copy(c);
  if (!h) return SPHDEM_ERR_ALLOC;
  memset(state, 0, sizeof(double) * (size_t)ns);
  for (int64_t f = 0; f < D->nface; f++) {
    if (!cfd_owned_face(D, f)) continue;
    int ix[3];
    int d = cfd_face_decode(D, f, ix);
    for (int e = 0; e < 3; e++) ix[e] += D->g0[e];
    state[gface(D, d, ix)] = h[f];
  }
  FOR_OWNED_CELLS(D, l, g) {
    int64_t ci = cfd_cellv(D, l), gi = gcell(D, g);
    state[gnf + gi] = h[D->nface + ci];
    state[gnf + D->gncell + gi] = h[D->nface + D->ncell + ci];
  }
  free(h);
  return comm_reduce(c, state, ns, SPHDEM_RED_SUM);
}

int sphdem_cfd_set_state(sphdem_cfd c, const double *state) {
  if (!c || !state) return SPHDEM_ERR_ARG;
  if (!c->decomp) return state_local_set(c, state);
  cfd_dev *D = &c->D;
  const int64_t gnf = gnface(D);
  double *h = (double *)malloc(sizeof(double) * (size_t)(D->nface + 2 * D->ncell));
  if (!h) return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the state copy");
  /* every local face and cell, halo included, from the whole grid's state */
  for (int64_t f = 0; f < D->nface; f++) {
    int ix[3];
    int d = cfd_face_decode(D, f, ix);
    for (int e = 0; e < 3; e++) ix[e] += D->g0[e];
    h[f] = state[gface(D, d, ix)];
  }
  for (int64_t ci = 0; ci < D->ncell; ci++) {
    int g[3];
    cfd_cell_decode(D, ci, g);
    for (int e = 0; e < 3; e++) g[e] += D->g0[e];
    h[D->nface + ci] = state[gnf + gcell(D, g)];
    h[D->nface + D->ncell + ci] = state[gnf + D->gncell + gcell(D, g)];
  }
  int rc = state_local_set(c, h);
  free(h);
  return rc;
}

int sphdem_cfd_get_fields(sphdem_cfd c, double *eps, double *p, double *u) {
  if (!c) return SPHDEM_ERR_ARG;
  if (!c->decomp) return fields_local(c, eps, p, u);
  cfd_dev *D = &c->D;
  const int64_t nc = D->gncell;
  double *h = host_copy(c);
  if (!h) return SPHDEM_ERR_ALLOC;
  double *all = (double *)calloc((size_t)(5 * nc), sizeof(double));
  if (!all) {
    free(h);
    return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the field copy");
  }
  FOR_OWNED_CELLS(D, l, g) {
    int64_t ci = cfd_cellv(D, l), gi = gcell(D, g);
    all[gi] = h[D->nface + D->ncell + ci];
    all[nc + gi] = h[D->nface + ci];
    for (int d = 0; d < 3; d++) {
      int a[3] = {l[0], l[1], l[2]};
      double lo = h[cfd_face(D, d, a)];
      a[d]++;
      all[2 * nc + 3 * gi + d] = 0.5 * (lo + h[cfd_face(D, d, a)]);
    }
  }
  free(h);
  int rc = comm_reduce(c, all, 5 * nc, SPHDEM_RED_SUM);
  if (!rc) {
    if (eps) memcpy(eps, all, sizeof(double) * (size_t)nc);
    if (p) memcpy(p, all + nc, sizeof(double) * (size_t)nc);
    if (u) memcpy(u, all + 2 * nc, sizeof(double) * 3 * (size_t)nc);
  }
  free(all);
  return rc;
}

int sphdem_cfd_set_velocity(sphdem_cfd c, const double u[3]) {
  if (!c || !u) return SPHDEM_ERR_ARG;
  cfd_dev *D = &c->D;
  double *uf = (double *)malloc(sizeof(double) * (size_t)D->nface);
  if (!uf) return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate the field copy");
  for (int64_t f = 0; f < D->nface; f++) {
    int ix[3];
    int d = cfd_face_decode(D, f, ix);
    uf[f] = u[d];
  }
  int rc = rt_h2d(&c->rt, D->u, uf, sizeof(double) * (size_t)D->nface);
  free(uf);
  if (!rc) rc = rt_zero(&c->rt, D->p, sizeof(double) * (size_t)D->ncell);
  return rc;
}

void sphdem_cfd_timers(sphdem_cfd c, double t[SPHDEM_CFD_NTIMERS]) {
  for (int i = 0; i < SPHDEM_CFD_NTIMERS; i++) t[i] = c ? c->timers[i] : 0.0;
}
void sphdem_cfd_timers_reset(sphdem_cfd c) {
  if (c) memset(c->timers, 0, sizeof c->timers);
}

int sphdem_cfd_set_comm(sphdem_cfd c, const sphdem_comm *comm) {
  if (!c) return SPHDEM_ERR_ARG;
  if (comm) c->rt.comm = *comm;
  else memset(&c->rt.comm, 0, sizeof c->rt.comm);
  if (rt_nranks(&c->rt) == 1 || c->decomp) return SPHDEM_OK;
  /* the host buffer of the deposit sums: the face sums K and Kv (the larger stage) and the failure flag */
  int64_t need = 2 * c->D.nface > c->D.ncell ? 2 * c->D.nface : c->D.ncell;
  need += 1;
  if (c->hred && c->nhred >= need) return SPHDEM_OK;
  free(c->hred);
  c->nhred = 0;
  c->hred = (double *)malloc(sizeof(double) * (size_t)need);
  if (!c->hred)
    return sphdem_cfd_fail(c, SPHDEM_ERR_ALLOC, "cannot allocate %lld host doubles for the sums over the ranks",
                           (long long)need);
  c->nhred = need;
  return SPHDEM_OK;
}
