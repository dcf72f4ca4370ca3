/* dem_passes.h - the per-element passes of the DEM context, listed once: each entry gives the dem_ops entry
 * (dem_internal.h), an OpenMP loop (dem_cpu.c) and a CUDA kernel with its launcher (dem_cuda.cu). The steps
 * of dem_ops (cells, count, fill, csr, forces) call them around the sorts and scans of each backend. Not
 * public.
 *
 * X(op, count, omp, cpu, params, args, body)
 *   op      the table entry: int (*op)(struct sphdem_dem_s *m <params>)
 *   count   elements of the pass, an expression in D (const dem_dev *) and the params; 0 skips the pass
 *   omp     CPU schedule: static, dyn256 (schedule(dynamic, 256)), each on one thread up to SPHDEM_DEM_OMP_MIN
 *           elements; serial: always one thread
 *   cpu     loop: the CPU table takes the generated loop sphdem_dem_cpu_loop_<op>; own: it takes
 *           sphdem_dem_cpu_<op>, written in the CPU backend (forces without atomics, pair force buffer)
 *   params  extra scalar arguments "(, type name, ...)", "()" for none; args: their names "(, name, ...)"
 *   body    the work on element i: a call of the shared bodies (dem_bodies.h) in D, i and the params
 * The touching-pair count is a reduction, written in each backend (dem_touching). */
#ifndef SPHDEM_DEM_PASSES_H
#define SPHDEM_DEM_PASSES_H

#include "sph_passes.h" /* SPHDEM_UNPAREN_ */

#define SPHDEM_DEM_PASSES(X)                                                                                  \
  X(cell, D->n, static, loop, (), (), dem_cell_body(D, i))           /* cell of each grain, sidx = i */      \
  X(cell_ranges, D->n, serial, loop, (), (),                         /* cell ranges of the sorted slots */   \
    dem_cell_range_body(D->cell, D->n, i, D->cstart, D->cend))                                                \
  X(scan_count, D->n, dyn256, loop, (), (), dem_count_body(D, i))    /* candidate pairs of each slot */      \
  X(scan_fill, D->n, dyn256, loop, (), (), dem_scan_slot(D, i, 1)) /* pa, pb, key */             \
  X(carry, D->np, static, loop, (), (), dem_carry_body(D, i))        /* history from the previous list */    \
  X(forward_ranges, D->np, serial, loop, (), (), dem_forward_range_body(D, i)) /* pairs as a: fstart, fend */ \
  X(reverse_ranges, D->np, serial, loop, (), (),                     /* pairs as b: rstart, rend of rkey */  \
    dem_range_body(D->rkey, D->np, i, D->rstart, D->rend))                                                    \
  X(pair_forces, D->np, static, own, (), (), dem_pair_force_body(D, i)) /* pair-parallel, atomic sums */     \
  X(particle_forces, D->n, dyn64, own, (), (), dem_particle_force_body(D, i)) /* particle-parallel */     \
  X(contact_record, D->np, static, loop, (, double *rec), (, rec),   /* the contacts for output */          \
    dem_contact_record_body(D, i, rec))                                                                       \
  X(heat, D->np, static, own,                                        /* heat conduction through contacts */ \
    (, const double *T, const double *k, const int *mb, int area, double A0, double *q, double *dq),            \
    (, T, k, mb, area, A0, q, dq), dem_heat_body(D, i, T, k, mb, area, A0, q, dq))

/* the table entry and the declarations of both backends' functions (dem_internal.h) */
#define SPHDEM_DEM_PASS_FIELD(op, count, omp, cpu, params, args, body) \
  int (*op)(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params);
#define SPHDEM_DEM_PASS_DECL_own(op, params) int sphdem_dem_cpu_##op(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params);
#define SPHDEM_DEM_PASS_DECL_loop(op, params)
#define SPHDEM_DEM_PASS_DECL_CPU(op, count, omp, cpu, params, args, body)       \
  int sphdem_dem_cpu_loop_##op(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params); \
  SPHDEM_DEM_PASS_DECL_##cpu(op, params)
#define SPHDEM_DEM_PASS_DECL_CUDA(op, count, omp, cpu, params, args, body) \
  int sphdem_dem_cuda_##op(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params);

/* CPU: the loop, and the table entry (the generated loop or the backend's own function). Below
 * SPHDEM_DEM_OMP_MIN elements a loop runs on one thread: the fork/join of a parallel region costs more than
 * the work (and much more when the cores are shared). */
#define SPHDEM_DEM_OMP_MIN 2048
#define SPHDEM_DEM_OMP_static _Pragma("omp parallel for schedule(static) if (n > SPHDEM_DEM_OMP_MIN)")
#define SPHDEM_DEM_OMP_dyn64 _Pragma("omp parallel for schedule(dynamic, 64) if (n > SPHDEM_DEM_OMP_MIN)")
#define SPHDEM_DEM_OMP_dyn256 _Pragma("omp parallel for schedule(dynamic, 256) if (n > SPHDEM_DEM_OMP_MIN)")
#define SPHDEM_DEM_OMP_serial
#define SPHDEM_DEM_PASS_CPU_LOOP(op, count, omp, cpu, params, args, body)      \
  int sphdem_dem_cpu_loop_##op(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params) { \
    const dem_dev *D = &m->D;                                                  \
    const int64_t n = (count);                                                 \
    SPHDEM_DEM_OMP_##omp                                                       \
    for (int64_t i = 0; i < n; i++) body;                                      \
    return SPHDEM_OK;                                                          \
  }
#define SPHDEM_DEM_PASS_CPU_FN_loop(op) sphdem_dem_cpu_loop_##op
#define SPHDEM_DEM_PASS_CPU_FN_own(op) sphdem_dem_cpu_##op
#define SPHDEM_DEM_PASS_CPU_ENTRY(op, count, omp, cpu, params, args, body) .op = SPHDEM_DEM_PASS_CPU_FN_##cpu(op),

/* CUDA: one thread per element (SPHDEM_DEM_PASS_BLOCK threads a block, set by the file that expands it), the
 * launcher, and the table entry (positional, in the order of the fields) */
#define SPHDEM_DEM_PASS_CUDA(op, count, omp, cpu, params, args, body)                                        \
  __global__ void k_dem_pass_##op(dem_dev Dv, int64_t n SPHDEM_UNPAREN_ params) {                            \
    const dem_dev *D = &Dv;                                                                                  \
    const int64_t i = RT_THREAD_INDEX();                                                                     \
    if (i < n) body;                                                                                         \
  }                                                                                                          \
  extern "C" int sphdem_dem_cuda_##op(struct sphdem_dem_s *m SPHDEM_UNPAREN_ params) {                       \
    const dem_dev *D = &m->D;                                                                                \
    const int64_t n = (count);                                                                               \
    if (n <= 0) return SPHDEM_OK;                                                                            \
    k_dem_pass_##op<<<(unsigned)((n + SPHDEM_DEM_PASS_BLOCK - 1) / SPHDEM_DEM_PASS_BLOCK),                   \
                      SPHDEM_DEM_PASS_BLOCK>>>(*D, n SPHDEM_UNPAREN_ args);                                  \
    return rt_cuda_check(&m->rt, cudaGetLastError(), "DEM " #op " kernel");                                  \
  }
#define SPHDEM_DEM_PASS_CUDA_ENTRY(op, count, omp, cpu, params, args, body) sphdem_dem_cuda_##op,

#endif
