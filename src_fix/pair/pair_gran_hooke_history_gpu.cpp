/* pair_gran_hooke_history_gpu.cpp - pair_style gran/hooke/history/gpu and gran/hertz/history/gpu
 * (LAMMPS): the stock arguments, the contacts computed by the sphdem DEM core, per-pair shear history
 * kept there keyed by the two atom tags (so it survives reneighboring and atom sorting). No physics
 * here: parse, map atoms to arrays, call the C API, report errors. */
#include "pair_gran_hertz_history_gpu.h"
#include "pair_gran_hooke_history_gpu.h"

#include <cstring>

#include "atom.h"
#include "comm.h"
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
    : Pair(lmp), kn(0), kt(0), gamman(0), gammat(0), xmu(0), dampflag(0), limit_damping(0),
      model(SPHDEM_DEM_HOOKE), style("gran/hooke/history/gpu"), freeze_group_bit(0), dem(nullptr),
      device_(SPHDEM_DEVICE_AUTO), algo_(SPHDEM_DEM_PARTICLE_PARALLEL) {
  single_enable = 0;
  no_virial_fdotr_compute = 1; /* the virial is summed per pair by the core */
  restartinfo = 1; /* settings, coefficients and the per-pair contact history go into restart files */
  for (int d = 0; d < 3; d++) box_lo[d] = box_hi[d] = 0.0, box_per[d] = 0;
}

PairGranHookeHistoryGPU::~PairGranHookeHistoryGPU() {
  sphdem_dem_destroy(&dem);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
}

void PairGranHookeHistoryGPU::fail(const std::string &msg) {
  sphdem_compat::error_all(error, __FILE__, __LINE__, "Pair " + style + ": " + msg);
}

void PairGranHookeHistoryGPU::allocate() {
  allocated = 1;
  int n = atom->ntypes;
  memory->create(setflag, n + 1, n + 1, "pair:setflag");
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n + 1, n + 1, "pair:cutsq");
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
    } else if (kw == "device" && k + 1 < narg) {
      std::string d = arg[++k];
      if (d == "auto") device_ = SPHDEM_DEVICE_AUTO;
      else if (d == "cpu") device_ = SPHDEM_DEVICE_CPU;
      else if (d == "gpu") device_ = SPHDEM_DEVICE_GPU;
      else fail("device must be auto, cpu or gpu (got '" + d + "')");
    } else if (kw == "algo" && k + 1 < narg) {
      std::string a = arg[++k];
      if (a == "pair") algo_ = SPHDEM_DEM_PAIR_PARALLEL;
      else if (a == "particle") algo_ = SPHDEM_DEM_PARTICLE_PARALLEL;
      else fail("algo must be pair or particle (got '" + a + "')");
    } else if (kw == "timers" && k + 1 < narg) {
      std::string a = arg[++k];
      if (a == "on") timers_.on = 1;
      else if (a == "off") timers_.on = 0;
      else fail("timers must be on or off (got '" + a + "')");
    } else {
      fail("unsupported argument '" + kw + "' (usage: " + USAGE + ")");
    }
  }
  if (kn < 0.0 || kt < 0.0 || gamman < 0.0 || gammat < 0.0 || xmu < 0.0 || xmu > 10000.0 || dampflag < 0 ||
      dampflag > 1)
    fail("illegal value: needs Kn, Kt, gamma_n, gamma_t >= 0, 0 <= xmu <= 10000, dampflag 0 or 1");
  if (dem) sync_params();
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
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    fail("requires atom attributes radius, rmass, omega, torque (atom_style sphere)");
  if (comm->nprocs > 1)
    fail("runs on one MPI rank only in this version (got " + std::to_string(comm->nprocs) + " ranks)");
  if (domain->triclinic) fail("triclinic boxes are not supported");
  freeze_group_bit = 0;
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (f->rigid_flag) fail(std::string("rigid bodies (fix ") + f->id + ") are not supported");
    if (std::strcmp(f->style, "freeze") == 0) freeze_group_bit = f->groupbit;
  }
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
  for (int i = 0; i < atom->nlocal; i++) {
    std::vector<double> &r = (atom->mask[i] & freeze_group_bit) ? frz : dyn;
    if (atom->radius[i] > r[atom->type[i]]) r[atom->type[i]] = atom->radius[i];
  }
  maxrad_dynamic.assign(nt + 1, 0.0);
  maxrad_frozen.assign(nt + 1, 0.0);
  MPI_Allreduce(&dyn[1], &maxrad_dynamic[1], nt, MPI_DOUBLE, MPI_MAX, world);
  MPI_Allreduce(&frz[1], &maxrad_frozen[1], nt, MPI_DOUBLE, MPI_MAX, world);
  sync_params();
  if (!dem) {
    char msg[512];
    int rc = sphdem_dem_create(&dem, &prm_, (sphdem_device)device_, msg, sizeof msg);
    if (rc) fail(std::string("cannot start the DEM core: ") + msg);
    if (comm->me == 0)
      sphdem_compat::logmesg(lmp, "Pair " + style + ": sphdem DEM core on the " +
                                      (sphdem_dem_backend(dem) == SPHDEM_DEVICE_GPU ? "GPU" : "CPU") + ", " +
                                      (algo_ == SPHDEM_DEM_PAIR_PARALLEL ? "pair" : "particle") + "-parallel\n");
  }
  if (pending_history.apply(dem)) fail(std::string("restoring the contact history: ") + sphdem_dem_last_error(dem));
}

/* Restart: the stock arguments (as parsed), pair_coeff flags and the core's contact history
 * (pair keys made of atom tags, so it does not depend on the atom order at read time). One rank. */
void PairGranHookeHistoryGPU::write_restart(FILE *fp) {
  double d[5] = {kn, kt, gamman, gammat, xmu};
  int iv[4] = {dampflag, limit_damping, device_, algo_};
  fwrite(d, sizeof(double), 5, fp);
  fwrite(iv, sizeof(int), 4, fp);
  sphdem_restart::write_setflag(fp, setflag, atom->ntypes);
  if (!sphdem_restart::write_history(fp, dem)) fail("reading the contact history for the restart file failed");
}

void PairGranHookeHistoryGPU::read_restart(FILE *fp) {
  if (comm->nprocs > 1)
    fail("runs on one MPI rank only in this version (got " + std::to_string(comm->nprocs) + " ranks)");
  if (!allocated) allocate();
  double d[5];
  int iv[4];
  if (!sphdem_restart::read_items(fp, d, sizeof(double), 5) || !sphdem_restart::read_items(fp, iv, sizeof(int), 4) ||
      !sphdem_restart::read_setflag(fp, setflag, atom->ntypes) || !pending_history.read(fp, (int64_t)atom->natoms))
    fail(pending_history.error_or("restart file ends inside the pair style's data"));
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
  p.skin = neighbor->skin;
  for (int d = 0; d < 3; d++) {
    p.boxlo[d] = box_lo[d] = domain->boxlo[d];
    p.boxhi[d] = box_hi[d] = domain->boxhi[d];
    p.periodic[d] = box_per[d] = domain->periodicity[d];
  }
  prm_ = p;
  if (dem && sphdem_dem_set_params(dem, &p)) fail(sphdem_dem_last_error(dem));
}

/* The largest contact distance of the type pair (stock init_one). Ghost atoms are not used (one rank,
 * minimum image in the core); the cutoff sizes atom sorting, communication and the neighbour summary. */
double PairGranHookeHistoryGPU::init_one(int i, int j) {
  if ((int)maxrad_dynamic.size() <= (i > j ? i : j)) return 0.0;
  const double *d = maxrad_dynamic.data(), *z = maxrad_frozen.data();
  double cut = d[i] + d[j];
  if (z[i] + d[j] > cut) cut = z[i] + d[j];
  if (d[i] + z[j] > cut) cut = d[i] + z[j];
  return cut;
}

void PairGranHookeHistoryGPU::compute(int eflag, int vflag) {
  ev_init(eflag, vflag);
  if (vflag_atom) fail("per-atom virial (compute stress/atom, centroid/stress/atom) is not supported");
  const int n = atom->nlocal;
  bool box_changed = false;
  for (int d = 0; d < 3; d++)
    box_changed |= domain->boxlo[d] != box_lo[d] || domain->boxhi[d] != box_hi[d] || domain->periodicity[d] != box_per[d];
  if (box_changed) sync_params();
  const double tp0 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  tags.resize(n);
  fbuf.resize(3 * (size_t)n);
  tbuf.resize(3 * (size_t)n);
  for (int i = 0; i < n; i++) tags[i] = atom->tag[i];
  const int *fl = nullptr; /* NULL: no grain frozen */
  if (freeze_group_bit) {
    flags.resize(n);
    for (int i = 0; i < n; i++) flags[i] = (atom->mask[i] & freeze_group_bit) ? SPHDEM_DEM_FROZEN : 0;
    fl = flags.data();
  }
  /* x, v, omega are contiguous n x 3 blocks (memory->create), radius and rmass plain arrays: the core
   * reads them in place */
  const double *xp = n ? atom->x[0] : nullptr, *vp = n ? atom->v[0] : nullptr, *wp = n ? atom->omega[0] : nullptr;
  double vir[6];
  const double tp1 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  /* during setup the forces are evaluated without advancing the shear history (as the stock style) */
  int rc = sphdem_dem_compute(dem, n, tags.data(), xp, vp, wp, atom->radius, atom->rmass, fl, update->dt,
                              update->setupflag ? 0 : 1, fbuf.data(), tbuf.data(), vflag_global ? vir : nullptr);
  if (rc) fail(std::string("DEM core: ") + sphdem_dem_last_error(dem));
  const double tp2 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  double **f = atom->f, **t = atom->torque;
  for (int i = 0; i < n; i++)
    for (int d = 0; d < 3; d++) {
      f[i][d] += fbuf[3 * i + d];
      t[i][d] += tbuf[3 * i + d];
    }
  if (vflag_global)
    for (int k = 0; k < 6; k++) virial[k] += vir[k];
  if (timers_.on) {
    timers_.pack += tp1 - tp0;
    timers_.unpack += sphdem_pair_timers::now() - tp2;
    if (update->setupflag) timers_.reset(dem);
    else if (update->ntimestep == update->laststep && comm->me == 0) sphdem_compat::logmesg(lmp, timers_.line(dem, style));
  }
}

double PairGranHookeHistoryGPU::memory_usage() {
  return (double)(tags.capacity() * sizeof(int64_t) + flags.capacity() * sizeof(int)) +
         (double)(fbuf.capacity() + tbuf.capacity()) * sizeof(double);
}

/* ---- gran/hertz/history/gpu: the same arguments, Kn and Kt in pressure units (stock: divided by nktv2p) */

PairGranHertzHistoryGPU::PairGranHertzHistoryGPU(LAMMPS *lmp) : PairGranHookeHistoryGPU(lmp) {
  model = SPHDEM_DEM_HERTZ;
  style = "gran/hertz/history/gpu";
}

void PairGranHertzHistoryGPU::settings(int narg, char **arg) {
  PairGranHookeHistoryGPU::settings(narg, arg);
  kn /= force->nktv2p;
  kt /= force->nktv2p;
  if (dem) sync_params();
}

/* ---- registration ---------------------------------------------------------------------------------- */

template <typename T> static Pair *pair_creator(LAMMPS *lmp) { return new T(lmp); }

void sphdem_register_pair_gran_gpu(LAMMPS *lmp) {
  (*lmp->force->pair_map)["gran/hooke/history/gpu"] = &pair_creator<PairGranHookeHistoryGPU>;
  (*lmp->force->pair_map)["gran/hertz/history/gpu"] = &pair_creator<PairGranHertzHistoryGPU>;
}
