/* pair_gran_gpu_base.cpp - what the GPU granular pair styles of LAMMPS and LIGGGHTS share: the DEM core
 * context, grains in, forces out, timers, contact-history restart, messages. No physics here. */
#include "pair_gran_gpu_base.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "memory.h"
#include "neighbor.h"
#include "sphdem_compat.h"
#include "update.h"

using namespace LAMMPS_NS;

PairGranGPUBase::PairGranGPUBase(LAMMPS *lmp, const std::string &style)
    : Pair(lmp), style_(style), device_(SPHDEM_DEVICE_AUTO), algo_(SPHDEM_DEM_PARTICLE_PARALLEL),
      freeze_group_bit_(0), dem_(nullptr) {
  single_enable = 0;
  no_virial_fdotr_compute = 1; /* the virial is summed per pair by the core */
  restartinfo = 1; /* settings, coefficients and the per-pair contact history go into restart files */
  for (int d = 0; d < 3; d++) box_lo_[d] = box_hi_[d] = 0.0, box_per_[d] = 0;
  sphdem_dem_params_default(&prm_);
}

PairGranGPUBase::~PairGranGPUBase() {
  sphdem_dem_destroy(&dem_);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
}

void PairGranGPUBase::fail(const std::string &msg) {
  sphdem_compat::error_all(error, __FILE__, __LINE__, "Pair " + style_ + ": " + msg);
}

void PairGranGPUBase::allocate() {
  allocated = 1;
  int n = atom->ntypes;
  memory->create(setflag, n + 1, n + 1, "pair:setflag");
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n + 1, n + 1, "pair:cutsq");
}

bool PairGranGPUBase::common_keyword(const std::string &kw, const std::string &val) {
  if (kw == "device") {
    if (val == "auto") device_ = SPHDEM_DEVICE_AUTO;
    else if (val == "cpu") device_ = SPHDEM_DEVICE_CPU;
    else if (val == "gpu") device_ = SPHDEM_DEVICE_GPU;
    else fail("device must be auto, cpu or gpu (got '" + val + "')");
  } else if (kw == "algo") {
    if (val == "pair") algo_ = SPHDEM_DEM_PAIR_PARALLEL;
    else if (val == "particle") algo_ = SPHDEM_DEM_PARTICLE_PARALLEL;
    else fail("algo must be pair or particle (got '" + val + "')");
  } else if (kw == "timers") {
    if (val == "on") timers_.on = 1;
    else if (val == "off") timers_.on = 0;
    else fail("timers must be on or off (got '" + val + "')");
  } else {
    return false;
  }
  return true;
}

void PairGranGPUBase::require_one_rank() {
  if (comm->nprocs > 1)
    fail("runs on one MPI rank only in this version (got " + std::to_string(comm->nprocs) + " ranks)");
}

void PairGranGPUBase::check_atoms(const char *atom_styles) {
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    fail(std::string("requires atom attributes radius, rmass, omega, torque (") + atom_styles + ")");
  require_one_rank();
  if (domain->triclinic) fail("triclinic boxes are not supported");
}

void PairGranGPUBase::reduce_maxrad(std::vector<double> &dyn, std::vector<double> &frz) {
  const int nt = atom->ntypes;
  for (int i = 0; i < atom->nlocal; i++) {
    std::vector<double> &r = (atom->mask[i] & freeze_group_bit_) ? frz : dyn;
    if (atom->radius[i] > r[atom->type[i]]) r[atom->type[i]] = atom->radius[i];
  }
  maxrad_dynamic_.assign(nt + 1, 0.0);
  maxrad_frozen_.assign(nt + 1, 0.0);
  MPI_Allreduce(&dyn[1], &maxrad_dynamic_[1], nt, MPI_DOUBLE, MPI_MAX, world);
  MPI_Allreduce(&frz[1], &maxrad_frozen_[1], nt, MPI_DOUBLE, MPI_MAX, world);
}

/* Ghost atoms are not used (one rank, minimum image in the core); the cutoff sizes atom sorting,
 * communication and the neighbour lists' bins, as with the stock style. */
double PairGranGPUBase::init_one(int i, int j) {
  if ((int)maxrad_dynamic_.size() <= (i > j ? i : j)) return 0.0;
  const double *d = maxrad_dynamic_.data(), *z = maxrad_frozen_.data();
  double cut = d[i] + d[j];
  if (z[i] + d[j] > cut) cut = z[i] + d[j];
  if (d[i] + z[j] > cut) cut = d[i] + z[j];
  return cut;
}

void PairGranGPUBase::set_box(sphdem_dem_params &p) {
  p.skin = neighbor->skin;
  for (int d = 0; d < 3; d++) {
    p.boxlo[d] = box_lo_[d] = domain->boxlo[d];
    p.boxhi[d] = box_hi_[d] = domain->boxhi[d];
    p.periodic[d] = box_per_[d] = domain->periodicity[d];
  }
}

void PairGranGPUBase::push_params(const sphdem_dem_params &p) {
  prm_ = p;
  if (dem_ && sphdem_dem_set_params(dem_, &p)) fail(sphdem_dem_last_error(dem_));
}

void PairGranGPUBase::create_core() {
  if (dem_) return;
  char msg[512];
  int rc = sphdem_dem_create(&dem_, &prm_, (sphdem_device)device_, msg, sizeof msg);
  if (rc) fail(std::string("cannot start the DEM core: ") + msg);
  if (comm->me == 0)
    sphdem_compat::logmesg(lmp, "Pair " + style_ + ": sphdem DEM core on the " +
                                    (sphdem_dem_backend(dem_) == SPHDEM_DEVICE_GPU ? "GPU" : "CPU") + ", " +
                                    (algo_ == SPHDEM_DEM_PAIR_PARALLEL ? "pair" : "particle") + "-parallel\n");
}

void PairGranGPUBase::restore_history() {
  if (pending_history_.apply(dem_)) fail(std::string("restoring the contact history: ") + sphdem_dem_last_error(dem_));
}

/* The history is written as pair keys made of atom tags, so it does not depend on the atom order at
 * read time. One rank. */
void PairGranGPUBase::write_restart_tail(FILE *fp) {
  sphdem_restart::write_setflag(fp, setflag, atom->ntypes);
  if (!sphdem_restart::write_history(fp, dem_)) fail("reading the contact history for the restart file failed");
}

void PairGranGPUBase::begin_read_restart() {
  require_one_rank();
  if (!allocated) allocate();
}

void PairGranGPUBase::read_restart_tail(FILE *fp, bool head_read) {
  if (!head_read || !sphdem_restart::read_setflag(fp, setflag, atom->ntypes) ||
      !pending_history_.read(fp, (int64_t)atom->natoms))
    fail(pending_history_.error_or("restart file ends inside the pair style's data"));
}

void PairGranGPUBase::compute_grains(bool material_types, bool follow_list_builds) {
  const int n = atom->nlocal;
  bool box_changed = false;
  for (int d = 0; d < 3; d++)
    box_changed |= domain->boxlo[d] != box_lo_[d] || domain->boxhi[d] != box_hi_[d] || domain->periodicity[d] != box_per_[d];
  if (box_changed) sync_params();
  const double tp0 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  tags_.resize(n);
  fbuf_.resize(3 * (size_t)n);
  tbuf_.resize(3 * (size_t)n);
  for (int i = 0; i < n; i++) tags_[i] = atom->tag[i];
  const int *fl = nullptr; /* NULL: no grain frozen, one material */
  if (freeze_group_bit_ || material_types) {
    flags_.resize(n);
    const int *type = atom->type;
    for (int i = 0; i < n; i++)
      flags_[i] = ((atom->mask[i] & freeze_group_bit_) ? SPHDEM_DEM_FROZEN : 0) |
                  (material_types ? (type[i] - 1) << SPHDEM_DEM_MATERIAL_SHIFT : 0);
    fl = flags_.data();
  }
  /* x, v, omega are contiguous n x 3 blocks (memory->create), radius and rmass plain arrays: the core
   * reads them in place */
  const double *xp = n ? atom->x[0] : nullptr, *vp = n ? atom->v[0] : nullptr, *wp = n ? atom->omega[0] : nullptr;
  double vir[6];
  const double tp1 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  /* the core's pair list is rebuilt (and drops pairs, with their history) on the engine's build steps */
  if (follow_list_builds && neighbor->ago == 0) sphdem_dem_request_build(dem_);
  /* during setup the forces are evaluated without advancing the shear history (as the stock style) */
  int rc = sphdem_dem_compute(dem_, n, tags_.data(), xp, vp, wp, atom->radius, atom->rmass, fl, update->dt,
                              update->setupflag ? 0 : 1, fbuf_.data(), tbuf_.data(), vflag_global ? vir : nullptr);
  if (rc) fail(std::string("DEM core: ") + sphdem_dem_last_error(dem_));
  const double tp2 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  double **f = atom->f, **t = atom->torque;
  for (int i = 0; i < n; i++)
    for (int d = 0; d < 3; d++) {
      f[i][d] += fbuf_[3 * i + d];
      t[i][d] += tbuf_[3 * i + d];
    }
  if (vflag_global)
    for (int k = 0; k < 6; k++) virial[k] += vir[k];
  if (timers_.on) {
    timers_.pack += tp1 - tp0;
    timers_.unpack += sphdem_pair_timers::now() - tp2;
    if (update->setupflag) timers_.reset(dem_);
    else if (update->ntimestep == update->laststep && comm->me == 0)
      sphdem_compat::logmesg(lmp, timers_.line(dem_, style_));
  }
}

double PairGranGPUBase::memory_usage() {
  return (double)(tags_.capacity() * sizeof(int64_t) + flags_.capacity() * sizeof(int)) +
         (double)(fbuf_.capacity() + tbuf_.capacity()) * sizeof(double);
}
