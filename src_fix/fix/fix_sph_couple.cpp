/* fix_sph_couple.cpp - fix sph/couple: parses the coupling keywords into sphdem_couple_params, uploads the
 * grains of its group before each fluid rate evaluation of a fix sph/fluid, holds the fluid forces on
 * them between fluid steps and adds them to atom->f every step. No physics here (gpu/couple/couple.c). */
#include "fix_sph_couple.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "group.h"
#include "memory.h"
#include "modify.h"
#include "sphdem_args.h"
#include "sphdem_compat.h"
#include "sphdem_grains.h"
#include "sphdem_peratom.h"
#include "sphdem_mpi.h"
#include "update.h"

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
const char *const SYNTAX =
    "fix ID group sph/couple FLUID-FIX-ID [drag ergun-wenyu|difelice|schiller-naumann|none] [mu V] [hc V] "
    "[eps_min V] [superficial yes|no] [torque yes|no] [dmax V] [wall_porosity none|fluid] [immersion S] [eps_walls yes|no] "
    "[pressure_form mass|volume]";
const char *const KEYWORDS = "drag, mu, hc, eps_min, superficial, torque, dmax, wall_porosity, immersion, eps_walls, pressure_form";
const char *const DRAGS = "ergun-wenyu, difelice, schiller-naumann or none";

const char *drag_name(int d) {
  switch (d) {
    case SPHDEM_DRAG_NONE: return "none";
    case SPHDEM_DRAG_ERGUN_WENYU: return "ergun-wenyu";
    case SPHDEM_DRAG_DIFELICE: return "difelice";
    case SPHDEM_DRAG_SCHILLER_NAUMANN: return "schiller-naumann";
  }
  return "?";
}
}  // namespace

/* ---------------------------------------------------------------------------------------------- */

FixSPHCouple::FixSPHCouple(LAMMPS *lmp, int narg, char **arg)
    : Fix(lmp, narg, arg), fluid_(nullptr), have_mu_(false), have_hc_(false), ca_(nullptr), nmax_(0),
      stats_dirty_(false) {
  /* the grains are gathered by group mask at every call, so a dynamic group (LAMMPS: the grains fix pour adds to
   * "all", selected as !(fluid || walls)) works */
  dynamic_group_allow = 1;
  std::memset(&cstats_, 0, sizeof cstats_);
  cstats_.eps_min = 1.0;
  for (int d = 0; d < 3; d++) pgrain_[d] = 0.0;
  parse_args(narg, arg);

  sphdem_peratom::start(this, atom, NOUT, NVEC, true);
  comm_forward = 6;
}

FixSPHCouple::~FixSPHCouple() {
  sphdem_peratom::stop(this, atom, memory, ca_);
}

int FixSPHCouple::setmask() { return POST_FORCE; }

void FixSPHCouple::fail(const std::string &msg) {
  sphdem_compat::error_all(error, FLERR, std::string("Fix sph/couple: ") + msg);
}

void FixSPHCouple::check(sphdem_ctx ctx, int rc, const char *what) {
  if (rc == SPHDEM_OK) return;
  const std::string m = std::string("Fix sph/couple: ") + what + ": " + sphdem_last_error(ctx) + " (" +
                        sphdem_strerror(rc) + ")";
  if (comm->nprocs > 1) sphdem_compat::error_one(error, FLERR, m); /* may fail on this rank alone */
  sphdem_compat::error_all(error, FLERR, m);
}

double FixSPHCouple::parse_number(const char *kw, const char *s, const char *usage) {
  return sphdem_args::number([this](const std::string &m) { fail(m); }, kw, s, usage);
}

/* ---- arguments --------------------------------------------------------------------------------- */

void FixSPHCouple::parse_args(int narg, char **arg) {
  sphdem_couple_params_default(&cp_);
  cp_.enabled = 1;
  cp_.drag = SPHDEM_DRAG_ERGUN_WENYU;
  if (narg < 4) fail(std::string("missing the ID of the fix sph/fluid (syntax: ") + SYNTAX + ")");
  fluid_id_ = arg[3];

  int iarg = 4;
  std::vector<std::string> seen;
  while (iarg < narg) {
    const std::string kw = arg[iarg];
    const bool dup = std::find(seen.begin(), seen.end(), kw) != seen.end(); /* refused after its value's check */
    seen.push_back(kw);
    if (iarg + 1 >= narg) {
      if (kw == "drag") fail(std::string("drag must be ") + DRAGS);
      if (kw == "superficial" || kw == "torque" || kw == "eps_walls") fail(kw + " must be yes or no");
      if (kw == "wall_porosity") fail("wall_porosity must be none or fluid");
      if (kw == "pressure_form") fail("pressure_form must be mass or volume");
      if (kw == "mu" || kw == "hc" || kw == "eps_min" || kw == "dmax" || kw == "immersion")
        fail("missing value for " + kw + " (usage: " + kw + " V)");
      fail("unknown keyword '" + kw + "'; keywords are " + KEYWORDS);
    }
    const std::string val = arg[iarg + 1];
    if (kw == "drag") {
      if (val == "ergun-wenyu") cp_.drag = SPHDEM_DRAG_ERGUN_WENYU;
      else if (val == "difelice") cp_.drag = SPHDEM_DRAG_DIFELICE;
      else if (val == "schiller-naumann") cp_.drag = SPHDEM_DRAG_SCHILLER_NAUMANN;
      else if (val == "none") cp_.drag = SPHDEM_DRAG_NONE;
      else fail(std::string("drag must be ") + DRAGS + " (got '" + val + "')");
    } else if (kw == "immersion") {
      cp_.immersion = parse_number("immersion", val.c_str(), "immersion S");
      if (!(cp_.immersion >= 0 && cp_.immersion <= 1)) fail("immersion must be in [0, 1], 0 = off (got " + val + ")");
    } else if (kw == "wall_porosity") {
      if (val != "none" && val != "fluid") fail("wall_porosity must be none or fluid (got '" + val + "')");
      cp_.wall_porosity = val == "fluid";
    } else if (kw == "pressure_form") {
      if (val != "mass" && val != "volume") fail("pressure_form must be mass or volume (got '" + val + "')");
      cp_.pressure_form = val == "volume";
    } else if (kw == "superficial" || kw == "torque" || kw == "eps_walls") {
      if (val != "yes" && val != "no") fail(kw + " must be yes or no (got '" + val + "')");
      (kw == "superficial" ? cp_.superficial : kw == "torque" ? cp_.torque : cp_.eps_walls) = val == "yes";
    } else if (kw == "mu") {
      cp_.mu = parse_number("mu", val.c_str(), "mu V");
      if (cp_.mu <= 0) fail("mu must be > 0 (got " + val + ")");
      have_mu_ = true;
    } else if (kw == "hc") {
      cp_.hc = parse_number("hc", val.c_str(), "hc V");
      if (cp_.hc <= 0) fail("hc must be > 0 (got " + val + ")");
      have_hc_ = true;
    } else if (kw == "eps_min") {
      cp_.eps_min = parse_number("eps_min", val.c_str(), "eps_min V");
      if (!(cp_.eps_min > 0 && cp_.eps_min < 1)) fail("eps_min must be in (0, 1) (got " + val + ")");
    } else if (kw == "dmax") {
      cp_.dmax = parse_number("dmax", val.c_str(), "dmax V");
      if (cp_.dmax < 0) fail("dmax must be >= 0 (got " + val + "; 0 = from the grains)");
    } else {
      fail("unknown keyword '" + kw + "'; keywords are " + KEYWORDS);
    }
    if (dup) fail("keyword " + kw + " is given twice (give each keyword once)");
    iarg += 2;
  }
  /* a coupling kernel wider than the box */
  double lmax = 0.0;
  for (int d = 0; d < domain->dimension; d++) lmax = std::max(lmax, domain->boxhi[d] - domain->boxlo[d]);
  if (have_hc_ && 2.0 * cp_.hc > lmax) {
    char m[256];
    snprintf(m, sizeof m, "hc %g: the coupling kernel support 2 hc exceeds the box (largest extent %g); hc is the "
             "coupling smoothing length, about h to 3 h of the fluid", cp_.hc, lmax);
    fail(m);
  }
}

/* ---- run set-up ---------------------------------------------------------------------------------- */

void FixSPHCouple::init() {
  int bad_restart = !restart_error_.empty(), any_bad = 0;
  MPI_Allreduce(&bad_restart, &any_bad, 1, MPI_INT, MPI_MAX, world);
  if (any_bad) fail(bad_restart ? restart_error_ : std::string("a restart record on another rank is corrupted"));
  const int ifluid = modify->find_fix(fluid_id_.c_str());
  if (ifluid < 0) fail("fix ID '" + fluid_id_ + "' does not exist (syntax: " + SYNTAX + ")");
  fluid_ = dynamic_cast<FixSPHFluid *>(modify->fix[ifluid]);
  if (!fluid_)
    fail("fix '" + fluid_id_ + "' is not a fix sph/fluid (its style is " + modify->fix[ifluid]->style + ")");
  int ime = -1;
  for (int k = 0; k < modify->nfix; k++)
    if (modify->fix[k] == this) ime = k;
  if (ime < ifluid)
    fail(std::string("define fix ") + id + " after fix sph/fluid " + fluid_id_ +
         " (the fluid's rate evaluation must precede the coupling forces in post_force)");
  if (!fluid_->attach_coupler(this))
    fail("fix sph/fluid " + fluid_id_ + " is already coupled by another fix sph/couple (one per fluid fix)");
  if (fluid_->many_ranks()) {
    /* each rank evaluates its own fluid and grains; the ghosts' porosity, grain forces and reaction come from
     * their owners inside the rate evaluation (sphdem_set_exchange): one coupling support of ghosts suffices */
    const double hc = cp_.hc > 0 ? cp_.hc : fluid_->params().h;
    fluid_->require_ghost_band(2.0 * hc);
  }

  if (!atom->radius_flag) fail("the atom style must define a per-atom radius (atom_style sphere or granular)");
  if (cp_.torque && !(atom->omega_flag && atom->torque_flag))
    fail("torque yes needs per-atom omega and torque (atom_style sphere or granular)");

  /* the grains are neither fluid nor wall particles */
  const int *mask = atom->mask;
  const int bad = fluid_->groupbit | fluid_->wall_groupbit();
  int overlap = 0, any = 0;
  for (int i = 0; i < atom->nlocal; i++)
    if ((mask[i] & groupbit) && (mask[i] & bad)) overlap = 1;
  MPI_Allreduce(&overlap, &any, 1, MPI_INT, MPI_MAX, world);
  if (any)
    fail(std::string("the grain group ") + group->names[igroup] +
         " overlaps the fluid or wall group of fix sph/fluid " + fluid_id_);

  const sphdem_params &fp = fluid_->params();
  if (!have_hc_) cp_.hc = fp.h;
  if (!have_mu_) {
    if (fp.visc == SPHDEM_VISC_MORRIS) cp_.mu = fp.mu;
    else if (cp_.drag != SPHDEM_DRAG_NONE || cp_.torque)
      fail(std::string(cp_.drag != SPHDEM_DRAG_NONE ? "drag " : "torque yes with drag ") + drag_name(cp_.drag) +
           " needs the fluid viscosity: give mu V, or use visc morris MU in fix sph/fluid " + fluid_id_);
  }

  check_grain_size();
  if (group->count(igroup) == 0) {
    if (comm->me == 0)
      sphdem_compat::warning(error, FLERR, std::string("Fix sph/couple: the grain group ") + group->names[igroup] +
                                               " has no atoms: the coupling acts once grains are inserted");
    return;
  }
  /* the drag is explicit and held over a fluid step: a grain whose Stokes relaxation time rho_p d^2 / (18 mu)
   * is below half the fluid step is unstable with any drag law (the dense-bed laws are stiffer still) */
  if (cp_.drag != SPHDEM_DRAG_NONE && atom->rmass && cp_.mu > 0) {
    const double pi = 3.14159265358979323846, dtf = (double)fluid_->every() * update->dt;
    double tmin = INFINITY;
    long long tag = 0;
    for (int i = 0; i < atom->nlocal; i++) {
      if (!(atom->mask[i] & groupbit) || !(atom->radius[i] > 0)) continue;
      const double r = atom->radius[i], d = 2.0 * r;
      const double vol = domain->dimension == 2 ? pi * r * r : 4.0 / 3.0 * pi * r * r * r;
      const double tau = sphdem_stokes_time(atom->rmass[i] / vol, d, cp_.mu);
      if (tau < tmin) tmin = tau, tag = (long long)atom->tag[i];
    }
    double all;
    MPI_Allreduce(&tmin, &all, 1, MPI_DOUBLE, MPI_MIN, world);
    if (all < 0.5 * dtf) {
      char m[512];
      snprintf(m, sizeof m, "mu %g%s: the Stokes relaxation time rho_p d^2 / (18 mu) of the grains is %g s (grain "
               "%lld), below half the fluid step %g s: the explicit drag is unstable. Lower mu, the timestep or "
               "every", cp_.mu, have_mu_ ? "" : " (from visc morris)", all, all == tmin ? tag : -1LL, dtf);
      fail(m);
    }
  }
}

/* The unresolved coupling smears each grain over the fluid within 2 hc (eq 26). A lone grain of diameter d at a
 * fluid particle takes the solid fraction V_p W(0, hc) there: in 3D (pi d^3/6) 21/(16 pi hc^3) = 7/32 (d/hc)^3,
 * in 2D (pi d^2/4) 7/(4 pi hc^2) = 7/16 (d/hc)^2. Refused where that alone leaves a porosity below eps_min
 * (d > 1.54 hc in 3D with eps_min 0.2); a warning where it leaves less than 0.5 (d > 1.32 hc in 3D): the porosity
 * field is then as coarse as the grains. Collective (the largest grain over the ranks). */
void FixSPHCouple::check_grain_size() {
  double dloc = 0.0;
  long long tag = -1;
  for (int i = 0; i < atom->nlocal; i++)
    if ((atom->mask[i] & groupbit) && 2.0 * atom->radius[i] > dloc) dloc = 2.0 * atom->radius[i], tag = (long long)atom->tag[i];
  double d = dloc;
  MPI_Allreduce(&dloc, &d, 1, MPI_DOUBLE, MPI_MAX, world);
  double t = d == dloc && d > 0 ? (double)tag : 0.0, tg = 0.0; /* the lowest-ranked owner names its grain */
  if (!(d == dloc && d > 0)) t = 1e300;
  MPI_Allreduce(&t, &tg, 1, MPI_DOUBLE, MPI_MIN, world);
  if (!(d > 0)) return;
  const int dim = domain->dimension;
  const double hc = cp_.hc, q = d / hc;
  const double s0 = dim == 2 ? 7.0 / 16.0 * q * q : 7.0 / 32.0 * q * q * q;
  const double cmax = dim == 2 ? 16.0 / 7.0 : 32.0 / 7.0, e = 1.0 / dim;
  const double dlim = std::pow(cmax * (1.0 - cp_.eps_min), e), dwarn = std::pow(cmax * 0.5, e); /* in hc */
  const double dx = fluid_->params().dx;
  if (s0 <= 0.5) return;
  char m[1400];
  snprintf(m, sizeof m,
           "grain %lld has diameter d = %g, %.3g hc (hc %g%s, fluid dx %g): a lone grain at a fluid particle takes the "
           "solid fraction V_p W(0,hc) = %s = %.3g there (He 2018 eq 26), leaving a porosity of %.3g. The unresolved "
           "coupling needs d <= %.3g hc = %g (porosity >= eps_min %g; with hc = h = 1.3 dx that is d <= %.3g dx); "
           "below d = %.3g hc = %g (porosity 0.5) the porosity field resolves the grains. Ways out: a larger hc (hc "
           "%g would admit d; the fluid-grain pairs grow as hc^%d), smaller grains, or a coarser fluid (larger dx and "
           "h; hc defaults to h)",
           (long long)tg, d, q, hc, have_hc_ ? "" : " = the fluid h", dx,
           dim == 2 ? "7/16 (d/hc)^2" : "7/32 (d/hc)^3", s0, 1.0 - s0, dlim, dlim * hc, cp_.eps_min, dlim * 1.3,
           dwarn, dwarn * hc, d / dlim, dim);
  if (s0 > 1.0 - cp_.eps_min) fail(m);
  if (comm->me == 0) sphdem_compat::warning(error, FLERR, std::string("Fix sph/couple: ") + m);
}

/* Called by the fluid fix in its setup(), after its context exists and before any rate evaluation. */
void FixSPHCouple::couple_setup(sphdem_ctx ctx) {
  check(ctx, sphdem_couple_set(ctx, &cp_), "couple_set");
  if (comm->me == 0) {
    char line[512];
    snprintf(line, sizeof line,
             "Fix sph/couple: drag %s, mu %g, hc %g, eps_min %g, superficial %s, torque %s, dmax %g%s, "
             "wall_porosity %s, immersion %g, eps_walls %s, pressure_form %s; fluid step every %ld engine steps\n",
             drag_name(cp_.drag), cp_.mu, cp_.hc, cp_.eps_min, cp_.superficial ? "yes" : "no",
             cp_.torque ? "yes" : "no", cp_.dmax, cp_.dmax > 0 ? "" : " (from the grains)",
             cp_.wall_porosity ? "fluid" : "none", cp_.immersion, cp_.eps_walls ? "yes" : "no",
             cp_.pressure_form ? "volume" : "mass", fluid_->every());
    sphdem_compat::logmesg(lmp, line);
  }
}

bool FixSPHCouple::couple_forces_valid() {
  const int *mask = atom->mask;
  int invalid = 0, any = 0;
  for (int i = 0; i < nloop(); i++)
    if ((mask[i] & groupbit) && ca_[i][C_VALID] <= 0) invalid = 1;
  MPI_Allreduce(&invalid, &any, 1, MPI_INT, MPI_MAX, world);
  return !any;
}

/* No grain within 2 hc of any fluid particle at set-up (the smallest porosity over the fluid is 1): a note, grains
 * may fall into the water later. Collective. */
void FixSPHCouple::note_reach() {
  sphdem_ctx ctx = fluid_ ? fluid_->context() : nullptr;
  if (!ctx || group->count(igroup) == 0) return;
  sphdem_couple_stats st;
  if (sphdem_couple_stats_get(ctx, &st) != SPHDEM_OK) return;
  cstats_ = st;
  stats_dirty_ = false;
  if (st.ngrains > 0 && st.eps_min >= 1.0 && comm->me == 0) {
    char m[512];
    snprintf(m, sizeof m, "Fix sph/couple: no grain of group %s is within 2 hc = %g of a fluid particle of fix "
             "sph/fluid %s at set-up: the coupling is on and acts on nothing yet (fine if the grains reach the "
             "water later)", group->names[igroup], 2.0 * cp_.hc, fluid_id_.c_str());
    sphdem_compat::warning(error, FLERR, m);
  }
}

/* Kinetic energy of the grains of the group: translational 1/2 m v^2 and rotational 1/2 I w^2 with I = 2/5 m r^2
 * (a solid sphere, as compute erotate/sphere), summed over the ranks' own grains. Collective. */
void FixSPHCouple::grain_ke(double ke[3]) const {
  double s[2] = {0.0, 0.0};
  const int *mask = atom->mask;
  double **v = atom->v, **om = atom->omega;
  for (int i = 0; i < atom->nlocal; i++) {
    if (!(mask[i] & groupbit)) continue;
    const double m = atom->rmass ? atom->rmass[i] : atom->mass[atom->type[i]];
    s[0] += 0.5 * m * (v[i][0] * v[i][0] + v[i][1] * v[i][1] + v[i][2] * v[i][2]);
    if (atom->omega_flag && om) {
      const double r = atom->radius[i];
      s[1] += 0.5 * 0.4 * m * r * r * (om[i][0] * om[i][0] + om[i][1] * om[i][1] + om[i][2] * om[i][2]);
    }
  }
  double all[2];
  MPI_Allreduce(s, all, 2, MPI_DOUBLE, MPI_SUM, world);
  ke[0] = all[0] + all[1], ke[1] = all[0], ke[2] = all[1];
}

/* The fluid fix's setup() (earlier in the fix list) has computed or kept the held forces. */
void FixSPHCouple::setup(int) {
  note_reach();
  const int *mask = atom->mask;
  double **f = atom->f, **t = atom->torque;
  for (int i = 0; i < nloop(); i++) {
    if (!(mask[i] & groupbit)) continue;
    for (int d = 0; d < 3; d++) f[i][d] += ca_[i][C_F + d];
    if (cp_.torque)
      for (int d = 0; d < 3; d++) t[i][d] += ca_[i][C_TORQUE + d];
  }
}

int FixSPHCouple::nloop() const { return sphdem_grains::nloop(atom, igroup); }

/* ---- the fluid step: upload grains, fetch forces ------------------------------------------------- */

void FixSPHCouple::couple_before_rates(sphdem_ctx ctx) {
  size_t n = sphdem_grains::gather(atom, groupbit, nloop(), gidx_, gx_, gv_, grad_, cp_.torque ? &gom_ : nullptr);
  ngown_ = n;
  if (fluid_->many_ranks()) {
    /* ghost grains: positions and radii from the engine, velocity and spin from their owners */
    const size_t nall = (size_t)(atom->nlocal + atom->nghost);
    if (gcomm_.size() < 6 * nall) gcomm_.resize(6 * nall, 0.0);
    for (size_t k = 0; k < ngown_; k++)
      for (int d = 0; d < 3; d++) {
        gcomm_[6 * gidx_[k] + d] = atom->v[gidx_[k]][d];
        gcomm_[6 * gidx_[k] + 3 + d] = atom->omega_flag ? atom->omega[gidx_[k]][d] : 0.0;
      }
    comm->forward_comm_fix(this);
    const int *mask = atom->mask;
    for (int i = atom->nlocal; i < (int)nall; i++) {
      if (!(mask[i] & groupbit)) continue;
      gidx_.push_back(i);
      for (int d = 0; d < 3; d++) {
        gx_.push_back(atom->x[i][d]);
        gv_.push_back(gcomm_[6 * i + d]);
        if (cp_.torque) gom_.push_back(gcomm_[6 * i + 3 + d]);
      }
      grad_.push_back(atom->radius[i]);
    }
    n = gidx_.size();
  }
  std::string gerr;
  const auto gv = grains_.hand_group(lmp, sphdem_backend(ctx), groupbit, nloop(), gidx_, ngown_, gx_, gv_, grad_,
                                     cp_.torque ? &gom_ : nullptr, gerr);
  int rc = gv.g ? sphdem_set_grains_store(ctx, gv.g, gv.n, gv.idx, cp_.torque) : SPHDEM_ERR_ARG;
  if (!gv.g) sphdem_compat::error_all(error, FLERR, "Fix sph/couple: grain store: " + gerr);
  if (rc == SPHDEM_OK && fluid_->many_ranks()) rc = sphdem_couple_set_ghosts(ctx, (int)(n - ngown_));
  /* grains that went non-finite during a run: the fluid fix writes its failure dump, with the grains */
  if (rc != SPHDEM_OK && update->ntimestep > update->beginstep)
    fluid_->fail_with_dump(std::string("Fix sph/couple: set_grains at step ") +
                           std::to_string((long long)update->ntimestep) + ": " + sphdem_last_error(ctx) + " (" +
                           sphdem_strerror(rc) + "); the grains blew up (their forces or time step).");
  check(ctx, rc, "set_grains");
}

void FixSPHCouple::couple_after_rates(sphdem_ctx ctx) {
  const size_t n = gidx_.size();
  gf_.resize(3 * n);
  gfd_.resize(3 * n);
  gfp_.resize(3 * n);
  gt_.resize(3 * n);
  const int rc = sphdem_get_grain_forces(ctx, gf_.data(), gfd_.data(), gfp_.data(), cp_.torque ? gt_.data() : nullptr);
  if (rc != SPHDEM_OK && update->ntimestep > update->beginstep) /* during a run: the state with the failure dump */
    fluid_->fail_with_dump(std::string("Fix sph/couple: get_grain_forces at step ") +
                           std::to_string((long long)update->ntimestep) + ": " + sphdem_last_error(ctx) + " (" +
                           sphdem_strerror(rc) + ")");
  check(ctx, rc, "get_grain_forces");
  for (size_t k = 0; k < ngown_; k++) { /* the ghosts' forces belong to their owners */
    double *row = ca_[gidx_[k]];
    for (int d = 0; d < 3; d++) {
      row[C_F + d] = gf_[3 * k + d];
      row[C_FDRAG + d] = gfd_[3 * k + d];
      row[C_FPG + d] = gfp_[3 * k + d];
      row[C_TORQUE + d] = cp_.torque ? gt_[3 * k + d] : 0.0;
    }
    row[C_VALID] = 1.0;
  }
  stats_dirty_ = true;
}

/* Many ranks, inside a rate evaluation: the owned grains' fluid force and Shepard sum to their ghost copies (the
 * reaction on each rank's fluid sums them), through this fix's forward communication. Collective. */
void FixSPHCouple::couple_exchange_grains(int nown, int nghost, const double *own, double *ghost) {
  const size_t nall = (size_t)(atom->nlocal + atom->nghost);
  if (gcomm_.size() < 6 * nall) gcomm_.resize(6 * nall, 0.0);
  const size_t no = std::min((size_t)nown, ngown_), ng = std::min((size_t)nghost, gidx_.size() - ngown_);
  for (size_t k = 0; k < no; k++)
    for (int c = 0; c < 4; c++) gcomm_[6 * (size_t)gidx_[k] + c] = own[4 * k + c];
  comm->forward_comm_fix(this);
  for (size_t j = 0; j < ng; j++)
    for (int c = 0; c < 4; c++) ghost[4 * j + c] = gcomm_[6 * (size_t)gidx_[ngown_ + j] + c];
}

int FixSPHCouple::sphdem_pack_forward(int n, int *list, double *buf, int, int *) {
  int m = 0;
  for (int j = 0; j < n; j++)
    for (int c = 0; c < 6; c++) buf[m++] = gcomm_[6 * (size_t)list[j] + c];
  return m;
}

void FixSPHCouple::sphdem_unpack_forward(int n, int first, double *buf) {
  if (gcomm_.size() < 6 * (size_t)(first + n)) gcomm_.resize(6 * (size_t)(first + n), 0.0);
  int m = 0;
  for (int i = first; i < first + n; i++)
    for (int c = 0; c < 6; c++) gcomm_[6 * (size_t)i + c] = buf[m++];
}

/* ---- every engine step: add the held forces ------------------------------------------------------- */

void FixSPHCouple::post_force(int) {
  const int *mask = atom->mask;
  double **f = atom->f, **t = atom->torque;
  double fsum[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < nloop(); i++) {
    if (!(mask[i] & groupbit)) continue;
    for (int d = 0; d < 3; d++) {
      f[i][d] += ca_[i][C_F + d];
      fsum[d] += ca_[i][C_F + d];
    }
    if (cp_.torque)
      for (int d = 0; d < 3; d++) t[i][d] += ca_[i][C_TORQUE + d];
  }
  /* momentum given to the grains: the held forces act over this engine step */
  const double dt = update->dt;
  double all[3];
  MPI_Allreduce(fsum, all, 3, MPI_DOUBLE, MPI_SUM, world);
  for (int d = 0; d < 3; d++) pgrain_[d] += all[d] * dt;
}

/* ---- output ------------------------------------------------------------------------------------------ */

/* The sums over the fluid need a download of the porosity and reaction of every fluid particle, so
 * they are fetched only when output asks for them; the core keeps them until the next rate evaluation. */
double FixSPHCouple::compute_vector(int n) {
  if (n >= V_PGRAIN && n < V_PGRAIN + 3) return pgrain_[n - V_PGRAIN];
  if (n >= V_KE && n <= V_KER) {
    double ke[3];
    grain_ke(ke);
    return ke[n - V_KE];
  }
  sphdem_ctx ctx = fluid_ ? fluid_->context() : nullptr;
  if (stats_dirty_ && ctx) {
    check(ctx, sphdem_couple_stats_get(ctx, &cstats_), "couple_stats_get");
    stats_dirty_ = false;
  }
  if (n >= V_FGRAIN && n < V_FGRAIN + 3) return cstats_.f_grains[n - V_FGRAIN];
  if (n >= V_FFLUID && n < V_FFLUID + 3) return cstats_.f_fluid[n - V_FFLUID];
  if (n >= V_FNET && n < V_FNET + 3) return cstats_.f_grains[n - V_FNET] + cstats_.f_fluid[n - V_FNET];
  if (n == V_EPSMIN) return cstats_.eps_min;
  if (n == V_NGRAIN) return (double)cstats_.ngrains;
  return 0.0;
}

double FixSPHCouple::memory_usage() {
  return (double)atom->nmax * NCOL * sizeof(double) +
         (double)(gx_.capacity() + gv_.capacity() + grad_.capacity() + gom_.capacity() + gf_.capacity() +
                  gfd_.capacity() + gfp_.capacity() + gt_.capacity()) *
             sizeof(double) +
         (double)gidx_.capacity() * sizeof(int);
}

/* global restart state: the momentum given to the grains */
void FixSPHCouple::write_restart(FILE *fp) {
  double list[3] = {pgrain_[0], pgrain_[1], pgrain_[2]};
  if (comm->me == 0) {
    int size = (int)sizeof(list);
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(list, sizeof(double), 3, fp);
  }
}

void FixSPHCouple::restart(char *buf) {
  double list[3];
  std::memcpy(list, buf, sizeof list);
  for (int d = 0; d < 3; d++) pgrain_[d] = list[d];
}

