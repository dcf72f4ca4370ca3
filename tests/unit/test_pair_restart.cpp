/* test_pair_restart.cpp - the restart-file reader of the GPU granular pair styles
 * (src_fix/pair/pair_gran_gpu_restart.h, no engine needed): a history written from a real DEM core reads
 * back and restores; corrupt or truncated counts and keys are refused with a message before anything
 * is allocated (no std::bad_alloc / std::length_error reaches the engine). */
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "pair_gran_gpu_restart.h"
#include "testlib.h"

/* a core with three grains in a row, each touching the next: two contacts with history */
static sphdem_dem touching_core() {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.kn = 1e5; p.kt = 2e4;
  p.skin = 1e-4;
  sphdem_dem d = nullptr;
  char msg[256];
  if (sphdem_dem_create(&d, &p, SPHDEM_DEVICE_CPU, msg, sizeof msg)) { printf("create: %s\n", msg); exit(1); }
  int64_t tag[3] = {4, 9, 11};
  double r0 = 0.001, x[9] = {0, 0, 0, 1.9 * r0, 0, 0, 3.8 * r0, 0, 0}, v[9] = {0, 0.1, 0, 0, -0.1, 0, 0, 0.2, 0};
  double om[9] = {0}, r[3] = {r0, r0, r0}, m[3] = {1e-6, 1e-6, 1e-6}, f[9], t[9];
  if (sphdem_dem_compute(d, 3, tag, x, v, om, r, m, nullptr, 1e-6, 1, f, t, nullptr)) {
    printf("compute: %s\n", sphdem_dem_last_error(d));
    exit(1);
  }
  return d;
}

/* the file as bytes: count, keys, histories, then `tail` bytes of whatever follows in a restart file */
static std::vector<unsigned char> history_file(sphdem_dem d) {
  FILE *fp = tmpfile();
  TEST_ASSERT(sphdem_restart::write_history(fp, d), "write_history");
  long n = ftell(fp);
  std::vector<unsigned char> b((size_t)n);
  rewind(fp);
  TEST_ASSERT(fread(b.data(), 1, b.size(), fp) == b.size(), "read back the written history");
  fclose(fp);
  return b;
}

/* read `bytes` (+ `tail` zero bytes after them) through PendingHistory::read */
static bool read_bytes(const std::vector<unsigned char> &bytes, int64_t natoms, sphdem_restart::PendingHistory &h,
                       size_t tail = 0) {
  FILE *fp = tmpfile();
  fwrite(bytes.data(), 1, bytes.size(), fp);
  std::vector<unsigned char> z(tail, 0);
  if (tail) fwrite(z.data(), 1, tail, fp);
  rewind(fp);
  bool ok = false;
  try {
    ok = h.read(fp, natoms);
  } catch (...) {
    TEST_ASSERT(false, "read threw an exception");
  }
  fclose(fp);
  return ok;
}

static void set_count(std::vector<unsigned char> &b, int64_t np) { memcpy(b.data(), &np, sizeof np); }

int main() {
  sphdem_dem d = touching_core();
  std::vector<unsigned char> good = history_file(d);
  int64_t np = 0;
  memcpy(&np, good.data(), sizeof np);
  TEST_ASSERT(np >= 2 && good.size() == 16 + (size_t)np * (8 + 8 * SPHDEM_DEM_HIST_DOUBLES), "history of %lld pairs, %zu bytes",
              (long long)np, good.size());
  uint64_t per = 0;
  memcpy(&per, good.data() + 8, sizeof per);
  TEST_ASSERT(per == SPHDEM_DEM_HIST_DOUBLES, "values per pair written after the count (%llu)", (unsigned long long)per);

  /* the good file reads and restores, also with the rest of a restart file behind it */
  sphdem_restart::PendingHistory h;
  TEST_ASSERT(read_bytes(good, 3, h, 4096) && h.have && (int64_t)h.keys.size() == np, "good history read: %s",
              h.error.c_str());
  sphdem_dem d2 = touching_core();
  TEST_ASSERT(h.apply(d2) == SPHDEM_OK, "history restored into a new core: %s", sphdem_dem_last_error(d2));
  sphdem_dem_destroy(&d2);

  /* a file written before the values-per-pair field: keys right after the count, 4 values per pair; it reads,
   * each pair's largest overlap 0 and its first 4 values as written */
  {
    const size_t H = SPHDEM_DEM_HIST_DOUBLES, n = (size_t)np;
    std::vector<unsigned char> old(good.begin(), good.begin() + 8);
    old.insert(old.end(), good.begin() + 16, good.begin() + 16 + 8 * n);
    const double *hv = reinterpret_cast<const double *>(good.data() + 16 + 8 * n);
    for (size_t k = 0; k < n; k++) {
      const unsigned char *q = reinterpret_cast<const unsigned char *>(hv + k * H);
      old.insert(old.end(), q, q + 4 * sizeof(double));
    }
    sphdem_restart::PendingHistory lg;
    bool ok = read_bytes(old, 3, lg, 4096);
    bool same = ok && lg.hist.size() == n * H;
    for (size_t k = 0; same && k < n; k++)
      for (size_t v = 0; v < H; v++) same = same && lg.hist[k * H + v] == (v < 4 ? hv[k * H + v] : 0.0);
    TEST_ASSERT(ok && lg.have && same, "a history of 4 values per pair (earlier files) reads: %s", lg.error.c_str());
    std::vector<unsigned char> b = good;
    const uint64_t seven = 7;
    memcpy(b.data() + 8, &seven, sizeof seven);
    sphdem_restart::PendingHistory p7;
    TEST_ASSERT(!read_bytes(b, 3, p7) && p7.error.find("values per pair") != std::string::npos,
                "7 values per pair refused ('%s')", p7.error.c_str());
  }

  /* cut: bytes removed from the end; tail: bytes appended (the rest of a restart file) */
  struct Case { const char *what; int64_t count; int64_t natoms; size_t cut, tail; const char *want; };
  const size_t per_pair = 8 + 8 * SPHDEM_DEM_HIST_DOUBLES;
  const Case cases[] = {
    {"count 2^60", (int64_t)1 << 60, 3, 0, 0, "does not fit"},
    {"count INT64_MAX", INT64_MAX, -1, 0, 0, "does not fit"},
    {"negative count", -5, 3, 0, 0, "does not fit"},
    {"count one above the pairs written", np + 1, 3, 0, 0, "does not fit"},
    {"count above what 1 atom can have (17 > 16 walls)", 17, 1, 0, 17 * per_pair, "exceeds what 1 atoms can have"},
    {"count above what 10 atoms can have", 206, 10, 0, 206 * per_pair, "exceeds what 10 atoms can have"},
    {"file cut inside the keys", np, 3, 20, 0, "does not fit"},
    {"file cut inside the count", np, 3, good.size() - 4, 0, "ends before the contact-history count"},
  };
  for (const Case &c : cases) {
    std::vector<unsigned char> b = good;
    set_count(b, c.count);
    b.resize(b.size() - c.cut);
    sphdem_restart::PendingHistory p;
    bool ok = read_bytes(b, c.natoms, p, c.tail);
    TEST_ASSERT(!ok && !p.have && p.keys.empty() && p.error.find(c.want) != std::string::npos,
                "%s: refused with '%s' (got ok %d, '%s')", c.what, c.want, ok, p.error.c_str());
    TEST_ASSERT(p.error_or("fallback") == p.error, "%s: the message reaches the caller", c.what);
  }
  /* keys: tag 0, a pair written in the wrong order */
  const size_t key0 = sizeof(int64_t) + sizeof(uint64_t); /* after the count and the values per pair */
  for (int k = 0; k < 2; k++) {
    std::vector<unsigned char> b = good;
    uint64_t key = k == 0 ? ((uint64_t)0 << 32) | 9u : ((uint64_t)9 << 32) | 4u;
    memcpy(b.data() + key0, &key, sizeof key);
    sphdem_restart::PendingHistory p;
    bool ok = read_bytes(b, 3, p);
    TEST_ASSERT(!ok && p.error.find("has atom tags") != std::string::npos, "bad key %d refused ('%s')", k,
                p.error.c_str());
  }
  /* no error from read: the caller's own message */
  sphdem_restart::PendingHistory none;
  TEST_ASSERT(none.error_or("restart file ends inside the pair style's data") ==
                  "restart file ends inside the pair style's data", "fallback message");
  sphdem_dem_destroy(&d);
  return test_summary("unit_pair_restart");
}
