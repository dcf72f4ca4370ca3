/* pair_gran_gpu_base.cpp - what the GPU granular pair styles of LAMMPS and LIGGGHTS share: the DEM core
 * context, grains in, forces out, timers, contact-history restart, messages. No physics here. */
#include "pair_gran_gpu_base.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "atom.h"
#include "comm.h"
#include "compute.h"
#include "domain.h"
#include "fix.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "sphdem_compat.h"
#include "sphdem_mpi.h"
#include "update.h"

using namespace LAMMPS_NS;

PairGranGPUBase::PairGranGPUBase(LAMMPS *lmp, const std::string &style)
    : Pair(lmp), style_(style), device_(SPHDEM_DEVICE_AUTO), algo_(SPHDEM_DEM_PARTICLE_PARALLEL),
      freeze_group_bit_(0), dem_(nullptr), ghosts_(comm->nprocs > 1), ghost_once_ok_(true), hand_rolling_(false), nall_mapped_(-1),
      owned_prev_set_(false), own_map_valid_(false), gathered_(false), check_req_(MPI_REQUEST_NULL), check_mine_(0), check_any_(0), check_pending_(0) {
  single_enable = 0;
  no_virial_fdotr_compute = 1; /* the virial is summed per pair by the core */
  restartinfo = 1; /* settings, coefficients and the per-pair contact history go into restart files */
  for (int d = 0; d < 3; d++) box_lo_[d] = box_hi_[d] = 0.0, box_per_[d] = 0, core_per_[d] = 0;
  sphdem_dem_params_default(&prm_);
}

PairGranGPUBase::~PairGranGPUBase() {
  int done = 0;
  MPI_Finalized(&done);
  if (check_req_ != MPI_REQUEST_NULL && !done) MPI_Wait(&check_req_, MPI_STATUS_IGNORE); /* every rank started it */
  sphdem_dem_destroy(&dem_);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
}

void PairGranGPUBase::fail(const std::string &msg) {
  sphdem_compat::error_all(error, __FILE__, __LINE__, "Pair " + style_ + ": " + msg);
}

void PairGranGPUBase::fail_one(const std::string &msg) {
  sphdem_compat::error_one(error, __FILE__, __LINE__, "Pair " + style_ + ": " + msg);
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

void PairGranGPUBase::scan_rigid_freeze() {
  freeze_group_bit_ = 0;
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (f->rigid_flag) fail(std::string("rigid bodies (fix ") + f->id + ") are not supported");
    if (std::strcmp(f->style, "freeze") == 0) freeze_group_bit_ = f->groupbit;
  }
}

void PairGranGPUBase::check_atoms(const char *atom_styles) {
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    fail(std::string("requires atom attributes radius, rmass, omega, torque (") + atom_styles + ")");
  if (ghosts_ && !comm->ghost_velocity)
    fail("on more than one MPI rank needs the velocities of ghost atoms: comm_modify vel yes (LIGGGHTS: "
         "communicate single vel yes), as the stock granular styles");
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

/* The cutoff sizes atom sorting, the ghost atoms' shell and the neighbour lists' bins, as with the stock
 * style. One rank: ghost atoms are not used (minimum image in the core). */
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
    box_per_[d] = domain->periodicity[d];
    p.periodic[d] = ghosts_ ? core_per_[d] : box_per_[d]; /* many ranks: else the ghost atoms are the images */
  }
}

void PairGranGPUBase::update_core_periodic() {
  bool changed = false;
  for (int d = 0; d < 3; d++) {
    const int per = domain->periodicity[d] && !sphdem_compat::comm_tiled(comm) && comm->procgrid[d] == 1 &&
                    domain->prd[d] >= 2.0 * neighbor->cutneighmax && neighbor->cutneighmax > 0.0;
    changed |= per != core_per_[d];
    core_per_[d] = per;
  }
  if (changed) sync_params();
}

void PairGranGPUBase::push_params(const sphdem_dem_params &p) {
  prm_ = p;
  if (dem_ && sphdem_dem_set_params(dem_, &p)) fail(sphdem_dem_last_error(dem_));
}

void PairGranGPUBase::create_core() {
  if (dem_) return;
  /* many ranks: each takes GPU (rank on its node) mod (GPUs on the node); several ranks may share one */
  if (ghosts_ && device_ != SPHDEM_DEVICE_CPU) {
    const std::string map = sphdem_mpi::select_gpus(world);
    if (comm->me == 0 && !map.empty()) sphdem_compat::logmesg(lmp, "Pair " + style_ + ": " + map + "\n");
  }
  char msg[512] = "";
  int rc = sphdem_dem_create(&dem_, &prm_, (sphdem_device)device_, msg, sizeof msg);
  if (ghosts_) {
    const std::string err = sphdem_mpi::first_failure(world, rc != 0, msg);
    if (!err.empty()) fail("cannot start the DEM core: " + err);
  } else if (rc) {
    fail(std::string("cannot start the DEM core: ") + msg);
  }
  if (comm->me == 0)
    sphdem_compat::logmesg(lmp, "Pair " + style_ + ": sphdem DEM core on the " +
                                    (sphdem_dem_backend(dem_) == SPHDEM_DEVICE_GPU ? "GPU" : "CPU") + ", " +
                                    (algo_ == SPHDEM_DEM_PAIR_PARALLEL ? "pair" : "particle") + "-parallel\n");
}

void PairGranGPUBase::check_ranks(bool bad, const std::string &why, bool now) {
  if (bad && !check_pending_) {
    check_pending_ = 1;
    check_pending_msg_ = why;
  }
  if (!now && update->ntimestep % kCheckEvery != 0) return; /* (the same steps on every rank) */
  finish_check();
  check_mine_ = check_pending_;
  check_msg_ = check_pending_msg_;
  check_pending_ = 0;
  check_pending_msg_.clear();
  if (now) {
    const std::string err = sphdem_mpi::first_failure(world, check_mine_ != 0, check_msg_);
    check_mine_ = 0;
    if (!err.empty()) fail("DEM core: " + err);
  } else {
    MPI_Iallreduce(&check_mine_, &check_any_, 1, MPI_INT, MPI_MAX, world, &check_req_);
  }
}

void PairGranGPUBase::finish_check() {
  if (check_req_ == MPI_REQUEST_NULL) return;
  MPI_Wait(&check_req_, MPI_STATUS_IGNORE);
  if (!check_any_) return;
  check_any_ = 0;
  const std::string err = sphdem_mpi::first_failure(world, check_mine_ != 0, check_msg_);
  check_mine_ = 0;
  if (!err.empty()) fail("DEM core: " + err);
}

void PairGranGPUBase::restore_history() {
  /* the engine's init after steps ran (write_restart calls it on every rank, between runs or among the commands of
   * run ... every; so do the next run's set-up and write_data, velocity ...): the history of those steps to rank 0,
   * for a write_restart that follows */
  if (ghosts_ && dem_ && history_dirty_) gather_for_restart();
  if (pending_history_.apply(dem_)) fail(std::string("restoring the contact history: ") + sphdem_dem_last_error(dem_));
}

/* The history is written as pair keys made of atom tags, so it does not depend on the atom order or the
 * number of ranks at read time. Rank 0 only (the engines write the pair style's part there). Many ranks:
 * the history gathered at the last step (gather_history), or the one read by read_restart if no step ran. */
void PairGranGPUBase::write_restart_tail(FILE *fp) {
  sphdem_restart::write_setflag(fp, setflag, atom->ntypes);
  if (!ghosts_) {
    if (!sphdem_restart::write_history(fp, dem_)) fail("reading the contact history for the restart file failed");
  } else if (gathered_) {
    sphdem_restart::write_history(fp, gkeys_, ghist_, groll_);
  } else {
    sphdem_restart::write_history(fp, pending_history_.keys, pending_history_.hist, pending_history_.roll);
  }
}

void PairGranGPUBase::begin_read_restart() {
  if (!allocated) allocate();
}

bool PairGranGPUBase::read_head(FILE *fp, void *p, size_t size, size_t n) {
  int ok = comm->me == 0 ? (int)sphdem_restart::read_items(fp, p, size, n) : 1;
  if (comm->nprocs > 1) {
    MPI_Bcast(&ok, 1, MPI_INT, 0, world);
    if (ok && n) MPI_Bcast(p, (int)(size * n), MPI_BYTE, 0, world);
  }
  return ok != 0;
}

/* Rank 0 reads; every rank gets the flags and the whole history (its core's builds carry the pairs it has). */
void PairGranGPUBase::read_restart_tail(FILE *fp, bool head_read) {
  int ok = 1;
  std::string err;
  if (comm->me == 0) {
    ok = head_read && sphdem_restart::read_setflag(fp, setflag, atom->ntypes) &&
         pending_history_.read(fp, (int64_t)atom->natoms);
    if (!ok) err = pending_history_.error_or("restart file ends inside the pair style's data");
  }
  if (comm->nprocs > 1) {
    err = sphdem_mpi::first_failure(world, !ok, err);
    if (!err.empty()) fail(err.substr(err.find(") ") + 2)); /* the message of rank 0, without its rank */
    for (int i = 1; i <= atom->ntypes; i++) MPI_Bcast(&setflag[i][1], atom->ntypes, MPI_INT, 0, world);
    int64_t np = (int64_t)pending_history_.keys.size();
    int have = pending_history_.have ? 1 : 0;
    MPI_Bcast(&have, 1, MPI_INT, 0, world);
    MPI_Bcast(&np, 1, MPI_INT64_T, 0, world);
    pending_history_.have = have != 0;
    pending_history_.keys.resize((size_t)np);
    pending_history_.hist.resize((size_t)np * SPHDEM_DEM_HIST_DOUBLES);
    if (np) {
      MPI_Bcast(pending_history_.keys.data(), (int)np, MPI_UINT64_T, 0, world);
      MPI_Bcast(pending_history_.hist.data(), (int)(np * SPHDEM_DEM_HIST_DOUBLES), MPI_DOUBLE, 0, world);
    }
    int64_t nr = (int64_t)pending_history_.roll.size();
    MPI_Bcast(&nr, 1, MPI_INT64_T, 0, world);
    pending_history_.roll.resize((size_t)nr);
    if (nr) MPI_Bcast(pending_history_.roll.data(), (int)nr, MPI_DOUBLE, 0, world);
  } else if (!ok) {
    fail(err);
  }
}

const sphdem_tagmap::TagMap &PairGranGPUBase::own_map(int nlocal) {
  if (!own_map_valid_) {
    const auto *tag = atom->tag;
    own_now_.build(nlocal, [tag](int i) { return tag[i]; });
    own_map_valid_ = true;
  }
  return own_now_;
}

void PairGranGPUBase::map_ghosts(int nlocal, int nall) {
  /* The own atoms lie in the box at a build (the engine's pbc), so a copy of one is outside the box along the
   * periodic axis it was shifted along: a copy outside it along an axis of core_per_ is an image along that axis,
   * one inside the box along every periodic axis is another rank's atom, and the others are looked up (the
   * engine's atom map, atom_modify map, where there is one; else a map of the owned tags) */
  const bool engine_map = atom->map_style != 0;
  image_of_.assign((size_t)(nall - nlocal), -1);
  images_.clear();
  double **x = atom->x;
  const double *lo = domain->boxlo, *hi = domain->boxhi;
  const int *per = domain->periodicity;
  for (int g = nlocal; g < nall; g++) {
    bool out = false, skip = false;
    for (int d = 0; d < 3; d++) {
      const bool o = per[d] && (x[g][d] < lo[d] || x[g][d] >= hi[d]);
      out |= o;
      skip |= o && core_per_[d];
    }
    if (skip) {
      image_of_[g - nlocal] = SKIPPED;
      continue;
    }
    if (!out) continue;
    const int i = engine_map ? atom->map(atom->tag[g]) : own_map(nlocal).find((int64_t)atom->tag[g]);
    if (i >= 0 && i < nlocal) {
      image_of_[g - nlocal] = i;
      images_.push_back(g);
    }
  }
  nall_mapped_ = nall;
}

namespace {
bool has_tag(const std::vector<int64_t> &sorted, int64_t t) { return std::binary_search(sorted.begin(), sorted.end(), t); }
/* one of the pair's atoms is in sorted */
bool pair_has(const std::vector<int64_t> &sorted, uint64_t key) {
  return has_tag(sorted, (int64_t)(key >> 32)) ||
         (!sphdem_restart::wall_key(key) && has_tag(sorted, (int64_t)(key & 0xffffffffu)));
}
}  // namespace

/* An atom moves at most one subdomain along each axis at an exchange of a brick decomposition (the engines lose
 * it otherwise), so it joins one of the 26 subdomains around this one: their ranks, without this one and each once.
 * Tiled decompositions: none (the hand-over then goes to every rank). */
const std::vector<int> &PairGranGPUBase::hand_ranks() {
  int key[7] = {comm->procgrid[0], comm->procgrid[1], comm->procgrid[2], domain->periodicity[0],
                domain->periodicity[1], domain->periodicity[2], sphdem_compat::comm_tiled(comm) ? 1 : 0};
  if (hand_key_valid_ && std::equal(key, key + 7, hand_key_)) return hand_ranks_;
  std::copy(key, key + 7, hand_key_);
  hand_key_valid_ = true;
  hand_ranks_.clear();
  if (key[6] || !comm->grid2proc) return hand_ranks_;
  for (int dx = -1; dx <= 1; dx++)
    for (int dy = -1; dy <= 1; dy++)
      for (int dz = -1; dz <= 1; dz++) {
        const int d[3] = {dx, dy, dz};
        int loc[3];
        bool in = true;
        for (int a = 0; a < 3; a++) {
          loc[a] = comm->myloc[a] + d[a];
          if (loc[a] < 0 || loc[a] >= comm->procgrid[a]) {
            if (!domain->periodicity[a]) in = false;
            loc[a] = (loc[a] + comm->procgrid[a]) % comm->procgrid[a];
          }
        }
        if (!in) continue;
        const int r = comm->grid2proc[loc[0]][loc[1]][loc[2]];
        if (r != comm->me) hand_ranks_.push_back(r);
      }
  std::sort(hand_ranks_.begin(), hand_ranks_.end());
  hand_ranks_.erase(std::unique(hand_ranks_.begin(), hand_ranks_.end()), hand_ranks_.end());
  return hand_ranks_;
}

/* Whether the cuts of the brick decomposition (fractions of the box) differ from those of the last call, which
 * are then remembered: LAMMPS' fix balance moves them and sends the atoms to their new ranks, any rank (the
 * first call: true). Tiled decompositions: false (their hand-over goes to every rank anyway). */
bool PairGranGPUBase::cuts_moved() {
  std::vector<double> now;
  if (!sphdem_compat::comm_tiled(comm) && comm->xsplit && comm->ysplit && comm->zsplit) {
    now.insert(now.end(), comm->xsplit, comm->xsplit + comm->procgrid[0] + 1);
    now.insert(now.end(), comm->ysplit, comm->ysplit + comm->procgrid[1] + 1);
    now.insert(now.end(), comm->zsplit, comm->zsplit + comm->procgrid[2] + 1);
  }
  const bool moved = now != cuts_;
  cuts_.swap(now);
  return moved && !sphdem_compat::comm_tiled(comm);
}

namespace {
/* The engine's exclusion lists (public in LAMMPS, protected in LIGGGHTS): pointers to members formed in a class
 * derived from Neighbor, applied to the engine's Neighbor. */
struct NeighborExclusions : LAMMPS_NS::Neighbor {
  static int Neighbor::*ntype() { return &NeighborExclusions::nex_type; }
  static int Neighbor::*ngroup() { return &NeighborExclusions::nex_group; }
  static int Neighbor::*nmol() { return &NeighborExclusions::nex_mol; }
  static int *Neighbor::*type1() { return &NeighborExclusions::ex1_type; }
  static int *Neighbor::*type2() { return &NeighborExclusions::ex2_type; }
  static int *Neighbor::*bit1() { return &NeighborExclusions::ex1_bit; }
  static int *Neighbor::*bit2() { return &NeighborExclusions::ex2_bit; }
};
}  // namespace

/* neigh_modify exclude type M N and exclude group G1 G2 as the core's exclusion classes: the types named get a
 * class index each (the others share index 0, which no type exclusion names), the groups named a bit each; a pair
 * of classes is excluded where the engine would exclude a pair of atoms of those types and groups (its rules: the
 * type pair, or one atom in G1 and the other in G2). Molecule exclusions and more than 16 classes stop the run. */
void PairGranGPUBase::setup_exclusions() {
  LAMMPS_NS::Neighbor *nb = neighbor;
  const int ntx = nb->*NeighborExclusions::ntype(), ngx = nb->*NeighborExclusions::ngroup();
  if (nb->*NeighborExclusions::nmol() > 0)
    fail("neigh_modify exclude molecule/intra or molecule/inter is not supported (type and group exclusions are)");
  excl_tcls_.assign(atom->ntypes + 1, 0);
  excl_bits_.clear();
  const int *t1 = nb->*NeighborExclusions::type1(), *t2 = nb->*NeighborExclusions::type2();
  const int *b1 = nb->*NeighborExclusions::bit1(), *b2 = nb->*NeighborExclusions::bit2();
  std::vector<int> rep(1, 0); /* a type of each type index (index 0: none named) */
  for (int k = 0; k < ntx; k++)
    for (const int t : {t1[k], t2[k]})
      if (t >= 1 && t <= atom->ntypes && excl_tcls_[t] == 0) {
        excl_tcls_[t] = (int)rep.size();
        rep.push_back(t);
      }
  std::vector<int> g1(ngx), g2(ngx); /* the bit of each exclusion's two groups in a class */
  for (int k = 0; k < ngx; k++)
    for (int side = 0; side < 2; side++) {
      const int b = side ? b2[k] : b1[k];
      const auto at = std::find(excl_bits_.begin(), excl_bits_.end(), b);
      (side ? g2 : g1)[k] = (int)(at - excl_bits_.begin());
      if (at == excl_bits_.end()) excl_bits_.push_back(b);
    }
  const int ng = (int)excl_bits_.size(), nt = (int)rep.size();
  const long ncls = ng < 16 ? (long)nt << ng : SPHDEM_DEM_MAX_CLASSES + 1L;
  excl_on_ = ntx > 0 || ngx > 0;
  if (excl_on_ && ncls > SPHDEM_DEM_MAX_CLASSES)
    fail("neigh_modify exclude: " + std::to_string(nt - 1) + " types and " + std::to_string(ng) +
         " groups named make more classes of atoms (" + std::to_string(nt) + " x 2^" + std::to_string(ng) +
         ") than the " + std::to_string(SPHDEM_DEM_MAX_CLASSES) + " the core tells apart");
  std::vector<uint16_t> rows(excl_on_ ? ncls : 0, 0);
  for (int c1 = 0; c1 < (int)rows.size(); c1++)
    for (int c2 = 0; c2 < ncls; c2++) {
      const int ta = rep[c1 >> ng], tb = rep[c2 >> ng], ga = c1 & ((1 << ng) - 1), gb = c2 & ((1 << ng) - 1);
      bool ex = false;
      for (int k = 0; k < ntx && ta && tb; k++)
        ex |= (t1[k] == ta && t2[k] == tb) || (t1[k] == tb && t2[k] == ta);
      for (int k = 0; k < ngx; k++)
        ex |= (((ga >> g1[k]) & 1) && ((gb >> g2[k]) & 1)) || (((ga >> g2[k]) & 1) && ((gb >> g1[k]) & 1));
      if (ex) rows[c1] |= (uint16_t)(1u << c2);
    }
  if (sphdem_dem_set_exclusions(dem_, (int)rows.size(), rows.data())) fail(sphdem_dem_last_error(dem_));
}

int PairGranGPUBase::exclusion_class(int i) const {
  const int ng = (int)excl_bits_.size();
  int g = 0;
  for (int q = 0; q < ng; q++)
    if (atom->mask[i] & excl_bits_[q]) g |= 1 << q;
  return (excl_tcls_[atom->type[i]] << ng) | g;
}

/* Stock LAMMPS and LIGGGHTS keep a contact's history with the atom that owns it and move it with the atom
 * (fix neigh/history, fix contacthistory). Here a rank holds every pair with one of its own atoms; an atom
 * that changes rank finds on the new rank the pairs with that rank's atoms already (evaluated there too), and
 * the others (its partners stayed behind, or moved too) come from the rank it left. */
void PairGranGPUBase::hand_over_history() {
  const int nlocal = atom->nlocal, H = SPHDEM_DEM_HIST_DOUBLES, R = hand_rolling_ ? 3 : 0, W = H + R;
  const auto *tag = atom->tag;
  /* an atom joins a rank next to its last one at the engine's exchanges, but any rank at the set-up of a run
   * (after balance, displace_atoms, change_box) and where fix balance moved the cuts (the same on every rank) */
  const bool anywhere = cuts_moved() || update->setupflag;
  if (!owned_prev_set_) { /* the core has no pair yet (or the one of read_restart, which every rank has) */
    owned_prev_.assign(tag, tag + nlocal);
    prev_map_.build(nlocal, [tag](int i) { return tag[i]; });
    owned_prev_set_ = true;
    return;
  }
  /* the atoms that left this rank and those that joined it since the last build (sorted, for pair_has) */
  const sphdem_tagmap::TagMap &now = own_map(nlocal);
  std::vector<int64_t> &left = left_, &arrived = arrived_;
  left.clear();
  arrived.clear();
  for (const int64_t t : owned_prev_)
    if (now.find(t) < 0) left.push_back(t);
  for (int i = 0; i < nlocal; i++)
    if (prev_map_.find((int64_t)tag[i]) < 0) arrived.push_back((int64_t)tag[i]);
  std::sort(left.begin(), left.end());
  std::sort(arrived.begin(), arrived.end());
  owned_prev_.assign(tag, tag + nlocal);
  prev_map_.swap(own_now_);
  own_map_valid_ = false;
  /* the history of the pairs of the atoms that left (and with rolling_friction epsd/epsd2 their rolling torques);
   * keys, hist, roll keep their size from one build to the next */
  std::vector<uint64_t> &keys = hkeys_, &sk = hsk_;
  std::vector<double> &hist = hhist_, &roll = hroll_, &sh = hsh_;
  sk.clear();
  sh.clear();
  int bad = 0;
  if (!left.empty()) {
    /* into the buffers as large as the last time; again, larger, where they were too small */
    const int64_t nl = (int64_t)left.size();
    int64_t c = -1;
    for (int pass = 0; pass < 2; pass++) {
      const int64_t cap = (int64_t)keys.size();
      c = sphdem_dem_get_history_of(dem_, nl, left.data(), keys.data(), hist.data(), R ? roll.data() : nullptr, cap);
      if (c <= cap) break;
      keys.resize((size_t)c);
      hist.resize((size_t)c * H);
      roll.resize((size_t)c * 3);
    }
    if (c < 0) bad = 1;
    for (int64_t p = 0; p < c; p++)
      if (sphdem_restart::has_history(&hist[p * H])) {
        sk.push_back(keys[p]);
        sh.insert(sh.end(), hist.begin() + p * H, hist.begin() + (p + 1) * H);
        sh.insert(sh.end(), roll.begin() + p * 3, roll.begin() + p * 3 + R);
      }
  }
  /* the pairs go to every rank an atom of this rank can join at an exchange (hand_ranks), or to every rank */
  const int ns = (int)sk.size();
  std::vector<uint64_t> rk;
  std::vector<double> rh;
  int total = 0;
  const std::vector<int> &nb = hand_ranks();
  if (!anywhere && !nb.empty()) {
    /* a rank that could not read its history: every rank stops with its message */
    int anybad = 0;
    MPI_Allreduce(&bad, &anybad, 1, MPI_INT, MPI_MAX, world);
    if (anybad)
      fail(sphdem_mpi::first_failure(world, bad, std::string("reading the contact history: ") +
                                                     sphdem_dem_last_error(dem_)));
    const int nn = (int)nb.size(), tag0 = 23870; /* tags of these messages alone (below 32767, the least MPI_TAG_UB) */
    std::vector<int> cnt(nn, 0);
    std::vector<MPI_Request> req;
    req.reserve(4 * (size_t)nn);
    for (int k = 0; k < nn; k++) {
      req.emplace_back();
      MPI_Irecv(&cnt[k], 1, MPI_INT, nb[k], tag0, world, &req.back());
    }
    for (int k = 0; k < nn; k++) {
      req.emplace_back();
      MPI_Isend(&ns, 1, MPI_INT, nb[k], tag0, world, &req.back());
    }
    MPI_Waitall((int)req.size(), req.data(), MPI_STATUSES_IGNORE);
    for (int k = 0; k < nn; k++) total += cnt[k];
    rk.resize((size_t)total);
    rh.resize((size_t)total * W);
    req.clear();
    for (int k = 0, off = 0; k < nn; off += cnt[k], k++) {
      if (cnt[k] == 0) continue;
      req.emplace_back();
      MPI_Irecv(rk.data() + off, cnt[k], MPI_UINT64_T, nb[k], tag0 + 1, world, &req.back());
      req.emplace_back();
      MPI_Irecv(rh.data() + (size_t)off * W, cnt[k] * W, MPI_DOUBLE, nb[k], tag0 + 2, world, &req.back());
    }
    for (int k = 0; k < nn && ns > 0; k++) {
      req.emplace_back();
      MPI_Isend(sk.data(), ns, MPI_UINT64_T, nb[k], tag0 + 1, world, &req.back());
      req.emplace_back();
      MPI_Isend(sh.data(), ns * W, MPI_DOUBLE, nb[k], tag0 + 2, world, &req.back());
    }
    MPI_Waitall((int)req.size(), req.data(), MPI_STATUSES_IGNORE);
  } else {
    /* the counts, and -1 from a rank that could not read its history (every rank then stops with its message) */
    const int nr = comm->nprocs, nsb = bad ? -1 : ns;
    std::vector<int> cnt(nr), dsp(nr), cnth(nr), dsph(nr);
    MPI_Allgather(&nsb, 1, MPI_INT, cnt.data(), 1, MPI_INT, world);
    if (*std::min_element(cnt.begin(), cnt.end()) < 0) {
      const std::string err = sphdem_mpi::first_failure(world, bad, std::string("reading the contact history: ") +
                                                                        sphdem_dem_last_error(dem_));
      fail(err);
    }
    for (int r = 0; r < nr; r++) dsp[r] = total, total += cnt[r], cnth[r] = cnt[r] * W, dsph[r] = dsp[r] * W;
    rk.resize((size_t)total);
    rh.resize((size_t)total * W);
    MPI_Allgatherv(sk.data(), ns, MPI_UINT64_T, rk.data(), cnt.data(), dsp.data(), MPI_UINT64_T, world);
    MPI_Allgatherv(sh.data(), ns * W, MPI_DOUBLE, rh.data(), cnth.data(), dsph.data(), MPI_DOUBLE, world);
  }
  if (total == 0) return;
  if (arrived.empty()) return;
  /* the pairs of atoms that joined this rank, each once, that the core does not hold already (a failure here is
   * this rank's alone: the engine's one-rank stop, as the other ranks are past their last collective of the
   * hand-over) */
  std::vector<std::pair<uint64_t, int>> take;
  for (int k = 0; k < total; k++)
    if (pair_has(arrived, rk[k])) take.emplace_back(rk[k], k);
  if (take.empty()) return;
  /* each pair once (from the lowest rank that sent it), in key order; the core keeps the pairs it holds already */
  std::stable_sort(take.begin(), take.end(),
                   [](const std::pair<uint64_t, int> &a, const std::pair<uint64_t, int> &b) { return a.first < b.first; });
  std::vector<uint64_t> ak;
  std::vector<double> ah, ar;
  for (size_t t = 0; t < take.size(); t++) {
    if (t && take[t].first == take[t - 1].first) continue;
    const size_t o = (size_t)take[t].second * W;
    ak.push_back(take[t].first);
    ah.insert(ah.end(), rh.begin() + o, rh.begin() + o + H);
    ar.insert(ar.end(), rh.begin() + o + H, rh.begin() + o + W);
  }
  if (sphdem_dem_add_history(dem_, (int64_t)ak.size(), ak.data(), ah.data(), R ? ar.data() : nullptr))
    fail_one(std::string("handing the contact history over: ") + sphdem_dem_last_error(dem_));
}

void PairGranGPUBase::gather_history() {
  const int H = SPHDEM_DEM_HIST_DOUBLES, R = hand_rolling_ ? 3 : 0, W = H + R;
  std::vector<uint64_t> &keys = gscr_keys_, &sk = gscr_sk_, &rk = gscr_rk_;
  std::vector<double> &hist = gscr_hist_, &roll = gscr_roll_, &sh = gscr_sh_, &rh = gscr_rh_;
  const bool bad = !sphdem_restart::get_history(dem_, keys, hist, R ? &roll : nullptr);
  const std::string err = sphdem_mpi::first_failure(world, bad, std::string("reading the contact history: ") +
                                                                    sphdem_dem_last_error(dem_));
  if (!err.empty()) fail(err);
  if (roll.size() != keys.size() * (size_t)R) roll.assign(keys.size() * (size_t)R, 0.0); /* none kept yet: 0 */
  sk.clear();
  sh.clear();
  for (size_t p = 0; p < keys.size(); p++)
    if (sphdem_restart::has_history(&hist[p * H])) {
      sk.push_back(keys[p]);
      sh.insert(sh.end(), hist.begin() + p * H, hist.begin() + (p + 1) * H);
      sh.insert(sh.end(), roll.begin() + p * R, roll.begin() + (p + 1) * R);
    }
  const int nr = comm->nprocs, ns = (int)sk.size();
  std::vector<int> cnt(nr), dsp(nr), cnth(nr), dsph(nr);
  MPI_Gather(&ns, 1, MPI_INT, cnt.data(), 1, MPI_INT, 0, world);
  int total = 0;
  for (int r = 0; r < nr; r++) dsp[r] = total, total += cnt[r], cnth[r] = cnt[r] * W, dsph[r] = dsp[r] * W;
  rk.resize(comm->me == 0 ? (size_t)total : 0);
  rh.resize(comm->me == 0 ? (size_t)total * W : 0);
  MPI_Gatherv(sk.data(), ns, MPI_UINT64_T, rk.data(), cnt.data(), dsp.data(), MPI_UINT64_T, 0, world);
  MPI_Gatherv(sh.data(), ns * W, MPI_DOUBLE, rh.data(), cnth.data(), dsph.data(), MPI_DOUBLE, 0, world);
  gathered_ = true;
  gkeys_.clear();
  ghist_.clear();
  groll_.clear();
  if (comm->me != 0) return;
  /* the pairs in key order; a pair split between two ranks is held by both (the same values): once, from the lower
   * rank. Each rank's part comes in the order of its key-sorted list: the parts are merged pairwise (stable, the
   * lower rank first among equal keys), a part out of order sorted first */
  std::vector<int> &order = gscr_order_;
  order.resize((size_t)total);
  for (int k = 0; k < total; k++) order[k] = k;
  const auto by_key = [&](int a, int b) { return rk[a] < rk[b]; };
  std::vector<int> bound(dsp);
  bound.push_back(total);
  for (int r = 0; r < nr; r++)
    if (!std::is_sorted(rk.begin() + bound[r], rk.begin() + bound[r + 1]))
      std::stable_sort(order.begin() + bound[r], order.begin() + bound[r + 1], by_key);
  while (bound.size() > 2) {
    std::vector<int> next;
    for (size_t s = 0; s + 1 < bound.size(); s += 2) {
      next.push_back(bound[s]);
      if (s + 2 < bound.size())
        std::inplace_merge(order.begin() + bound[s], order.begin() + bound[s + 1], order.begin() + bound[s + 2], by_key);
    }
    next.push_back(bound.back()); /* (an odd count of parts: the last one stays as it is this round) */
    bound.swap(next);
  }
  gkeys_.reserve((size_t)total);
  ghist_.reserve((size_t)total * H);
  groll_.reserve((size_t)total * R);
  for (size_t t = 0; t < order.size(); t++) {
    if (t && rk[order[t]] == rk[order[t - 1]]) continue;
    const size_t o = (size_t)order[t] * W;
    gkeys_.push_back(rk[order[t]]);
    ghist_.insert(ghist_.end(), rh.begin() + o, rh.begin() + o + H);
    groll_.insert(groll_.end(), rh.begin() + o + H, rh.begin() + o + W);
  }
}

bool PairGranGPUBase::restart_step() const {
#ifdef SPHDEM_ENGINE_LIGGGHTS
  return output->restart_requested(update->ntimestep);
#else
  return output->restart_flag && update->ntimestep == output->next_restart;
#endif
}

void PairGranGPUBase::gather_for_restart() {
  gather_history();
  gather_more();
  history_dirty_ = false;
}

int64_t PairGranGPUBase::contacts_now(std::vector<int32_t> &ij, std::vector<double> &ft, std::vector<double> &hist,
                                      std::vector<double> &roll, std::string &err, bool step) {
  if (!dem_) {
    err = "the pair style has evaluated no forces yet";
    return -1;
  }
  const int nlocal = atom->nlocal, n = ghosts_ ? nlocal + atom->nghost : nlocal;
  sphdem_grain_store g = grains_.put_atoms(lmp, sphdem_dem_backend(dem_), nlocal, n - nlocal, err);
  if (!g) return -1;
  const int64_t cap = std::max<int64_t>(sphdem_dem_get_history(dem_, nullptr, nullptr, 0), 1); /* >= the touching */
  ij.resize(2 * cap);
  ft.resize(SPHDEM_DEM_CONTACT_DOUBLES * cap);
  hist.resize(SPHDEM_DEM_HIST_DOUBLES * cap);
  roll.resize(3 * cap);
  const int64_t k = step ? sphdem_dem_step_contacts(dem_, g, cap, ij.data(), ft.data())
                         : sphdem_dem_contacts(dem_, g, cap, ij.data(), ft.data(), hist.data(), roll.data());
  if (k < 0 || k > cap) {
    err = k < 0 ? sphdem_dem_last_error(dem_) : "more touching pairs than pairs";
    return -1;
  }
  return k;
}

bool PairGranGPUBase::heat_now(const double *temp, const double *cond, const int *member, int area, double area_value,
                               double *heat, double **dir, std::string &err) {
  if (!dem_) {
    err = "the pair style has evaluated no forces yet";
    return false;
  }
  if (last_once_) {
    err = "heat conduction needs every rank to evaluate its split pairs (newton off)";
    return false;
  }
  const int nlocal = atom->nlocal, n = ghosts_ ? nlocal + atom->nghost : nlocal;
  sphdem_grain_store g = grains_.put_atoms(lmp, sphdem_dem_backend(dem_), nlocal, n - nlocal, err);
  if (!g) return false;
  heat_q_.resize(std::max(n, 1));
  heat_dq_.resize(dir ? 3 * std::max(n, 1) : 0);
  if (sphdem_dem_heat(dem_, g, temp, cond, member, area, area_value, heat_q_.data(), dir ? heat_dq_.data() : nullptr)) {
    err = sphdem_dem_last_error(dem_);
    return false;
  }
  for (int i = 0; i < n; i++) {
    int o = i;
    if (i >= nlocal) {
      o = image_of_[i - nlocal]; /* a periodic image of an own atom, or another rank's atom (< 0) */
      if (o < 0) continue;
    }
    heat[o] += heat_q_[i];
    if (dir)
      for (int d = 0; d < 3; d++) dir[o][d] += heat_dq_[3 * i + d];
  }
  return true;
}

bool PairGranGPUBase::pair_local_present() const {
  for (int i = 0; i < modify->ncompute; i++)
    if (std::strcmp(modify->compute[i]->style, "pair/local") == 0) return true;
  return false;
}

const double *PairGranGPUBase::single_contact(int i, int j, bool &i_is_a) {
  const int n = atom->nlocal + atom->nghost;
  if (update->ntimestep != single_step_ || n != single_n_) {
    std::string err;
    const int64_t np = contacts_now(single_ij_, single_ft_, single_hist_, single_roll_, err);
    if (np < 0) fail_one("compute pair/local: " + err);
    single_map_.clear();
    for (int64_t k = 0; k < np; k++) {
      const uint64_t ta = (uint64_t)atom->tag[single_ij_[2 * k]], tb = (uint64_t)atom->tag[single_ij_[2 * k + 1]];
      single_map_.emplace(ta < tb ? ta << 32 | tb : tb << 32 | ta, k);
    }
    single_step_ = update->ntimestep;
    single_n_ = n;
  }
  const uint64_t ti = (uint64_t)atom->tag[i], tj = (uint64_t)atom->tag[j];
  const auto it = single_map_.find(ti < tj ? ti << 32 | tj : tj << 32 | ti);
  if (it == single_map_.end())
    fail_one("compute pair/local: atoms " + std::to_string(ti) + " and " + std::to_string(tj) +
             " overlap but the DEM core has no contact of them (is the pair excluded?)");
  const int64_t k = it->second;
  i_is_a = (uint64_t)atom->tag[single_ij_[2 * k]] == ti;
  return &single_ft_[SPHDEM_DEM_CONTACT_DOUBLES * k];
}

void PairGranGPUBase::add_virial_atom(bool step) {
  std::string err;
  std::vector<int32_t> ij;
  std::vector<double> ft, hist, roll;
  const int64_t np = contacts_now(ij, ft, hist, roll, err, step);
  if (np < 0) fail_one("per-atom virial: " + err);
  const int nlocal = atom->nlocal;
  auto share = [&](int i, const double *v) {
    if (i >= nlocal && !last_once_) { /* a split pair evaluated on both ranks: the other atom's share is there */
      const int o = ghosts_ ? image_of_[i - nlocal] : -1;
      if (o < 0) return;
      i = o; /* a periodic image of an own atom */
    }
    for (int d = 0; d < 6; d++) vatom[i][d] += 0.5 * v[d];
  };
  for (int64_t k = 0; k < np; k++) {
    const int a = ij[2 * k], b = ij[2 * k + 1];
    const double *F = &ft[SPHDEM_DEM_CONTACT_DOUBLES * k], *del = F + 9; /* (x_a - x_b as the core took it) */
    const double v[6] = {del[0] * F[0], del[1] * F[1], del[2] * F[2], del[0] * F[1], del[0] * F[2], del[1] * F[2]};
    share(a, v);
    share(b, v);
  }
}

void PairGranGPUBase::compute_grains(bool material_types, bool follow_list_builds) {
  const int nlocal = atom->nlocal;
  const int n = ghosts_ ? nlocal + atom->nghost : nlocal; /* many ranks: own atoms, then the ghost atoms */
  bool box_changed = false;
  for (int d = 0; d < 3; d++)
    box_changed |= domain->boxlo[d] != box_lo_[d] || domain->boxhi[d] != box_hi_[d] || domain->periodicity[d] != box_per_[d];
  if (box_changed) sync_params();
  /* the engine's exclusions, set up with its neighbour settings (at each run's set-up) */
  if (update->setupflag) setup_exclusions();
  const double tp0 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  /* an engine list build: a failure kept since the last check stops every rank before the hand-over (the engine
   * rebuilds on every rank at the same step) */
  if (ghosts_ && neighbor->ago == 0 && !update->setupflag) check_ranks(false, "", true);
  own_map_valid_ = false;
  if (ghosts_ && neighbor->ago == 0) update_core_periodic();
  if (ghosts_ && (neighbor->ago == 0 || n != nall_mapped_)) map_ghosts(nlocal, n);
  /* many ranks: after the engine moved atoms between ranks (its list builds), their contacts' history */
  if (ghosts_ && neighbor->ago == 0) hand_over_history();
  if (neighbor->ago == 0) list_built();
  /* the atoms are reordered, inserted or exchanged only on the engine's list builds (and at set-up) */
  if (neighbor->ago == 0 || update->setupflag || tags_.size() != (size_t)n) {
    tags_.resize(n);
    for (int i = 0; i < n; i++) tags_[i] = atom->tag[i];
  } else {
    sphdem_dem_same_tags(dem_); /* (the core need not compare them) */
  }
  const int *fl = nullptr; /* NULL: no grain frozen, one material, one rank */
  /* frozen grains and materials read the engine's mask and type at every step, as the stock styles; the ghost
   * flags alone change only with the ghost atoms (the engine's list builds) */
  const bool per_step = freeze_group_bit_ || material_types || excl_on_;
  if (per_step || (ghosts_ && (neighbor->ago == 0 || update->setupflag || flags_.size() != (size_t)n))) {
    flags_.resize(n);
    const int *type = atom->type;
    for (int i = 0; i < n; i++)
      flags_[i] = ((atom->mask[i] & freeze_group_bit_) ? SPHDEM_DEM_FROZEN : 0) |
                  (material_types ? (type[i] - 1) << SPHDEM_DEM_MATERIAL_SHIFT : 0) |
                  (excl_on_ ? exclusion_class(i) << SPHDEM_DEM_CLASS_SHIFT : 0);
    for (int i = nlocal; i < n; i++) {
      const int o = image_of_[i - nlocal];
      flags_[i] |= o >= 0 ? SPHDEM_DEM_IMAGE : o == SKIPPED ? SPHDEM_DEM_SKIP : SPHDEM_DEM_GHOST;
    }
  }
  if (per_step || ghosts_) fl = flags_.data();
  double vir[6];
  const double tp1 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  /* the core's pair list is rebuilt (and drops pairs, with their history) on the engine's build steps; many
   * ranks: on every one (the ghost atoms are new) */
  if ((follow_list_builds || ghosts_) && neighbor->ago == 0) sphdem_dem_request_build(dem_);
  /* during setup the forces are evaluated without advancing the shear history (as the stock style) */
  /* the atoms go to the grain store in place (x, v, omega contiguous n x 3 blocks, radius and rmass) */
  std::string gerr;
  sphdem_grain_store g = grains_.put_atoms(lmp, sphdem_dem_backend(dem_), nlocal, n - nlocal, gerr);
  /* the core adds force and torque to the engine's arrays (contiguous blocks of n x 3, ghost rows included) itself.
   * Split pairs evaluated once (LAMMPS, newton on): the ghost rows (periodic images included) get the other atom's
   * share, which the engine's reverse communication adds to the atom. Else the ghost rows are kept aside and
   * zeroed first; after the call each periodic image's share goes to the atom itself, and the ghost rows get
   * their values back (other ranks' atoms get their share there, so the reverse communication must not carry it) */
#ifdef SPHDEM_ENGINE_LIGGGHTS
  const bool once = false;
#else
  const bool once = ghosts_ && force->newton_pair && ghost_once_ok_;
#endif
  sphdem_dem_set_ghost_once(dem_, once ? 1 : 0);
  last_once_ = once;
  double **f = atom->f, **t = atom->torque;
  /* the ghost rows are kept aside only where the engine adds them to their atoms (force->newton: its reverse
   * communication); else the engine neither clears nor reads them, and they are only zeroed (the periodic images'
   * share is moved to the atom below) */
  const int nghost = once ? 0 : n - nlocal, ng = force->newton ? nghost : 0;
  if (ng > 0) {
    fbuf_.assign(f[nlocal], f[nlocal] + 3 * (size_t)ng);
    tbuf_.assign(t[nlocal], t[nlocal] + 3 * (size_t)ng);
  }
  if (nghost > 0) {
    std::fill(f[nlocal], f[nlocal] + 3 * (size_t)nghost, 0.0);
    std::fill(t[nlocal], t[nlocal] + 3 * (size_t)nghost, 0.0);
  }
  sphdem_dem_set_accumulate(dem_, 1);
  int rc = g ? sphdem_dem_compute_store(dem_, g, tags_.data(), fl, update->dt, update->setupflag ? 0 : 1,
                                        n > 0 ? f[0] : nullptr, n > 0 ? t[0] : nullptr, vflag_global ? vir : nullptr)
             : SPHDEM_ERR_ARG;
  if (ghosts_) {
    /* a failure stops every rank; on the steps between the set-up, restart files and the end of the run, within
     * kCheckEvery steps or at the next list build, so that the ranks do not wait for each other at every step */
    check_ranks(rc != 0, rc ? (g ? sphdem_dem_last_error(dem_) : gerr) : "",
                update->setupflag || update->ntimestep == update->laststep || restart_step());
  } else if (rc) {
    fail(std::string("DEM core: ") + (g ? sphdem_dem_last_error(dem_) : gerr));
  }
  const double tp2 = timers_.on ? sphdem_pair_timers::now() : 0.0;
  /* a periodic image's share goes to the atom itself */
  for (size_t k = 0; k < images_.size() && !once; k++) {
    const int i = images_[k], o = image_of_[i - nlocal];
    for (int d = 0; d < 3; d++) {
      f[o][d] += f[i][d];
      t[o][d] += t[i][d];
    }
  }
  if (ng > 0) {
    std::copy(fbuf_.begin(), fbuf_.end(), f[nlocal]);
    std::copy(tbuf_.begin(), tbuf_.end(), t[nlocal]);
  }
  if (vflag_global)
    for (int k = 0; k < 6; k++) virial[k] += vir[k];
  /* many ranks: rank 0 keeps every rank's history for a restart file written at this step; one written after the
   * run gets it from write_restart's init (restore_history), so a run that writes none does not gather */
  if (ghosts_ && !update->setupflag) history_dirty_ = true;
  if (ghosts_ && restart_step()) gather_for_restart();
  if (timers_.on) {
    timers_.pack += tp1 - tp0;
    timers_.unpack += sphdem_pair_timers::now() - tp2;
    if (update->setupflag) {
      timers_.reset(dem_);
    } else if (update->ntimestep == update->laststep) {
      const std::string line = timers_.line(dem_, style_, world); /* collective */
      if (comm->me == 0) sphdem_compat::logmesg(lmp, line);
    }
  }
}

double PairGranGPUBase::memory_usage() {
  return (double)(tags_.capacity() * sizeof(int64_t) + flags_.capacity() * sizeof(int)) +
         (double)(fbuf_.capacity() + tbuf_.capacity()) * sizeof(double);
}
