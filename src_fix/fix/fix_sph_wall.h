/* fix_sph_wall.h - fix sph/wall: creates the dummy-wall particles of fix sph/fluid (keyword wall) behind an STL
 * mesh or outside a region, in layers at spacing DX, and adds them to the fix's group. */
#ifdef FIX_CLASS
FixStyle(sph/wall,FixSPHWall)
#else

#ifndef SPHDEM_FIX_SPH_WALL_H
#define SPHDEM_FIX_SPH_WALL_H

#include <string>

#include "fix.h"

namespace LAMMPS_NS {

class FixSPHWall : public Fix {
 public:
  FixSPHWall(class LAMMPS *, int, char **);
  int setmask() override;
  void init() override;
  double compute_scalar() override;

 private:
  [[noreturn]] void fail(const std::string &msg);
  long long created_;
  bool warned_;
};

}  // namespace LAMMPS_NS

#endif
#endif
