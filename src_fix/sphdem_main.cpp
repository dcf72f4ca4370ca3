/* sphdem_main.cpp - the lmp_sphdem / liggghts_sphdem launchers: the stock engine with the sphdem
 * styles registered, so every stock command-line flag (-in, -var, -log, -screen, -echo ...) works. */
#include <mpi.h>

#include "input.h"
#include "lammps.h"
#include "sphdem_register.h"

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  LAMMPS_NS::LAMMPS *lmp = new LAMMPS_NS::LAMMPS(argc, argv, MPI_COMM_WORLD);
  sphdem_register_styles(lmp);
  lmp->input->file();
  delete lmp;
  MPI_Barrier(MPI_COMM_WORLD);
  MPI_Finalize();
  return 0;
}
