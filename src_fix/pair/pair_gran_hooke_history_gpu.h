/* pair_gran_hooke_history_gpu.h - pair_style gran/hooke/history/gpu (LAMMPS): the stock granular
 * Hooke contact with shear history, evaluated by the sphdem DEM core (CPU or CUDA). */
#ifdef PAIR_CLASS
PairStyle(gran/hooke/history/gpu,PairGranHookeHistoryGPU)
#else

#ifndef SPHDEM_PAIR_GRAN_HOOKE_HISTORY_GPU_H
#define SPHDEM_PAIR_GRAN_HOOKE_HISTORY_GPU_H

#include <string>
#include <vector>

#include "pair.h"
#include "pair_gran_gpu_restart.h"
#include "pair_gran_gpu_timers.h"
#include "sphdem.h"

namespace LAMMPS_NS {

class PairGranHookeHistoryGPU : public Pair {
 public:
  explicit PairGranHookeHistoryGPU(class LAMMPS *);
  ~PairGranHookeHistoryGPU() override;
  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  double memory_usage() override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;

 protected:
  /* the stock arguments (pair_gran_hooke_history semantics) */
  double kn, kt, gamman, gammat, xmu;
  int dampflag, limit_damping;
  int model;                /* sphdem_dem_model */
  std::string style;        /* for messages */
  std::vector<double> maxrad_dynamic, maxrad_frozen; /* per type (1..ntypes), as the stock style */
  int freeze_group_bit;
  sphdem_dem dem;
  int device_;              /* sphdem_device (keyword device) */
  int algo_;                /* sphdem_dem_algo (keyword algo) */
  sphdem_dem_params prm_;
  double box_lo[3], box_hi[3];
  int box_per[3];
  std::vector<int64_t> tags;
  std::vector<double> fbuf, tbuf;
  std::vector<int> flags;
  sphdem_pair_timers::RunTimers timers_;  /* keyword timers on */
  sphdem_restart::PendingHistory pending_history; /* from read_restart, handed to the core in init_style */

  void allocate();
  [[noreturn]] void fail(const std::string &msg);
  void sync_params();
};

}  // namespace LAMMPS_NS

#endif
#endif
