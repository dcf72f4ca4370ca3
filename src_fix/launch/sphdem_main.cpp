/* sphdem_main.cpp - the lmp_sphdem / liggghts_sphdem launchers: the stock engine with the sphdem
 * styles registered, so every stock command-line flag (-in, -var, -log, -screen, -echo ...) works. */
#include <mpi.h>

#include <cstdio>
#include <cstdlib>
#include <exception>

#include "input.h"
#include "lammps.h"
#include "sphdem_register.h"

/* LAMMPS built with exceptions (always so since 2023; optional before, with LAMMPS_EXCEPTIONS) reports
 * an input error by printing the ERROR line and throwing LAMMPSException: catch it as LAMMPS' own
 * main.cpp does, so an error ends the run with exit status 1 instead of an abort. Without exceptions
 * (Debian's LAMMPS 2021, LIGGGHTS 3.8) error->all prints and exits by itself. */
#if defined(SPHDEM_ENGINE_LAMMPS) && (defined(LAMMPS_EXCEPTIONS) || __has_include("exceptions.h"))
#include "exceptions.h"
#define SPHDEM_LAMMPS_THROWS 1
#endif

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
#ifdef SPHDEM_LAMMPS_THROWS
  try {
    LAMMPS_NS::LAMMPS *lmp = new LAMMPS_NS::LAMMPS(argc, argv, MPI_COMM_WORLD);
    sphdem_register_styles(lmp);
    lmp->input->file();
    delete lmp;
  } catch (LAMMPS_NS::LAMMPSAbortException &) {
    /* error->one: the ERROR line is printed by the rank that failed; the others cannot be waited for */
    MPI_Abort(MPI_COMM_WORLD, 1);
  } catch (LAMMPS_NS::LAMMPSException &) {
    /* error->all: every rank threw together after the ERROR line was printed */
    MPI_Barrier(MPI_COMM_WORLD);
    MPI_Finalize();
    exit(1);
  } catch (std::exception &e) {
    fprintf(stderr, "Exception: %s\n", e.what());
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
#else
  LAMMPS_NS::LAMMPS *lmp = new LAMMPS_NS::LAMMPS(argc, argv, MPI_COMM_WORLD);
  sphdem_register_styles(lmp);
  lmp->input->file();
  delete lmp;
#endif
  MPI_Barrier(MPI_COMM_WORLD);
  MPI_Finalize();
  return 0;
}
