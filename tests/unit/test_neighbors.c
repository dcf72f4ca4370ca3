/* test_neighbors.c - cell-list neighbor search and sort vs brute force (2D/3D, periodic or not). */
#include "scene.h"
#include "sph_bodies.h"
#include "testlib.h"

static int cmp_pair(const void *a, const void *b) {
  const int64_t *x = (const int64_t *)a, *y = (const int64_t *)b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  if (x[1] != y[1]) return x[1] < y[1] ? -1 : 1;
  return 0;
}

static void run_case(int dim, int periodic, int n, unsigned seed, sphdem_device dev) {
  sphdem_params p;
  sphdem_params_default(&p);
  p.dim = dim; p.dx = 0.01; p.h = 0.013; p.rho0 = 1000; p.c0 = 10; p.skin = 0.003;
  double L = dim == 3 ? 0.1 : 0.3;
  for (int d = 0; d < dim; d++) { p.boxlo[d] = 0; p.boxhi[d] = L; p.periodic[d] = periodic; }
  srand(seed);
  scene s;
  memset(&s, 0, sizeof s);
  for (int i = 0; i < n; i++) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < dim; d++) x[d] = L * rand() / (RAND_MAX + 1.0);
    /* shuffle tags so that device order differs from upload order */
    scene_push_fluid(&s, x, 1000, 1e-3);
  }
  for (int i = 0; i < n; i++) s.tag[i] = (int64_t)((i * 7919L) % n) + 1;
  sphdem_ctx c;
  char msg[256];
  TEST_ASSERT(sphdem_create(&c, &p, dev, msg, sizeof msg) == SPHDEM_OK, "create: %s", msg);
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, n, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  int64_t maxp = (int64_t)n * 200;
  int64_t *got = (int64_t *)malloc(16 * (size_t)maxp), *ref = (int64_t *)malloc(16 * (size_t)maxp);
  int64_t ng = sphdem_debug_pairs(c, got, maxp), nr = 0;
  double h2 = 4 * p.h * p.h;
  for (int i = 0; i < n; i++)
    for (int j = i + 1; j < n; j++) {
      double r2 = 0;
      for (int d = 0; d < dim; d++) {
        double dd = s.x[3 * i + d] - s.x[3 * j + d];
        if (periodic) dd -= L * rint(dd / L);
        r2 += dd * dd;
      }
      if (r2 < h2) { ref[2 * nr] = i; ref[2 * nr + 1] = j; nr++; }
    }
  qsort(got, (size_t)ng, 16, cmp_pair);
  qsort(ref, (size_t)nr, 16, cmp_pair);
  TEST_ASSERT(ng == nr, "dim %d periodic %d: cell search found %lld pairs, brute force %lld", dim, periodic,
              (long long)ng, (long long)nr);
  int same = ng == nr && memcmp(got, ref, 16 * (size_t)nr) == 0;
  TEST_ASSERT(same, "dim %d periodic %d: pair lists differ", dim, periodic);
  /* round trip: download gives back what was uploaded, in the caller's order */
  double *x = (double *)malloc(24 * (size_t)n);
  SPHDEM_CHECK_RC(c, sphdem_get_fluid(c, x, NULL, NULL, NULL, NULL));
  TEST_ASSERT(memcmp(x, s.x, 24 * (size_t)n) == 0, "download after sort returns the upload order");
  /* in-place re-upload (same tags, other order) keeps the device order: no new sort */
  int64_t ns = sphdem_nsorts(c);
  SPHDEM_CHECK_RC(c, sphdem_set_fluid(c, n, s.tag, s.x, s.v, s.rho, s.mass, NULL));
  TEST_ASSERT(sphdem_debug_pairs(c, got, maxp) == nr && sphdem_nsorts(c) == ns,
              "in-place re-upload keeps the order (sorts %lld -> %lld)", (long long)ns, (long long)sphdem_nsorts(c));
  printf("  dim %d periodic %d: %lld pairs match brute force\n", dim, periodic, (long long)nr);
  free(got); free(ref); free(x);
  scene_free(&s);
  sphdem_destroy(&c);
}

int main(void) {
  sphdem_device dev = test_device();
  for (int dim = 2; dim <= 3; dim++)
    for (int per = 0; per <= 1; per++) run_case(dim, per, dim == 2 ? 3000 : 4000, 12345u + dim * 10 + per, dev);
  return test_summary("neighbors");
}
