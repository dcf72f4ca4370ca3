/* testlib.h - minimal assertions for the C tests; each test prints "N passed, N failed". */
#ifndef SPHDEM_TESTLIB_H
#define SPHDEM_TESTLIB_H
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sphdem.h"

static int test_npass_, test_nfail_;
#define TEST_ASSERT(cond, ...)                                             \
  do {                                                                     \
    if (cond) test_npass_++;                                               \
    else { test_nfail_++; printf("FAIL %s:%d: ", __FILE__, __LINE__); printf(__VA_ARGS__); printf("\n"); } \
  } while (0)

/* Backend under test: SPHDEM_TEST_DEVICE=cpu|gpu|auto (default cpu). */
static sphdem_device test_device(void) {
  const char *e = getenv("SPHDEM_TEST_DEVICE");
  if (e && !strcmp(e, "gpu")) return SPHDEM_DEVICE_GPU;
  if (e && !strcmp(e, "auto")) return SPHDEM_DEVICE_AUTO;
  return SPHDEM_DEVICE_CPU;
}

static int test_summary(const char *name) {
  printf("%s: %d passed, %d failed\n", name, test_npass_, test_nfail_);
  return test_nfail_ ? 1 : 0;
}
#endif
