/* test_cfd_comm.c - the gas grid on many ranks without MPI: threads stand for the ranks, joined by an allreduce
 * callback (sphdem_comm) that adds the ranks' buffers in rank order and a halo-exchange callback between the
 * face neighbours of a px x 1 x pz processor grid. Decomposed grid: each rank stores its block and a halo; fields,
 * grain forces and global sums agree with 1 rank within the pressure-solver bound (DECOMP_BOUND); one block is
 * bit-identical to 1 rank; a state written at one rank count continues at another; a block thinner than the
 * stencil is refused. Replicated grid (each rank the whole grid and a share of the grains): The fields of every rank are bit-identical; fields, grain forces and
 * global sums equal the 1-rank run up to the order of the deposit sums (1e-12 relative); a bad grain on one
 * rank stops every rank at the same step with that rank's message (no rank is left waiting in a reduction). */
#include <math.h>
#include <pthread.h>
#define TEST_RNG_SEED 0x9E3779B97F4A7C15ull
#include "testlib.h"

#define MAXR 4

/* ---- the stand-in for MPI_Allreduce: every rank's buffer, combined in rank order by each rank ---------- */
typedef struct {
  int nranks;
  pthread_barrier_t bar;
  double *buf[MAXR];
  int n[MAXR];
  long calls;
  /* decomposed grid: px x 1 x pz processor grid (rank = ix + px iz); the posted halo messages */
  int px, pz;
  const double *sbuf[MAXR];
  int sn[MAXR];
  long xcalls;
} fake_world;

typedef struct {
  fake_world *w;
  int rank;
} fake_rank;

static int fake_allreduce(void *user, double *buf, int n, int op) {
  fake_rank *me = (fake_rank *)user;
  fake_world *w = me->w;
  w->buf[me->rank] = buf;
  w->n[me->rank] = n;
  pthread_barrier_wait(&w->bar);
  int ok = 1;
  for (int r = 0; r < w->nranks; r++) ok = ok && w->n[r] == n;
  double *out = (double *)malloc(sizeof(double) * (size_t)(n > 0 ? n : 1));
  for (int i = 0; ok && i < n; i++) {
    double a = w->buf[0][i];
    for (int r = 1; r < w->nranks; r++) {
      double b = w->buf[r][i];
      a = op == SPHDEM_RED_SUM ? a + b : op == SPHDEM_RED_MAX ? (b > a ? b : a) : (b < a ? b : a);
    }
    out[i] = a;
  }
  pthread_barrier_wait(&w->bar); /* every rank has read every buffer */
  if (ok) memcpy(buf, out, sizeof(double) * (size_t)n);
  free(out);
  if (me->rank == 0) w->calls++;
  pthread_barrier_wait(&w->bar);
  return ok ? 0 : 1; /* counts that differ between ranks: a broken collective */
}

/* ---- the stand-in for MPI_Sendrecv with the face neighbours of the processor grid --------------------------- */
static int fake_neighbour(const fake_world *w, int rank, int axis, int dir) {
  int ix = rank % w->px, iz = rank / w->px;
  if (axis == 0) ix += dir;
  else if (axis == 2) iz += dir;
  else return -1;
  if (ix < 0 || ix >= w->px || iz < 0 || iz >= w->pz) return -1;
  return ix + w->px * iz;
}

static int fake_exchange(void *user, int axis, int dir, const double *send, int nsend, double *recv, int nrecv) {
  fake_rank *me = (fake_rank *)user;
  fake_world *w = me->w;
  w->sbuf[me->rank] = send;
  w->sn[me->rank] = nsend;
  pthread_barrier_wait(&w->bar);
  int ok = 1;
  if (nsend > 0) ok = fake_neighbour(w, me->rank, axis, dir) >= 0;
  if (nrecv > 0) {
    int src = fake_neighbour(w, me->rank, axis, -dir);
    ok = ok && src >= 0 && w->sn[src] == nrecv;
    if (ok) memcpy(recv, w->sbuf[src], sizeof(double) * (size_t)nrecv);
  }
  pthread_barrier_wait(&w->bar);
  if (me->rank == 0) w->xcalls++;
  return ok ? 0 : 1;
}

/* ---- the scene: a 4 x 3 x 10 cell column, 300 moving grains, 12 gas steps -------------------------------- */
#define NG 300
#define NSTEP 12
#define NX 4
#define NY 3
#define NZ 10
#define NCELL (NX * NY * NZ)

static double gx0[3 * NG], gv0[3 * NG], grad0[NG];

static int g_solver = SPHDEM_CFD_SOLVER_MG; /* the pressure solve's preconditioner of the runs that follow */

static void scene_params(sphdem_cfd_params *p, int voidage) {
  sphdem_cfd_params_default(p);
  p->solver = g_solver;
  p->nc[0] = NX; p->nc[1] = NY; p->nc[2] = NZ;
  for (int d = 0; d < 3; d++) { p->boxlo[d] = 0.0; p->boxhi[d] = 0.004 * p->nc[d]; }
  for (int s = 0; s < 6; s++) p->bc[s] = SPHDEM_CFD_NOSLIP;
  p->bc[4] = SPHDEM_CFD_INLET;
  p->inlet_u[4] = 0.8;
  p->bc[5] = SPHDEM_CFD_OUTLET;
  p->voidage = voidage;
}

static void make_grains(void) {
  for (int i = 0; i < NG; i++) {
    grad0[i] = 0.0005 * (0.8 + 0.4 * urand());
    for (int d = 0; d < 3; d++) {
      double L = 0.004 * (d == 0 ? NX : d == 1 ? NY : NZ);
      gx0[3 * i + d] = L * (d == 2 ? 0.6 : 1.0) * (0.02 + 0.96 * urand());
      gv0[3 * i + d] = 0.2 * (urand() - 0.5);
    }
  }
}

typedef struct {
  fake_rank fr;
  int voidage;
  int bad_step;  /* this rank passes a grain of radius -1 at this gas step (-1: never) */
  /* results */
  int rc, fail_step;
  char msg[1100];
  double eps[NCELL], p[NCELL], u[3 * NCELL];
  double fd[3 * NG], fp[3 * NG]; /* forces of this rank's grains at their global index (others 0) */
  sphdem_cfd_stats st;
  /* decomposed grid (px > 0): the cut planes (box units) along x and z; the gas steps [s0, s1); a whole-grid
   * state to start from (NULL: at rest) and one to write at the end (NULL: none) */
  int px, pz, s0, s1;
  double xcut, zcut;
  const double *state_in;
  double *state_out;
  int want_state;
  int64_t local_cells, want_cells; /* cells stored; the owned block plus 2 halo layers per cut side */
} rank_job;

#define NSTATE ((NX + 1) * NY * NZ + NX * (NY + 1) * NZ + NX * NY * (NZ + 1) + 2 * NCELL)
#define H 0.004

/* the grains of rank r of R: every R-th one (an arbitrary partition: each grain on exactly one rank) */
static void *rank_main(void *arg) {
  rank_job *J = (rank_job *)arg;
  const int R = J->fr.w ? J->fr.w->nranks : 1, me = J->fr.rank;
  sphdem_cfd_params p;
  scene_params(&p, J->voidage);
  sphdem_cfd c = NULL;
  char msg[512];
  J->rc = sphdem_cfd_create(&c, &p, test_device(), msg, sizeof msg);
  J->fail_step = -1;
  if (J->rc) {
    snprintf(J->msg, sizeof J->msg, "%s", msg);
    return NULL;
  }
  if (J->fr.w) {
    sphdem_comm cm = {&J->fr, fake_allreduce, me, R, fake_exchange};
    J->rc = sphdem_cfd_set_comm(c, &cm);
  }
  /* decomposed: the cells whose centres lie in this rank's slab, the grains whose positions do */
  double sub_lo[3] = {-1e300, -1e300, -1e300}, sub_hi[3] = {1e300, 1e300, 1e300};
  if (J->px && !J->rc) {
    int ix = me % J->px, iz = me / J->px, lo[3] = {0, 0, 0}, hi[3] = {NX, NY, NZ};
    if (J->px > 1) {
      int cut = (int)ceil(J->xcut / H - 0.5);
      if (ix == 0) { hi[0] = cut; sub_hi[0] = J->xcut; }
      else { lo[0] = cut; sub_lo[0] = J->xcut; }
    }
    if (J->pz > 1) {
      int cut = (int)ceil(J->zcut / H - 0.5);
      if (iz == 0) { hi[2] = cut; sub_hi[2] = J->zcut; }
      else { lo[2] = cut; sub_lo[2] = J->zcut; }
    }
    J->rc = sphdem_cfd_set_subdomain(c, lo, hi);
    J->want_cells = 1;
    for (int d = 0; d < 3; d++) {
      int nd = p.nc[d];
      J->want_cells *= hi[d] - lo[d] + (lo[d] > 0 ? 2 : 0) + (hi[d] < nd ? 2 : 0);
    }
  }
  if (!J->rc && J->state_in) J->rc = sphdem_cfd_set_state(c, J->state_in);
  J->local_cells = sphdem_cfd_local_cells(c);
  int idx[NG], n = 0;
  double x[3 * NG], v[3 * NG], r[NG], fd[3 * NG], fp[3 * NG];
  const int s1 = J->px ? J->s1 : NSTEP;
  for (int s = J->px ? J->s0 : 0; s < s1 && !J->rc; s++) {
    n = 0;
    for (int i = 0; i < NG; i++) {
      int mine = 1;
      if (J->px) {
        for (int d = 0; d < 3; d++) {
          double xd = gx0[3 * i + d] + 2e-4 * s * gv0[3 * i + d];
          mine = mine && xd >= sub_lo[d] && xd < sub_hi[d];
        }
      } else {
        mine = i % R == me;
      }
      if (mine) idx[n++] = i;
    }
    for (int k = 0; k < n; k++) {
      int i = idx[k];
      r[k] = grad0[i];
      for (int d = 0; d < 3; d++) {
        x[3 * k + d] = gx0[3 * i + d] + 2e-4 * s * gv0[3 * i + d];
        v[3 * k + d] = gv0[3 * i + d];
      }
    }
    if (s == J->bad_step && n) r[0] = -1.0;
    J->rc = sphdem_cfd_step(c, 2e-4, n, x, v, r, fd, fp);
    if (J->rc) J->fail_step = s;
  }
  snprintf(J->msg, sizeof J->msg, "%s", sphdem_cfd_last_error(c));
  if (!J->rc && J->want_state) { /* collective: every rank takes part, rank 0 keeps it */
    double *st = J->state_out ? J->state_out : (double *)malloc(sizeof(double) * NSTATE);
    J->rc = sphdem_cfd_get_state(c, st);
    if (!J->state_out) free(st);
  }
  if (!J->rc) {
    sphdem_cfd_get_fields(c, J->eps, J->p, J->u);
    sphdem_cfd_stats_get(c, &J->st);
    memset(J->fd, 0, sizeof J->fd);
    memset(J->fp, 0, sizeof J->fp);
    for (int k = 0; k < n; k++)
      for (int d = 0; d < 3; d++) {
        J->fd[3 * idx[k] + d] = fd[3 * k + d];
        J->fp[3 * idx[k] + d] = fp[3 * k + d];
      }
  }
  sphdem_cfd_destroy(&c);
  return NULL;
}

/* R ranks (R = 1: no comm at all), rank bad_rank fails at bad_step */
static void run_ranks(int R, int voidage, int bad_rank, int bad_step, rank_job *jobs, fake_world *w) {
  memset(w, 0, sizeof *w);
  w->nranks = R;
  pthread_barrier_init(&w->bar, NULL, (unsigned)R);
  pthread_t th[MAXR];
  for (int r = 0; r < R; r++) {
    memset(&jobs[r], 0, sizeof jobs[r]);
    jobs[r].fr.w = R > 1 ? w : NULL;
    jobs[r].fr.rank = r;
    jobs[r].voidage = voidage;
    jobs[r].bad_step = r == bad_rank ? bad_step : -1;
    pthread_create(&th[r], NULL, rank_main, &jobs[r]);
  }
  for (int r = 0; r < R; r++) pthread_join(th[r], NULL);
  pthread_barrier_destroy(&w->bar);
}

static double maxabs(const double *a, int n) {
  double m = 0;
  for (int i = 0; i < n; i++) m = fmax(m, fabs(a[i]));
  return m > 0 ? m : 1e-300;
}
static double reldiff(const double *a, const double *b, int n) {
  double d = 0;
  for (int i = 0; i < n; i++) d = fmax(d, fabs(a[i] - b[i]));
  return d / maxabs(a, n);
}

static rank_job one[1], many[MAXR];

static void test_ranks(int R, int voidage) {
  fake_world w;
  run_ranks(1, voidage, -1, -1, one, &w);
  TEST_ASSERT(one[0].rc == SPHDEM_OK, "1 rank ran (%s)", one[0].msg);
  run_ranks(R, voidage, -1, -1, many, &w);
  int ok = 1;
  for (int r = 0; r < R; r++) ok = ok && many[r].rc == SPHDEM_OK;
  TEST_ASSERT(ok, "%d ranks ran (%s)", R, many[0].msg);
  if (!ok || one[0].rc) return;
  /* identical copies on every rank */
  int same = 1;
  for (int r = 1; r < R; r++)
    same = same && !memcmp(many[r].eps, many[0].eps, sizeof many[0].eps) &&
           !memcmp(many[r].p, many[0].p, sizeof many[0].p) && !memcmp(many[r].u, many[0].u, sizeof many[0].u) &&
           !memcmp(&many[r].st, &many[0].st, sizeof many[0].st);
  TEST_ASSERT(same, "%d ranks, voidage %d: fields and statistics bit-identical on every rank", R, voidage);
  /* equal to one rank up to the order of the sums */
  double de = reldiff(one[0].eps, many[0].eps, NCELL), dpp = reldiff(one[0].p, many[0].p, NCELL);
  double du = reldiff(one[0].u, many[0].u, 3 * NCELL);
  double fd[3 * NG], fp[3 * NG];
  for (int i = 0; i < 3 * NG; i++) {
    fd[i] = fp[i] = 0;
    for (int r = 0; r < R; r++) {
      fd[i] += many[r].fd[i];
      fp[i] += many[r].fp[i];
    }
  }
  double dfd = reldiff(one[0].fd, fd, 3 * NG), dfp = reldiff(one[0].fp, fp, 3 * NG);
  double dst = 0, sc = 0;
  for (int d = 0; d < 3; d++) {
    sc = fmax(sc, fmax(fabs(one[0].st.f_grains[d]), fabs(one[0].st.f_pg[d])));
    dst = fmax(dst, fmax(fabs(one[0].st.f_grains[d] - many[0].st.f_grains[d]),
                         fabs(one[0].st.f_pg[d] - many[0].st.f_pg[d])));
  }
  dst /= sc > 0 ? sc : 1e-300;
  double ddp = fabs(one[0].st.dp - many[0].st.dp) / fabs(one[0].st.dp);
  double worst = fmax(fmax(fmax(de, dpp), fmax(du, dfd)), fmax(fmax(dfp, dst), ddp));
  printf("  %d ranks, voidage %d, %ld reductions: eps %.2e, p %.2e, u %.2e, drag %.2e, pressure force %.2e, "
         "force sums %.2e, dp %.2e (dp %.6g Pa, %d iterations)\n",
         R, voidage, w.calls, de, dpp, du, dfd, dfp, dst, ddp, one[0].st.dp, one[0].st.iters);
  TEST_ASSERT(worst < 1e-12, "%d ranks, voidage %d: equal to 1 rank within 1e-12 (%.3g)", R, voidage, worst);
  TEST_ASSERT(fabs(one[0].st.f_grains[2]) > 0 && one[0].st.dp > 0, "the grains feel the gas (f_grains z %.3g)",
              one[0].st.f_grains[2]);
  /* 2 deposit sums + 1 force sum per gas step */
  TEST_ASSERT(w.calls == 3 * NSTEP, "%d reductions for %d gas steps (3 each)", (int)w.calls, NSTEP);
}

static void test_bad_rank(void) {
  fake_world w;
  const int R = 3, bad = 1, step = 4;
  run_ranks(R, SPHDEM_CFD_VOID_SMOOTH, bad, step, many, &w);
  for (int r = 0; r < R; r++) {
    const char *m = many[r].msg;
    int ok = many[r].rc == SPHDEM_ERR_NAN && many[r].fail_step == step && strstr(m, "radius -1") &&
             (r == bad ? strncmp(m, "rank", 4) != 0 : strncmp(m, "rank 1: ", 8) == 0);
    TEST_ASSERT(ok, "rank %d stops at gas step %d with code %d and the message of rank %d: '%s'", r,
                many[r].fail_step, many[r].rc, bad, m);
  }
}

/* ---- the decomposed grid ------------------------------------------------------------------------------------ */

static rank_job dec[MAXR];
static double state_a[NSTATE], state_b[NSTATE];

/* px x 1 x pz ranks on the decomposed grid, gas steps [s0, s1) */
static void run_decomp(int px, int pz, int voidage, int s0, int s1, const double *in, double *out, fake_world *w) {
  const int R = px * pz;
  memset(w, 0, sizeof *w);
  w->nranks = R;
  w->px = px;
  w->pz = pz;
  pthread_barrier_init(&w->bar, NULL, (unsigned)R);
  pthread_t th[MAXR];
  for (int r = 0; r < R; r++) {
    memset(&dec[r], 0, sizeof dec[r]);
    dec[r].fr.w = R > 1 ? w : NULL;
    dec[r].fr.rank = r;
    dec[r].voidage = voidage;
    dec[r].bad_step = -1;
    dec[r].px = px;
    dec[r].pz = pz;
    dec[r].xcut = 1.7 * H; /* cells 0-1 | 2-3: grains between 1.7 h and 2 h deposit into the other rank's cell */
    dec[r].zcut = 4.6 * H; /* cells 0-4 | 5-9 */
    dec[r].s0 = s0;
    dec[r].s1 = s1;
    dec[r].state_in = in;
    dec[r].state_out = r == 0 ? out : NULL;
    dec[r].want_state = out != NULL;
    pthread_create(&th[r], NULL, rank_main, &dec[r]);
  }
  for (int r = 0; r < R; r++) pthread_join(th[r], NULL);
  pthread_barrier_destroy(&w->bar);
}

/* the worst relative difference of the ranks' results (fields of rank 0, forces summed) from job a */
static double decomp_diff(const rank_job *a, int R, double *dfield, double *dforce) {
  double fd[3 * NG], fp[3 * NG];
  for (int i = 0; i < 3 * NG; i++) {
    fd[i] = fp[i] = 0;
    for (int r = 0; r < R; r++) {
      fd[i] += dec[r].fd[i];
      fp[i] += dec[r].fp[i];
    }
  }
  *dfield = fmax(fmax(reldiff(a->eps, dec[0].eps, NCELL), reldiff(a->p, dec[0].p, NCELL)),
                 reldiff(a->u, dec[0].u, 3 * NCELL));
  *dforce = fmax(reldiff(a->fd, fd, 3 * NG), reldiff(a->fp, fp, 3 * NG));
  double ddp = fabs(a->st.dp - dec[0].st.dp) / fabs(a->st.dp);
  double dfs = 0.0;
  for (int d = 0; d < 3; d++)
    dfs = fmax(dfs, fabs(a->st.f_grains[d] - dec[0].st.f_grains[d]) / fmax(fabs(a->st.f_grains[2]), 1e-300));
  return fmax(fmax(*dfield, *dforce), fmax(ddp, dfs));
}

/* Bound of the rank-count comparisons. The deposits differ from 1 rank only by the order of the sums (1e-16
 * relative); the preconditioner is block Jacobi over the ranks' blocks, so the iterates differ and each solve
 * stops at relative residual tol = 1e-10 somewhere else: the pressures of two rank counts differ by up to about
 * tol times the condition share left by the warm start (measured 1e-11 to 1e-9 of max |p| in this scene). Over
 * 12 gas steps the difference enters the next step's drag and predictor linearly; 1e-8 leaves a factor 10 over
 * the largest measured. */
#define DECOMP_BOUND 1e-8

static void test_decomposed(int px, int pz, int voidage) {
  fake_world w;
  const int R = px * pz;
  run_ranks(1, voidage, -1, -1, one, &w);
  TEST_ASSERT(one[0].rc == SPHDEM_OK, "1 rank ran (%s)", one[0].msg);
  run_decomp(px, pz, voidage, 0, NSTEP, NULL, NULL, &w);
  int ok = 1;
  for (int r = 0; r < R; r++) ok = ok && dec[r].rc == SPHDEM_OK;
  TEST_ASSERT(ok, "decomposed %d x 1 x %d ran (%s)", px, pz, dec[0].msg);
  if (!ok) return;
  int same = 1;
  for (int r = 1; r < R; r++)
    same = same && !memcmp(dec[r].eps, dec[0].eps, sizeof dec[0].eps) && !memcmp(dec[r].p, dec[0].p, sizeof dec[0].p) &&
           !memcmp(&dec[r].st, &dec[0].st, sizeof dec[0].st);
  TEST_ASSERT(same, "decomposed %d x 1 x %d: the gathered fields and statistics are the same on every rank", px, pz);
  double dfield, dforce, worst = decomp_diff(&one[0], R, &dfield, &dforce);
  int64_t lmax = 0;
  for (int r = 0; r < R; r++) lmax = dec[r].local_cells > lmax ? dec[r].local_cells : lmax;
  printf("  decomposed %d x 1 x %d, solver %s, voidage %d: fields %.2e, grain forces %.2e, all %.2e (bound %.0e); PCG "
         "iterations of the last step %d (1 rank %d); %ld halo exchanges; largest rank holds %lld of %d cells\n",
         px, pz, g_solver == SPHDEM_CFD_SOLVER_LINE ? "line" : "mg", voidage, dfield, dforce, worst, DECOMP_BOUND, dec[0].st.iters, one[0].st.iters, w.xcalls,
         (long long)lmax, NCELL);
  TEST_ASSERT(worst < DECOMP_BOUND, "decomposed %d x 1 x %d, voidage %d: equal to 1 rank within %.0e (%.3g)", px, pz,
              voidage, DECOMP_BOUND, worst);
  if (R == 1) {
    TEST_ASSERT(worst == 0.0, "one block (no halo): bit-identical to the replicated grid (%.3g)", worst);
  } else {
    int blocks = 1;
    for (int r = 0; r < R; r++) blocks = blocks && dec[r].local_cells == dec[r].want_cells;
    /* (4 cells along x cut in two: 2 owned + 2 halo is all 4, so the z cuts show the saving) */
    TEST_ASSERT(blocks && (pz == 1 || lmax < NCELL), "each rank stores its block and halo only (largest %lld of %d "
                "cells)", (long long)lmax, NCELL);
    TEST_ASSERT(w.xcalls > 0, "halo exchanges happened (%ld)", w.xcalls);
  }
}

/* the state written at ra ranks after half the steps, read at rb ranks: the end equals the unbroken 1-rank run */
static void test_decomposed_restart(int pxa, int pza, int pxb, int pzb) {
  fake_world w;
  run_ranks(1, SPHDEM_CFD_VOID_SMOOTH, -1, -1, one, &w);
  run_decomp(pxa, pza, SPHDEM_CFD_VOID_SMOOTH, 0, NSTEP / 2, NULL, state_a, &w);
  TEST_ASSERT(dec[0].rc == SPHDEM_OK, "first half at %d ranks (%s)", pxa * pza, dec[0].msg);
  run_decomp(pxb, pzb, SPHDEM_CFD_VOID_SMOOTH, NSTEP / 2, NSTEP, state_a, state_b, &w);
  TEST_ASSERT(dec[0].rc == SPHDEM_OK, "second half at %d ranks (%s)", pxb * pzb, dec[0].msg);
  double dfield, dforce, worst = decomp_diff(&one[0], pxb * pzb, &dfield, &dforce);
  printf("  state written at %d ranks, read at %d: fields %.2e, grain forces %.2e vs the unbroken 1-rank run\n",
         pxa * pza, pxb * pzb, dfield, dforce);
  TEST_ASSERT(worst < DECOMP_BOUND, "restart %d -> %d ranks within %.0e of the unbroken run (%.3g)", pxa * pza,
              pxb * pzb, DECOMP_BOUND, worst);
}

/* a subdomain thinner than the stencil is refused with the axis named */
static void test_thin(void) {
  sphdem_cfd_params p;
  scene_params(&p, SPHDEM_CFD_VOID_SMOOTH);
  sphdem_cfd c = NULL;
  char msg[512];
  TEST_ASSERT(sphdem_cfd_create(&c, &p, test_device(), msg, sizeof msg) == SPHDEM_OK, "create (%s)", msg);
  int lo[3] = {0, 0, 3}, hi[3] = {NX, NY, 4};
  int rc = sphdem_cfd_set_subdomain(c, lo, hi);
  const char *m = sphdem_cfd_last_error(c);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(m, "thinner than the gas stencil") && strstr(m, "along z"),
              "1 cell along a cut z refused: '%s'", m);
  int lo1[3] = {2, 0, 0}, hi1[3] = {2, NY, NZ};
  rc = sphdem_cfd_set_subdomain(c, lo1, hi1);
  m = sphdem_cfd_last_error(c);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(m, "not a part of the grid") && strstr(m, "along x"),
              "no cell along x refused: '%s'", m);
  int lo2[3] = {0, 0, 0}, hi2[3] = {NX, NY, 2};
  TEST_ASSERT(sphdem_cfd_set_subdomain(c, lo2, hi2) == SPHDEM_OK, "2 cells along a cut z accepted (%s)",
              sphdem_cfd_last_error(c));
  sphdem_cfd_destroy(&c);
}

int main(void) {
  make_grains();
  test_decomposed(1, 1, SPHDEM_CFD_VOID_SMOOTH);
  test_decomposed(2, 1, SPHDEM_CFD_VOID_SMOOTH);
  test_decomposed(1, 2, SPHDEM_CFD_VOID_CENTROID);
  test_decomposed(2, 2, SPHDEM_CFD_VOID_SMOOTH);
  g_solver = SPHDEM_CFD_SOLVER_LINE; /* the lines along z (the longest axis) cut by the z planes: block lines */
  test_decomposed(1, 1, SPHDEM_CFD_VOID_SMOOTH);
  test_decomposed(2, 2, SPHDEM_CFD_VOID_SMOOTH);
  g_solver = SPHDEM_CFD_SOLVER_MG;
  test_decomposed_restart(2, 1, 1, 1);
  test_decomposed_restart(1, 1, 2, 2);
  test_thin();
  test_ranks(2, SPHDEM_CFD_VOID_SMOOTH);
  test_ranks(3, SPHDEM_CFD_VOID_CENTROID);
  test_ranks(4, SPHDEM_CFD_VOID_SMOOTH);
  test_bad_rank();
  return test_summary("unit_cfd_comm");
}
