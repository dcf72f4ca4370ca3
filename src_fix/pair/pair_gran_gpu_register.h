/* pair_gran_gpu_register.h - registers the GPU granular pair styles of the engine being built
 * (LAMMPS: gran/hooke/history/gpu, gran/hertz/history/gpu in pair_gran_hooke_history_gpu.cpp, granular/gpu in
 * pair_granular_gpu.cpp;
 * LIGGGHTS: gran/gpu in pair_gran_gpu.cpp). */
#ifndef SPHDEM_PAIR_GRAN_GPU_REGISTER_H
#define SPHDEM_PAIR_GRAN_GPU_REGISTER_H

namespace LAMMPS_NS {
class LAMMPS;
}

void sphdem_register_pair_gran_gpu(LAMMPS_NS::LAMMPS *lmp);
/* LAMMPS: granular/gpu (pair_granular_gpu.cpp), registered by sphdem_register_pair_gran_gpu */
void sphdem_register_pair_granular_gpu(LAMMPS_NS::LAMMPS *lmp);

#endif
