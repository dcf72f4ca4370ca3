/* test_fluid_comm.c - the fluid on two ranks without MPI: threads stand for the ranks, joined by an allreduce and an
 * exchange function (sphdem_set_exchange) that hand the owners' values to the other rank's ghost copies. The 2D dam
 * break (fluid and Adami walls) is cut at x = a/2; each rank holds its own particles and the other's within 2h + skin
 * of the cut as ghosts, and between the steps copies the rows the other rank needs down (sphdem_get_fluid_rows) and
 * its ghosts up (sphdem_update_ghosts), as the engine shims do with the engine's forward communication.
 * Checks: two ranks agree with one within round-off (bound 1e-9 of each field's largest value); the exchanges that
 * move only the boundary rows (sphdem_set_exchange_rows) give the same bits as those that move every owned row;
 * sphdem_get_fluid_rows returns sphdem_get_fluid's values at those rows and leaves the other entries alone;
 * sphdem_fluid_moved equals the largest move since the upload computed here; bad rows are refused by name.
 * On the backend under test (SPHDEM_TEST_DEVICE=gpu: the device gathers and scatters of the boundary slice). */
#include <math.h>
#include <pthread.h>
#include "testlib.h"
#include "scene.h"

#define NSTEP 50
#define BOUND 1e-9

typedef struct {
  pthread_barrier_t bar;
  double *buf[2];
  int n[2];
  const double *own[2]; /* the owners' values posted by each rank's exchange */
  int ncomp[2];
} fake_world;

/* one rank's share of the scene: caller order = owned particles, then the other rank's within the band */
typedef struct {
  fake_world *w;
  int rank, use_rows;
  const scene *s;
  const sphdem_params *p;
  int nf, nfown, nw, nwown;
  int *fg, *wg;          /* caller index -> global index */
  int *f_owner, *w_owner;/* ghosts: the owner's caller index */
  int *frows, nfrows, *wrows, nwrows; /* owned rows within the band (what the other rank needs) */
  /* per step the owners' boundary rows for the other rank's ghosts, in the owner's caller layout */
  double *rx, *rv, *rrho, *rst;
  sphdem_ctx c;
  int rc;
  /* results: owned particles' x, v, rho by global index */
  double *gx, *gv, *grho;
  double moved_core, moved_host;
  int rows_same, rows_kept;
} fake_rank;

static fake_rank *g_ranks[2];

static int fake_allreduce(void *user, double *buf, int n, int op) {
  fake_rank *me = (fake_rank *)user;
  fake_world *w = me->w;
  w->buf[me->rank] = buf;
  w->n[me->rank] = n;
  pthread_barrier_wait(&w->bar);
  const int ok = w->n[0] == w->n[1];
  double *out = (double *)malloc(sizeof(double) * (size_t)(n > 0 ? n : 1));
  for (int i = 0; ok && i < n; i++) {
    const double a = w->buf[0][i], b = w->buf[1][i];
    out[i] = op == SPHDEM_RED_SUM ? a + b : op == SPHDEM_RED_MAX ? (b > a ? b : a) : (b < a ? b : a);
  }
  pthread_barrier_wait(&w->bar); /* both have read both buffers */
  if (ok) memcpy(buf, out, sizeof(double) * (size_t)n);
  free(out);
  pthread_barrier_wait(&w->bar);
  return ok ? 0 : 1;
}

/* the forward communication inside the rate evaluation: each ghost takes its owner's values */
static int fake_exchange(void *user, int what, int ncomp, int nown, int nghost, const double *own, double *ghost) {
  fake_rank *me = (fake_rank *)user;
  fake_world *w = me->w;
  const int walls = what == SPHDEM_XCHG_WALL;
  w->own[me->rank] = own;
  w->ncomp[me->rank] = ncomp;
  pthread_barrier_wait(&w->bar);
  const int other = 1 - me->rank;
  int ok = w->ncomp[other] == ncomp && nown == (walls ? me->nwown : me->nfown) &&
           nghost == (walls ? me->nw - me->nwown : me->nf - me->nfown);
  const int *owner = walls ? me->w_owner : me->f_owner;
  for (int g = 0; ok && g < nghost; g++)
    for (int k = 0; k < ncomp; k++) ghost[(size_t)ncomp * g + k] = w->own[other][(size_t)ncomp * owner[g] + k];
  pthread_barrier_wait(&w->bar);
  return ok ? 0 : 1;
}

/* the ghosts' new state from their owners after the drift (the shims: the engine's forward communication) */
static int ghost_update(fake_rank *me) {
  fake_world *w = me->w;
  int rc = sphdem_get_fluid_rows(me->c, me->rx, me->rv, me->rrho, me->rst);
  pthread_barrier_wait(&w->bar);
  const fake_rank *o = g_ranks[1 - me->rank];
  const int ng = me->nf - me->nfown;
  double *x = (double *)malloc(24 * (size_t)(ng + 1)), *v = (double *)malloc(24 * (size_t)(ng + 1));
  double *rho = (double *)malloc(8 * (size_t)(ng + 1)), *st = (double *)calloc((size_t)(ng + 1), 8 * SPHDEM_NSTATE);
  for (int g = 0; g < ng; g++) {
    const int k = me->f_owner[g];
    for (int d = 0; d < 3; d++) x[3 * g + d] = o->rx[3 * k + d], v[3 * g + d] = o->rv[3 * k + d];
    rho[g] = o->rrho[k];
    for (int j = 0; j < 4; j++) st[SPHDEM_NSTATE * g + j] = o->rst[SPHDEM_NSTATE * k + j];
  }
  pthread_barrier_wait(&w->bar); /* both have read the other's rows */
  if (!rc) rc = sphdem_update_ghosts(me->c, ng, x, v, rho, st);
  free(x); free(v); free(rho); free(st);
  return rc;
}

static void *rank_main(void *arg) {
  fake_rank *me = (fake_rank *)arg;
  const scene *s = me->s;
  char msg[256];
  int rc = sphdem_create(&me->c, me->p, test_device(), msg, sizeof msg);
  if (rc) { printf("create: %s\n", msg); me->rc = rc; return NULL; }
  sphdem_comm cm = {me, fake_allreduce, me->rank, 2, NULL};
  double *fx = (double *)malloc(24 * (size_t)me->nf), *fv = (double *)calloc((size_t)me->nf, 24);
  double *frho = (double *)malloc(8 * (size_t)me->nf), *fm = (double *)malloc(8 * (size_t)me->nf);
  int64_t *ft = (int64_t *)malloc(8 * (size_t)me->nf);
  double *wx = (double *)malloc(24 * (size_t)me->nw), *wm = (double *)malloc(8 * (size_t)me->nw);
  for (int k = 0; k < me->nf; k++) {
    const int i = me->fg[k];
    for (int d = 0; d < 3; d++) fx[3 * k + d] = s->x[3 * i + d];
    frho[k] = s->rho[i], fm[k] = s->mass[i], ft[k] = s->tag[i];
  }
  for (int k = 0; k < me->nw; k++) {
    const int i = me->wg[k];
    for (int d = 0; d < 3; d++) wx[3 * k + d] = s->wx[3 * i + d];
    wm[k] = s->wmass[i];
  }
  const double dt = 0.2 * me->p->h / (1.2 * me->p->c0);
  rc = sphdem_set_comm(me->c, &cm);
  if (!rc) rc = sphdem_set_exchange(me->c, fake_exchange, me);
  if (!rc) rc = sphdem_set_walls(me->c, me->nw, wx, NULL, NULL, wm);
  if (!rc) rc = sphdem_set_fluid(me->c, me->nf, ft, fx, fv, frho, fm, NULL);
  if (!rc) rc = sphdem_set_ghosts(me->c, me->nf - me->nfown, me->nw - me->nwown);
  if (!rc && me->use_rows) rc = sphdem_set_exchange_rows(me->c, 0, me->nfrows, me->frows);
  if (!rc && me->use_rows) rc = sphdem_set_exchange_rows(me->c, 1, me->nwrows, me->wrows);
  if (!rc) rc = sphdem_compute_rates(me->c);
  for (int step = 0; step < NSTEP && !rc; step++) {
    rc = sphdem_kick(me->c, 0.5 * dt);
    if (!rc) rc = sphdem_drift(me->c, dt);
    if (!rc) rc = ghost_update(me);
    if (!rc) rc = sphdem_compute_rates(me->c);
    if (!rc) rc = sphdem_kick(me->c, 0.5 * dt);
  }
  if (!rc) rc = sphdem_fluid_moved(me->c, &me->moved_core);
  /* the owned particles, their largest move since the upload, and the rows against the full download */
  double *x = (double *)malloc(24 * (size_t)me->nf), *v = (double *)malloc(24 * (size_t)me->nf);
  double *rho = (double *)malloc(8 * (size_t)me->nf), *st = (double *)malloc(8 * SPHDEM_NSTATE * (size_t)me->nf);
  if (!rc) rc = sphdem_get_fluid(me->c, x, v, rho, NULL, st);
  me->moved_host = 0.0;
  for (int k = 0; !rc && k < me->nfown; k++) {
    const int i = me->fg[k];
    double d2 = 0.0;
    for (int d = 0; d < 2; d++) d2 += (x[3 * k + d] - fx[3 * k + d]) * (x[3 * k + d] - fx[3 * k + d]);
    if (d2 > me->moved_host) me->moved_host = d2;
    for (int d = 0; d < 3; d++) me->gx[3 * i + d] = x[3 * k + d], me->gv[3 * i + d] = v[3 * k + d];
    me->grho[i] = rho[k];
  }
  if (!rc) {
    const double sentinel = -12345.0;
    double *rx = (double *)malloc(24 * (size_t)me->nf), *rst = (double *)malloc(8 * SPHDEM_NSTATE * (size_t)me->nf);
    for (int k = 0; k < 3 * me->nf; k++) rx[k] = sentinel;
    for (int k = 0; k < SPHDEM_NSTATE * me->nf; k++) rst[k] = sentinel;
    rc = sphdem_get_fluid_rows(me->c, rx, NULL, NULL, rst);
    char *in = (char *)calloc((size_t)me->nf, 1);
    for (int r = 0; r < (me->use_rows ? me->nfrows : me->nfown); r++) in[me->use_rows ? me->frows[r] : r] = 1;
    me->rows_same = me->rows_kept = 1;
    for (int k = 0; k < me->nf; k++) {
      for (int d = 0; d < 3; d++)
        if (in[k] ? memcmp(&rx[3 * k + d], &x[3 * k + d], 8) != 0 : rx[3 * k + d] != sentinel)
          in[k] ? (me->rows_same = 0) : (me->rows_kept = 0);
      for (int j = 0; j < SPHDEM_NSTATE; j++) /* drho and a at the rows; the rest (u) left alone */
        if (in[k] && j < 4 ? memcmp(&rst[SPHDEM_NSTATE * k + j], &st[SPHDEM_NSTATE * k + j], 8) != 0
                           : rst[SPHDEM_NSTATE * k + j] != sentinel)
          in[k] && j < 4 ? (me->rows_same = 0) : (me->rows_kept = 0);
    }
    free(in); free(rx); free(rst);
  }
  if (rc) printf("rank %d: %s (%s)\n", me->rank, sphdem_strerror(rc), sphdem_last_error(me->c));
  me->rc = rc;
  free(x); free(v); free(rho); free(st);
  free(fx); free(fv); free(frho); free(fm); free(ft); free(wx); free(wm);
  sphdem_destroy(&me->c);
  return NULL;
}

/* the two ranks' shares of the scene, cut at xc; band = 2h + skin */
static void split(fake_rank r[2], const scene *s, double xc, double band) {
  for (int me = 0; me < 2; me++) {
    fake_rank *R = &r[me];
    R->fg = (int *)malloc(sizeof(int) * (size_t)s->nf), R->wg = (int *)malloc(sizeof(int) * (size_t)s->nw);
    R->f_owner = (int *)malloc(sizeof(int) * (size_t)s->nf), R->w_owner = (int *)malloc(sizeof(int) * (size_t)s->nw);
    R->frows = (int *)malloc(sizeof(int) * (size_t)s->nf), R->wrows = (int *)malloc(sizeof(int) * (size_t)s->nw);
  }
  int *fslot[2], *wslot[2]; /* global index -> caller index of its owner */
  for (int me = 0; me < 2; me++) {
    fslot[me] = (int *)malloc(sizeof(int) * (size_t)s->nf), wslot[me] = (int *)malloc(sizeof(int) * (size_t)s->nw);
    fake_rank *R = &r[me];
    R->nf = R->nw = R->nfrows = R->nwrows = 0;
    for (int i = 0; i < s->nf; i++)
      if ((s->x[3 * i] < xc) == (me == 0)) {
        fslot[me][i] = R->nf;
        if (fabs(s->x[3 * i] - xc) < band) R->frows[R->nfrows++] = R->nf;
        R->fg[R->nf++] = i;
      }
    R->nfown = R->nf;
    for (int i = 0; i < s->nw; i++)
      if ((s->wx[3 * i] < xc) == (me == 0)) {
        wslot[me][i] = R->nw;
        if (fabs(s->wx[3 * i] - xc) < band) R->wrows[R->nwrows++] = R->nw;
        R->wg[R->nw++] = i;
      }
    R->nwown = R->nw;
  }
  for (int me = 0; me < 2; me++) {
    fake_rank *R = &r[me];
    for (int i = 0; i < s->nf; i++)
      if ((s->x[3 * i] < xc) != (me == 0) && fabs(s->x[3 * i] - xc) < band) {
        R->f_owner[R->nf - R->nfown] = fslot[1 - me][i];
        R->fg[R->nf++] = i;
      }
    for (int i = 0; i < s->nw; i++)
      if ((s->wx[3 * i] < xc) != (me == 0) && fabs(s->wx[3 * i] - xc) < band) {
        R->w_owner[R->nw - R->nwown] = wslot[1 - me][i];
        R->wg[R->nw++] = i;
      }
  }
  for (int me = 0; me < 2; me++) { free(fslot[me]); free(wslot[me]); }
}

static void free_split(fake_rank r[2]) {
  for (int me = 0; me < 2; me++) {
    free(r[me].fg); free(r[me].wg); free(r[me].f_owner); free(r[me].w_owner); free(r[me].frows); free(r[me].wrows);
    free(r[me].rx); free(r[me].rv); free(r[me].rrho); free(r[me].rst);
  }
}

/* two ranks: the owned particles' x, v, rho by global index into gx, gv, grho; returns the ranks' rc */
static int run_two(const sphdem_params *p, const scene *s, int use_rows, double *gx, double *gv, double *grho,
                   fake_rank r[2]) {
  fake_world w;
  memset(&w, 0, sizeof w);
  pthread_barrier_init(&w.bar, NULL, 2);
  const double band = 2.0 * p->h + p->skin;
  memset(r, 0, 2 * sizeof *r);
  split(r, s, 0.05, band);
  pthread_t th[2];
  for (int me = 0; me < 2; me++) {
    fake_rank *R = &r[me];
    R->w = &w, R->rank = me, R->use_rows = use_rows, R->s = s, R->p = p;
    R->rx = (double *)calloc((size_t)R->nf, 24), R->rv = (double *)calloc((size_t)R->nf, 24);
    R->rrho = (double *)calloc((size_t)R->nf, 8), R->rst = (double *)calloc((size_t)R->nf, 8 * SPHDEM_NSTATE);
    R->gx = gx, R->gv = gv, R->grho = grho;
    g_ranks[me] = R;
  }
  for (int me = 0; me < 2; me++) pthread_create(&th[me], NULL, rank_main, &r[me]);
  for (int me = 0; me < 2; me++) pthread_join(th[me], NULL);
  pthread_barrier_destroy(&w.bar);
  return r[0].rc ? r[0].rc : r[1].rc;
}

/* the largest difference of a field relative to its largest magnitude */
static double rel_diff(const double *a, const double *b, int n) {
  double d = 0.0, m = 0.0;
  for (int i = 0; i < n; i++) {
    if (fabs(a[i] - b[i]) > d || isnan(a[i] - b[i])) d = isnan(a[i] - b[i]) ? INFINITY : fabs(a[i] - b[i]);
    if (fabs(a[i]) > m) m = fabs(a[i]);
  }
  return m > 0 ? d / m : d;
}

int main(void) {
  sphdem_params p;
  scene s;
  const double a = 0.1;
  scene_params_dambreak2d(&p, a, 20);
  scene_tank(&s, &p, 5 * a, 0, 4 * a, a, 2 * a, 3);
  const int nf = s.nf;
  printf("2D dam break: %d fluid, %d wall particles, %d steps, cut at x = %g (band 2h + skin = %g)\n", nf, s.nw, NSTEP,
         0.5 * a, 2 * p.h + p.skin);

  /* one rank */
  double *x1 = (double *)malloc(24 * (size_t)nf), *v1 = (double *)malloc(24 * (size_t)nf);
  double *rho1 = (double *)malloc(8 * (size_t)nf);
  sphdem_ctx c = scene_start(&p, &s, test_device());
  const double dt = 0.2 * p.h / (1.2 * p.c0);
  for (int step = 0; step < NSTEP; step++) SPHDEM_CHECK_RC(c, scene_step(c, dt));
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x1, v1, rho1, NULL, NULL));
  double moved1 = -1.0, moved_here = 0.0;
  SPHDEM_CHECK_RC(c, sphdem_fluid_moved(c, &moved1));
  for (int i = 0; i < nf; i++) {
    double d2 = 0.0;
    for (int d = 0; d < 2; d++) d2 += (x1[3 * i + d] - s.x[3 * i + d]) * (x1[3 * i + d] - s.x[3 * i + d]);
    if (d2 > moved_here) moved_here = d2;
  }
  TEST_ASSERT(moved1 == moved_here && moved1 > 0, "one rank: fluid_moved %.17g, here %.17g", moved1, moved_here);
  printf("one rank: largest move since the upload %.3e (core) %.3e (here)\n", sqrt(moved1), sqrt(moved_here));
  /* bad rows, each refused by name */
  int rows_bad[2] = {0, nf};
  int rc = sphdem_set_exchange_rows(c, 0, 2, rows_bad);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "row 1"), "a row past the owned ones: rc %d (%s)", rc,
              sphdem_last_error(c));
  rc = sphdem_set_exchange_rows(c, 2, 0, NULL);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(sphdem_last_error(c), "set must be"), "set 2: rc %d (%s)", rc,
              sphdem_last_error(c));
  rc = sphdem_set_exchange_rows(c, 0, 3, NULL);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG, "rows without an array: rc %d", rc);
  sphdem_destroy(&c);

  /* two ranks, the boundary rows only and every owned row */
  double *x2 = (double *)malloc(24 * (size_t)nf), *v2 = (double *)malloc(24 * (size_t)nf);
  double *rho2 = (double *)malloc(8 * (size_t)nf);
  double *x3 = (double *)malloc(24 * (size_t)nf), *v3 = (double *)malloc(24 * (size_t)nf);
  double *rho3 = (double *)malloc(8 * (size_t)nf);
  fake_rank r[2], ra[2];
  rc = run_two(&p, &s, 1, x2, v2, rho2, r);
  TEST_ASSERT(rc == SPHDEM_OK, "two ranks, boundary rows: rc %d", rc);
  int rc_all = run_two(&p, &s, 0, x3, v3, rho3, ra);
  TEST_ASSERT(rc_all == SPHDEM_OK, "two ranks, every row: rc %d", rc_all);
  if (rc == SPHDEM_OK && rc_all == SPHDEM_OK) {
    printf("ranks: owned %d + %d fluid (ghosts %d, %d), boundary rows %d + %d; walls owned %d + %d, rows %d + %d\n",
           r[0].nfown, r[1].nfown, r[0].nf - r[0].nfown, r[1].nf - r[1].nfown, r[0].nfrows, r[1].nfrows, r[0].nwown,
           r[1].nwown, r[0].nwrows, r[1].nwrows);
    const double ex = rel_diff(x2, x1, 3 * nf), ev = rel_diff(v2, v1, 3 * nf), er = rel_diff(rho2, rho1, nf);
    printf("two ranks against one after %d steps (relative to the field's largest value): x %.2e, v %.2e, rho %.2e "
           "(bound %.0e)\n", NSTEP, ex, ev, er, BOUND);
    TEST_ASSERT(ex <= BOUND && ev <= BOUND && er <= BOUND, "two ranks vs one: x %g v %g rho %g", ex, ev, er);
    double vmax = 0.0;
    for (int i = 0; i < 3 * nf; i++) vmax = fmax(vmax, fabs(v1[i]));
    TEST_ASSERT(vmax > 1e-3, "the fluid moves (largest |v| %g)", vmax);
    TEST_ASSERT(!memcmp(x2, x3, 24 * (size_t)nf) && !memcmp(v2, v3, 24 * (size_t)nf) &&
                !memcmp(rho2, rho3, 8 * (size_t)nf), "boundary rows and every owned row give the same bits");
    for (int me = 0; me < 2; me++) {
      TEST_ASSERT(r[me].nfrows > 0 && r[me].nfrows < r[me].nfown && r[me].nwrows > 0 && r[me].nwrows < r[me].nwown,
                  "rank %d: a boundary slice (fluid %d of %d, walls %d of %d)", me, r[me].nfrows, r[me].nfown,
                  r[me].nwrows, r[me].nwown);
      TEST_ASSERT(r[me].rows_same && ra[me].rows_same, "rank %d: get_fluid_rows gives get_fluid's bits at the rows", me);
      TEST_ASSERT(r[me].rows_kept, "rank %d: get_fluid_rows leaves the other entries", me);
      TEST_ASSERT(r[me].moved_core == r[me].moved_host && r[me].moved_core > 0,
                  "rank %d: fluid_moved %.17g, here %.17g", me, r[me].moved_core, r[me].moved_host);
    }
  }
  free_split(r);
  free_split(ra);
  free(x1); free(v1); free(rho1); free(x2); free(v2); free(rho2); free(x3); free(v3); free(rho3);
  scene_free(&s);
  return test_summary("unit_fluid_comm");
}
