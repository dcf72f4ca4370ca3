/* pair_gran_hertz_history_gpu.h - pair_style gran/hertz/history/gpu (LAMMPS): the stock Hertzian
 * contact with shear history, evaluated by the sphdem DEM core (CPU or CUDA). */
#ifdef PAIR_CLASS
PairStyle(gran/hertz/history/gpu,PairGranHertzHistoryGPU)
#else

#ifndef SPHDEM_PAIR_GRAN_HERTZ_HISTORY_GPU_H
#define SPHDEM_PAIR_GRAN_HERTZ_HISTORY_GPU_H

#include "pair_gran_hooke_history_gpu.h"

namespace LAMMPS_NS {

class PairGranHertzHistoryGPU : public PairGranHookeHistoryGPU {
 public:
  explicit PairGranHertzHistoryGPU(class LAMMPS *);
  void settings(int, char **) override;
};

}  // namespace LAMMPS_NS

#endif
#endif
