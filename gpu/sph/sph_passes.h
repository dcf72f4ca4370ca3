/* sph_passes.h - the per-element passes of the fluid context and of the SPH-DEM coupling, listed once: each
 * entry gives the sphdem_ops entry (sph_internal.h), an OpenMP loop (sph_cpu.c, couple_cpu.c) and a CUDA
 * kernel with its launcher (sph_cuda.cu, couple_cuda.cu). Not public.
 *
 * X(op, count, omp, cpu, params, args, body)
 *   op      the table entry: int (*op)(struct sphdem_ctx_s *c <params>)
 *   count   elements of the pass, an expression in D (const sphdem_dev *) and the params; 0 skips the pass
 *   omp     CPU schedule: static, dyn16 or dyn64 (schedule(dynamic, 16 / 64))
 *   cpu     loop: the CPU table takes the generated loop sphdem_cpu_loop_<op>; own: it takes sphdem_cpu_<op>,
 *           written in the CPU backend (neighbour lists, half lists, pair lists), which falls back to the loop
 *   params  extra scalar arguments "(, type name, ...)", "()" for none; args: their names "(, name, ...)"
 *   body    the work on element i: a call of the shared bodies (sph_bodies.h, mp_bodies.h, fluid_rates.h,
 *           couple_bodies.h) in D, i and the params */
#ifndef SPHDEM_SPH_PASSES_H
#define SPHDEM_SPH_PASSES_H

/* Fluid (sph.c, mp.c call them in the order of a step, doc/architecture.md) */
#define SPHDEM_FLUID_PASSES(X)                                                                                \
  X(ksum, D->iso.ksum ? D->nf : 0, static, loop, (), (), ksum_body(D, i)) /* kernel sums (keyword isolated) */    \
  X(pressure, D->nf, static, loop, (), (), predict_body(D, i))        /* state at the force time, EOS */      \
  X(wall_state, D->nw, static, own, (), (),                           /* Adami eqs 13-15, or MLS ghosts */    \
    D->ghost.on ? mls_wall_state_body(D, i) : wall_state_body(D, i))                                              \
  X(mp_grad, D->nf, dyn64, loop, (), (), mp_grad_body(D, i))     /* delta-plus: L_i, gradients, viscosity */  \
  X(mp_shift, D->nf, dyn64, loop, (), (), mp_shift_body(D, i))   /* delta-plus: shifting velocity */          \
  X(rates, D->nf, dyn64, own, (), (), rates_body(D, i))          /* the one fluid rate pass (fluid_rates.h) */ \
  X(kick, D->nf, static, loop, (, double dth), (, dth), kick_body(D, i, dth))                                \
  X(drift, D->nf, static, loop, (, double dt), (, dt), drift_body(D, i, dt))                                 \
  X(rk, D->nf, static, loop, (, int mode, double wk, double cst), (, mode, wk, cst), /* mode 0 saves t_n */  \
    rk_stage_body(D, i, mode, wk, cst))                                                                       \
  X(probe, npts, static, loop, (, int64_t npts, const double *pts, double *out), (, npts, pts, out),               \
    probe_body(D, pts, out, i))

/* SPH-DEM coupling (couple.c; He 2018 §2.3-2.4, couple_bodies.h) */
#define SPHDEM_COUPLE_PASSES(X)                                                                               \
  X(couple_porosity, D->nf, dyn64, own, (), (), couple_porosity_body(D, i)) /* eq 26 at fluid particles */   \
  X(couple_grains, D->couple.ng, dyn16, own, (), (), couple_grain_body(D, i))      /* eqs 27-32 on grains */        \
  X(couple_reaction, D->nf, dyn64, own, (), (), couple_reaction_body(D, i)) /* eq 33 on the fluid */

#define SPHDEM_UNPAREN_(...) __VA_ARGS__

/* the table entry and the declarations of both backends' functions (sph_internal.h) */
#define SPHDEM_PASS_FIELD(op, count, omp, cpu, params, args, body) \
  int (*op)(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params);
#define SPHDEM_PASS_DECL_own(op, params) int sphdem_cpu_##op(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params);
#define SPHDEM_PASS_DECL_loop(op, params)
#define SPHDEM_PASS_DECL_CPU(op, count, omp, cpu, params, args, body)        \
  int sphdem_cpu_loop_##op(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params); \
  SPHDEM_PASS_DECL_##cpu(op, params)
#define SPHDEM_PASS_DECL_CUDA(op, count, omp, cpu, params, args, body) \
  int sphdem_cuda_##op(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params);

/* CPU: the loop, and the table entry (the generated loop or the backend's own function) */
#define SPHDEM_OMP_static _Pragma("omp parallel for schedule(static)")
#define SPHDEM_OMP_dyn16 _Pragma("omp parallel for schedule(dynamic, 16)")
#define SPHDEM_OMP_dyn64 _Pragma("omp parallel for schedule(dynamic, 64)")
#define SPHDEM_PASS_CPU_LOOP(op, count, omp, cpu, params, args, body)       \
  int sphdem_cpu_loop_##op(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params) { \
    const sphdem_dev *D = &c->D;                                            \
    const int64_t n = (count);                                              \
    SPHDEM_OMP_##omp                                                        \
    for (int64_t i = 0; i < n; i++) body;                                   \
    return SPHDEM_OK;                                                       \
  }
#define SPHDEM_PASS_CPU_FN_loop(op) sphdem_cpu_loop_##op
#define SPHDEM_PASS_CPU_FN_own(op) sphdem_cpu_##op
#define SPHDEM_PASS_CPU_ENTRY(op, count, omp, cpu, params, args, body) .op = SPHDEM_PASS_CPU_FN_##cpu(op),

/* CUDA: one thread per element (SPHDEM_PASS_BLOCK threads a block, set by the file that expands it), the
 * launcher, and the table entry (positional, in the order of the fields) */
#define SPHDEM_PASS_CUDA(op, count, omp, cpu, params, args, body)                                        \
  __global__ void k_pass_##op(sphdem_dev Dv, int64_t n SPHDEM_UNPAREN_ params) {                         \
    const sphdem_dev *D = &Dv;                                                                           \
    const int64_t i = RT_THREAD_INDEX();                                                                 \
    if (i < n) body;                                                                                     \
  }                                                                                                      \
  extern "C" int sphdem_cuda_##op(struct sphdem_ctx_s *c SPHDEM_UNPAREN_ params) {                       \
    const sphdem_dev *D = &c->D;                                                                         \
    const int64_t n = (count);                                                                           \
    if (n <= 0) return SPHDEM_OK;                                                                        \
    k_pass_##op<<<(unsigned)((n + SPHDEM_PASS_BLOCK - 1) / SPHDEM_PASS_BLOCK), SPHDEM_PASS_BLOCK>>>(     \
        *D, n SPHDEM_UNPAREN_ args);                                                                     \
    return rt_cuda_check(&c->rt, cudaGetLastError(), #op " kernel");                                     \
  }
#define SPHDEM_PASS_CUDA_ENTRY(op, count, omp, cpu, params, args, body) sphdem_cuda_##op,

#endif
