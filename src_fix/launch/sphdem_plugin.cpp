/* sphdem_plugin.cpp - lammpsplugin_init entry of sphdemplugin.so for LAMMPS builds with the PLUGIN
 * package (`plugin load sphdemplugin.so`). Debian's LAMMPS has no PLUGIN package; the plugin record
 * is declared in lammpsplugin_decl.h. A plugin works only in the LAMMPS whose headers it was compiled
 * with (class layouts and symbols change between versions), so it reports that version and LAMMPS
 * warns "compiled for LAMMPS version X, loaded into LAMMPS version Y" when they differ. */
#include "compute_sph_probe.h"
#include "fix_cfd_grid.h"
#include "fix_sph_couple.h"
#include "fix_sph_fill.h"
#include "fix_sph_fluid.h"
#include "fix_sph_wall.h"
#include "lammps.h"
#include "pair_gran_hertz_history_gpu.h"
#include "pair_gran_hooke_history_gpu.h"
#include "pair_granular_gpu.h"
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

template <typename T> static void *style_creator(void *lmp, int argc, char **argv) {
  return new T(static_cast<LAMMPS_NS::LAMMPS *>(lmp), argc, argv);
}

template <typename T> static void *pair_creator(void *lmp) { return new T(static_cast<LAMMPS_NS::LAMMPS *>(lmp)); }

/* One row per style; add later sphdem styles here as in sphdem_register.cpp. Fixes and computes are made
 * by a factory2 (lmp, argc, argv), pair styles by a factory1 (lmp). */
namespace {
struct PluginStyle {
  const char *style, *name, *info;
  lammpsplugin_factory1 *v1;
  lammpsplugin_factory2 *v2;
};
const PluginStyle kStyles[] = {
    {"fix", "sph/fluid", "sphdem " SPHDEM_VERSION " SPH fluid on CPU or GPU", nullptr,
     &style_creator<LAMMPS_NS::FixSPHFluid>},
    {"fix", "sph/couple", "sphdem " SPHDEM_VERSION " SPH-DEM coupling (fluid force on grains, reaction on the fluid)",
     nullptr, &style_creator<LAMMPS_NS::FixSPHCouple>},
    {"fix", "cfd/grid",
     "sphdem " SPHDEM_VERSION " coarse-grid gas of CFD-DEM (drag and pressure-gradient force on grains)", nullptr,
     &style_creator<LAMMPS_NS::FixCFDGrid>},
    {"fix", "sph/wall", "sphdem " SPHDEM_VERSION " dummy-wall particles behind an STL mesh or outside a region", nullptr,
     &style_creator<LAMMPS_NS::FixSPHWall>},
    {"fix", "sph/fill", "sphdem " SPHDEM_VERSION " fluid particles on a lattice in a region", nullptr,
     &style_creator<LAMMPS_NS::FixSPHFill>},
    {"compute", "sph/probe", "sphdem " SPHDEM_VERSION " fluid fields at fixed points", nullptr,
     &style_creator<LAMMPS_NS::ComputeSPHProbe>},
    {"pair", "gran/hooke/history/gpu",
     "sphdem " SPHDEM_VERSION " granular Hooke contacts with history on the sphdem DEM core (CPU or GPU)",
     &pair_creator<LAMMPS_NS::PairGranHookeHistoryGPU>, nullptr},
    {"pair", "gran/hertz/history/gpu",
     "sphdem " SPHDEM_VERSION " granular Hertz contacts with history on the sphdem DEM core (CPU or GPU)",
     &pair_creator<LAMMPS_NS::PairGranHertzHistoryGPU>, nullptr},
    {"pair", "granular/gpu",
     "sphdem " SPHDEM_VERSION " LAMMPS pair_style granular contacts on the sphdem DEM core (CPU or GPU)",
     &pair_creator<LAMMPS_NS::PairGranularGPU>, nullptr},
};
}  // namespace

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc) {
  lammpsplugin_regfunc register_plugin = (lammpsplugin_regfunc)regfunc;
  for (const PluginStyle &st : kStyles) {
    lammpsplugin_t plugin;
    plugin.version = SPHDEM_BUILT_FOR_LAMMPS; /* compiled for this LAMMPS, not the one that loads it */
    plugin.style = st.style;
    plugin.name = st.name;
    plugin.info = st.info;
    plugin.author = "sphdem developers";
    if (st.v1) plugin.creator.v1 = st.v1;
    else plugin.creator.v2 = st.v2;
    plugin.handle = handle;
    (*register_plugin)(&plugin, lmp);
  }
}
