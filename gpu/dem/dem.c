/* dem.c - the GPU DEM context: parameters, grain upload, pair-list builds with history carry, forces. */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dem_internal.h"
#include "grains.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

SPHDEM_RT_FAIL_FN(sphdem_dem_fail, struct sphdem_dem_s)

void sphdem_dem_params_default(sphdem_dem_params *p) {
  memset(p, 0, sizeof *p);
  p->model = SPHDEM_DEM_HOOKE;
  p->algo = SPHDEM_DEM_PAIR_PARALLEL;
  p->ct = -1.0;
  p->nu = 0.3;
  p->mu = 0.5;
}

/* the models of LIGGGHTS' granular pair style (material from E, nu, e; its history rule and options) */
static int liggghts_model(int model) {
  return model == SPHDEM_DEM_HERTZ_LIGGGHTS || model == SPHDEM_DEM_HOOKE_LIGGGHTS ||
         model == SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS;
}

#define BAD(...) do { if (msg && msglen) snprintf(msg, msglen, __VA_ARGS__); return SPHDEM_ERR_ARG; } while (0)

int sphdem_dem_params_check(const sphdem_dem_params *p, char *msg, size_t msglen) {
  if (!p) BAD("params: NULL");
  if (p->model < SPHDEM_DEM_HOOKE || p->model > SPHDEM_DEM_GRANULAR)
    BAD("model: %d is not a sphdem_dem_model (0 hooke, 1 hertz, 2 hertz_mindlin, 3 hertz_liggghts, 4 hooke_liggghts, "
        "5 hooke_hysteresis_liggghts, 6 granular)", p->model);
  if (p->algo != SPHDEM_DEM_PAIR_PARALLEL && p->algo != SPHDEM_DEM_PARTICLE_PARALLEL)
    BAD("algo: %d is not a sphdem_dem_algo (0 pair-parallel, 1 particle-parallel)", p->algo);
  if (!(p->en >= 0.0 && p->en <= 1.0)) BAD("en: restitution coefficient %g outside [0, 1]", p->en);
  if (p->model == SPHDEM_DEM_HOOKE_LIGGGHTS || p->model == SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS) {
    if (!(p->charvel > 0.0) || !isfinite(p->charvel))
      BAD("charvel: the characteristic velocity of LIGGGHTS model hooke must be > 0 (got %g)", p->charvel);
    if (p->kt_to_kn != 0 && p->kt_to_kn != 1) BAD("kt_to_kn: must be 0 or 1 (got %d)", p->kt_to_kn);
  }
  if (p->model == SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS) {
    /* kn2kcmax 1 would make the plastic limit overlap k_2,max / (k_2,max - k_n) 2 phi_F R* infinite */
    if (!(p->kn2kcmax > 1.0) || !isfinite(p->kn2kcmax))
      BAD("kn2kcmax: the ratio of the largest unloading stiffness to k_n must be > 1 (got %g)", p->kn2kcmax);
    if (!(p->kn2kc >= 0.0) || !isfinite(p->kn2kc)) BAD("kn2kc: the adhesion stiffness ratio must be >= 0 (got %g)", p->kn2kc);
    if (!(p->phif >= 0.0) || !isfinite(p->phif)) BAD("phif: the plasticity depth must be >= 0 (got %g)", p->phif);
    if (p->limit_damping) BAD("limit_damping: LIGGGHTS' model hooke/hysteresis has no force limit");
  }
  if (liggghts_model(p->model)) {
    if (!(p->E > 0.0)) BAD("E: Young's modulus must be > 0 (got %g)", p->E);
    if (!(p->nu >= 0.0 && p->nu <= 0.5)) BAD("nu: Poisson ratio %g outside [0, 0.5]", p->nu);
    if (!(p->en > 0.05 && p->en <= 1.0)) BAD("en: restitution coefficient %g outside (0.05, 1]", p->en);
  } else if (p->model == SPHDEM_DEM_GRANULAR) {
    if (p->first_contact) BAD("first_contact: not a word of LAMMPS pair_style granular");
    if (p->mu_r != 0.0) BAD("mu_r: the granular model takes its rolling friction from its type-pair table");
  } else if (p->model != SPHDEM_DEM_HERTZ_MINDLIN) {
    if (!(p->kn > 0.0)) BAD("kn: normal stiffness must be > 0 (got %g)", p->kn);
    if (!(p->kt >= 0.0)) BAD("kt: tangential stiffness must be >= 0 (got %g)", p->kt);
    if (!(p->gamman >= 0.0)) BAD("gamman: normal damping must be >= 0 (got %g)", p->gamman);
    if (!(p->gammat >= 0.0)) BAD("gammat: tangential damping must be >= 0 (got %g)", p->gammat);
    if (p->model == SPHDEM_DEM_HERTZ && p->en > 0.0)
      BAD("en: damping from a restitution coefficient is defined for the hooke and hertz_mindlin models, "
          "not hertz (give gamman, gammat)");
    if (p->en > 0.0 && (p->gamman > 0.0 || p->gammat > 0.0))
      BAD("en: give either en or gamman/gammat, not both");
  } else {
    if (!(p->E > 0.0)) BAD("E: Young's modulus must be > 0 (got %g)", p->E);
    if (!(p->nu > -1.0 && p->nu <= 0.5)) BAD("nu: Poisson ratio %g outside (-1, 0.5]", p->nu);
    if (!(p->en > 0.0)) BAD("en: hertz_mindlin needs a restitution coefficient in (0, 1] (got %g)", p->en);
    if (!(p->ct <= 1.0)) BAD("ct: tangential damping coefficient %g above 1 (< 0 means c_n)", p->ct);
  }
  if (!(p->mu >= 0.0)) BAD("mu: friction coefficient must be >= 0 (got %g)", p->mu);
  if (!(p->mu_r >= 0.0)) BAD("mu_r: rolling friction must be >= 0 (got %g)", p->mu_r);
  if (!(p->skin >= 0.0) || !isfinite(p->skin)) BAD("skin: must be finite and >= 0 (got %g)", p->skin);
  if (p->limit_damping != 0 && p->limit_damping != 1) BAD("limit_damping: must be 0 or 1 (got %d)", p->limit_damping);
  if (p->cohesion < SPHDEM_DEM_COH_NONE || p->cohesion > SPHDEM_DEM_COH_SJKR2)
    BAD("cohesion: %d is not a sphdem_dem_cohesion (0 none, 1 sjkr, 2 sjkr2)", p->cohesion);
  if (p->cohesion && !liggghts_model(p->model))
    BAD("cohesion: sjkr and sjkr2 are LIGGGHTS' cohesion models, for the LIGGGHTS models (hertz_liggghts, "
        "hooke_liggghts, hooke_hysteresis_liggghts)");
  if (!(p->ced >= 0.0) || !isfinite(p->ced)) BAD("ced: cohesion energy density must be >= 0 (got %g)", p->ced);
  if (p->rolling_model < SPHDEM_DEM_ROLL_CDT || p->rolling_model > SPHDEM_DEM_ROLL_EPSD)
    BAD("rolling_model: %d is not a sphdem_dem_rolling (0 cdt, 1 epsd2, 2 epsd)", p->rolling_model);
  if (p->rolling_model != SPHDEM_DEM_ROLL_CDT && !liggghts_model(p->model))
    BAD("rolling_model: epsd and epsd2 are LIGGGHTS' rolling models, for the LIGGGHTS models (hertz_liggghts, "
        "hooke_liggghts, hooke_hysteresis_liggghts)");
  if (!(p->rvd >= 0.0) || !isfinite(p->rvd)) BAD("rvd: rolling viscous damping must be >= 0 (got %g)", p->rvd);
  if (p->no_tangential_damping != 0 && p->no_tangential_damping != 1)
    BAD("no_tangential_damping: must be 0 or 1 (got %d)", p->no_tangential_damping);
  if (p->no_tangential_damping && !liggghts_model(p->model))
    BAD("no_tangential_damping: LIGGGHTS' tangential_damping off, for the LIGGGHTS models (hertz_liggghts, "
        "hooke_liggghts, hooke_hysteresis_liggghts)");
  if (p->keep_history != 0 && p->keep_history != 1) BAD("keep_history: must be 0 or 1 (got %d)", p->keep_history);
  if (p->keep_history && !liggghts_model(p->model))
    BAD("keep_history: LIGGGHTS' history rule, for the LIGGGHTS models (hertz_liggghts, hooke_liggghts, "
        "hooke_hysteresis_liggghts)");
  if (p->first_contact != 0 && p->first_contact != 1) BAD("first_contact: must be 0 or 1 (got %d)", p->first_contact);
  if (p->first_contact && p->model != SPHDEM_DEM_HOOKE && p->model != SPHDEM_DEM_HERTZ)
    BAD("first_contact: Yu eq 12 applies to the hooke and hertz models");
  for (int d = 0; d < 3; d++) {
    if (p->periodic[d] != 0 && p->periodic[d] != 1) BAD("periodic[%d]: must be 0 or 1", d);
    if (p->periodic[d] && !(p->boxhi[d] > p->boxlo[d]))
      BAD("boxhi[%d]: periodic axis needs boxhi > boxlo (got %g, %g)", d, p->boxlo[d], p->boxhi[d]);
  }
  return SPHDEM_OK;
}

/* LIGGGHTS' material of the pair (i, j), as its property registry derives it (global_properties.cpp:
 * createYeff, createGeff, createCoeffRestLog, createBetaEff), operation by operation. */
static void derive_mat(dem_mat *M, double Yi, double vi, double Yj, double vj, double e, double mu, double mu_r,
                       double ced) {
  M->Yeff = 1. / ((1. - pow(vi, 2.)) / Yi + (1. - pow(vj, 2.)) / Yj);
  M->Geff = 1. / (2. * (2. - vi) * (1. + vi) / Yi + 2. * (2. - vj) * (1. + vj) / Yj);
  const double lg = e > 0.0 ? log(e) : 0.0;
  M->betaeff = lg / sqrt(pow(lg, 2.) + pow(M_PI, 2.));
  M->lnen = lg;
  M->mu = mu;
  M->mu_r = mu_r;
  M->ced = ced;
  M->rvd = 0.0;
  M->kn2kcmax = M->kn2kc = M->phif = 0.0;
}

static void derive(dem_dev *D, const sphdem_dem_params *p) {
  D->P = *p;
  D->use_en = p->en > 0.0;
  double le = p->en > 0.0 ? fabs(log(p->en)) : 0.0;
  D->cdamp = le / sqrt(M_PI * M_PI + le * le);        /* Yu eq 11 / He eq 23 */
  D->ct = p->ct < 0.0 ? D->cdamp : p->ct;
  D->Estar = p->E / (2.0 * (1.0 - p->nu * p->nu));    /* He eq 21, one material */
  D->tmax_fac = (2.0 - p->nu) / (2.0 - 2.0 * p->nu) * p->mu; /* He eq 22 */
  D->halfL2min = HUGE_VAL;
  for (int d = 0; d < 3; d++) {
    D->L[d] = p->boxhi[d] - p->boxlo[d];
    D->halfL[d] = p->periodic[d] ? 0.5 * D->L[d] : HUGE_VAL;
    if (p->periodic[d] && D->halfL[d] * D->halfL[d] < D->halfL2min) D->halfL2min = D->halfL[d] * D->halfL[d];
  }
  /* LIGGGHTS' material model for two grains of one material, evaluated as it does */
  const double Y = p->E, v = p->nu;
  /* the moduli exist only for the models that take E (the LAMMPS-syntax models leave E = 0) */
  if (Y > 0.0) derive_mat(&D->mat0, Y, v, Y, v, p->en, p->mu, p->mu_r, p->ced);
  else memset(&D->mat0, 0, sizeof D->mat0), D->mat0.mu = p->mu, D->mat0.mu_r = p->mu_r;
  D->mat0.rvd = p->rvd;
  D->mat0.kn2kcmax = p->kn2kcmax;
  D->mat0.kn2kc = p->kn2kc;
  D->mat0.phif = p->phif;
}

int sphdem_dem_create(sphdem_dem *out, const sphdem_dem_params *p, sphdem_device dev, char *msg, size_t msglen) {
  if (!out) BAD("out: NULL");
  *out = NULL;
  int rc = sphdem_dem_params_check(p, msg, msglen);
  if (rc) return rc;
  if (dev != SPHDEM_DEVICE_AUTO && dev != SPHDEM_DEVICE_CPU && dev != SPHDEM_DEVICE_GPU)
    BAD("dev: %d is not a sphdem_device", (int)dev);
  struct sphdem_dem_s *m = (struct sphdem_dem_s *)calloc(1, sizeof *m);
  if (!m) {
    if (msg && msglen) snprintf(msg, msglen, "cannot allocate the DEM context");
    return SPHDEM_ERR_ALLOC;
  }
  m->ops = &sphdem_dem_cpu_ops;
  m->backend = SPHDEM_DEVICE_CPU;
  sphdem_rt_init(&m->rt, SPHDEM_DEVICE_CPU);
  m->zero_copy = 1;
  if (dev != SPHDEM_DEVICE_CPU) {
#ifdef SPHDEM_WITH_CUDA
    char why[256];
    if (sphdem_rt_gpu_probe(why, sizeof why) == SPHDEM_OK) {
      m->ops = &sphdem_dem_cuda_ops;
      m->backend = SPHDEM_DEVICE_GPU;
      sphdem_rt_init(&m->rt, SPHDEM_DEVICE_GPU);
      m->zero_copy = 0;
    } else if (dev == SPHDEM_DEVICE_GPU) {
      if (msg && msglen) snprintf(msg, msglen, "GPU requested but none is usable: %s", why);
      free(m);
      return SPHDEM_ERR_NO_GPU;
    }
#else
    if (dev == SPHDEM_DEVICE_GPU) {
      if (msg && msglen) snprintf(msg, msglen, "GPU requested but sphdem was built without CUDA");
      free(m);
      return SPHDEM_ERR_NO_GPU;
    }
#endif
  }
  derive(&m->D, p);
  m->need_build = 1;
  /* virial, a device counter, the coincident-pair slot */
  rc = rt_alloc(&m->rt, (void **)&m->D.vir, SPHDEM_DEM_VIR_DOUBLES * sizeof(double));
  if (rc) {
    if (msg && msglen) snprintf(msg, msglen, "%s", m->rt.err);
    free(m);
    return rc;
  }
  *out = m;
  return SPHDEM_OK;
}

/* Host memory for the history's host-side work: the backend's allocation on the CPU backend (whose arrays are host
 * memory, so that such an array can be swapped with a device array), malloc else. */
static int host_alloc(struct sphdem_dem_s *m, void **ptr, size_t bytes) {
  if (m->backend == SPHDEM_DEVICE_CPU) return rt_alloc(&m->rt, ptr, bytes);
  *ptr = malloc(bytes ? bytes : 8);
  return *ptr ? SPHDEM_OK : sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate %zu bytes on the host", bytes);
}
static void host_free(struct sphdem_dem_s *m, void **ptr) {
  if (m->backend == SPHDEM_DEVICE_CPU) {
    rt_free(&m->rt, ptr, 0);
  } else {
    free(*ptr);
    *ptr = NULL;
  }
}

/* A host view of bytes of the device array dev: dev itself on the CPU backend, else a copy in *tmp (the caller frees
 * *tmp, NULL on the CPU backend). NULL when the copy fails (the error set). */
static void *host_view(struct sphdem_dem_s *m, void *dev, size_t bytes, void **tmp) {
  *tmp = NULL;
  if (m->backend == SPHDEM_DEVICE_CPU || !dev) return dev;
  if (!(*tmp = malloc(bytes ? bytes : 8))) {
    sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot copy %zu bytes to the host", bytes);
    return NULL;
  }
  if (rt_d2h(&m->rt, *tmp, dev, bytes)) {
    free(*tmp);
    *tmp = NULL;
    return NULL;
  }
  return *tmp;
}

int sphdem_dem_destroy(sphdem_dem *pm) {
  if (!pm || !*pm) return SPHDEM_OK;
  struct sphdem_dem_s *m = *pm;
  dem_dev *D = &m->D;
  D->x = D->v = D->om = D->rad = D->mass = NULL; /* the grain store's arrays */
  if (m->zero_copy) D->f = D->tq = NULL;         /* the caller's arrays */
  void *arrs[] = {D->x, D->v, D->om, D->rad, D->mass, D->f, D->tq, D->flags, D->tag, D->sidx, D->cell,
                  D->cnt, D->off, D->fstart, D->fend, D->rstart, D->rend, D->cstart, D->cend, D->pa, D->pb,
                  D->key, D->hin, D->hout, D->rlist, D->rkey, D->key_old, D->hist_old, D->vir, D->mat,
                  D->rin, D->rout, D->roll_old, D->gran};
  for (size_t k = 0; k < sizeof arrs / sizeof arrs[0]; k++) rt_free(&m->rt, &arrs[k], 0);
  rt_free(&m->rt, (void **)&m->snap_h, 0);
  rt_free(&m->rt, (void **)&m->snap_r, 0);
  free(m->hx0);
  free(m->hr0);
  free(m->cpu_gap);
  free(m->cpu_act);
  free(m->cpu_xact);
  free(m->cpu_head);
  free(m->acc_f);
  free(m->cpu_bt);
  free(m->htag);
  free(m->cpu_pfb);
  free(m->cpu_tf);
  free(m->add_key);
  free(m->add_hist);
  free(m->add_roll);
  host_free(m, (void **)&m->mk);
  host_free(m, (void **)&m->mh);
  host_free(m, (void **)&m->mr);
  sphdem_grains_destroy(&m->gstore);
  free(m);
  *pm = NULL;
  return SPHDEM_OK;
}

const char *sphdem_dem_last_error(sphdem_dem m) { return m ? m->rt.err : "no DEM context"; }
int sphdem_dem_backend(sphdem_dem m) { return m ? m->backend : SPHDEM_DEVICE_CPU; }

int sphdem_dem_set_params(sphdem_dem m, const sphdem_dem_params *p) {
  if (!m) return SPHDEM_ERR_ARG;
  int rc = sphdem_dem_params_check(p, m->rt.err, sizeof m->rt.err);
  if (rc) return rc;
  /* only the box bounds changed (an engine's deforming box): the list stands; compute counts the change of the
   * periodic lengths with the grains' moves (box_move) */
  sphdem_dem_params q = *p;
  memcpy(q.boxlo, m->D.P.boxlo, sizeof q.boxlo);
  memcpy(q.boxhi, m->D.P.boxhi, sizeof q.boxhi);
  const int box_only = !memcmp(&q, &m->D.P, sizeof q);
  derive(&m->D, p);
  if (!box_only) m->need_build = 1;
  return SPHDEM_OK;
}

/* How much closer the periodic images of two grains may be than at the last build because the periodic box
 * lengths changed since (|Delta L| over the periodic axes); 0 for a box that did not change. */
static double box_move(const struct sphdem_dem_s *m) {
  double s = 0.0;
  for (int d = 0; d < 3; d++)
    if (m->D.P.periodic[d]) s += (m->D.L[d] - m->Lbuilt[d]) * (m->D.L[d] - m->Lbuilt[d]);
  return sqrt(s);
}

int sphdem_dem_set_materials(sphdem_dem m, const sphdem_dem_materials *mat) {
  if (!m) return SPHDEM_ERR_ARG;
  dem_dev *D = &m->D;
  if (!mat || mat->n == 0) {
    D->nmat = 0;
    return SPHDEM_OK;
  }
  const int n = mat->n;
  if (!liggghts_model(D->P.model))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "materials: a table of materials is for the LIGGGHTS models "
                           "(hertz_liggghts, hooke_liggghts, hooke_hysteresis_liggghts)");
  const int hyst = D->P.model == SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS;
  if (hyst && (!mat->kn2kcmax || !mat->kn2kc || !mat->phif))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "materials: kn2kcmax, kn2kc, phif are needed by hooke_hysteresis_liggghts "
                           "(one is NULL)");
  if (n < 0 || n > SPHDEM_DEM_MAX_MATERIALS)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "materials: n %d outside 0..%d", n, SPHDEM_DEM_MAX_MATERIALS);
  if (!mat->E || !mat->nu || !mat->en || !mat->mu)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "materials: E, nu, en, mu are needed (one is NULL)");
  for (int i = 0; i < n; i++) {
    if (!(mat->E[i] > 0.0) || !isfinite(mat->E[i]))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "E[%d]: Young's modulus must be > 0 (got %g)", i, mat->E[i]);
    if (!(mat->nu[i] >= 0.0 && mat->nu[i] <= 0.5))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "nu[%d]: Poisson ratio %g outside [0, 0.5]", i, mat->nu[i]);
    for (int j = 0; j < n; j++) {
      const int64_t k = (int64_t)i * n + j, t = (int64_t)j * n + i;
      const double en = mat->en[k], mu = mat->mu[k], mr = mat->mu_r ? mat->mu_r[k] : 0.0;
      if (!(en > 0.05 && en <= 1.0))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "en[%d][%d]: restitution coefficient %g outside (0.05, 1]", i, j, en);
      if (!(mu >= 0.0) || !isfinite(mu))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "mu[%d][%d]: friction coefficient must be >= 0 (got %g)", i, j, mu);
      if (!(mr >= 0.0) || !isfinite(mr))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "mu_r[%d][%d]: rolling friction must be >= 0 (got %g)", i, j, mr);
      const double ck = mat->ced ? mat->ced[k] : 0.0;
      const double rv = mat->rvd ? mat->rvd[k] : 0.0;
      if (!(rv >= 0.0) || !isfinite(rv) || (mat->rvd && rv != mat->rvd[t]))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "rvd[%d][%d]: rolling viscous damping must be >= 0 and symmetric "
                               "(got %g)", i, j, rv);
      if (!(ck >= 0.0) || !isfinite(ck))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "ced[%d][%d]: cohesion energy density must be >= 0 (got %g)", i, j, ck);
      if (hyst) {
        const double k2 = mat->kn2kcmax[k], kc = mat->kn2kc[k], ph = mat->phif[k];
        if (!(k2 > 1.0) || !isfinite(k2) || k2 != mat->kn2kcmax[t])
          return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "kn2kcmax[%d][%d]: must be > 1 and symmetric (got %g)", i, j, k2);
        if (!(kc >= 0.0) || !isfinite(kc) || kc != mat->kn2kc[t])
          return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "kn2kc[%d][%d]: must be >= 0 and symmetric (got %g)", i, j, kc);
        if (!(ph >= 0.0) || !isfinite(ph) || ph != mat->phif[t])
          return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "phif[%d][%d]: must be >= 0 and symmetric (got %g)", i, j, ph);
      }
      if (en != mat->en[t] || mu != mat->mu[t] || (mat->mu_r && mr != mat->mu_r[t]) || (mat->ced && ck != mat->ced[t]))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "materials: the pair values of [%d][%d] and [%d][%d] differ "
                               "(en %g, %g; mu %g, %g): the table must be symmetric", i, j, j, i, en, mat->en[t], mu,
                               mat->mu[t]);
    }
  }
  dem_mat *h = (dem_mat *)malloc(sizeof(dem_mat) * (size_t)n * (size_t)n);
  if (!h) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "materials: cannot allocate %d x %d pairs", n, n);
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) {
      const int64_t k = (int64_t)i * n + j;
      derive_mat(&h[k], mat->E[i], mat->nu[i], mat->E[j], mat->nu[j], mat->en[k], mat->mu[k],
                 mat->mu_r ? mat->mu_r[k] : 0.0, mat->ced ? mat->ced[k] : 0.0);
      h[k].rvd = mat->rvd ? mat->rvd[k] : 0.0;
      if (hyst) h[k].kn2kcmax = mat->kn2kcmax[k], h[k].kn2kc = mat->kn2kc[k], h[k].phif = mat->phif[k];
    }
  rt_free(&m->rt, (void **)&D->mat, 0);
  D->mat = NULL;
  D->nmat = 0;
  int rc = rt_alloc(&m->rt, (void **)&D->mat, sizeof(dem_mat) * (size_t)n * (size_t)n);
  if (!rc) rc = rt_h2d(&m->rt, D->mat, h, sizeof(dem_mat) * (size_t)n * (size_t)n);
  free(h);
  if (rc) return rc;
  D->nmat = n;
  return SPHDEM_OK;
}

int sphdem_dem_set_granular(sphdem_dem m, int n, const sphdem_dem_granular *g) {
  if (!m) return SPHDEM_ERR_ARG;
  dem_dev *D = &m->D;
  if (D->P.model != SPHDEM_DEM_GRANULAR)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular: a type-pair table is for the granular model (model 6)");
  if (n < 1 || n > SPHDEM_DEM_MAX_MATERIALS)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular: n %d outside 1..%d", n, SPHDEM_DEM_MAX_MATERIALS);
  if (!g) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular: pairs NULL");
  int rolling = 0;
  for (int i = 0; i < n; i++)
    for (int j = 0; j < n; j++) {
      const sphdem_dem_granular *c = &g[(int64_t)i * n + j];
      if (c->normal < SPHDEM_GRAN_HOOKE || c->normal > SPHDEM_GRAN_DMT)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d].normal: %d is not a sphdem_gran_normal", i, j, c->normal);
      if (c->damping < SPHDEM_GRAN_DAMP_VELOCITY || c->damping > SPHDEM_GRAN_DAMP_TSUJI)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d].damping: %d is not a sphdem_gran_damping", i, j, c->damping);
      if (c->tangential < SPHDEM_GRAN_TANG_LINEAR_NOHISTORY || c->tangential > SPHDEM_GRAN_TANG_MINDLIN)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d].tangential: %d is not a sphdem_gran_tangential", i, j,
                               c->tangential);
      if (c->rolling < SPHDEM_GRAN_ROLL_NONE || c->rolling > SPHDEM_GRAN_ROLL_SDS)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d].rolling: %d is not a sphdem_gran_rolling", i, j, c->rolling);
      if (c->twisting < SPHDEM_GRAN_TWIST_NONE || c->twisting > SPHDEM_GRAN_TWIST_SDS)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d].twisting: %d is not a sphdem_gran_twisting", i, j,
                               c->twisting);
      const double v[] = {c->kn, c->damp, c->cohesion, c->kt, c->damp_t, c->mu, c->kr, c->damp_r, c->mu_r, c->ktw,
                          c->damp_tw, c->mu_tw};
      for (size_t k = 0; k < sizeof v / sizeof v[0]; k++)
        if (!isfinite(v[k]))
          return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular[%d][%d]: coefficient %d is not finite", i, j, (int)k);
      if (memcmp(c, &g[(int64_t)j * n + i], sizeof *c) != 0)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "granular: pairs [%d][%d] and [%d][%d] differ (the table must be "
                               "symmetric)", i, j, j, i);
      rolling |= c->rolling != SPHDEM_GRAN_ROLL_NONE;
    }
  rt_free(&m->rt, (void **)&D->gran, 0);
  D->gran = NULL;
  D->ngran = 0;
  const size_t bytes = sizeof(sphdem_dem_granular) * (size_t)n * (size_t)n;
  int rc = rt_alloc(&m->rt, (void **)&D->gran, bytes);
  if (!rc) rc = rt_h2d(&m->rt, D->gran, g, bytes);
  if (rc) return rc;
  D->ngran = n;
  if (rolling != D->gran_rolling) m->need_build = 1; /* the rolling history is allocated at a build */
  D->gran_rolling = rolling;
  return SPHDEM_OK;
}

static int cmp_u64(const void *a, const void *b) {
  const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return x < y ? -1 : x > y;
}

/* Negates the rolling and twisting history of the listed pairs in the history the next build carries over and in
 * the pairs added since the last build, at the engine's list builds only (the keys sorted once, bisection). */
int sphdem_dem_flip_history(sphdem_dem m, int64_t n, const uint64_t *keys) {
  if (!m) return SPHDEM_ERR_ARG;
  dem_dev *D = &m->D;
  if (n < 0 || (n > 0 && !keys)) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "flip_history: n %lld, keys NULL", (long long)n);
  /* the history the next build carries over: a seed (restart, hand-over between ranks) or the current list */
  const int seeded = m->seeded;
  const int64_t np = seeded ? D->np_old : m->nbuilds ? D->np : 0;
  if (n == 0 || D->P.model != SPHDEM_DEM_GRANULAR || (np == 0 && m->nadd == 0)) return SPHDEM_OK;
  uint64_t *fk = (uint64_t *)malloc(sizeof(uint64_t) * (size_t)n);
  if (!fk) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "flip_history: %lld pairs", (long long)n);
  memcpy(fk, keys, sizeof(uint64_t) * (size_t)n);
  qsort(fk, (size_t)n, sizeof(uint64_t), cmp_u64);
  for (int64_t j = 0; j < m->nadd; j++) { /* the pairs added since the last build (sphdem_dem_add_history) */
    if (!bsearch(&m->add_key[j], fk, (size_t)n, sizeof(uint64_t), cmp_u64)) continue;
    m->add_hist[SPHDEM_DEM_NHIST * j + 4] = -m->add_hist[SPHDEM_DEM_NHIST * j + 4];
    for (int q = 0; q < 3; q++) m->add_roll[3 * j + q] = -m->add_roll[3 * j + q];
  }
  uint64_t *dk = seeded ? D->key_old : D->key;
  double *dh = seeded ? D->hist_old : D->hin;
  double *dr = seeded ? (m->seed_roll ? D->roll_old : NULL) : D->rin;
  void *tk = NULL, *th = NULL, *tr = NULL;
  const size_t hb = sizeof(double) * SPHDEM_DEM_NHIST * (size_t)np, rb = sizeof(double) * 3 * (size_t)np;
  const uint64_t *pk = np ? (const uint64_t *)host_view(m, dk, sizeof(uint64_t) * (size_t)np, &tk) : NULL;
  double *h = pk ? (double *)host_view(m, dh, hb, &th) : NULL;
  double *r = h && dr ? (double *)host_view(m, dr, rb, &tr) : NULL;
  int rc = np && (!h || (dr && !r)) ? SPHDEM_ERR_ALLOC : SPHDEM_OK, changed = 0;
  for (int64_t p = 0; !rc && p < np; p++) {
    if (!bsearch(&pk[p], fk, (size_t)n, sizeof(uint64_t), cmp_u64)) continue;
    h[SPHDEM_DEM_NHIST * p + 4] = -h[SPHDEM_DEM_NHIST * p + 4];
    if (r)
      for (int q = 0; q < 3; q++) r[3 * p + q] = -r[3 * p + q];
    changed = 1;
  }
  if (changed) m->tf_valid = 0;
  if (!rc && changed && th) rc = rt_h2d(&m->rt, dh, th, hb); /* (the CPU backend changed them in place) */
  if (!rc && changed && tr) rc = rt_h2d(&m->rt, dr, tr, rb);
  free(fk);
  free(tk);
  free(th);
  free(tr);
  return rc;
}

int sphdem_dem_set_exclusions(sphdem_dem m, int n, const uint16_t *rows) {
  if (!m) return SPHDEM_ERR_ARG;
  if (n < 0 || n > SPHDEM_DEM_MAX_CLASSES)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "exclusions: n %d outside 0..%d", n, SPHDEM_DEM_MAX_CLASSES);
  if (n > 0 && !rows) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "exclusions: rows NULL for %d classes", n);
  uint16_t e[SPHDEM_DEM_MAX_CLASSES] = {0};
  const unsigned keep = n >= 16 ? 0xffffu : (1u << n) - 1u;
  int any = 0;
  for (int c = 0; c < n; c++) {
    if (rows[c] & ~keep)
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "exclusions: rows[%d] names a class >= %d", c, n);
    e[c] = rows[c];
    any |= e[c] != 0;
  }
  for (int a = 0; a < n; a++)
    for (int b = 0; b < n; b++)
      if (((e[a] >> b) & 1) != ((e[b] >> a) & 1))
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "exclusions: not symmetric (classes %d and %d)", a, b);
  if (memcmp(e, m->D.excl, sizeof e) != 0) m->need_build = 1; /* the pair rule of dem_pair_kept changes */
  memcpy(m->D.excl, e, sizeof e);
  m->D.any_excl = any;
  return SPHDEM_OK;
}

int sphdem_dem_set_walls(sphdem_dem m, int nw, const sphdem_dem_wall *w) {
  if (!m) return SPHDEM_ERR_ARG;
  if (nw < 0 || nw > SPHDEM_DEM_MAX_WALLS)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "nw: %d walls, allowed 0..%d", nw, SPHDEM_DEM_MAX_WALLS);
  if (nw > 0 && !w) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "walls: NULL with nw = %d", nw);
  for (int k = 0; k < nw; k++) {
    const double *n = w[k].normal;
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(fabs(nn - 1.0) < 1e-9))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "walls[%d].normal: not a unit vector (|n| = %g)", k, nn);
    m->D.walls[k] = w[k];
  }
  m->D.nw = nw;
  m->need_build = 1;
  return SPHDEM_OK;
}

int sphdem_dem_set_accumulate(sphdem_dem m, int on) {
  if (!m) return SPHDEM_ERR_ARG;
  m->accumulate = on != 0;
  return SPHDEM_OK;
}

int sphdem_dem_same_tags(sphdem_dem m) {
  if (!m) return SPHDEM_ERR_ARG;
  m->same_tags = 1;
  return SPHDEM_OK;
}

int sphdem_dem_set_ghost_once(sphdem_dem m, int on) {
  if (!m) return SPHDEM_ERR_ARG;
  if ((on != 0) != m->D.ghost_once) m->need_build = 1; /* the pair rule of dem_pair_kept changes */
  m->D.ghost_once = on != 0;
  return SPHDEM_OK;
}

int sphdem_dem_request_build(sphdem_dem m) {
  if (!m) return SPHDEM_ERR_ARG;
  m->need_build = 1;
  m->build_requested = 1;
  return SPHDEM_OK;
}

/* (Re)allocate a device array for at least need elements; contents are not kept. */
static int grow(struct sphdem_dem_s *m, void **ptr, size_t elem, int64_t need, int64_t cap_new) {
  (void)need;
  rt_free(&m->rt, ptr, 0);
  return rt_alloc(&m->rt, ptr, elem * (size_t)(cap_new > 0 ? cap_new : 1));
}

static int ensure_grains(struct sphdem_dem_s *m, int64_t n) {
  if (n <= m->cap_n && m->D.sidx) return SPHDEM_OK;
  dem_dev *D = &m->D;
  int64_t cap = n + n / 4 + 16, rc = 0;
  if (!m->zero_copy) { /* x, v, om, rad, mass are the grain store's */
    rc |= grow(m, (void **)&D->f, 3 * sizeof(double), n, cap);
    rc |= grow(m, (void **)&D->tq, 3 * sizeof(double), n, cap);
  }
  rc |= grow(m, (void **)&D->flags, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->tag, sizeof(int64_t), n, cap);
  rc |= grow(m, (void **)&D->sidx, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->cell, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->cnt, sizeof(int64_t), n, cap);
  rc |= grow(m, (void **)&D->off, sizeof(int64_t), n, cap);
  rc |= grow(m, (void **)&D->fstart, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->fend, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->rstart, sizeof(int32_t), n, cap);
  rc |= grow(m, (void **)&D->rend, sizeof(int32_t), n, cap);
  if (rc) return SPHDEM_ERR_ALLOC;
  double *hx = (double *)realloc(m->hx0, sizeof(double) * 3 * cap);
  if (hx) m->hx0 = hx;
  double *hr = (double *)realloc(m->hr0, sizeof(double) * cap);
  if (hr) m->hr0 = hr;
  if (!hr) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate host copies for %lld grains", (long long)n);
  int64_t *ht = (int64_t *)realloc(m->htag, sizeof(int64_t) * cap);
  if (ht) m->htag = ht;
  if (!hx || !ht) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate host copies for %lld grains", (long long)n);
  m->cap_n = cap;
  m->need_build = 1;
  m->tags_valid = 0; /* tags must be uploaded again */
  return SPHDEM_OK;
}

/* Cell grid: periodic axes span the box, the others the grains' bounding box; cells >= d_max + skin. */
static int setup_grid(struct sphdem_dem_s *m, int64_t n, const double *x, double dmax) {
  dem_dev *D = &m->D;
  double cut = dmax + D->P.skin;
  if (!(cut > 0.0)) cut = 1.0;
  double lo[3], hi[3];
  for (int d = 0; d < 3; d++) {
    if (D->P.periodic[d]) { lo[d] = D->P.boxlo[d]; hi[d] = D->P.boxhi[d]; continue; }
    lo[d] = n ? x[d] : 0.0;
    hi[d] = lo[d];
    for (int64_t i = 1; i < n; i++) {
      double v = x[3 * i + d];
      if (v < lo[d]) lo[d] = v;
      if (v > hi[d]) hi[d] = v;
    }
  }
  for (int iter = 0;; iter++) {
    double tot = 1.0; /* in double: three axes of up to 2^30 cells overflow int64 */
    for (int d = 0; d < 3; d++) {
      double len = hi[d] - lo[d];
      int nc = (int)fmin(floor(len / cut), 1073741824.0);
      if (nc < 1) nc = 1;
      D->nc[d] = nc;
      D->glo[d] = lo[d];
      D->cs_inv[d] = D->P.periodic[d] ? nc / len : 1.0 / cut;
      tot *= nc;
    }
    if (tot <= SPHDEM_DEM_MAX_CELLS) { D->ncells = (int64_t)tot; break; }
    if (iter == 400)
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "the grains span %g x %g x %g: no cell grid of at most %d cells "
                             "covers them (a grain far away from the others?)", hi[0] - lo[0], hi[1] - lo[1],
                             hi[2] - lo[2], SPHDEM_DEM_MAX_CELLS);
    cut *= 1.26;
  }
  if (D->ncells + 1 > m->cap_cells) { /* the cells, and the one of the SPHDEM_DEM_SKIP grains */
    int rc = grow(m, (void **)&D->cstart, sizeof(int32_t), D->ncells + 1, D->ncells + 1);
    rc |= grow(m, (void **)&D->cend, sizeof(int32_t), D->ncells + 1, D->ncells + 1);
    if (rc) return SPHDEM_ERR_ALLOC;
    m->cap_cells = D->ncells + 1;
  }
  return SPHDEM_OK;
}

#define TRY(call) do { int rc_ = (call); if (rc_) return rc_; } while (0)

/* the pair arrays with room for cap pairs (their contents are not kept) */
static int grow_pairs(struct sphdem_dem_s *m, int64_t np, int64_t cap) {
  dem_dev *D = &m->D;
  TRY(grow(m, (void **)&D->pa, sizeof(int32_t), np, cap));
  TRY(grow(m, (void **)&D->pb, sizeof(int32_t), np, cap));
  TRY(grow(m, (void **)&D->rlist, sizeof(int32_t), np, cap));
  TRY(grow(m, (void **)&D->rkey, sizeof(int32_t), np, cap));
  TRY(grow(m, (void **)&D->key, sizeof(uint64_t), np, cap));
  TRY(grow(m, (void **)&D->hin, sizeof(double) * SPHDEM_DEM_NHIST, np, cap));
  TRY(grow(m, (void **)&D->hout, sizeof(double) * SPHDEM_DEM_NHIST, np, cap));
  m->cap_p = cap;
  return SPHDEM_OK;
}

/* The pairs of sphdem_dem_add_history merged into the history the build carries over (key_old, hist_old and, for a
 * model with rolling torques, roll_old; np_old pairs sorted by key): one walk of the two sorted lists into the
 * spare arrays, a pair held already keeping its values. The CPU backend swaps the spare arrays in; the GPU backend
 * copies the old list to the host and the merged one back. */
static int merge_added(struct sphdem_dem_s *m, int roll) {
  dem_dev *D = &m->D;
  const int64_t no = D->np_old, na = m->nadd, cap = no + na + (no + na) / 4 + 16;
  const int H = SPHDEM_DEM_NHIST, cpu = m->backend == SPHDEM_DEVICE_CPU;
  const int with_roll = roll && (D->roll_carry || m->add_roll_given);
  m->nadd = 0;
  m->add_roll_given = 0;
  /* the merged list goes to the spare arrays */
  if (no + na > m->cap_m) {
    host_free(m, (void **)&m->mk);
    host_free(m, (void **)&m->mh);
    m->cap_m = 0;
    TRY(host_alloc(m, (void **)&m->mk, sizeof(uint64_t) * (size_t)cap));
    TRY(host_alloc(m, (void **)&m->mh, sizeof(double) * H * (size_t)cap));
    m->cap_m = cap;
  }
  if (with_roll && no + na > m->cap_mr) {
    host_free(m, (void **)&m->mr);
    m->cap_mr = 0;
    TRY(host_alloc(m, (void **)&m->mr, sizeof(double) * 3 * (size_t)cap));
    m->cap_mr = cap;
  }
  void *tk = NULL, *th = NULL, *tr = NULL;
  const uint64_t *ok = no ? (const uint64_t *)host_view(m, D->key_old, sizeof(uint64_t) * (size_t)no, &tk) : NULL;
  const double *oh = ok ? (const double *)host_view(m, D->hist_old, sizeof(double) * H * (size_t)no, &th) : NULL;
  const double *orr = oh && D->roll_carry ? (const double *)host_view(m, D->roll_old, sizeof(double) * 3 * (size_t)no, &tr)
                                          : NULL;
  if (no && (!oh || (D->roll_carry && !orr))) {
    free(tk), free(th), free(tr);
    return SPHDEM_ERR_ALLOC;
  }
  int64_t i = 0, j = 0, k = 0;
  while (i < no || j < na) {
    const int take_old = j >= na || (i < no && ok[i] <= m->add_key[j]);
    if (take_old && j < na && i < no && ok[i] == m->add_key[j]) j++; /* held already: its own values */
    if (take_old) {
      m->mk[k] = ok[i];
      memcpy(m->mh + H * k, oh + H * i, sizeof(double) * H);
      if (with_roll) {
        if (orr) memcpy(m->mr + 3 * k, orr + 3 * i, sizeof(double) * 3);
        else m->mr[3 * k] = m->mr[3 * k + 1] = m->mr[3 * k + 2] = 0.0;
      }
      i++;
    } else {
      m->mk[k] = m->add_key[j];
      memcpy(m->mh + H * k, m->add_hist + H * j, sizeof(double) * H);
      if (with_roll) memcpy(m->mr + 3 * k, m->add_roll + 3 * j, sizeof(double) * 3);
      j++;
    }
    k++;
  }
  free(tk), free(th), free(tr);
  if (cpu) { /* the merged arrays become the old list, the old ones the spares */
    uint64_t *k0 = D->key_old;
    double *h0 = D->hist_old;
    int64_t c0 = m->cap_pold;
    D->key_old = m->mk, D->hist_old = m->mh, m->cap_pold = m->cap_m;
    m->mk = k0, m->mh = h0, m->cap_m = c0;
    if (with_roll) {
      double *r0 = D->roll_old;
      int64_t cr = m->cap_rold;
      D->roll_old = m->mr, m->cap_rold = m->cap_mr;
      m->mr = r0, m->cap_mr = cr;
    }
  } else {
    if (k > m->cap_pold) {
      TRY(grow(m, (void **)&D->key_old, sizeof(uint64_t), k, cap));
      TRY(grow(m, (void **)&D->hist_old, sizeof(double) * H, k, cap));
      m->cap_pold = cap;
    }
    if (with_roll && k > m->cap_rold) {
      TRY(grow(m, (void **)&D->roll_old, sizeof(double) * 3, k, cap));
      m->cap_rold = cap;
    }
    TRY(rt_h2d(&m->rt, D->key_old, m->mk, sizeof(uint64_t) * (size_t)k));
    TRY(rt_h2d(&m->rt, D->hist_old, m->mh, sizeof(double) * H * (size_t)k));
    if (with_roll) TRY(rt_h2d(&m->rt, D->roll_old, m->mr, sizeof(double) * 3 * (size_t)k));
  }
  D->np_old = k;
  D->roll_carry = with_roll && k > 0;
  return SPHDEM_OK;
}

static int build(struct sphdem_dem_s *m, int64_t n, const double *x, double dmax) {
  dem_dev *D = &m->D;
  m->tf_valid = 0; /* a new list, a carried history */
  /* keep the current list (sorted by key) and its history for the carry, unless a restart seeded it */
  int64_t npold = m->seeded ? D->np_old : m->nbuilds ? D->np : 0;
  if (!m->seeded && npold > m->cap_pold) {
    int64_t cap = npold + npold / 4 + 16;
    TRY(grow(m, (void **)&D->key_old, sizeof(uint64_t), npold, cap));
    TRY(grow(m, (void **)&D->hist_old, sizeof(double) * SPHDEM_DEM_NHIST, npold, cap));
    m->cap_pold = cap;
  }
  if (npold && !m->seeded) {
    TRY(rt_d2d(&m->rt, D->key_old, D->key, sizeof(uint64_t) * npold));
    TRY(rt_d2d(&m->rt, D->hist_old, D->hin, sizeof(double) * SPHDEM_DEM_NHIST * npold));
  }
  /* epsd2: the rolling torques of the current list, for the carry (not kept by a restart seed) */
  const int roll = (D->P.rolling_model != SPHDEM_DEM_ROLL_CDT && D->P.mu_r > 0.0) ||
                   (D->P.model == SPHDEM_DEM_GRANULAR && D->gran_rolling);
  D->roll_carry = roll && npold > 0 && (m->seeded ? m->seed_roll : m->roll_valid);
  if (D->roll_carry && !m->seeded) { /* (a seed with rolling torques put them into roll_old) */
    if (npold > m->cap_rold) {
      int64_t cap = npold + npold / 4 + 16;
      TRY(grow(m, (void **)&D->roll_old, sizeof(double) * 3, npold, cap));
      m->cap_rold = cap;
    }
    TRY(rt_d2d(&m->rt, D->roll_old, D->rin, sizeof(double) * 3 * npold));
  }
  D->np_old = npold;
  m->seeded = 0;
  m->seed_roll = 0;
  if (m->nadd > 0) TRY(merge_added(m, roll));
  TRY(setup_grid(m, n, x, dmax));
  TRY(m->ops->cells(m));
  int64_t np = 0;
  if (!D->pa && m->backend == SPHDEM_DEVICE_CPU && n > 0) {
    /* the first list on the CPU: room for 8 pairs a grain (a dense packing has 6-7), so that the one-thread scan
     * writes the pairs as it counts them (host pages that are never written cost no memory) */
    TRY(grow_pairs(m, 0, 8 * n + 64));
  }
  D->pcap = D->pa ? m->cap_p : 0;
  TRY(m->ops->count(m, &np));
  if (np > 2147483647LL) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "%lld candidate pairs exceed 2^31", (long long)np);
  if (np > m->cap_p || !D->pa) TRY(grow_pairs(m, np, np + np / 4 + 64));
  D->pcap = m->cap_p;
  if (roll && (np > m->cap_roll || !D->rin)) {
    int64_t cap = np + np / 4 + 64;
    TRY(grow(m, (void **)&D->rin, sizeof(double) * 3, np, cap));
    TRY(grow(m, (void **)&D->rout, sizeof(double) * 3, np, cap));
    m->cap_roll = cap;
  }
  if (!roll && D->rin) { /* rolling model switched off: no rolling history */
    rt_free(&m->rt, (void **)&D->rin, 0);
    rt_free(&m->rt, (void **)&D->rout, 0);
    m->cap_roll = 0;
  }
  D->np = np;
  D->carry_touching = D->P.keep_history && m->build_requested;
  TRY(m->ops->fill(m));
  if (D->P.algo == SPHDEM_DEM_PARTICLE_PARALLEL) TRY(m->ops->csr(m));
  if (n) memcpy(m->hx0, x, sizeof(double) * 3 * n); /* x may be NULL when no grain is left */
  for (int d = 0; d < 3; d++) m->Lbuilt[d] = D->L[d];
  m->dmax_built = dmax;
  m->nbuilds++;
  m->need_build = 0;
  m->build_requested = 0;
  m->roll_valid = D->rin != NULL;
  return SPHDEM_OK;
}

int sphdem_dem_compute(sphdem_dem m, int n, const int64_t *tag, const double *x, const double *v,
                       const double *omega, const double *radius, const double *mass, const int *flags,
                       double dt, int update_history, double *f, double *torque, double *virial) {
  if (!m) return SPHDEM_ERR_ARG;
  if (n < 0) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "n: %d grains", n);
  if (n > 0 && (!tag || !x || !v || !omega || !radius || !mass || !f || !torque))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "tag, x, v, omega, radius, mass, f, torque: all needed (one is NULL)");
  TRY(sphdem_grains_put_private(&m->gstore, &m->rt, m->backend, n, x, v, omega, radius, mass));
  return sphdem_dem_compute_store(m, m->gstore, tag, flags, dt, update_history, f, torque, virial);
}

/* the per-step loops over all grains: an AVX2 copy beside the baseline one, chosen at load time (gcc, x86-64) */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define SPHDEM_DEM_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define SPHDEM_DEM_CLONES
#endif

/* The rebuild check's sums over the grains, in one loop over radii and masses and one over positions, which the
 * compiler vectorises: whether a position, radius or mass is inf or NaN (its exponent bits all set: adding 1 to
 * them carries into the top bit); for finite grains the least radius and mass, the largest radius, squared
 * displacement since x0 and radius growth since r0 (max and min of finite values are the same bits in any order,
 * so the attribute may let the compiler reorder them). Returns 1 when a value is not finite. */
#define SPHDEM_NONFINITE_BITS(v) ((dem_u64_bits(v) & 0x7ff0000000000000ull) + 0x0010000000000000ull)
static inline uint64_t dem_u64_bits(double v) {
  uint64_t u;
  memcpy(&u, &v, sizeof u);
  return u;
}
__attribute__((optimize("finite-math-only", "no-signed-zeros"))) SPHDEM_DEM_CLONES
static int grains_scan(const double *x, const double *x0, const double *radius, const double *r0, const double *mass,
                       int n, double *rmin_, double *rmax_, double *mmin_, double *d2max_, double *drmax_) {
  double rmin = DBL_MAX, rmax = *rmax_, mmin = DBL_MAX, d2max = 0.0, drmax = 0.0;
  uint64_t bad = 0;
  for (int i = 0; i < n; i++) {
    const double r = radius[i], ms = mass[i], dr = r - r0[i];
    bad |= SPHDEM_NONFINITE_BITS(r) | SPHDEM_NONFINITE_BITS(ms);
    rmax = r > rmax ? r : rmax;
    rmin = r < rmin ? r : rmin;
    mmin = ms < mmin ? ms : mmin;
    drmax = dr > drmax ? dr : drmax;
  }
  for (int i = 0; i < n; i++) {
    const double xa = x[3 * i], ya = x[3 * i + 1], za = x[3 * i + 2];
    bad |= SPHDEM_NONFINITE_BITS(xa) | SPHDEM_NONFINITE_BITS(ya) | SPHDEM_NONFINITE_BITS(za);
    const double dx = xa - x0[3 * i], dy = ya - x0[3 * i + 1], dz = za - x0[3 * i + 2];
    const double d2 = dx * dx + dy * dy + dz * dz; /* (may overflow for finite, far apart positions) */
    d2max = d2 > d2max ? d2 : d2max;
  }
  *rmin_ = rmin, *rmax_ = rmax, *mmin_ = mmin, *d2max_ = d2max, *drmax_ = drmax;
  return (bad >> 63) != 0;
}
#undef SPHDEM_NONFINITE_BITS

/* The first bad grain of sphdem_dem_compute_store, in the words of its checks (rc of sphdem_dem_fail). */
static int grain_error(struct sphdem_dem_s *m, int n, const int64_t *tag, const double *x, const double *radius,
                       const double *mass, const int *flags, int nmat) {
  for (int i = 0; i < n; i++) {
    if (tag[i] < 1 || tag[i] > SPHDEM_DEM_MAX_TAG)
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "tag[%d]: %lld outside 1..2^31-1", i, (long long)tag[i]);
    if (!(radius[i] > 0.0))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "radius[%d] (grain %lld): must be > 0 (got %g)", i, (long long)tag[i],
                             radius[i]);
    if (!(mass[i] > 0.0))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "mass[%d] (grain %lld): must be > 0 (got %g)", i, (long long)tag[i],
                             mass[i]);
    if (!isfinite(radius[i]) || !isfinite(mass[i]))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "grain %lld: radius %g or mass %g is not finite", (long long)tag[i],
                             radius[i], mass[i]);
    /* checked before binning: a non-finite position has no cell */
    if (!isfinite(x[3 * i]) || !isfinite(x[3 * i + 1]) || !isfinite(x[3 * i + 2]))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "grain %lld: position (%g, %g, %g) is not finite", (long long)tag[i],
                             x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    if (flags && (flags[i] < 0 || (flags[i] >> SPHDEM_DEM_MATERIAL_SHIFT) >= nmat))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "grain %lld: material %d, but %d material%s given", (long long)tag[i],
                             flags[i] < 0 ? -1 : flags[i] >> SPHDEM_DEM_MATERIAL_SHIFT, nmat, nmat > 1 ? "s are" : " is");
  }
  return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "a grain is not valid");
}

int sphdem_dem_compute_store(sphdem_dem m, sphdem_grain_store g, const int64_t *tag, const int *flags, double dt,
                             int update_history, double *f, double *torque, double *virial) {
  if (!m) return SPHDEM_ERR_ARG;
  dem_dev *D = &m->D;
  TRY(sphdem_grains_check(g, &m->rt, m->backend, 0, NULL, "dem_compute"));
  const int n = g->have ? g->nown + g->nghost : 0;
  const double *x = g->hx, *radius = g->hrad, *mass = g->hmass;
  if (n > 0 && (!tag || !g->hom || !mass || !f || !torque))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "tag, omega, mass, f, torque: all needed (one is NULL)");
  if (!(dt >= 0.0) || !isfinite(dt)) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "dt: must be finite and >= 0 (got %g)", dt);
  double t0 = rt_now(), t1;
  double rmax = 0.0;
  int has_ghosts = 0;
  const int granular = D->P.model == SPHDEM_DEM_GRANULAR;
  const int nmat = granular ? D->ngran : D->nmat > 0 ? D->nmat : 1;
  if (granular && D->ngran == 0)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "the granular model needs its type-pair table (sphdem_dem_set_granular)");
  if (granular && n > 0 && !flags)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "the granular model needs the grain types in the flags (NULL given)");
  /* one pass without early exits, which also measures how far the grains moved since the last build (when
   * the same grains come again: else the list is rebuilt anyway); the message comes from grain_error when a
   * grain is bad */
  const int same_n = !m->need_build && m->tags_valid && n == D->n && m->hx0 && m->hr0;
  const double lim = 0.25 * D->P.skin * D->P.skin, *x0 = same_n ? m->hx0 : x, *r0 = same_n ? m->hr0 : radius;
  /* extremes only (no test and branch per grain), in loops the compiler vectorises */
  double rmin = HUGE_VAL, mmin = HUGE_VAL, d2max = 0.0, drmax = 0.0;
  const int nonfinite = grains_scan(x, x0, radius, r0, mass, n, &rmin, &rmax, &mmin, &d2max, &drmax);
  int bad = nonfinite | !(rmin > 0.0) | !(mmin > 0.0);
  /* the tags: unless they are those of the last call (checked then; the caller's word, sphdem_dem_same_tags, or
   * compared) */
  const int tags_same = m->tags_valid && n == D->n && m->htag &&
                        (m->same_tags || !n || !memcmp(m->htag, tag, sizeof(int64_t) * n));
  m->same_tags = 0;
  if (!tags_same)
    for (int i = 0; i < n; i++) bad |= (tag[i] < 1) | (tag[i] > SPHDEM_DEM_MAX_TAG);
  /* a pair's gap shrinks by at most the moves of its two grains and the change of the periodic lengths */
  const double dbox = box_move(m), dmove = sqrt(d2max) + 0.5 * dbox;
  const int moved = d2max > lim || dmove * dmove > lim;
  int any_frozen = 0;
  if (flags)
    for (int i = 0; i < n; i++) {
      any_frozen |= (flags[i] & SPHDEM_DEM_FROZEN) != 0;
      has_ghosts |= (flags[i] & (SPHDEM_DEM_GHOST | SPHDEM_DEM_IMAGE | SPHDEM_DEM_SKIP)) != 0;
      bad |= (flags[i] < 0) | ((flags[i] >> SPHDEM_DEM_MATERIAL_SHIFT) >= nmat);
    }
  if (bad) return grain_error(m, n, tag, x, radius, mass, flags, nmat);
  TRY(ensure_grains(m, n));
  D->any_frozen = any_frozen;
  if (has_ghosts != m->has_ghosts) m->need_build = 1; /* the pair rule of dem_pair_kept changes */
  m->has_ghosts = has_ghosts;
  /* rebuild when the grains, their order or their sizes changed, or one moved more than skin/2 */
  int new_tags = !tags_same;
  if (new_tags) m->need_build = 1;
  if (2.0 * rmax > m->dmax_built) m->need_build = 1;
  if (same_n && moved) m->need_build = 1;
  D->n = n;
  t1 = rt_now();
  m->t[SPHDEM_DEM_T_CHECK] += t1 - t0;
  t0 = t1;
  if (n) {
    /* the grains are read where the store keeps them (CPU backend: the caller's arrays); the CPU writes f,
     * torque in place */
    TRY(sphdem_grains_device(g, &m->rt));
    D->x = g->dx, D->v = g->dv, D->om = g->dom, D->rad = g->drad, D->mass = g->dmass;
    if (m->zero_copy) D->f = f, D->tq = torque;
    /* adding to the caller's forces: the one-thread CPU pass adds in place; the other passes write their own
     * arrays (here, or the device's), added below */
    m->cpu_adds = m->accumulate && m->zero_copy && sphdem_dem_cpu_serial_pass(m);
    if (m->accumulate && !m->cpu_adds) {
      if (6 * (int64_t)n > m->cap_acc) {
        const int64_t cap = 6 * (int64_t)n + 6 * (int64_t)(n / 4) + 64;
        double *a = (double *)realloc(m->acc_f, sizeof(double) * (size_t)cap);
        if (!a) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "cannot allocate the force buffer (%d grains)", n);
        m->acc_f = a;
        m->cap_acc = cap;
      }
      if (m->zero_copy) D->f = m->acc_f, D->tq = m->acc_f + 3 * (int64_t)n;
    }
    if (flags) {
      TRY(rt_h2d(&m->rt, D->flags, flags, sizeof(int32_t) * n));
      m->flags_zero = NULL;
    } else if (m->flags_zero != D->flags || m->flags_zero_n != n) { /* (still zero from the last call: kept) */
      TRY(rt_zero(&m->rt, D->flags, sizeof(int32_t) * n));
      m->flags_zero = D->flags;
      m->flags_zero_n = n;
    }
    if (new_tags) {
      TRY(rt_h2d(&m->rt, D->tag, tag, sizeof(int64_t) * n));
      memcpy(m->htag, tag, sizeof(int64_t) * n);
    }
  }
  m->tags_valid = 1;
  t1 = rt_now();
  m->t[SPHDEM_DEM_T_UPLOAD] += t1 - t0;
  t0 = t1;
  /* no grain moved by more than sqrt(d2max) nor grew by more than drmax since the build, and the periodic
   * lengths changed by dbox */
  D->gap_thr = 2.0 * (sqrt(d2max) + drmax) + dbox;
  m->gap_rest = 2.0 * drmax + dbox;
  if (m->need_build) {
    TRY(build(m, n, x, 2.0 * rmax));
    D->gap_thr = m->gap_rest = 0.0;
    if (n) memcpy(m->hr0, radius, sizeof(double) * n);
    t1 = rt_now();
    m->t[SPHDEM_DEM_T_DETECT] += t1 - t0;
    t0 = t1;
  }
  D->dt = dt;
  D->update = update_history ? 1 : 0;
  D->want_virial = virial != NULL;
  if (virial) TRY(rt_zero(&m->rt, D->vir, 6 * sizeof(double)));
  int64_t ntouch = 0;
  m->snap_valid = 0;
  if (m->snap_req) { /* the history this evaluation starts from, for sphdem_dem_step_contacts */
    const int64_t np = D->np > 0 ? D->np : 1;
    if (np > m->cap_snap) {
      rt_free(&m->rt, (void **)&m->snap_h, 0);
      rt_free(&m->rt, (void **)&m->snap_r, 0);
      m->cap_snap = 0;
      TRY(rt_alloc(&m->rt, (void **)&m->snap_h, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)(np + np / 4)));
      TRY(rt_alloc(&m->rt, (void **)&m->snap_r, sizeof(double) * 3 * (size_t)(np + np / 4)));
      m->cap_snap = np + np / 4;
    }
    TRY(rt_d2d(&m->rt, m->snap_h, D->hin, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)D->np));
    if (D->rin) TRY(rt_d2d(&m->rt, m->snap_r, D->rin, sizeof(double) * 3 * (size_t)D->np));
    m->snap_update = D->update;
    m->snap_valid = 1;
    m->snap_req = 0;
  }
  if (n) {
    uint64_t *slot = (uint64_t *)(D->vir + SPHDEM_DEM_VIR_COINCIDENT);
    TRY(rt_zero(&m->rt, slot, sizeof(uint64_t)));
    TRY(m->ops->forces(m, &ntouch));
    uint64_t code = 0;
    TRY(rt_d2h(&m->rt, &code, slot, sizeof code));
    if (code) { /* a pair whose centres coincide has no contact normal (the force would be 0/0) */
      int64_t a = (int64_t)(code >> 32) - 1, b = (int64_t)(code & 0xffffffffu);
      if (a >= 0 && a < n && b >= 0 && b < n)
        return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "grains %lld and %lld are at the same position (%g, %g, %g): "
                               "remove one of them (created twice?)", (long long)tag[a], (long long)tag[b],
                               x[3 * a], x[3 * a + 1], x[3 * a + 2]);
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "two grains are at the same position");
    }
  }
  m->ncontacts = ntouch;
  /* the new history becomes the current one (unless the backend wrote it in place) */
  if (!m->hist_in_place) {
    double *t = D->hin;
    D->hin = D->hout;
    D->hout = t;
    if (D->rin) {
      t = D->rin;
      D->rin = D->rout;
      D->rout = t;
    }
  }
  t1 = rt_now();
  m->t[SPHDEM_DEM_T_FORCE] += t1 - t0;
  t0 = t1;
  if (n) {
    const int add = m->accumulate && !m->cpu_adds;
    double *fo = add ? m->acc_f : f, *to = add ? m->acc_f + 3 * (int64_t)n : torque;
    if (!m->zero_copy) {
      TRY(rt_d2h(&m->rt, fo, D->f, sizeof(double) * 3 * n));
      TRY(rt_d2h(&m->rt, to, D->tq, sizeof(double) * 3 * n));
    }
    if (add)
      for (int64_t k = 0; k < 3 * (int64_t)n; k++) {
        f[k] += fo[k];
        torque[k] += to[k];
      }
  }
  if (virial) TRY(rt_d2h(&m->rt, virial, D->vir, 6 * sizeof(double)));
  m->t[SPHDEM_DEM_T_DOWNLOAD] += rt_now() - t0;
  m->ncalls++;
  return SPHDEM_OK;
}

int64_t sphdem_dem_timers(sphdem_dem m, double t[SPHDEM_DEM_NTIMERS]) {
  if (!m || !t) return 0;
  for (int k = 0; k < SPHDEM_DEM_NTIMERS; k++) t[k] = m->t[k];
  return m->ncalls;
}

void sphdem_dem_timers_reset(sphdem_dem m) {
  if (!m) return;
  for (int k = 0; k < SPHDEM_DEM_NTIMERS; k++) m->t[k] = 0.0;
  m->ncalls = 0;
}

int sphdem_dem_stats_get(sphdem_dem m, sphdem_dem_stats *s) {
  if (!m || !s) return SPHDEM_ERR_ARG;
  s->npairs = m->D.np;
  if (m->has_ghosts && m->D.np > 0 && m->D.n > 0) { /* the pairs this rank counts (dem_pair_counted) */
    int64_t np = m->D.np, n = m->D.n, c = 0;
    int32_t *a = (int32_t *)malloc(sizeof(int32_t) * (size_t)np), *fl = (int32_t *)malloc(sizeof(int32_t) * (size_t)n);
    int rc = (!a || !fl) ? SPHDEM_ERR_ALLOC : rt_d2h(&m->rt, a, m->D.pa, sizeof(int32_t) * (size_t)np);
    if (!rc) rc = rt_d2h(&m->rt, fl, m->D.flags, sizeof(int32_t) * (size_t)n);
    for (int64_t p = 0; !rc && p < np; p++) c += !(fl[a[p]] & SPHDEM_DEM_GHOST);
    free(a);
    free(fl);
    if (rc) return sphdem_dem_fail(m, rc, "stats: cannot read the pair list");
    s->npairs = c;
  }
  s->ncontacts = m->ncontacts;
  s->nbuilds = m->nbuilds;
  return SPHDEM_OK;
}

int64_t sphdem_dem_debug_pairs(sphdem_dem m, int64_t *pairs, int64_t maxpairs) {
  if (!m || (!pairs && maxpairs > 0)) return -SPHDEM_ERR_ARG;
  int64_t np = m->D.np, k = np < maxpairs ? np : maxpairs;
  if (k <= 0) return np;
  int32_t *a = (int32_t *)malloc(sizeof(int32_t) * np), *b = (int32_t *)malloc(sizeof(int32_t) * np);
  if (!a || !b) { free(a); free(b); return -SPHDEM_ERR_ALLOC; }
  int rc = rt_d2h(&m->rt, a, m->D.pa, sizeof(int32_t) * np);
  if (!rc) rc = rt_d2h(&m->rt, b, m->D.pb, sizeof(int32_t) * np);
  for (int64_t p = 0; !rc && p < k; p++) { pairs[2 * p] = a[p]; pairs[2 * p + 1] = b[p]; }
  free(a);
  free(b);
  return rc ? -rc : np;
}

int sphdem_dem_keep_step_history(sphdem_dem m) {
  if (!m) return SPHDEM_ERR_ARG;
  m->snap_req = 1;
  return SPHDEM_OK;
}

/* sphdem_dem_contacts (step 0: the current history, not advanced) and sphdem_dem_step_contacts (step 1: the history
 * the last evaluation started from, advanced into scratch as that evaluation did) */
static int64_t dem_contacts(sphdem_dem m, sphdem_grain_store g, int64_t max, int32_t *ab, double *ft, double *hist,
                            double *roll, int step) {
  if (!m || max < 0 || (max > 0 && (!ab || !ft))) return -SPHDEM_ERR_ARG;
  if (step && !m->snap_valid)
    return -sphdem_dem_fail(m, SPHDEM_ERR_ARG, "step contacts: the last evaluation kept no history (call "
                            "sphdem_dem_keep_step_history before it)");
  dem_dev *D = &m->D;
  int rc = sphdem_grains_check(g, &m->rt, m->backend, 0, NULL, "dem_contacts");
  if (rc) return -rc;
  const int64_t n = g->have ? g->nown + g->nghost : 0, np = m->nbuilds ? D->np : 0;
  if (!m->tags_valid || n != D->n)
    return -sphdem_dem_fail(m, SPHDEM_ERR_ARG, "contacts: %lld grains given, the last evaluation had %lld (evaluate "
                            "the forces of these grains first)", (long long)n, (long long)D->n);
  if (np == 0) return 0;
  if (!g->hom || !g->hmass) return -sphdem_dem_fail(m, SPHDEM_ERR_ARG, "contacts: the grains need omega and mass");
  rc = sphdem_grains_device(g, &m->rt);
  if (rc) return -rc;
  /* scratch: the records, the history the law writes (and the rolling history), all discarded */
  double *rec = NULL, *hs = NULL, *rs = NULL;
  const size_t nr = 1 + SPHDEM_DEM_CONTACT_DOUBLES; /* doubles per record (dem_contact_record_body) */
  rc = rt_alloc(&m->rt, (void **)&rec, sizeof(double) * nr * (size_t)np);
  if (!rc) rc = rt_alloc(&m->rt, (void **)&hs, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)np);
  if (!rc && D->rin) rc = rt_alloc(&m->rt, (void **)&rs, sizeof(double) * 3 * (size_t)np);
  double *hrec = rc ? NULL : (double *)malloc(sizeof(double) * nr * (size_t)np);
  int32_t *pa = hrec ? (int32_t *)malloc(sizeof(int32_t) * 2 * (size_t)np) : NULL;
  double *hh = pa && hist ? (double *)malloc(sizeof(double) * SPHDEM_DEM_NHIST * (size_t)np) : NULL;
  double *hr = pa && roll && D->rin ? (double *)malloc(sizeof(double) * 3 * (size_t)np) : NULL;
  if (!rc && (!hrec || !pa || (hist && !hh) || (roll && D->rin && !hr)))
    rc = sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "contacts: cannot allocate for %lld pairs", (long long)np);
  if (!rc) {
    const dem_dev keep = *D;
    D->x = g->dx, D->v = g->dv, D->om = g->dom, D->rad = g->drad, D->mass = g->dmass;
    D->hout = hs, D->rout = rs, D->update = 0, D->want_virial = 0;
    if (step) {
      D->hin = m->snap_h, D->update = m->snap_update;
      if (D->rin) D->rin = m->snap_r;
    }
    rc = m->ops->contact_record(m, rec);
    *D = keep;
  }
  if (!rc) rc = rt_d2h(&m->rt, hrec, rec, sizeof(double) * nr * (size_t)np);
  if (!rc) rc = rt_d2h(&m->rt, pa, D->pa, sizeof(int32_t) * (size_t)np);
  if (!rc) rc = rt_d2h(&m->rt, pa + np, D->pb, sizeof(int32_t) * (size_t)np);
  if (!rc && hh) rc = rt_d2h(&m->rt, hh, D->hin, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)np);
  if (!rc && hr) rc = rt_d2h(&m->rt, hr, D->rin, sizeof(double) * 3 * (size_t)np);
  int64_t k = 0;
  for (int64_t p = 0; !rc && p < np; p++) {
    const double *r = hrec + nr * p;
    if (r[0] == 0.0) continue;
    if (k < max) {
      ab[2 * k] = pa[p], ab[2 * k + 1] = pa[np + p];
      for (int q = 0; q < SPHDEM_DEM_CONTACT_DOUBLES; q++) ft[SPHDEM_DEM_CONTACT_DOUBLES * k + q] = r[1 + q];
      if (hist)
        for (int q = 0; q < SPHDEM_DEM_NHIST; q++) hist[SPHDEM_DEM_NHIST * k + q] = hh[SPHDEM_DEM_NHIST * p + q];
      if (roll)
        for (int q = 0; q < 3; q++) roll[3 * k + q] = hr ? hr[3 * p + q] : 0.0;
    }
    k++;
  }
  rt_free(&m->rt, (void **)&rec, sizeof(double) * nr * (size_t)np);
  rt_free(&m->rt, (void **)&hs, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)np);
  rt_free(&m->rt, (void **)&rs, sizeof(double) * 3 * (size_t)np);
  free(hrec);
  free(pa);
  free(hh);
  free(hr);
  return rc ? -rc : k;
}

int64_t sphdem_dem_contacts(sphdem_dem m, sphdem_grain_store g, int64_t max, int32_t *ab, double *ft, double *hist,
                            double *roll) {
  return dem_contacts(m, g, max, ab, ft, hist, roll, 0);
}

int64_t sphdem_dem_step_contacts(sphdem_dem m, sphdem_grain_store g, int64_t max, int32_t *ab, double *ft) {
  return dem_contacts(m, g, max, ab, ft, NULL, NULL, 1);
}

int sphdem_dem_heat(sphdem_dem m, sphdem_grain_store g, const double *temp, const double *cond, const int *member,
                    int area, double area_value, double *heat, double *dheat) {
  if (!m) return SPHDEM_ERR_ARG;
  if (area != SPHDEM_DEM_HEAT_AREA_OVERLAP && area != SPHDEM_DEM_HEAT_AREA_PROJECTION &&
      area != SPHDEM_DEM_HEAT_AREA_CONSTANT)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "heat: area %d is not one of overlap (%d), projection (%d), constant "
                           "(%d)", area, SPHDEM_DEM_HEAT_AREA_OVERLAP, SPHDEM_DEM_HEAT_AREA_PROJECTION,
                           SPHDEM_DEM_HEAT_AREA_CONSTANT);
  if (area == SPHDEM_DEM_HEAT_AREA_CONSTANT && !(area_value > 0.0 && isfinite(area_value)))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "heat: the constant contact area must be > 0 (got %g)", area_value);
  dem_dev *D = &m->D;
  int rc = sphdem_grains_check(g, &m->rt, m->backend, 0, NULL, "dem_heat");
  if (rc) return rc;
  const int64_t n = g->have ? g->nown + g->nghost : 0, np = m->nbuilds ? D->np : 0;
  if (!m->tags_valid || n != D->n)
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "heat: %lld grains given, the last evaluation had %lld (evaluate the "
                           "forces of these grains first)", (long long)n, (long long)D->n);
  if (n > 0 && (!temp || !cond || !heat)) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "heat: temp, cond and heat are needed");
  for (int64_t i = 0; i < n; i++)
    if (!(cond[i] >= 0.0 && isfinite(cond[i])))
      return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "heat: conductivity %g of grain %lld (must be finite and >= 0)",
                             cond[i], (long long)i);
  for (int64_t i = 0; i < n; i++) heat[i] = 0.0;
  if (dheat)
    for (int64_t i = 0; i < 3 * n; i++) dheat[i] = 0.0;
  if (np == 0) return SPHDEM_OK;
  rc = sphdem_grains_device(g, &m->rt);
  if (rc) return rc;
  if (m->backend == SPHDEM_DEVICE_CPU) { /* the caller's arrays are the backend's memory (the sums zeroed above) */
    const dem_dev keep = *D;
    D->x = g->dx, D->rad = g->drad;
    rc = m->ops->heat(m, temp, cond, member, area, area_value, heat, dheat);
    *D = keep;
    return rc;
  }
  /* on the device: temperature, conductivity, the sums (zeroed) */
  double *dT = NULL, *dk = NULL, *dq = NULL, *ddq = NULL;
  int *dm = NULL;
  const size_t bn = sizeof(double) * (size_t)n;
  rc = rt_alloc(&m->rt, (void **)&dT, bn);
  if (!rc) rc = rt_alloc(&m->rt, (void **)&dk, bn);
  if (!rc) rc = rt_alloc(&m->rt, (void **)&dq, bn);
  if (!rc && dheat) rc = rt_alloc(&m->rt, (void **)&ddq, 3 * bn);
  if (!rc && member) rc = rt_alloc(&m->rt, (void **)&dm, sizeof(int) * (size_t)n);
  if (!rc && member) rc = rt_h2d(&m->rt, dm, member, sizeof(int) * (size_t)n);
  if (!rc) rc = rt_h2d(&m->rt, dT, temp, bn);
  if (!rc) rc = rt_h2d(&m->rt, dk, cond, bn);
  if (!rc) rc = rt_zero(&m->rt, dq, bn);
  if (!rc && ddq) rc = rt_zero(&m->rt, ddq, 3 * bn);
  if (!rc) {
    const dem_dev keep = *D;
    D->x = g->dx, D->rad = g->drad;
    rc = m->ops->heat(m, dT, dk, dm, area, area_value, dq, ddq);
    *D = keep;
  }
  if (!rc) rc = rt_d2h(&m->rt, heat, dq, bn);
  if (!rc && ddq) rc = rt_d2h(&m->rt, dheat, ddq, 3 * bn);
  rt_free(&m->rt, (void **)&dT, bn);
  rt_free(&m->rt, (void **)&dk, bn);
  rt_free(&m->rt, (void **)&dq, bn);
  rt_free(&m->rt, (void **)&ddq, 3 * bn);
  rt_free(&m->rt, (void **)&dm, sizeof(int) * (size_t)n);
  return rc;
}

int sphdem_dem_debug_history(sphdem_dem m, int64_t ta, int64_t tb, double hist[4]) {
  if (!m || !hist) return SPHDEM_ERR_ARG;
  uint64_t k = tb >= 0 ? ((uint64_t)ta << 32) | (uint64_t)tb : ((uint64_t)ta << 32) | (0xffffffffu - (uint32_t)(-1 - tb));
  int64_t np = m->D.np;
  if (np == 0) return SPHDEM_ERR_ARG;
  uint64_t *keys = (uint64_t *)malloc(sizeof(uint64_t) * np);
  double *h = (double *)malloc(sizeof(double) * SPHDEM_DEM_NHIST * np);
  int rc = (!keys || !h) ? SPHDEM_ERR_ALLOC : rt_d2h(&m->rt, keys, m->D.key, sizeof(uint64_t) * np);
  if (!rc) rc = rt_d2h(&m->rt, h, m->D.hin, sizeof(double) * SPHDEM_DEM_NHIST * np);
  int found = 0;
  for (int64_t p = 0; !rc && p < np; p++)
    if (keys[p] == k) {
      for (int q = 0; q < 4; q++) hist[q] = h[SPHDEM_DEM_NHIST * p + q];
      found = 1;
      break;
    }
  free(keys);
  free(h);
  if (rc) return rc;
  return found ? SPHDEM_OK : sphdem_dem_fail(m, SPHDEM_ERR_ARG, "pair (%lld, %lld): not in the pair list", (long long)ta, (long long)tb);
}

#if SPHDEM_DEM_NHIST != SPHDEM_DEM_HIST_DOUBLES
#error "SPHDEM_DEM_HIST_DOUBLES (sphdem.h) must equal SPHDEM_DEM_NHIST (dem_internal.h)"
#endif

int64_t sphdem_dem_get_history(sphdem_dem m, uint64_t *keys, double *hist, int64_t max) {
  if (!m || max < 0 || (max > 0 && (!keys || !hist))) return -SPHDEM_ERR_ARG;
  int64_t np = m->nbuilds ? m->D.np : 0, k = np < max ? np : max;
  if (k > 0) {
    int rc = rt_d2h(&m->rt, keys, m->D.key, sizeof(uint64_t) * k);
    if (!rc) rc = rt_d2h(&m->rt, hist, m->D.hin, sizeof(double) * SPHDEM_DEM_NHIST * k);
    if (rc) return -rc;
  }
  return np;
}

typedef struct { uint64_t key; int64_t i; } key_index;
static int cmp_key_index(const void *a, const void *b) {
  uint64_t ka = ((const key_index *)a)->key, kb = ((const key_index *)b)->key;
  return ka < kb ? -1 : ka > kb;
}

int64_t sphdem_dem_get_rolling(sphdem_dem m, double *roll, int64_t max) {
  if (!m || max < 0 || (max > 0 && !roll)) return -SPHDEM_ERR_ARG;
  const dem_dev *D = &m->D;
  if (!m->nbuilds || !D->rin || !m->roll_valid) return 0;
  const int64_t np = D->np, k = np < max ? np : max;
  if (k > 0) {
    int rc = rt_d2h(&m->rt, roll, D->rin, sizeof(double) * 3 * k);
    if (rc) return -rc;
  }
  return np;
}

int sphdem_dem_set_history(sphdem_dem m, int64_t n, const uint64_t *keys, const double *hist) {
  return sphdem_dem_set_history_rolling(m, n, keys, hist, NULL);
}

int sphdem_dem_set_history_rolling(sphdem_dem m, int64_t n, const uint64_t *keys, const double *hist,
                                   const double *roll) {
  if (!m) return SPHDEM_ERR_ARG;
  if (n < 0 || (n > 0 && (!keys || !hist))) return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "set_history: n %lld, keys/hist missing", (long long)n);
  dem_dev *D = &m->D;
  if (n > m->cap_pold) {
    TRY(grow(m, (void **)&D->key_old, sizeof(uint64_t), 0, n + 16));
    TRY(grow(m, (void **)&D->hist_old, sizeof(double) * SPHDEM_DEM_NHIST, 0, n + 16));
    m->cap_pold = n + 16;
  }
  /* the carry looks keys up by bisection: sort (key, history) by key on the host */
  key_index *idx = (key_index *)malloc(sizeof(key_index) * (size_t)(n ? n : 1));
  uint64_t *ks = (uint64_t *)malloc(sizeof(uint64_t) * (size_t)(n ? n : 1));
  double *hs = (double *)malloc(sizeof(double) * SPHDEM_DEM_NHIST * (size_t)(n ? n : 1));
  if (!idx || !ks || !hs) { free(idx); free(ks); free(hs); return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "set_history: %lld pairs", (long long)n); }
  for (int64_t i = 0; i < n; i++) idx[i].key = keys[i], idx[i].i = i;
  qsort(idx, (size_t)n, sizeof(key_index), cmp_key_index);
  int dup = 0;
  for (int64_t i = 0; i < n; i++) {
    ks[i] = idx[i].key;
    if (i && ks[i] == ks[i - 1]) dup = 1;
    for (int q = 0; q < SPHDEM_DEM_NHIST; q++) hs[SPHDEM_DEM_NHIST * i + q] = hist[SPHDEM_DEM_NHIST * idx[i].i + q];
  }
  int rc = dup ? sphdem_dem_fail(m, SPHDEM_ERR_ARG, "set_history: a pair key appears twice") : SPHDEM_OK;
  if (!rc && n) rc = rt_h2d(&m->rt, D->key_old, ks, sizeof(uint64_t) * (size_t)n);
  if (!rc && n) rc = rt_h2d(&m->rt, D->hist_old, hs, sizeof(double) * SPHDEM_DEM_NHIST * (size_t)n);
  /* the rolling torques in the same key order, for the carry of the next build (roll_old) */
  if (!rc && roll && n > m->cap_rold) {
    rc = grow(m, (void **)&D->roll_old, sizeof(double) * 3, n, n + 16);
    if (!rc) m->cap_rold = n + 16;
  }
  if (!rc && roll && n) {
    for (int64_t i = 0; i < n; i++)
      for (int q = 0; q < 3; q++) hs[3 * i + q] = roll[3 * idx[i].i + q];
    rc = rt_h2d(&m->rt, D->roll_old, hs, sizeof(double) * 3 * (size_t)n);
  }
  free(idx); free(ks); free(hs);
  if (rc) return rc;
  D->np_old = n;
  m->seeded = 1;
  m->seed_roll = roll != NULL;
  m->need_build = 1;
  return SPHDEM_OK;
}

/* a tag of key k (its grain a, and b unless it is a wall pair) in the sorted tags */
static int key_has_tag(uint64_t k, int64_t ntags, const int64_t *tags) {
  const int64_t ta = (int64_t)(k >> 32), tb = (int64_t)(uint32_t)k;
  for (int s = 0; s < 2; s++) {
    const int64_t t = s ? tb : ta;
    if (s && t > SPHDEM_DEM_MAX_TAG) return 0; /* a wall */
    int64_t lo = 0, hi = ntags - 1;
    while (lo <= hi) {
      const int64_t mid = lo + (hi - lo) / 2;
      if (tags[mid] == t) return 1;
      if (tags[mid] < t) lo = mid + 1;
      else hi = mid - 1;
    }
  }
  return 0;
}

int64_t sphdem_dem_get_history_of(sphdem_dem m, int64_t ntags, const int64_t *tags, uint64_t *keys, double *hist,
                                  double *roll, int64_t max) {
  if (!m || ntags < 0 || (ntags > 0 && !tags) || max < 0 || (max > 0 && (!keys || !hist))) return -SPHDEM_ERR_ARG;
  dem_dev *D = &m->D;
  const int64_t np = m->nbuilds ? D->np : 0;
  const int H = SPHDEM_DEM_NHIST;
  if (np == 0 || ntags == 0) return 0;
  double *rsrc = m->roll_valid ? D->rin : NULL;
  void *tk = NULL, *th = NULL, *tr = NULL;
  const uint64_t *k = (const uint64_t *)host_view(m, D->key, sizeof(uint64_t) * (size_t)np, &tk);
  const double *h = k ? (const double *)host_view(m, D->hin, sizeof(double) * H * (size_t)np, &th) : NULL;
  const double *r = h && rsrc ? (const double *)host_view(m, rsrc, sizeof(double) * 3 * (size_t)np, &tr) : NULL;
  if (!h || (rsrc && !r)) {
    free(tk), free(th), free(tr);
    return -SPHDEM_ERR_ALLOC;
  }
  int64_t c = 0;
  for (int64_t p = 0; p < np; p++) {
    if (!key_has_tag(k[p], ntags, tags)) continue;
    if (c < max) {
      keys[c] = k[p];
      memcpy(hist + H * c, h + H * p, sizeof(double) * H);
      if (roll) {
        if (r) memcpy(roll + 3 * c, r + 3 * p, sizeof(double) * 3);
        else roll[3 * c] = roll[3 * c + 1] = roll[3 * c + 2] = 0.0;
      }
    }
    c++;
  }
  free(tk), free(th), free(tr);
  return c;
}

int sphdem_dem_add_history(sphdem_dem m, int64_t n, const uint64_t *keys, const double *hist, const double *roll) {
  if (!m) return SPHDEM_ERR_ARG;
  if (n < 0 || (n > 0 && (!keys || !hist)))
    return sphdem_dem_fail(m, SPHDEM_ERR_ARG, "add_history: n %lld, keys/hist missing", (long long)n);
  if (n == 0) return SPHDEM_OK;
  const int H = SPHDEM_DEM_NHIST;
  const int64_t na = m->nadd, need = na + n;
  if (need > m->cap_add) {
    const int64_t cap = need + need / 4 + 16;
    uint64_t *k = (uint64_t *)realloc(m->add_key, sizeof(uint64_t) * (size_t)cap);
    if (k) m->add_key = k;
    double *h = k ? (double *)realloc(m->add_hist, sizeof(double) * H * (size_t)cap) : NULL;
    if (h) m->add_hist = h;
    double *r = h ? (double *)realloc(m->add_roll, sizeof(double) * 3 * (size_t)cap) : NULL;
    if (r) m->add_roll = r;
    if (!k || !h || !r) return sphdem_dem_fail(m, SPHDEM_ERR_ALLOC, "add_history: %lld pairs", (long long)need);
    m->cap_add = cap;
  }
  /* appended, then the whole list put in key order by insertion from the end (a few pairs a build) */
  for (int64_t i = 0; i < n; i++) {
    int64_t j = m->nadd;
    while (j > 0 && m->add_key[j - 1] > keys[i]) j--;
    if (j > 0 && m->add_key[j - 1] == keys[i]) continue; /* given before: the first values stay */
    memmove(m->add_key + j + 1, m->add_key + j, sizeof(uint64_t) * (size_t)(m->nadd - j));
    memmove(m->add_hist + H * (j + 1), m->add_hist + H * j, sizeof(double) * H * (size_t)(m->nadd - j));
    memmove(m->add_roll + 3 * (j + 1), m->add_roll + 3 * j, sizeof(double) * 3 * (size_t)(m->nadd - j));
    m->add_key[j] = keys[i];
    memcpy(m->add_hist + H * j, hist + H * i, sizeof(double) * H);
    for (int q = 0; q < 3; q++) m->add_roll[3 * j + q] = roll ? roll[3 * i + q] : 0.0;
    m->nadd++;
  }
  m->add_roll_given |= roll != NULL;
  m->need_build = 1;
  return SPHDEM_OK;
}

int sphdem_dem_set_comm(sphdem_dem c, const sphdem_comm *comm) {
  if (!c) return SPHDEM_ERR_ARG;
  if (comm) c->rt.comm = *comm;
  else memset(&c->rt.comm, 0, sizeof c->rt.comm);
  return SPHDEM_OK;
}
