/* plugin_host.cpp - stands in for LAMMPS' `plugin load` (absent from Debian's LAMMPS): creates a
 * LAMMPS instance from liblammps, dlopens a *plugin.so, calls its lammpsplugin_init with a register
 * function that inserts fix creators into Modify::fix_map as the PLUGIN package does, then reads
 * the input. Usage: plugin_host PLUGIN.so [lmp flags...] */
#include <dlfcn.h>
#include <mpi.h>

#include <cstdio>
#include <cstring>

#include "input.h"
#include "lammps.h"
#include "lammpsplugin_decl.h"
#include "force.h"
#include "modify.h"

using namespace LAMMPS_NS;

static int nregistered = 0;

static void register_plugin(lammpsplugin_t *p, void *ptr) {
  LAMMPS *lmp = static_cast<LAMMPS *>(ptr);
  if (std::strcmp(p->version, lmp->version) != 0)
    std::fprintf(stderr, "plugin_host: plugin version '%s' differs from LAMMPS '%s'\n", p->version, lmp->version);
  if (std::strcmp(p->style, "fix") == 0) (*lmp->modify->fix_map)[p->name] = (Modify::FixCreator)p->creator.v2;
  else if (std::strcmp(p->style, "pair") == 0) (*lmp->force->pair_map)[p->name] = (Force::PairCreator)p->creator.v1;
  else return;
  std::printf("plugin_host: registered %s %s (%s)\n", p->style, p->name, p->info);
  nregistered++;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: plugin_host PLUGIN.so [lmp flags]\n");
    return 2;
  }
  MPI_Init(&argc, &argv);
  void *handle = dlopen(argv[1], RTLD_NOW | RTLD_GLOBAL);
  if (!handle) {
    std::fprintf(stderr, "plugin_host: %s\n", dlerror());
    return 1;
  }
  lammpsplugin_initfunc init = (lammpsplugin_initfunc)dlsym(handle, "lammpsplugin_init");
  if (!init) {
    std::fprintf(stderr, "plugin_host: no lammpsplugin_init in %s\n", argv[1]);
    return 1;
  }
  argv[1] = argv[0];
  LAMMPS *lmp = new LAMMPS(argc - 1, argv + 1, MPI_COMM_WORLD);
  init(lmp, handle, (void *)&register_plugin);
  if (nregistered == 0) {
    std::fprintf(stderr, "plugin_host: the plugin registered no fix style\n");
    return 1;
  }
  lmp->input->file();
  delete lmp;
  MPI_Finalize();
  return 0;
}
