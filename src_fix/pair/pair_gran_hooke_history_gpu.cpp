/* pair_gran_hooke_history_gpu.cpp - pair_style gran/hooke/history/gpu and gran/hertz/history/gpu
 * (LAMMPS): the stock arguments, the contacts computed by the sphdem DEM core, per-pair shear history
 * kept there keyed by the two atom tags (so it survives reneighboring and atom sorting). No physics
 * here: parse, map atoms to arrays, call the C API, report errors. */
#include "pair_gran_hertz_history_gpu.h"
#include "pair_gran_hooke_history_gpu.h"

#include <cmath>
#include <cstring>

#include "atom.h"
#include "comm.h"
#include "compute.h"
#include "domain.h"
#include "fix.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "pair_gran_gpu_register.h"
#include "sphdem_compat.h"
#include "update.h"
#include "utils.h"

using namespace LAMMPS_NS;

static const char *const USAGE =
    "Kn Kt|NULL gamma_n gamma_t|NULL xmu dampflag [limit_damping] [device auto|cpu|gpu] [algo pair|particle] [timers on|off]";

PairGranHookeHistoryGPU::PairGranHookeHistoryGPU(LAMMPS *lmp)
    : PairGranGPUBase(lmp, "gran/hooke/history/gpu"), kn(0), kt(0), gamman(0), gammat(0), xmu(0), dampflag(0),
      limit_damping(0), model(SPHDEM_DEM_HOOKE) {
  single_enable = 1;
  single_extra = 10;
  svector = new double[10];
}

PairGranHookeHistoryGPU::~PairGranHookeHistoryGPU() { delete[] svector; }

double PairGranHookeHistoryGPU::single(int i, int j, int, int, double rsq, double, double, double &fforce) {
  fforce = 0.0;
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  const double radsum = atom->radius[i] + atom->radius[j];
  if (rsq >= radsum * radsum) return 0.0;
  bool i_is_a;
  const double *F = single_contact(i, j, i_is_a);
  const double s = i_is_a ? 1.0 : -1.0; /* the force on i */
  double **x = atom->x, **v = atom->v;
  const double del[3] = {x[i][0] - x[j][0], x[i][1] - x[j][1], x[i][2] - x[j][2]};
  const double fi[3] = {s * F[0], s * F[1], s * F[2]};
  /* the normal force along del (ccel del), the rest tangential */
  const double ccel = (fi[0] * del[0] + fi[1] * del[1] + fi[2] * del[2]) / rsq;
  double fs[3], vn[3], vt[3];
  const double vr[3] = {v[i][0] - v[j][0], v[i][1] - v[j][1], v[i][2] - v[j][2]};
  const double vnnr = (vr[0] * del[0] + vr[1] * del[1] + vr[2] * del[2]) / rsq;
  for (int d = 0; d < 3; d++) {
    fs[d] = fi[d] - ccel * del[d];
    vn[d] = del[d] * vnnr;
    vt[d] = vr[d] - vn[d];
  }
  fforce = ccel;
  for (int d = 0; d < 3; d++) svector[d] = fs[d], svector[4 + d] = vn[d], svector[7 + d] = vt[d];
  svector[3] = std::sqrt(fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]);
  return 0.0;
}

/* The stock argument list and its checks (LAMMPS pair_style gran/hooke/history). */
void PairGranHookeHistoryGPU::settings(int narg, char **arg) {
  if (narg < 6) fail("expected " + std::string(USAGE) + " (got " + std::to_string(narg) + " arguments)");
  auto num = [&](int k, const char *name) {
    double v;
    if (!sphdem_compat::to_double(arg[k], &v)) fail(std::string(name) + " '" + arg[k] + "' is not a number");
    return v;
  };
  kn = num(0, "Kn");
  kt = std::strcmp(arg[1], "NULL") == 0 ? kn * 2.0 / 7.0 : num(1, "Kt");
  gamman = num(2, "gamma_n");
  gammat = std::strcmp(arg[3], "NULL") == 0 ? 0.5 * gamman : num(3, "gamma_t");
  xmu = num(4, "xmu");
  long df;
  if (!sphdem_compat::to_int(arg[5], &df)) fail(std::string("dampflag '") + arg[5] + "' is not an integer");
  dampflag = (int)df;
  if (dampflag == 0) gammat = 0.0;
  limit_damping = 0;
  for (int k = 6; k < narg; k++) {
    std::string kw = arg[k];
    if (kw == "limit_damping") {
      limit_damping = 1;
    } else if (k + 1 < narg && common_keyword(kw, arg[k + 1])) {
      k++; /* device, algo, timers */
    } else {
      fail("unsupported argument '" + kw + "' (usage: " + USAGE + ")");
    }
  }
  if (kn < 0.0 || kt < 0.0 || gamman < 0.0 || gammat < 0.0 || xmu < 0.0 || xmu > 10000.0 || dampflag < 0 ||
      dampflag > 1)
    fail("illegal value: needs Kn, Kt, gamma_n, gamma_t >= 0, 0 <= xmu <= 10000, dampflag 0 or 1");
  if (dem_) sync_params();
}

void PairGranHookeHistoryGPU::coeff(int narg, char **arg) {
  if (narg > 2) fail("pair_coeff takes only the two type ranges (pair_coeff * *)");
  if (!allocated) allocate();
  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, atom->ntypes, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, atom->ntypes, jlo, jhi, error);
  int count = 0;
  for (int i = ilo; i <= ihi; i++)
    for (int j = (jlo > i ? jlo : i); j <= jhi; j++) {
      setflag[i][j] = 1;
      count++;
    }
  if (count == 0) fail("incorrect args for pair coefficients");
}

void PairGranHookeHistoryGPU::init_style() {
  check_atoms("atom_style sphere");
  scan_rigid_freeze();
  /* compute pair/local asks each rank for the pairs of its own list: with newton on a pair split between two ranks
   * is then evaluated on both (so that either rank has its contact) */
  ghost_once_ok_ = !pair_local_present();
  /* the cutoff of the stock style (PairGranHookeHistory::init_style/init_one): per type the largest
   * radius of the grains, frozen ones apart, and of the particles fix pour / fix deposit will insert */
  const int nt = atom->ntypes;
  std::vector<double> dyn(nt + 1, 0.0), frz(nt + 1, 0.0);
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (std::strcmp(f->style, "pour") != 0 && std::strcmp(f->style, "deposit") != 0) continue;
    for (int t = 1; t <= nt; t++) {
      int itype = t;
      const double *r = (const double *)f->extract("radius", itype);
      if (r && *r > dyn[t]) dyn[t] = *r;
    }
  }
  reduce_maxrad(dyn, frz);
  sync_params();
  create_core();
  restore_history();
}

/* Restart: the stock arguments (as parsed), then pair_coeff flags and the core's contact history. */
void PairGranHookeHistoryGPU::write_restart(FILE *fp) {
  double d[5] = {kn, kt, gamman, gammat, xmu};
  int iv[4] = {dampflag, limit_damping, device_, algo_};
  fwrite(d, sizeof(double), 5, fp);
  fwrite(iv, sizeof(int), 4, fp);
  write_restart_tail(fp);
}

void PairGranHookeHistoryGPU::read_restart(FILE *fp) {
  begin_read_restart();
  double d[5];
  int iv[4];
  read_restart_tail(fp, read_head(fp, d, sizeof(double), 5) && read_head(fp, iv, sizeof(int), 4));
  kn = d[0], kt = d[1], gamman = d[2], gammat = d[3], xmu = d[4];
  dampflag = iv[0], limit_damping = iv[1], device_ = iv[2], algo_ = iv[3];
}

/* Core parameters from the stock arguments, the neighbor skin and the current box. */
void PairGranHookeHistoryGPU::sync_params() {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = model;
  p.algo = algo_;
  p.kn = kn;
  p.kt = kt;
  p.gamman = gamman;
  p.gammat = gammat;
  p.mu = xmu;
  p.limit_damping = limit_damping;
  set_box(p);
  push_params(p);
}

void PairGranHookeHistoryGPU::compute(int eflag, int vflag) {
  ev_init(eflag, vflag);
  compute_grains(false, false);
  if (vflag_atom) add_virial_atom(); /* compute stress/atom (and centroid/stress/atom: the same for pair forces) */
}

/* ---- gran/hertz/history/gpu: the same arguments, Kn and Kt in pressure units (stock: divided by nktv2p) */

PairGranHertzHistoryGPU::PairGranHertzHistoryGPU(LAMMPS *lmp) : PairGranHookeHistoryGPU(lmp) {
  model = SPHDEM_DEM_HERTZ;
  style_ = "gran/hertz/history/gpu";
}

void PairGranHertzHistoryGPU::settings(int narg, char **arg) {
  PairGranHookeHistoryGPU::settings(narg, arg);
  kn /= force->nktv2p;
  kt /= force->nktv2p;
  if (dem_) sync_params();
}

/* ---- registration ---------------------------------------------------------------------------------- */

template <typename T> static Pair *pair_creator(LAMMPS *lmp) { return new T(lmp); }

void sphdem_register_pair_gran_gpu(LAMMPS *lmp) {
  (*lmp->force->pair_map)["gran/hooke/history/gpu"] = &pair_creator<PairGranHookeHistoryGPU>;
  (*lmp->force->pair_map)["gran/hertz/history/gpu"] = &pair_creator<PairGranHertzHistoryGPU>;
  sphdem_register_pair_granular_gpu(lmp);
}
