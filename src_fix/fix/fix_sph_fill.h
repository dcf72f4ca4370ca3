/* fix_sph_fill.h - fix sph/fill: creates the fluid particles of fix sph/fluid on the sc lattice inside a region,
 * leaving out the points near the atoms of other groups (walls), and adds them to the fix's group. */
#ifdef FIX_CLASS
FixStyle(sph/fill,FixSPHFill)
#else

#ifndef SPHDEM_FIX_SPH_FILL_H
#define SPHDEM_FIX_SPH_FILL_H

#include <string>

#include "fix.h"

namespace LAMMPS_NS {

class FixSPHFill : public Fix {
 public:
  FixSPHFill(class LAMMPS *, int, char **);
  int setmask() override;
  double compute_scalar() override;
  double compute_vector(int) override;

 private:
  [[noreturn]] void fail(const std::string &msg);
  long long created_;
  double top_;
};

}  // namespace LAMMPS_NS

#endif
#endif
