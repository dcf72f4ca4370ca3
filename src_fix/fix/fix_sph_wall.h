/* fix_sph_wall.h - fix sph/wall: creates the dummy-wall particles of fix sph/fluid (keyword wall) behind an STL
 * mesh or outside a region, in layers at spacing DX, and adds them to the fix's group. */
#ifdef FIX_CLASS
FixStyle(sph/wall,FixSPHWall)
#else

#ifndef SPHDEM_FIX_SPH_WALL_H
#define SPHDEM_FIX_SPH_WALL_H

#include <string>

#include <vector>

#include "fix.h"
#include "sphdem_geom.h"

namespace LAMMPS_NS {

class FixSPHWall : public Fix {
 public:
  FixSPHWall(class LAMMPS *, int, char **);
  int setmask() override;
  void init() override;
  double compute_scalar() override;
  /* the walls' mesh as used (scaled, moved, oriented; empty for region walls) and the region ID (empty for a mesh):
   * fix sph/fill ... inside ID keeps its points on the fluid side of them */
  const std::vector<sphdem_facet> &facets() const { return facets_; }
  const std::string &region_id() const { return region_id_; }

 private:
  [[noreturn]] void fail(const std::string &msg);
  long long created_;
  bool warned_;
  std::vector<sphdem_facet> facets_;
  std::string region_id_;
};

}  // namespace LAMMPS_NS

#endif
#endif
