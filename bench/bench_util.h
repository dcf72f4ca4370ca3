/* bench_util.h - what the C benchmarks of bench/ share: a wall clock, the --device and --threads options. */
#ifndef SPHDEM_BENCH_UTIL_H
#define SPHDEM_BENCH_UTIL_H
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include "sphdem.h"

static inline double wtime(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* "--name value" options: each sets a double ('d'), an int ('i') or a string ('s') */
typedef struct { const char *name; char type; void *dst; } bench_opt;

/* parses argv[1..] against the n options; 0: all known, 1: -h/--help, 2: an unknown option or one without value */
static inline int bench_parse(int argc, char **argv, const bench_opt *opt, int n) {
  for (int i = 1; i < argc; i++) {
    const char *k = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    if (!strcmp(k, "-h") || !strcmp(k, "--help")) return 1;
    if (!v) return 2;
    int j = 0;
    while (j < n && strcmp(k, opt[j].name)) j++;
    if (j == n) return 2;
    if (opt[j].type == 'd') *(double *)opt[j].dst = atof(v);
    else if (opt[j].type == 'i') *(int *)opt[j].dst = atoi(v);
    else *(const char **)opt[j].dst = v;
    i++;
  }
  return 0;
}

/* --device cpu|gpu|auto; 0 with *dev set, -1 for another name */
static inline int bench_device(const char *name, sphdem_device *dev) {
  if (!strcmp(name, "gpu")) *dev = SPHDEM_DEVICE_GPU;
  else if (!strcmp(name, "auto")) *dev = SPHDEM_DEVICE_AUTO;
  else if (!strcmp(name, "cpu")) *dev = SPHDEM_DEVICE_CPU;
  else return -1;
  return 0;
}

/* --threads T (> 0: omp_set_num_threads); returns the OpenMP thread count the run uses (1 without OpenMP) */
static inline int bench_threads(int threads) {
#ifdef _OPENMP
  if (threads > 0) omp_set_num_threads(threads);
  return omp_get_max_threads();
#else
  (void)threads;
  return 1;
#endif
}
#endif
