/* pair_gran_gpu_timers.h - per-run time split of the GPU granular pair styles of both engines (keyword
 * "timers on"): the host loops that map the atoms to the core's arrays and add the results back, and
 * the core's own split (sphdem_dem_timers); one line at the last step of each run, with the grain uploads of
 * every grain store of the process since the run's first step (before the fixes' post_force of the last step). Many MPI ranks: the times,
 * calls and builds are the largest of the ranks, pairs and contacts their sums (each pair counted once). */
#ifndef SPHDEM_PAIR_GRAN_GPU_TIMERS_H
#define SPHDEM_PAIR_GRAN_GPU_TIMERS_H

#include <chrono>
#include <cstdio>
#include <string>

#include "sphdem.h"
#include "sphdem_mpi.h"

namespace sphdem_pair_timers {

inline double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct RunTimers {
  int on = 0;
  double pack = 0.0, unpack = 0.0;
  int64_t uploads0 = 0; /* grain uploads of the process (every grain store) at the reset */
  /* called after the setup evaluation: time only the steps of the run */
  void reset(sphdem_dem dem) {
    pack = unpack = 0.0;
    uploads0 = sphdem_grains_uploads(nullptr);
    sphdem_dem_timers_reset(dem);
  }
  /* collective over world */
  std::string line(sphdem_dem dem, const std::string &style, MPI_Comm world) const {
    double t[SPHDEM_DEM_NTIMERS];
    double calls_d = (double)sphdem_dem_timers(dem, t);
    sphdem_dem_stats s;
    sphdem_dem_stats_get(dem, &s);
    double mx[SPHDEM_DEM_NTIMERS + 5], sm[2] = {(double)s.npairs, (double)s.ncontacts};
    for (int k = 0; k < SPHDEM_DEM_NTIMERS; k++) mx[k] = t[k];
    mx[SPHDEM_DEM_NTIMERS] = pack, mx[SPHDEM_DEM_NTIMERS + 1] = unpack, mx[SPHDEM_DEM_NTIMERS + 2] = calls_d;
    mx[SPHDEM_DEM_NTIMERS + 3] = (double)s.nbuilds;
    mx[SPHDEM_DEM_NTIMERS + 4] = (double)(sphdem_grains_uploads(nullptr) - uploads0);
    sphdem_mpi::max(world, mx, SPHDEM_DEM_NTIMERS + 5);
    sphdem_mpi::sum(world, sm, 2);
    for (int k = 0; k < SPHDEM_DEM_NTIMERS; k++) t[k] = mx[k];
    const double pk = mx[SPHDEM_DEM_NTIMERS], upk = mx[SPHDEM_DEM_NTIMERS + 1];
    const long long calls = (long long)mx[SPHDEM_DEM_NTIMERS + 2];
    s.nbuilds = (int64_t)mx[SPHDEM_DEM_NTIMERS + 3], s.npairs = (int64_t)sm[0], s.ncontacts = (int64_t)sm[1];
    char buf[768];
    std::snprintf(buf, sizeof buf,
                  "Pair %s timers: calls=%lld pack_s=%.6g upload_s=%.6g check_s=%.6g detect_s=%.6g force_s=%.6g "
                  "download_s=%.6g unpack_s=%.6g builds_total=%lld pairs=%lld contacts=%lld grain_uploads=%lld\n",
                  style.c_str(), calls, pk, t[SPHDEM_DEM_T_UPLOAD], t[SPHDEM_DEM_T_CHECK], t[SPHDEM_DEM_T_DETECT],
                  t[SPHDEM_DEM_T_FORCE], t[SPHDEM_DEM_T_DOWNLOAD], upk, (long long)s.nbuilds, (long long)s.npairs,
                  (long long)s.ncontacts, (long long)mx[SPHDEM_DEM_NTIMERS + 4]);
    return buf;
  }
};

}  // namespace sphdem_pair_timers

#endif
