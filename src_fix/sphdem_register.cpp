/* sphdem_register.cpp - the one place that lists the sphdem styles; add later styles here
 * (fix sph/couple, pair gran/gpu, compute sph/probe). */
#include "sphdem_register.h"

#include "compute_sph_probe.h"
#include "fix_sph_couple.h"
#include "fix_sph_fluid.h"
#include "lammps.h"
#include "modify.h"
#include "pair_gran_gpu_register.h"
#include "sphdem_compat.h"

using namespace LAMMPS_NS;

void sphdem_register_styles(LAMMPS *lmp) {
  sphdem_compat::FixCreatorMap &fixes = *sphdem_compat::fix_map(lmp->modify);
  fixes["sph/fluid"] = &sphdem_compat::fix_creator<FixSPHFluid>;
  fixes["sph/couple"] = &sphdem_compat::fix_creator<FixSPHCouple>;
  sphdem_compat::ComputeCreatorMap &computes = *sphdem_compat::compute_map(lmp->modify);
  computes["sph/probe"] = &sphdem_compat::compute_creator<ComputeSPHProbe>;
  sphdem_register_pair_gran_gpu(lmp); /* pair styles of this engine (pair_gran_gpu_register.h) */
}
