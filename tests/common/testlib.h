/* testlib.h - minimal assertions for the C tests; each test prints "N passed, N failed". */
#ifndef SPHDEM_TESTLIB_H
#define SPHDEM_TESTLIB_H
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sphdem.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* urand(): xorshift64, uniform in [0, 1), for the tests that define TEST_RNG_SEED (their own seed) before this header */
#ifdef TEST_RNG_SEED
static uint64_t test_rng_ = TEST_RNG_SEED;
static double urand(void) {
  test_rng_ ^= test_rng_ << 13; test_rng_ ^= test_rng_ >> 7; test_rng_ ^= test_rng_ << 17;
  return (double)(test_rng_ >> 11) / 9007199254740992.0;
}
#endif

static int test_npass_, test_nfail_;
#define TEST_ASSERT(cond, ...)                                             \
  do {                                                                     \
    if (cond) test_npass_++;                                               \
    else { test_nfail_++; printf("FAIL %s:%d: ", __FILE__, __LINE__); printf(__VA_ARGS__); printf("\n"); } \
  } while (0)

/* Exit status of a test that cannot run here: 77, which ctest reports as skipped (SKIP_RETURN_CODE), or 1 (failed)
 * when SPHDEM_REQUIRE_GPU=1 says that this machine must run the GPU tests (bench/gpu/gpu_check.sh sets it). */
static int test_skip(const char *why) {
  const char *r = getenv("SPHDEM_REQUIRE_GPU");
  int required = r && strcmp(r, "") && strcmp(r, "0");
  printf("%s: %s\n", required ? "FAIL (SPHDEM_REQUIRE_GPU=1)" : "skipped", why);
  fflush(stdout);
  return required ? 1 : 77;
}

/* Backend under test: SPHDEM_TEST_DEVICE=cpu|gpu|auto (default cpu). */
static sphdem_device test_device(void) {
  const char *e = getenv("SPHDEM_TEST_DEVICE");
  if (e && !strcmp(e, "gpu")) return SPHDEM_DEVICE_GPU;
  if (e && !strcmp(e, "auto")) return SPHDEM_DEVICE_AUTO;
  return SPHDEM_DEVICE_CPU;
}

/* With SPHDEM_TEST_DEVICE=gpu and no usable GPU (or a build without the CUDA backend) every test that includes this
 * header stops before main with test_skip's status, so the GPU registrations of ctest (label gpu) skip at once. */
#if defined(__GNUC__)
__attribute__((constructor)) static void test_gpu_gate_(void) {
  if (test_device() == SPHDEM_DEVICE_GPU && !sphdem_gpu_available()) exit(test_skip("no usable GPU (or built without CUDA)"));
}
#endif

/* A DEM context on the backend under test with one wall, the floor y = 0 (normal +y): the rc of the create (its
 * message printed; *dem = NULL) or of the wall upload. */
static inline int test_dem_on_floor(const sphdem_dem_params *p, sphdem_dem *dem) {
  char msg[256];
  int rc = sphdem_dem_create(dem, p, test_device(), msg, sizeof msg);
  if (rc) { printf("create: %s\n", msg); *dem = NULL; return rc; }
  sphdem_dem_wall wall = {{0, 0, 0}, {0, 1, 0}};
  return sphdem_dem_set_walls(*dem, 1, &wall);
}

static int test_summary(const char *name) {
  printf("%s: %d passed, %d failed\n", name, test_npass_, test_nfail_);
  return test_nfail_ ? 1 : 0;
}
#endif
