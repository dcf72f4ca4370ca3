/* sphdem_register.cpp - the one place that lists the sphdem styles; add later styles here
 * (fix sph/couple, pair gran/gpu, compute sph/probe). */
#include "sphdem_register.h"

#include <cctype>
#include <string>

#include "compute_sph_probe.h"
#include "fix_cfd_grid.h"
#include "fix_sph_couple.h"
#include "fix_sph_fill.h"
#include "fix_sph_fluid.h"
#include "fix_sph_wall.h"
#include "input.h"
#include "lammps.h"
#include "modify.h"
#include "pair_gran_gpu_register.h"
#include "sphdem_compat.h"
#include "variable.h"

using namespace LAMMPS_NS;

void sphdem_register_styles(LAMMPS *lmp) {
  sphdem_compat::FixCreatorMap &fixes = *sphdem_compat::fix_map(lmp->modify);
  fixes["sph/fluid"] = &sphdem_compat::fix_creator<FixSPHFluid>;
  fixes["sph/couple"] = &sphdem_compat::fix_creator<FixSPHCouple>;
  fixes["cfd/grid"] = &sphdem_compat::fix_creator<FixCFDGrid>;
  fixes["sph/wall"] = &sphdem_compat::fix_creator<FixSPHWall>;
  fixes["sph/fill"] = &sphdem_compat::fix_creator<FixSPHFill>;
  sphdem_compat::ComputeCreatorMap &computes = *sphdem_compat::compute_map(lmp->modify);
  computes["sph/probe"] = &sphdem_compat::compute_creator<ComputeSPHProbe>;
  sphdem_register_pair_gran_gpu(lmp); /* pair styles of this engine (pair_gran_gpu_register.h) */

  /* index variable sphdem_engine = lammps | liggghts: one input script can pick the commands whose
   * syntax differs between the engines (granular pair styles, fix wall/gran); -var on the command
   * line wins (an index variable is not redefined) */
  char name[] = "sphdem_engine", style[] = "index";
  std::string value = sphdem_compat::engine_name;
  for (char &ch : value) ch = (char)std::tolower((unsigned char)ch);
  char *args[3] = {name, style, &value[0]};
  lmp->input->variable->set(3, args);
}
