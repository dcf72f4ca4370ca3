/* pair_gran_gpu.h - pair_style gran/gpu (LIGGGHTS): "model hertz tangential history
 * [rolling_friction cdt]" with the material of fix property/global, evaluated by the sphdem DEM core. */
#ifdef PAIR_CLASS
PairStyle(gran/gpu,PairGranGPU)
#else

#ifndef SPHDEM_PAIR_GRAN_GPU_H
#define SPHDEM_PAIR_GRAN_GPU_H

#include <string>
#include <vector>

#include "pair.h"
#include "pair_gran_gpu_restart.h"
#include "pair_gran_gpu_timers.h"
#include "sphdem.h"

namespace LAMMPS_NS {

class PairGranGPU : public Pair {
 public:
  explicit PairGranGPU(class LAMMPS *);
  ~PairGranGPU() override;
  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  double memory_usage() override;
  void write_restart(FILE *) override;
  void read_restart(FILE *, const int major, const int minor) override; /* LIGGGHTS signature */

 private:
  int rolling_, limit_force_, device_, algo_; /* rolling_: 0 off, 1 cdt, 2 epsd2, 3 epsd */
  int hooke_, kt_to_kn_; /* model hooke (else hertz); ktToKnUser on */
  int tangential_damping_; /* tangential_damping on (default) / off */
  int cohesion_;           /* sphdem_dem_cohesion: off, sjkr, sjkr2 */
  int nmat_;               /* 0: one material; else atom->ntypes materials, their type-pair values below */
  std::vector<double> mat_E_, mat_nu_, mat_en_, mat_mu_, mat_mur_, mat_ced_, mat_rvd_;
  std::vector<double> maxrad_dynamic_, maxrad_frozen_; /* per type (1..ntypes), as the stock style */
  int freeze_group_bit_;
  sphdem_dem dem_;
  sphdem_dem_params prm_;
  double box_lo_[3], box_hi_[3];
  int box_per_[3];
  std::vector<int64_t> tags_;
  std::vector<double> fbuf_, tbuf_;
  std::vector<int> flags_;
  sphdem_pair_timers::RunTimers timers_;  /* keyword timers on */
  sphdem_restart::PendingHistory pending_history_; /* from read_restart, handed to the core in init_style */

  void allocate();
  [[noreturn]] void fail(const std::string &msg);
  bool material(const char *name, const char *kind, std::vector<double> &out);
  void apply_materials();
  void sync_params();
};

}  // namespace LAMMPS_NS

#endif
#endif
