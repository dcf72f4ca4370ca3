/* plugin_host.cpp - stands in for LAMMPS' `plugin load` (absent from Debian's LAMMPS): creates a
 * LAMMPS instance from liblammps, dlopens a *plugin.so, calls its lammpsplugin_init with a register
 * function that inserts fix, compute and pair creators into the style maps as the PLUGIN package
 * does, then reads the input. Usage: plugin_host PLUGIN.so [lmp flags...]
 * Exit status 1 (with LAMMPS' ERROR line) on an input error, as lmp and lmp_sphdem. */
#include <dlfcn.h>
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "force.h"
#include "input.h"
#include "lammps.h"
#include "lammpsplugin_decl.h"
#include "modify.h"

/* LAMMPS that throws LAMMPSException on errors (always since 2023): see src_fix/launch/sphdem_main.cpp */
#if defined(LAMMPS_EXCEPTIONS) || __has_include("exceptions.h")
#include "exceptions.h"
#define SPHDEM_LAMMPS_THROWS 1
#endif

using namespace LAMMPS_NS;

static int nregistered = 0, nunknown = 0;

static void register_plugin(lammpsplugin_t *p, void *ptr) {
  LAMMPS *lmp = static_cast<LAMMPS *>(ptr);
  if (std::strcmp(p->version, lmp->version) != 0)
    std::fprintf(stderr, "plugin_host: plugin compiled for LAMMPS version '%s', loaded into LAMMPS version '%s'\n",
                 p->version, lmp->version);
  if (std::strcmp(p->style, "fix") == 0) (*lmp->modify->fix_map)[p->name] = (Modify::FixCreator)p->creator.v2;
  else if (std::strcmp(p->style, "compute") == 0)
    (*lmp->modify->compute_map)[p->name] = (Modify::ComputeCreator)p->creator.v2;
  else if (std::strcmp(p->style, "pair") == 0) (*lmp->force->pair_map)[p->name] = (Force::PairCreator)p->creator.v1;
  else {
    std::fprintf(stderr, "plugin_host: plugin style '%s' (%s) is not handled here\n", p->style, p->name);
    nunknown++;
    return;
  }
  std::printf("plugin_host: registered %s %s (%s) for LAMMPS %s\n", p->style, p->name, p->info, p->version);
  nregistered++;
}

static void run(int argc, char **argv, lammpsplugin_initfunc init, void *handle) {
  LAMMPS *lmp = new LAMMPS(argc, argv, MPI_COMM_WORLD);
  init(lmp, handle, (void *)&register_plugin);
  if (nregistered == 0 || nunknown > 0) {
    std::fprintf(stderr, "plugin_host: the plugin registered %d styles, %d of an unknown kind\n", nregistered,
                 nunknown);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  lmp->input->file();
  delete lmp;
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
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  lammpsplugin_initfunc init = (lammpsplugin_initfunc)dlsym(handle, "lammpsplugin_init");
  if (!init) {
    std::fprintf(stderr, "plugin_host: no lammpsplugin_init in %s\n", argv[1]);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  argv[1] = argv[0];
#ifdef SPHDEM_LAMMPS_THROWS
  try {
    run(argc - 1, argv + 1, init, handle);
  } catch (LAMMPSAbortException &) {
    MPI_Abort(MPI_COMM_WORLD, 1);
  } catch (LAMMPSException &) {
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    exit(1);
  } catch (std::exception &e) {
    std::fprintf(stderr, "Exception: %s\n", e.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
#else
  run(argc - 1, argv + 1, init, handle);
#endif
  MPI_Finalize();
  return 0;
}
