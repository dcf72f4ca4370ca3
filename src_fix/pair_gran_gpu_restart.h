/* pair_gran_gpu_restart.h - restart-file part shared by the GPU granular pair styles of both engines:
 * pair_coeff flags and the DEM core's tag-keyed contact history, written by write_restart and read
 * back into a pending copy that init_style hands to the core once it exists. One rank. */
#ifndef SPHDEM_PAIR_GRAN_GPU_RESTART_H
#define SPHDEM_PAIR_GRAN_GPU_RESTART_H

#include <cstdint>
#include <cstdio>
#include <vector>

#include "sphdem.h"

namespace sphdem_restart {

/* fread of n items; false when the file ends early */
inline bool read_items(FILE *fp, void *p, size_t size, size_t n) { return !n || fread(p, size, n, fp) == n; }

/* setflag[i][j] for 1 <= i <= j <= ntypes */
inline void write_setflag(FILE *fp, int **setflag, int ntypes) {
  for (int i = 1; i <= ntypes; i++)
    for (int j = i; j <= ntypes; j++) fwrite(&setflag[i][j], sizeof(int), 1, fp);
}
inline bool read_setflag(FILE *fp, int **setflag, int ntypes) {
  for (int i = 1; i <= ntypes; i++)
    for (int j = i; j <= ntypes; j++)
      if (!read_items(fp, &setflag[i][j], sizeof(int), 1)) return false;
  return true;
}

/* The contact history: count, keys, SPHDEM_DEM_HIST_DOUBLES doubles per pair. */
inline bool write_history(FILE *fp, sphdem_dem dem) {
  int64_t np = dem ? sphdem_dem_get_history(dem, nullptr, nullptr, 0) : 0;
  if (np < 0) return false;
  std::vector<uint64_t> keys((size_t)np);
  std::vector<double> hist((size_t)np * SPHDEM_DEM_HIST_DOUBLES);
  if (np > 0 && sphdem_dem_get_history(dem, keys.data(), hist.data(), np) != np) return false;
  fwrite(&np, sizeof(int64_t), 1, fp);
  if (np > 0) {
    fwrite(keys.data(), sizeof(uint64_t), (size_t)np, fp);
    fwrite(hist.data(), sizeof(double), hist.size(), fp);
  }
  return true;
}

struct PendingHistory {
  bool have = false;
  std::vector<uint64_t> keys;
  std::vector<double> hist;

  bool read(FILE *fp) {
    int64_t np = 0;
    if (!read_items(fp, &np, sizeof(int64_t), 1) || np < 0) return false;
    keys.resize((size_t)np);
    hist.resize((size_t)np * SPHDEM_DEM_HIST_DOUBLES);
    if (!read_items(fp, keys.data(), sizeof(uint64_t), keys.size()) ||
        !read_items(fp, hist.data(), sizeof(double), hist.size()))
      return false;
    have = true;
    return true;
  }
  /* hand the history to the core (once); SPHDEM_OK when there is nothing to hand over */
  int apply(sphdem_dem dem) {
    if (!have) return SPHDEM_OK;
    int rc = sphdem_dem_set_history(dem, (int64_t)keys.size(), keys.data(), hist.data());
    have = false;
    keys.clear();
    hist.clear();
    return rc;
  }
};

}  // namespace sphdem_restart

#endif
