/* pair_gran_hooke_history_gpu.h - pair_style gran/hooke/history/gpu (LAMMPS): the stock granular
 * Hooke contact with shear history, evaluated by the sphdem DEM core (CPU or CUDA). */
#ifdef PAIR_CLASS
PairStyle(gran/hooke/history/gpu,PairGranHookeHistoryGPU)
#else

#ifndef SPHDEM_PAIR_GRAN_HOOKE_HISTORY_GPU_H
#define SPHDEM_PAIR_GRAN_HOOKE_HISTORY_GPU_H

#include "pair_gran_gpu_base.h"

namespace LAMMPS_NS {

class PairGranHookeHistoryGPU : public PairGranGPUBase {
 public:
  explicit PairGranHookeHistoryGPU(class LAMMPS *);
  ~PairGranHookeHistoryGPU() override;
  /* compute pair/local: the stock values of a pair (fforce the normal force over the distance; svector the
   * tangential force, its magnitude, the normal and the tangential relative velocity), from the core's contacts of
   * the step (single_contact) */
  double single(int, int, int, int, double, double, double, double &) override;
  void compute(int, int) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;

 protected:
  /* the stock arguments (pair_gran_hooke_history semantics) */
  double kn, kt, gamman, gammat, xmu;
  int dampflag, limit_damping;
  int model;                /* sphdem_dem_model */

  void sync_params() override;
};

}  // namespace LAMMPS_NS

#endif
#endif
