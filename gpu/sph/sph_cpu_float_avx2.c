/* sph_cpu_float_avx2.c - sph_cpu_float.c built with AVX2 + FMA (compile options in gpu/CMakeLists.txt); sph_cpu.c
 * calls it only where the CPU has both. */
#define SPHDEM_FLOAT_ISA avx2
#include "sph_cpu_float.c"
