/* hd.h - SPHDEM_HD marks a physics body for both backends: __host__ __device__ under nvcc, static inline in C
 * (the bodies headers of every subsystem use it). Not public. */
#ifndef SPHDEM_HD_H
#define SPHDEM_HD_H

#ifdef __CUDACC__
#define SPHDEM_HD __host__ __device__ static inline
#else
#define SPHDEM_HD static inline
#endif

#endif
