/* test_cfd_comm.c - the gas grid on many ranks without MPI: threads stand for the ranks, each with its own
 * context holding the whole grid and a share of the grains, joined by an allreduce callback (sphdem_comm) that
 * adds the ranks' buffers in rank order. The fields of every rank are bit-identical; fields, grain forces and
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

/* ---- the scene: a 4 x 3 x 10 cell column, 300 moving grains, 12 gas steps -------------------------------- */
#define NG 300
#define NSTEP 12
#define NX 4
#define NY 3
#define NZ 10
#define NCELL (NX * NY * NZ)

static double gx0[3 * NG], gv0[3 * NG], grad0[NG];

static void scene_params(sphdem_cfd_params *p, int voidage) {
  sphdem_cfd_params_default(p);
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
} rank_job;

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
    sphdem_comm cm = {&J->fr, fake_allreduce, me, R};
    J->rc = sphdem_cfd_set_comm(c, &cm);
  }
  int idx[NG], n = 0;
  for (int i = me; i < NG; i += R) idx[n++] = i;
  double x[3 * NG], v[3 * NG], r[NG], fd[3 * NG], fp[3 * NG];
  for (int s = 0; s < NSTEP && !J->rc; s++) {
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

int main(void) {
  make_grains();
  test_ranks(2, SPHDEM_CFD_VOID_SMOOTH);
  test_ranks(3, SPHDEM_CFD_VOID_CENTROID);
  test_ranks(4, SPHDEM_CFD_VOID_SMOOTH);
  test_bad_rank();
  return test_summary("unit_cfd_comm");
}
