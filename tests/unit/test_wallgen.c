/* test_wallgen.c - dummy-wall points behind STL meshes (gpu/geom/wallgen.c): a lattice-aligned box gives the
 * hand-built lattice walls exactly, closed and open-top; no two points closer than dx/2; a drum's shell has
 * 2 pi r_k / dx points per ring and no gaps; flip and orient; a tilted box; exclusion near spheres; the fluid side of a
 * mesh (clip: a lattice in a large block keeps exactly the points inside a tilted box, an open-top box and a drum,
 * the far ones on both sides included); STL errors. */
#include <math.h>

#include "sphdem_geom.h"
#include "testlib.h"

static void add_tri(sphdem_mesh *m, const double *a, const double *b, const double *c) {
  m->f = (sphdem_facet *)realloc(m->f, (size_t)(m->nfacet + 1) * sizeof *m->f);
  sphdem_facet *f = &m->f[m->nfacet++];
  memcpy(f->v[0], a, 3 * sizeof(double));
  memcpy(f->v[1], b, 3 * sizeof(double));
  memcpy(f->v[2], c, 3 * sizeof(double));
  double u[3], v[3];
  for (int d = 0; d < 3; d++) {
    u[d] = b[d] - a[d];
    v[d] = c[d] - a[d];
  }
  f->n[0] = u[1] * v[2] - u[2] * v[1];
  f->n[1] = u[2] * v[0] - u[0] * v[2];
  f->n[2] = u[0] * v[1] - u[1] * v[0];
  double l = sqrt(f->n[0] * f->n[0] + f->n[1] * f->n[1] + f->n[2] * f->n[2]);
  for (int d = 0; d < 3; d++) f->n[d] /= l;
}
/* quad a b c d listed clockwise seen from the side the normal is to face (as tools/stl_shapes.py) */
static void add_quad(sphdem_mesh *m, const double *a, const double *b, const double *c, const double *d) {
  add_tri(m, a, c, b);
  add_tri(m, a, d, c);
}

static void rot(double *p, double ang, const double *piv) { /* about y through piv */
  double x = p[0] - piv[0], z = p[2] - piv[2], c = cos(ang), s = sin(ang);
  p[0] = piv[0] + c * x + s * z;
  p[2] = piv[2] - s * x + c * z;
}

/* box [lo, hi], normals inward; open_top leaves out z = hi; rotated by ang about y through the centre */
static void make_box(sphdem_mesh *m, const double *lo, const double *hi, int open_top, double ang) {
  memset(m, 0, sizeof *m);
  double P[8][3], piv[3];
  for (int i = 0; i < 8; i++) {
    P[i][0] = (i & 1) ? hi[0] : lo[0];
    P[i][1] = (i & 2) ? hi[1] : lo[1];
    P[i][2] = (i & 4) ? hi[2] : lo[2];
  }
  for (int d = 0; d < 3; d++) piv[d] = 0.5 * (lo[d] + hi[d]);
  if (ang != 0.0)
    for (int i = 0; i < 8; i++) rot(P[i], ang, piv);
#define Q(i, j, k) P[(i) | ((j) << 1) | ((k) << 2)]
  add_quad(m, Q(0, 0, 0), Q(0, 1, 0), Q(1, 1, 0), Q(1, 0, 0));
  if (!open_top) add_quad(m, Q(0, 0, 1), Q(1, 0, 1), Q(1, 1, 1), Q(0, 1, 1));
  add_quad(m, Q(0, 0, 0), Q(0, 0, 1), Q(0, 1, 1), Q(0, 1, 0));
  add_quad(m, Q(1, 0, 0), Q(1, 1, 0), Q(1, 1, 1), Q(1, 0, 1));
  add_quad(m, Q(0, 0, 0), Q(1, 0, 0), Q(1, 0, 1), Q(0, 0, 1));
  add_quad(m, Q(0, 1, 0), Q(0, 1, 1), Q(1, 1, 1), Q(1, 1, 0));
#undef Q
}

/* drum along y: radius r, length len, centre (0,0,0), seg facets, closed ends, normals inward */
static void make_drum(sphdem_mesh *m, double r, double len, int seg, int closed) {
  memset(m, 0, sizeof *m);
  double c0[3] = {0, -0.5 * len, 0}, c1[3] = {0, 0.5 * len, 0};
  for (int i = 0; i < seg; i++) {
    double t0 = 2 * M_PI * i / seg, t1 = 2 * M_PI * (i + 1) / seg;
    double a0[3] = {r * cos(t0), -0.5 * len, r * sin(t0)}, b0[3] = {r * cos(t1), -0.5 * len, r * sin(t1)};
    double a1[3] = {a0[0], 0.5 * len, a0[2]}, b1[3] = {b0[0], 0.5 * len, b0[2]};
    add_quad(m, a0, a1, b1, b0);
    if (closed) {
      add_tri(m, c0, b0, a0);
      add_tri(m, c1, a1, b1);
    }
  }
}

static int cmp3(const void *a, const void *b) {
  const double *x = (const double *)a, *y = (const double *)b;
  for (int d = 0; d < 3; d++)
    if (fabs(x[d] - y[d]) > 1e-9) return x[d] < y[d] ? -1 : 1;
  return 0;
}

/* the lattice walls the examples build by hand: points (i+1/2) dx in [lo - N dx, hi + N dx] (top: hi_z if open)
 * outside the box (inside: only those within N dx of a face, when inner) */
static void hand_walls(sphdem_points *p, const double *lo, const double *hi, double dx, int N, int open_top,
                       int inner) {
  double zt = open_top ? hi[2] : hi[2] + N * dx;
  for (double x = lo[0] - N * dx + 0.5 * dx; x < hi[0] + N * dx; x += dx)
    for (double y = lo[1] - N * dx + 0.5 * dx; y < hi[1] + N * dx; y += dx)
      for (double z = lo[2] - N * dx + 0.5 * dx; z < zt; z += dx) {
        int in = x > lo[0] && x < hi[0] && y > lo[1] && y < hi[1] && z > lo[2] && z < hi[2];
        if (!inner && in) continue;
        if (inner) {
          if (!in) continue;
          double dmin = fmin(fmin(fmin(x - lo[0], hi[0] - x), fmin(y - lo[1], hi[1] - y)), fmin(z - lo[2], hi[2] - z));
          if (dmin > N * dx) continue;
        }
        sphdem_points_push(p, x, y, z);
      }
}

/* the points as a set equal the expected set (within 1e-9 dx) */
static int same_set(sphdem_points *a, sphdem_points *b, double dx, const char *what) {
  if (a->n != b->n) {
    printf("  %s: %ld points, expected %ld\n", what, a->n, b->n);
    return 0;
  }
  for (long i = 0; i < 3 * a->n; i++) a->x[i] /= dx, b->x[i] /= dx;
  qsort(a->x, (size_t)a->n, 3 * sizeof(double), cmp3);
  qsort(b->x, (size_t)b->n, 3 * sizeof(double), cmp3);
  double worst = 0;
  for (long i = 0; i < 3 * a->n; i++) worst = fmax(worst, fabs(a->x[i] - b->x[i]));
  for (long i = 0; i < 3 * a->n; i++) a->x[i] *= dx, b->x[i] *= dx;
  printf("  %s: %ld points, max position difference %.2e dx\n", what, a->n, worst);
  return worst < 1e-9;
}

/* the walls of mesh m (N layers) against the hand-built ones (hand_walls(lo, hi, N, open_top 0, inner)); frees both */
static void expect_hand_walls(const sphdem_mesh *m, const double *lo, const double *hi, double dx, int N, int inner,
                              const double *O, const char *what, const char *claim) {
  sphdem_points got = {0}, want = {0};
  char msg[256] = "";
  int rc = sphdem_wall_from_mesh(m, dx, N, O, &got, msg, sizeof msg);
  hand_walls(&want, lo, hi, dx, N, 0, inner);
  TEST_ASSERT(rc == SPHDEM_OK && same_set(&got, &want, dx, what), "%s %s", claim, msg);
  sphdem_points_free(&got);
  sphdem_points_free(&want);
}

static double min_pair_distance(const sphdem_points *p) {
  double dmin = HUGE_VAL;
  for (long i = 0; i < p->n; i++)
    for (long j = i + 1; j < p->n; j++) {
      double d0 = p->x[3 * i] - p->x[3 * j], d1 = p->x[3 * i + 1] - p->x[3 * j + 1], d2 = p->x[3 * i + 2] - p->x[3 * j + 2];
      double d = d0 * d0 + d1 * d1 + d2 * d2;
      if (d < dmin) dmin = d;
    }
  return sqrt(dmin);
}

static double nearest(const sphdem_points *p, const double *x) {
  double dmin = HUGE_VAL;
  for (long i = 0; i < p->n; i++) {
    double d0 = p->x[3 * i] - x[0], d1 = p->x[3 * i + 1] - x[1], d2 = p->x[3 * i + 2] - x[2];
    double d = d0 * d0 + d1 * d1 + d2 * d2;
    if (d < dmin) dmin = d;
  }
  return sqrt(dmin);
}

static void test_box(void) {
  const double dx = 0.01, O[3] = {0.5 * dx, 0.5 * dx, 0.5 * dx};
  const double lo[3] = {0, 0, 0}, hi[3] = {8 * dx, 6 * dx, 10 * dx};
  char msg[256];
  for (int open_top = 0; open_top <= 1; open_top++) {
    sphdem_mesh m;
    make_box(&m, lo, hi, open_top, 0.0);
    sphdem_points got = {0}, want = {0};
    int rc = sphdem_wall_from_mesh(&m, dx, 3, O, &got, msg, sizeof msg);
    TEST_ASSERT(rc == SPHDEM_OK, "box walls: %s", msg);
    hand_walls(&want, lo, hi, dx, 3, open_top, 0);
    TEST_ASSERT(same_set(&got, &want, dx, open_top ? "open-top box, 3 layers" : "closed box, 3 layers"),
                "lattice-aligned box (open top %d) gives the hand-built lattice walls", open_top);
    TEST_ASSERT(min_pair_distance(&got) >= 0.5 * dx, "box: no two points closer than dx/2");
    /* flip: fluid outside, walls inside the box (3 layers from each face) */
    sphdem_points_free(&got);
    sphdem_points_free(&want);
    if (!open_top) {
      sphdem_mesh_flip(&m);
      expect_hand_walls(&m, lo, hi, dx, 2, 1, O, "flipped box, 2 layers inside", "flip: the walls go inside the box");
      /* orient toward the centre turns every facet back (the box again) */
      double c[3] = {4 * dx, 3 * dx, 5 * dx};
      long turned = sphdem_mesh_orient(&m, c);
      TEST_ASSERT(turned == m.nfacet, "orient turns all %ld flipped facets (turned %ld)", m.nfacet, turned);
      turned = sphdem_mesh_orient(&m, c);
      TEST_ASSERT(turned == 0, "orient again turns none (turned %ld)", turned);
      /* half of the facets flipped, then oriented: the box walls again */
      for (long f = 0; f < m.nfacet; f += 2) {
        sphdem_mesh tmp = {&m.f[f], 1, 0, 0};
        sphdem_mesh_flip(&tmp);
      }
      turned = sphdem_mesh_orient(&m, c);
      TEST_ASSERT(turned == m.nfacet / 2, "orient turns the %ld flipped facets (turned %ld)", m.nfacet / 2, turned);
      expect_hand_walls(&m, lo, hi, dx, 3, 0, O, "mixed normals oriented to the centre",
                        "orient: mixed normals give the box walls");
    }
    sphdem_mesh_free(&m);
  }
  /* transform: scale then move (a unit box scaled by 8 dx ... and moved by 2 dx) */
  sphdem_mesh m;
  double one[3] = {1, 1, 1}, zero[3] = {0, 0, 0}, mv[3] = {2 * dx, -3 * dx, 0};
  make_box(&m, zero, one, 0, 0.0);
  sphdem_mesh_transform(&m, 8 * dx, mv);
  double blo[3], bhi[3];
  sphdem_mesh_bbox(&m, blo, bhi);
  TEST_ASSERT(fabs(blo[0] - 2 * dx) < 1e-15 && fabs(bhi[0] - 10 * dx) < 1e-15 && fabs(blo[1] + 3 * dx) < 1e-15 &&
                  fabs(bhi[2] - 8 * dx) < 1e-15,
              "scale then move: bbox x [%g %g] y [%g %g]", blo[0], bhi[0], blo[1], bhi[1]);
  sphdem_mesh_free(&m);
}

static void test_drum(void) {
  const double dx = 0.01, r = 20 * dx, len = 10 * dx, O[3] = {0.5 * dx, 0.5 * dx, 0.5 * dx};
  const int N = 3, seg = 24;
  char msg[256];
  sphdem_mesh m;
  make_drum(&m, r, len, seg, 0);
  sphdem_points got = {0};
  int rc = sphdem_wall_from_mesh(&m, dx, N, O, &got, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "drum walls: %s", msg);
  double dmin = min_pair_distance(&got);
  TEST_ASSERT(dmin >= 0.5 * dx, "drum: no two points closer than dx/2 (min %.3f dx)", dmin / dx);
  /* rings: the layer k of a point is its depth behind the facet plane it lies behind, in dx, rounded down;
   * the mantle is open, so rows along the axis between -len/2 and len/2 (and N dx beyond? no: open edges) */
  const double apothem = r * cos(M_PI / seg);
  long ring[8] = {0}, inside = 0, outside_band = 0;
  for (long i = 0; i < got.n; i++) {
    const double *x = got.x + 3 * i;
    double rho = sqrt(x[0] * x[0] + x[2] * x[2]);
    if (rho < apothem - 1e-9) inside++;
    int k = (int)floor((rho - r) / dx); /* radial layer (centres at r + (k + 1/2) dx) */
    if (k < 0) k = 0;
    if (k >= N + 1) outside_band++;
    else ring[k]++;
    (void)x;
  }
  TEST_ASSERT(inside == 0, "drum: no wall point inside the drum (%ld)", inside);
  TEST_ASSERT(outside_band == 0, "drum: every point within %d dx of the mantle (%ld beyond)", N, outside_band);
  /* rows along the axis: only points over the facets (open ends are not extended): len / dx rows */
  long rows = (long)floor(len / dx + 1e-9);
  double total_expected = 0, total = 0;
  for (int k = 0; k < N; k++) total_expected += 2 * M_PI * (r + (k + 0.5) * dx) / dx * rows;
  for (int k = 0; k <= N; k++) total += ring[k];
  printf("  drum r = %.0f dx, %d facets, %d layers: %ld points, 2 pi r_k / dx per ring x %ld rows = %.0f "
         "(rings by radius: %ld %ld %ld %ld)\n", r / dx, seg, N, got.n, rows, total_expected, ring[0], ring[1],
         ring[2], ring[3]);
  for (int k = 0; k < N; k++) {
    double e = 2 * M_PI * (r + (k + 0.5) * dx) / dx * rows;
    TEST_ASSERT(fabs(ring[k] / e - 1.0) < 0.10, "drum ring %d: %ld points, 2 pi r_k / dx x rows = %.0f (bound 10 %%)",
                k, ring[k], e);
  }
  TEST_ASSERT(fabs(total / total_expected - 1.0) < 0.10, "drum shell count within 10 %% of sum_k 2 pi r_k / dx "
              "per row (%.0f vs %.0f)", total, total_expected);
  /* no gaps: every point of the inner two layers' band (radius r + 0.1 dx .. r + (N - 1) dx, inside the ends)
   * has a wall point within dx (a square lattice leaves at most 0.87 dx) */
  double worst = 0;
  for (int a = 0; a < 720; a++)
    for (int s = 0; s < 5; s++) {
      double t = 2 * M_PI * (a + 0.37) / 720, rr = r + (0.1 + s * (N - 1.1) / 4.0) * dx;
      double y = -0.5 * len + (0.5 + (a % 10)) * len / 11.0;
      double x[3] = {rr * cos(t), y, rr * sin(t)};
      worst = fmax(worst, nearest(&got, x));
    }
  TEST_ASSERT(worst <= dx, "drum: no gap in the shell (largest distance to a wall point %.3f dx, bound 1)",
              worst / dx);
  printf("  drum shell: largest distance from the band to a wall point %.3f dx\n", worst / dx);
  sphdem_points_free(&got);
  sphdem_mesh_free(&m);
  /* closed drum: the ends give walls too, and the rim has no gap */
  make_drum(&m, r, len, seg, 1);
  rc = sphdem_wall_from_mesh(&m, dx, N, O, &got, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "closed drum: %s", msg);
  dmin = min_pair_distance(&got);
  TEST_ASSERT(dmin >= 0.5 * dx, "closed drum: no two points closer than dx/2 (min %.3f dx)", dmin / dx);
  long in_fluid = 0;
  for (long i = 0; i < got.n; i++) {
    const double *x = got.x + 3 * i;
    if (sqrt(x[0] * x[0] + x[2] * x[2]) < apothem - 1e-9 && fabs(x[1]) < 0.5 * len - 1e-9) in_fluid++;
  }
  TEST_ASSERT(in_fluid == 0, "closed drum: no wall point in the fluid (%ld)", in_fluid);
  worst = 0;
  for (int a = 0; a < 360; a++) { /* the rim: beyond the end and beyond the mantle at once */
    double t = 2 * M_PI * (a + 0.37) / 360, rr = r + 0.6 * dx;
    double x[3] = {rr * cos(t), 0.5 * len + 0.6 * dx, rr * sin(t)};
    worst = fmax(worst, nearest(&got, x));
  }
  TEST_ASSERT(worst <= dx, "closed drum: no gap at the rim (largest distance %.3f dx, bound 1)", worst / dx);
  sphdem_points_free(&got);
  sphdem_mesh_free(&m);
}

/* facets narrower than dx (128 facets on a radius of 12 dx): no lattice column of their own; the fillers close
 * the shell */
static void test_narrow_facets(void) {
  const double dx = 0.005, r = 12 * dx, len = 6 * dx, O[3] = {0.5 * dx, 0.5 * dx, 0.5 * dx};
  char msg[256];
  sphdem_mesh m;
  make_drum(&m, r, len, 128, 1);
  sphdem_points got = {0};
  int rc = sphdem_wall_from_mesh(&m, dx, 3, O, &got, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "narrow facets: %s", msg);
  double worst = 0;
  for (int a = 0; a < 1440; a++) {
    double t = 2 * M_PI * (a + 0.37) / 1440, rr = r + (0.2 + 1.6 * (a % 7) / 6.0) * dx;
    double x[3] = {rr * cos(t), -0.5 * len + (0.5 + (a % 6)) * dx, rr * sin(t)};
    worst = fmax(worst, nearest(&got, x));
  }
  printf("  drum with 128 facets of width %.2f dx: %ld points, largest distance from the shell to a wall point "
         "%.3f dx\n", 2 * r * sin(M_PI / 128) / dx, got.n, worst / dx);
  TEST_ASSERT(worst <= dx, "narrow facets: no gap in the shell (%.3f dx, bound 1)", worst / dx);
  double dmin = min_pair_distance(&got);
  TEST_ASSERT(dmin >= 0.5 * dx, "narrow facets: no two points closer than dx/2 (min %.3f dx)", dmin / dx);
  sphdem_points_free(&got);
  sphdem_mesh_free(&m);
}

static void test_tilted(void) {
  const double dx = 0.01, O[3] = {0.5 * dx, 0.5 * dx, 0.5 * dx}, ang = 15.0 * M_PI / 180.0;
  const double lo[3] = {0, 0, 0}, hi[3] = {10 * dx, 5 * dx, 8 * dx};
  const int N = 3;
  char msg[256];
  sphdem_mesh m;
  make_box(&m, lo, hi, 0, ang);
  sphdem_points got = {0};
  int rc = sphdem_wall_from_mesh(&m, dx, N, O, &got, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK, "tilted box: %s", msg);
  double dmin = min_pair_distance(&got);
  TEST_ASSERT(dmin >= 0.5 * dx, "tilted box: no two points closer than dx/2 (min %.3f dx)", dmin / dx);
  /* in the box's own frame: nothing inside, everything within N dx (L-infinity) of the box */
  double piv[3] = {5 * dx, 2.5 * dx, 4 * dx};
  long bad_in = 0, bad_far = 0;
  for (long i = 0; i < got.n; i++) {
    double x[3] = {got.x[3 * i], got.x[3 * i + 1], got.x[3 * i + 2]};
    rot(x, -ang, piv);
    int in = 1;
    double far = 0;
    for (int d = 0; d < 3; d++) {
      if (!(x[d] > lo[d] + 1e-9 && x[d] < hi[d] - 1e-9)) in = 0;
      far = fmax(far, fmax(lo[d] - x[d], x[d] - hi[d]));
    }
    if (in) bad_in++;
    if (far > N * dx + 1e-9) bad_far++;
  }
  TEST_ASSERT(bad_in == 0 && bad_far == 0, "tilted box: %ld points inside, %ld beyond %d dx", bad_in, bad_far, N);
  /* no gap in the shell: the band 0.1 .. N - 1 dx outside each face (including edges) */
  double worst = 0;
  for (int s = 0; s < 4000; s++) {
    double u = (s * 0.6180339887) - floor(s * 0.6180339887), v = (s * 0.7548776662) - floor(s * 0.7548776662);
    double w = (s * 0.5698402910) - floor(s * 0.5698402910), dpt = (0.1 + (N - 1.1) * w) * dx;
    double x[3] = {lo[0] + u * (hi[0] - lo[0]), lo[1] + v * (hi[1] - lo[1]), lo[2] - dpt};
    if (s % 3 == 1) x[0] = hi[0] + dpt, x[2] = lo[2] + w * (hi[2] - lo[2]);
    if (s % 3 == 2) x[0] = lo[0] - dpt, x[1] = lo[1] - dpt, x[2] = lo[2] + u * (hi[2] - lo[2]); /* an edge */
    rot(x, ang, piv);
    worst = fmax(worst, nearest(&got, x));
  }
  printf("  tilted box (15 deg): %ld points, largest distance from the shell to a wall point %.3f dx\n", got.n,
         worst / dx);
  TEST_ASSERT(worst <= dx, "tilted box: no gap in the shell (%.3f dx, bound 1)", worst / dx);
  sphdem_points_free(&got);
  sphdem_mesh_free(&m);
}

static void test_points(void) {
  sphdem_points p = {0};
  for (int i = 0; i < 10; i++) sphdem_points_push(&p, 0.1 * i, 0, 0);
  sphdem_points_push(&p, 0.1 * 3 + 0.04, 0, 0); /* closer than 0.05 to point 3 */
  sphdem_points_push(&p, 0.5, 0.06, 0);         /* farther */
  long rm = sphdem_points_merge(&p, 0.05);
  TEST_ASSERT(rm == 1 && p.n == 11, "merge removes the one close point (removed %ld, left %ld)", rm, p.n);
  double sph[8] = {0.2, 0, 0, 0.05, 0.8, 0.0, 0.0, 0.05};
  /* gap 0.05: excluded if closer than r + gap = 0.1: the points at 0.2 and 0.8; those exactly 0.1 away (0.1, 0.3,
   * 0.7, 0.9, up to round-off) are kept */
  rm = sphdem_points_exclude(&p, sph, 2, 0.05, 1e-9);
  TEST_ASSERT(rm == 2 && p.n == 9, "exclude removes the points closer than r + gap (removed %ld)", rm);
  sphdem_points_free(&p);
}

static void test_stl(void) {
  char msg[256];
  sphdem_mesh m;
  const char *ok = "solid t\n facet normal 0 0 -1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n"
                   "   vertex 0 1 0\n  endloop\n endfacet\n facet normal 0 0 1\n outer loop vertex 0 0 0 vertex 1 0 0"
                   " vertex 2 0 0 endloop endfacet\nendsolid t\n";
  int rc = sphdem_stl_parse(ok, "ok.stl", &m, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_OK && m.nfacet == 1 && m.ndegenerate == 1 && m.ndisagree == 1,
              "parse: 1 facet, 1 degenerate, 1 normal against the winding (rc %d, %ld %ld %ld)", rc, m.nfacet,
              m.ndegenerate, m.ndisagree);
  TEST_ASSERT(rc == SPHDEM_OK && fabs(m.f[0].n[2] - 1.0) < 1e-15, "the normal comes from the winding");
  sphdem_mesh_free(&m);
  rc = sphdem_stl_parse("solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 zz\n", "bad.stl", &m, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "bad.stl:4") && strstr(msg, "zz"), "bad number named: %s", msg);
  rc = sphdem_stl_parse("\x50\x4b binary", "bin.stl", &m, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "ASCII"), "not ASCII STL refused: %s", msg);
  rc = sphdem_stl_read("/nonexistent/drum.stl", &m, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG && strstr(msg, "/nonexistent/drum.stl"), "missing file named: %s", msg);
  sphdem_mesh_free(&m);
  sphdem_points p = {0};
  double O[3] = {0, 0, 0};
  make_box(&m, O, (double[3]){1, 1, 1}, 0, 0);
  rc = sphdem_wall_from_mesh(&m, 0.0, 3, O, &p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG, "spacing 0 refused");
  rc = sphdem_wall_from_mesh(&m, 0.1, 0, O, &p, msg, sizeof msg);
  TEST_ASSERT(rc == SPHDEM_ERR_ARG, "layers 0 refused");
  sphdem_mesh_free(&m);
}

/* the lattice of spacing dx through (dx/2, dx/2, dx/2) in [lo, hi] */
static void lattice(sphdem_points *p, const double *lo, const double *hi, double dx) {
  for (double x = lo[0] + 0.5 * dx; x < hi[0]; x += dx)
    for (double y = lo[1] + 0.5 * dx; y < hi[1]; y += dx)
      for (double z = lo[2] + 0.5 * dx; z < hi[2]; z += dx) sphdem_points_push(p, x, y, z);
}

/* clip a lattice in a block much larger than the mesh: the kept points are those with inside(x) (an analytic
 * signed distance, > 0 inside) >= gap, up to the points within 1e-6 dx of that level */
static void clip_case(const char *what, sphdem_mesh *m, const double *lo, const double *hi, double dx, double gap,
                      double (*inside)(const double *)) {
  sphdem_points p = {0};
  lattice(&p, lo, hi, dx);
  long n0 = p.n, want = 0, amb = 0;
  for (long i = 0; i < n0; i++) {
    double s = inside(p.x + 3 * i);
    if (fabs(s - gap) < 1e-6 * dx) amb++;
    else if (s > gap) want++;
  }
  long rm = sphdem_points_clip_mesh(&p, m, dx, gap);
  long wrong = 0;
  for (long i = 0; i < p.n; i++)
    if (inside(p.x + 3 * i) < gap - 1e-6 * dx) wrong++;
  printf("  clip %s (gap %.2f dx): %ld of %ld lattice points kept, %ld expected (+ up to %ld on the level), "
         "%ld kept on the wrong side\n", what, gap / dx, p.n, n0, want, amb, wrong);
  TEST_ASSERT(rm >= 0 && wrong == 0 && p.n >= want && p.n <= want + amb,
              "clip %s: exactly the points on the fluid side (kept %ld, expected %ld..%ld, wrong %ld)", what, p.n,
              want, want + amb, wrong);
  sphdem_points_free(&p);
}

static const double CB_LO[3] = {0.013, 0.021, 0.017}, CB_HI[3] = {0.093, 0.071, 0.117};
static double CB_ANG = 0.0;
static double in_box(const double *x) { /* distance to the nearest face of the (rotated) box, > 0 inside */
  double piv[3], y[3] = {x[0], x[1], x[2]};
  for (int d = 0; d < 3; d++) piv[d] = 0.5 * (CB_LO[d] + CB_HI[d]);
  rot(y, -CB_ANG, piv);
  double s = HUGE_VAL;
  for (int d = 0; d < 3; d++) s = fmin(s, fmin(y[d] - CB_LO[d], CB_HI[d] - y[d]));
  return s;
}
static double in_open_box(const double *x) { /* open top: the top does not bound; above it the side walls' edges */
  double s = HUGE_VAL;
  for (int d = 0; d < 3; d++) {
    s = fmin(s, x[d] - CB_LO[d]);
    if (d < 2) s = fmin(s, CB_HI[d] - x[d]);
  }
  return s;
}
static double in_drum(const double *x) { /* 24-gon of circumradius 0.05 along y, length 0.04 */
  double a = atan2(x[2], x[0]), w = 2 * M_PI / 24, mid = (floor(a / w) + 0.5) * w;
  double s = 0.05 * cos(M_PI / 24) - (x[0] * cos(mid) + x[2] * sin(mid));
  return fmin(s, 0.02 - fabs(x[1]));
}

static void test_clip(void) {
  const double dx = 0.005;
  sphdem_mesh m;
  const double lo[3] = {-0.04, -0.03, -0.05}, hi[3] = {0.16, 0.13, 0.18};
  make_box(&m, CB_LO, CB_HI, 0, 0.0);
  CB_ANG = 0.0;
  clip_case("closed box", &m, lo, hi, dx, 0.0, in_box);
  clip_case("closed box", &m, lo, hi, dx, 0.2 * dx, in_box);
  sphdem_mesh_free(&m);
  CB_ANG = 15.0 * M_PI / 180.0;
  make_box(&m, CB_LO, CB_HI, 0, CB_ANG);
  clip_case("box tilted 15 deg", &m, lo, hi, dx, 0.0, in_box);
  sphdem_mesh_free(&m);
  make_box(&m, CB_LO, CB_HI, 1, 0.0);
  /* an open top: the points above the box within the side walls' planes count as inside (their nearest facet is
   * a side wall, whose normal points in); compare below the top only, where the answer is unambiguous */
  const double hi_open[3] = {0.16, 0.13, CB_HI[2] - 0.25 * dx};
  clip_case("open-top box (below its top)", &m, lo, hi_open, dx, 0.0, in_open_box);
  sphdem_mesh_free(&m);
  make_drum(&m, 0.05, 0.04, 24, 1);
  const double dlo[3] = {-0.09, -0.06, -0.09}, dhi[3] = {0.09, 0.06, 0.09};
  clip_case("closed drum (24 facets)", &m, dlo, dhi, dx, 0.0, in_drum);
  sphdem_mesh_free(&m);
}

int main(void) {
  test_box();
  test_drum();
  test_narrow_facets();
  test_tilted();
  test_points();
  test_clip();
  test_stl();
  printf("%d passed, %d failed\n", test_npass_, test_nfail_);
  return test_nfail_ ? 1 : 0;
}
