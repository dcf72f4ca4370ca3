/* pair_gran_gpu.h - pair_style gran/gpu (LIGGGHTS): "model hertz|hooke|hooke/hysteresis tangential history
 * [rolling_friction ...] [cohesion ...]" with the material of fix property/global, evaluated by the sphdem DEM core. */
#ifdef PAIR_CLASS
PairStyle(gran/gpu,PairGranGPU)
#else

#ifndef SPHDEM_PAIR_GRAN_GPU_H
#define SPHDEM_PAIR_GRAN_GPU_H

#include <string>
#include <vector>

#include "pair_gran_gpu_base.h"

namespace LAMMPS_NS {

class PairGranGPU : public PairGranGPUBase {
 public:
  explicit PairGranGPU(class LAMMPS *);
  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  void write_restart(FILE *) override;
  void read_restart(FILE *, const int major, const int minor) override; /* LIGGGHTS signature */
  /* the history compute pair/gran/local writes besides the shear: the largest overlap (model hooke/hysteresis),
   * the rolling torque (rolling_friction epsd2, epsd) */
  bool hysteresis() const { return hooke_ == 2; }
  bool rolling_history() const { return rolling_ == 2 || rolling_ == 3; }

 private:
  int rolling_, limit_force_; /* rolling_: 0 off, 1 cdt, 2 epsd2, 3 epsd */
  int hooke_, kt_to_kn_; /* 0 model hertz, 1 hooke, 2 hooke/hysteresis; ktToKnUser on */
  int tangential_damping_; /* tangential_damping on (default) / off */
  int cohesion_;           /* sphdem_dem_cohesion: off, sjkr, sjkr2 */
  int nmat_;               /* 0: one material; else atom->ntypes materials, their type-pair values below */
  std::vector<double> mat_E_, mat_nu_, mat_en_, mat_mu_, mat_mur_, mat_ced_, mat_rvd_;
  std::vector<double> mat_k2_, mat_kc_, mat_phif_; /* hooke/hysteresis: kn2kcMax, kn2kc, phiF */

  bool material(const char *name, const char *kind, std::vector<double> &out);
  void apply_materials();
  void sync_params() override;
};

}  // namespace LAMMPS_NS

#endif
#endif
