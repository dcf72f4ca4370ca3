/* pair_gran_gpu_register_liggghts.cpp - LIGGGHTS build: no GPU granular pair style yet (the LIGGGHTS
 * syntax pair_style gran/gpu is not implemented; the LAMMPS styles are in the LAMMPS shim only). */
#include "pair_gran_gpu_register.h"

void sphdem_register_pair_gran_gpu(LAMMPS_NS::LAMMPS *) {}
