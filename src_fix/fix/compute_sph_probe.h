/* compute_sph_probe.h - compute sph/probe: fluid pressure, density and velocity at fixed points. */
#ifdef COMPUTE_CLASS
ComputeStyle(sph/probe,ComputeSPHProbe)
#else

#ifndef SPHDEM_COMPUTE_SPH_PROBE_H
#define SPHDEM_COMPUTE_SPH_PROBE_H

#include <string>
#include <vector>

#include "compute.h"

namespace LAMMPS_NS {

class ComputeSPHProbe : public Compute {
 public:
#ifdef SPHDEM_ENGINE_LAMMPS
  ComputeSPHProbe(class LAMMPS *, int, char **);
#else
  ComputeSPHProbe(class LAMMPS *, int &, int, char **);
#endif
  ~ComputeSPHProbe() override;
  void init() override;
  void compute_array() override;

 private:
  void parse(int first, int narg, char **arg);
  [[noreturn]] void fail(const std::string &msg);
  std::string fix_id_;
  std::vector<double> pts_, out_;
  int npts_;
  class FixSPHFluid *fix_;
};

}  // namespace LAMMPS_NS

#endif
#endif
