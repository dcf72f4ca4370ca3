/* sphdem_plugin.cpp - lammpsplugin_init entry of sphdemplugin.so for LAMMPS builds with the PLUGIN
 * package (`plugin load sphdemplugin.so`). Debian's LAMMPS has no PLUGIN package; the plugin record
 * is declared in lammpsplugin_decl.h. A plugin works only in the LAMMPS whose headers it was compiled
 * with (class layouts and symbols change between versions), so it reports that version and LAMMPS
 * warns "compiled for LAMMPS version X, loaded into LAMMPS version Y" when they differ. */
#include "compute_sph_probe.h"
#include "fix_cfd_grid.h"
#include "fix_sph_couple.h"
#include "fix_sph_fluid.h"
#include "lammps.h"
#include "pair_gran_hertz_history_gpu.h"
#include "pair_gran_hooke_history_gpu.h"
#include "lammpsplugin_decl.h"
#include "sphdem.h"

/* The version of the headers: version.h of a LAMMPS source tree; Debian's headers have none, then
 * the build passes the version string of the library (src_fix/CMakeLists.txt). */
#if __has_include("version.h")
#include "version.h"
#define SPHDEM_BUILT_FOR_LAMMPS LAMMPS_VERSION
#elif defined(SPHDEM_LAMMPS_VERSION)
#define SPHDEM_BUILT_FOR_LAMMPS SPHDEM_LAMMPS_VERSION
#else
#error "no version.h in the LAMMPS headers and no SPHDEM_LAMMPS_VERSION given"
#endif

static void *sph_fluid_creator(void *lmp, int argc, char **argv) {
  return new LAMMPS_NS::FixSPHFluid(static_cast<LAMMPS_NS::LAMMPS *>(lmp), argc, argv);
}

static void *sph_couple_creator(void *lmp, int argc, char **argv) {
  return new LAMMPS_NS::FixSPHCouple(static_cast<LAMMPS_NS::LAMMPS *>(lmp), argc, argv);
}

static void *cfd_grid_creator(void *lmp, int argc, char **argv) {
  return new LAMMPS_NS::FixCFDGrid(static_cast<LAMMPS_NS::LAMMPS *>(lmp), argc, argv);
}

static void *sph_probe_creator(void *lmp, int argc, char **argv) {
  return new LAMMPS_NS::ComputeSPHProbe(static_cast<LAMMPS_NS::LAMMPS *>(lmp), argc, argv);
}

static void *pair_hooke_gpu_creator(void *lmp) {
  return new LAMMPS_NS::PairGranHookeHistoryGPU(static_cast<LAMMPS_NS::LAMMPS *>(lmp));
}

static void *pair_hertz_gpu_creator(void *lmp) {
  return new LAMMPS_NS::PairGranHertzHistoryGPU(static_cast<LAMMPS_NS::LAMMPS *>(lmp));
}

/* One registration per style; add later sphdem styles here as in sphdem_register.cpp. */
extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc) {
  lammpsplugin_regfunc register_plugin = (lammpsplugin_regfunc)regfunc;
  lammpsplugin_t plugin;
  plugin.version = SPHDEM_BUILT_FOR_LAMMPS; /* compiled for this LAMMPS, not the one that loads it */
  plugin.style = "fix";
  plugin.name = "sph/fluid";
  plugin.info = "sphdem " SPHDEM_VERSION " SPH fluid on CPU or GPU";
  plugin.author = "sphdem developers";
  plugin.creator.v2 = (lammpsplugin_factory2 *)&sph_fluid_creator;
  plugin.handle = handle;
  (*register_plugin)(&plugin, lmp);
  plugin.name = "sph/couple";
  plugin.info = "sphdem " SPHDEM_VERSION " SPH-DEM coupling (fluid force on grains, reaction on the fluid)";
  plugin.creator.v2 = (lammpsplugin_factory2 *)&sph_couple_creator;
  (*register_plugin)(&plugin, lmp);
  plugin.name = "cfd/grid";
  plugin.info = "sphdem " SPHDEM_VERSION " coarse-grid gas of CFD-DEM (drag and pressure-gradient force on grains)";
  plugin.creator.v2 = (lammpsplugin_factory2 *)&cfd_grid_creator;
  (*register_plugin)(&plugin, lmp);
  plugin.style = "compute";
  plugin.name = "sph/probe";
  plugin.info = "sphdem " SPHDEM_VERSION " fluid fields at fixed points";
  plugin.creator.v2 = (lammpsplugin_factory2 *)&sph_probe_creator;
  (*register_plugin)(&plugin, lmp);
  plugin.style = "pair";
  plugin.name = "gran/hooke/history/gpu";
  plugin.info = "sphdem " SPHDEM_VERSION " granular Hooke contacts with history on the sphdem DEM core (CPU or GPU)";
  plugin.creator.v1 = (lammpsplugin_factory1 *)&pair_hooke_gpu_creator;
  (*register_plugin)(&plugin, lmp);
  plugin.name = "gran/hertz/history/gpu";
  plugin.info = "sphdem " SPHDEM_VERSION " granular Hertz contacts with history on the sphdem DEM core (CPU or GPU)";
  plugin.creator.v1 = (lammpsplugin_factory1 *)&pair_hertz_gpu_creator;
  (*register_plugin)(&plugin, lmp);
}
