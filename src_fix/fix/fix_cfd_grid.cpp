/* fix_cfd_grid.cpp - fix cfd/grid: parses the gas keywords into sphdem_cfd_params, advances the coarse-grid
 * gas of CFD-DEM (Yu 2024 §2.1-2.4) every N engine steps with the grains of its group, holds the gas
 * forces on them between gas steps and adds them to atom->f every step; VTK output of the cell fields.
 * No physics here (gpu/cfd/cfd.c). */
#include "fix_cfd_grid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "group.h"
#include "input.h"
#include "memory.h"
#include "modify.h"
#include "sphdem_args.h"
#include "sphdem_compat.h"
#include "sphdem_grains.h"
#include "sphdem_mpi.h"
#include "sphdem_peratom.h"
#include "update.h"
#include "variable.h"

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
const char *const SYNTAX =
    "fix ID group cfd/grid grid NX NY NZ rho V mu V [box xlo xhi ylo yhi zlo zhi] [gravity gx gy gz] "
    "[bc SIDE noslip|slip|inlet U|outlet] [patch SIDE A0 A1 B0 B1 U] [every N] [drag gidaspow|wenyu|none] "
    "[voidage centroid|smooth] [eps_min V] [ddt_eps yes|no] [pressure_force yes|no] [solver mg|line] [tol V] "
    "[maxiter N] "
    "[cfl V] [device auto|gpu|cpu] [init_u ux uy uz] [vtk N PREFIX]";
const char *const KEYWORDS =
    "grid, box, rho, mu, gravity, bc, patch, every, drag, voidage, eps_min, ddt_eps, pressure_force, solver, "
    "tol, maxiter, cfl, device, init_u, vtk";
const char *const SIDES = "xlo, xhi, ylo, yhi, zlo or zhi";
const char *const SIDE_NAME[6] = {"xlo", "xhi", "ylo", "yhi", "zlo", "zhi"};
const char *const BCS = "noslip, slip, inlet U (a number or v_name) or outlet";
const char *const DRAGS = "gidaspow, wenyu or none";
const char *const BC_NAME[4] = {"noslip", "slip", "inlet", "outlet"};
const char *const DRAG_NAME[3] = {"gidaspow", "wenyu", "none"};
const char *const TIMER_NAME[SPHDEM_CFD_NTIMERS] = {"couple", "predict", "solve", "correct", "transfer"};

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

int side_index(const std::string &s) {
  for (int k = 0; k < 6; k++)
    if (s == SIDE_NAME[k]) return k;
  return -1;
}

/* restart record: a version tag, the gas step count, the state size, time and its step, the state, the
 * statistics of the last gas step (NSTATS doubles) */
constexpr double RESTART_TAG = 20260003.0;
constexpr size_t NSTATS = (sizeof(sphdem_cfd_stats) + sizeof(double) - 1) / sizeof(double);
}  // namespace

/* ---------------------------------------------------------------------------------------------- */

FixCFDGrid::FixCFDGrid(LAMMPS *lmp, int narg, char **arg)
    : Fix(lmp, narg, arg), device_(SPHDEM_DEVICE_AUTO), have_box_(false), every_(1), have_init_u_(false),
      vtk_every_(0), pvd_loaded_(false), ctx_(nullptr), announced_(false), have_pending_(false), fa_(nullptr),
      nmax_(0), ngas_steps_(0), time_(0.0), clock_step_(0), keep_stats_(false), host_time_(0.0) {
  for (int s = 0; s < 6; s++) inlet_ivar_[s] = -1;
  for (int d = 0; d < 3; d++) init_u_[d] = 0.0;
  std::memset(&stats_, 0, sizeof stats_);
  red_.world = &world;
  red_.seconds = 0.0;
  red_.calls = 0;
  red_.values = 0;
  parse_args(narg, arg);
  time_ = update->atime + (double)(update->ntimestep - update->atimestep) * update->dt;
  clock_step_ = update->ntimestep;

  sphdem_peratom::start(this, atom, NCOL, NVEC, true);
}

FixCFDGrid::~FixCFDGrid() {
  sphdem_peratom::stop(this, atom, memory, fa_);
  sphdem_cfd_destroy(&ctx_);
}

int FixCFDGrid::setmask() { return POST_FORCE | POST_RUN; }

void FixCFDGrid::fail(const std::string &msg) {
  sphdem_compat::error_all(error, FLERR, std::string("Fix cfd/grid: ") + msg);
}
void FixCFDGrid::fail_one(const std::string &msg) {
  sphdem_compat::error_one(error, FLERR, std::string("Fix cfd/grid: ") + msg);
}

/* the core's reductions over the ranks (solver scalars, statistics, gathers), timed for the run summary */
int FixCFDGrid::reduce_cb(void *user, double *buf, int n, int op) {
  Reduce *r = (Reduce *)user;
  const double t0 = MPI_Wtime();
  const int rc = sphdem_mpi::allreduce_cb(r->world, buf, n, op);
  r->seconds += MPI_Wtime() - t0;
  r->calls++;
  r->values += n;
  return rc;
}

/* the halo exchange of the decomposed grid: nsend doubles to the face neighbour at dir along axis, nrecv from the
 * one opposite (a count of 0: no message that way) */
int FixCFDGrid::exchange_cb(void *user, int axis, int dir, const double *send, int nsend, double *recv, int nrecv) {
  Reduce *r = (Reduce *)user;
  const double t0 = MPI_Wtime();
  const int to = nsend > 0 ? r->neigh[axis][dir > 0 ? 1 : 0] : MPI_PROC_NULL;
  const int from = nrecv > 0 ? r->neigh[axis][dir > 0 ? 0 : 1] : MPI_PROC_NULL;
  const int tag = 7400 + 2 * axis + (dir > 0);
  const int rc = MPI_Sendrecv(send, nsend, MPI_DOUBLE, to, tag, recv, nrecv, MPI_DOUBLE, from, tag, *r->world,
                              MPI_STATUS_IGNORE);
  r->xseconds += MPI_Wtime() - t0;
  r->xcalls++;
  r->xvalues += nsend;
  return rc == MPI_SUCCESS ? 0 : 1;
}

/* This rank's block of gas cells: those whose centres lie in its subdomain (domain->sublo/subhi; the first and
 * last rank along an axis take the cells beyond the box too). "" or what is wrong (collective check that the
 * blocks tile the grid: a regular processor grid). */
std::string FixCFDGrid::subdomain() {
  if (domain->triclinic) return "a triclinic box on many ranks is not supported (the gas grid is decomposed along "
                                "the orthogonal processor grid)";
  if (sphdem_compat::comm_tiled(comm))
    return "comm_style tiled (or balance rcb) is not supported: the gas grid is decomposed along a regular "
           "processor grid (comm_style brick, processors)";
  for (int d = 0; d < 3; d++) {
    const double h = (prm_.boxhi[d] - prm_.boxlo[d]) / prm_.nc[d];
    auto cell_at = [&](double x) {
      double c = std::ceil((x - prm_.boxlo[d]) / h - 0.5);
      return (int)std::max(0.0, std::min((double)prm_.nc[d], c));
    };
    slo_[d] = comm->myloc[d] == 0 ? 0 : cell_at(domain->sublo[d]);
    shi_[d] = comm->myloc[d] == comm->procgrid[d] - 1 ? prm_.nc[d] : cell_at(domain->subhi[d]);
    red_.neigh[d][0] = comm->procneigh[d][0];
    red_.neigh[d][1] = comm->procneigh[d][1];
  }
  double mine = (double)std::max(0, shi_[0] - slo_[0]) * std::max(0, shi_[1] - slo_[1]) * std::max(0, shi_[2] - slo_[2]);
  double all = mine;
  MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, world);
  const double want = (double)prm_.nc[0] * prm_.nc[1] * prm_.nc[2];
  if (all != want) {
    char m[256];
    snprintf(m, sizeof m, "the ranks' blocks of gas cells add up to %.0f cells, not the grid's %.0f: the engine's "
             "subdomains are not a regular processor grid (comm_style tiled, balance rcb)", all, want);
    return m;
  }
  return "";
}

/* Every non-OK core code ends the run with the core's message. */
void FixCFDGrid::check(int rc, const char *what) {
  if (rc == SPHDEM_OK) return;
  /* the core's message names the cause; the generic text of the code only when it has none (the code
   * list is shared with the SPH core, whose texts may not fit the gas) */
  const char *m = ctx_ ? sphdem_cfd_last_error(ctx_) : "";
  fail(std::string(what) + ": " + (m && *m ? m : sphdem_strerror(rc)));
}

double FixCFDGrid::parse_number(const char *kw, const char *s, const char *usage) {
  return sphdem_args::number([this](const std::string &m) { fail(m); }, kw, s, usage);
}

/* ---- arguments --------------------------------------------------------------------------------- */

void FixCFDGrid::parse_args(int narg, char **arg) {
  sphdem_cfd_params_default(&prm_);
  prm_.gravity[0] = 0.0;
  prm_.gravity[1] = 0.0;
  prm_.gravity[2] = -9.81;
  for (int s = 0; s < 6; s++) {
    prm_.bc[s] = SPHDEM_CFD_NOSLIP;
    prm_.inlet_u[s] = 0.0;
  }
  prm_.npatch = 0;
  if (domain->triclinic) fail("triclinic boxes are not supported");
  if (domain->dimension != 3)
    fail("the gas grid is 3D: fix cfd/grid needs a 3D run (dimension 3; this run has dimension " +
         std::to_string(domain->dimension) + ")");
  bool have_grid = false, have_rho = false, have_mu = false;
  std::vector<std::string> seen; /* keywords given so far (bc per side, patch may repeat) */

  int iarg = 3;
  auto need = [&](int n, const char *usage) {
    if (iarg + n >= narg) fail(std::string("missing value(s) for ") + arg[iarg] + " (usage: " + usage + ")");
  };
  auto bad = [this](const std::string &m) { fail(m); };
  auto integer = [&](const std::string &kw, const char *s, long nmin, const char *usage) -> long {
    long n;
    if (!sphdem_compat::to_int(s, &n) || n < nmin)
      fail(kw + " expects an integer >= " + std::to_string(nmin) + ", got '" + s + "' (usage: " + usage + ")");
    return n;
  };

  while (iarg < narg) {
    const std::string kw = arg[iarg];
    std::string key = kw;
    if (kw == "bc" && iarg + 1 < narg) key = "bc " + std::string(arg[iarg + 1]);
    const bool dup = kw != "patch" && std::find(seen.begin(), seen.end(), key) != seen.end(); /* after its values */
    seen.push_back(key);
    if (kw == "grid") {
      const char *usage = "grid NX NY NZ, integers >= 1";
      need(3, usage);
      for (int d = 0; d < 3; d++) prm_.nc[d] = (int)integer("grid", arg[iarg + 1 + d], 1, usage);
      have_grid = true;
      iarg += 4;
    } else if (kw == "box") {
      const char *usage = "box xlo xhi ylo yhi zlo zhi";
      need(6, usage);
      for (int d = 0; d < 3; d++) {
        prm_.boxlo[d] = parse_number("box", arg[iarg + 1 + 2 * d], usage);
        prm_.boxhi[d] = parse_number("box", arg[iarg + 2 + 2 * d], usage);
        if (!(prm_.boxhi[d] > prm_.boxlo[d]))
          fail(std::string("box: ") + "xyz"[d] + "hi must be > " + "xyz"[d] + "lo (usage: " + usage + ")");
      }
      have_box_ = true;
      iarg += 7;
    } else if (kw == "rho" || kw == "mu" || kw == "eps_min" || kw == "tol" || kw == "cfl") {
      const std::string usage = kw + " V";
      need(1, usage.c_str());
      const double v = parse_number(kw.c_str(), arg[iarg + 1], usage.c_str());
      if (kw == "rho") {
        if (!(v > 0)) fail("rho must be > 0 (got " + std::string(arg[iarg + 1]) + ")");
        prm_.rho_g = v;
        have_rho = true;
      } else if (kw == "mu") {
        if (!(v > 0)) fail("mu must be > 0 (got " + std::string(arg[iarg + 1]) + ")");
        prm_.mu_g = v;
        have_mu = true;
      } else if (kw == "eps_min") {
        if (!(v > 0 && v < 1)) fail("eps_min must be in (0, 1) (got " + std::string(arg[iarg + 1]) + ")");
        prm_.eps_min = v;
      } else if (kw == "tol") {
        if (!(v > 0 && v < 1)) fail("tol must be in (0, 1) (got " + std::string(arg[iarg + 1]) + ")");
        prm_.tol = v;
      } else {
        if (!(v > 0)) fail("cfl must be > 0 (got " + std::string(arg[iarg + 1]) + ")");
        prm_.cfl_max = v;
      }
      iarg += 2;
    } else if (kw == "gravity" || kw == "init_u") {
      const std::string usage = kw == "gravity" ? "gravity gx gy gz" : "init_u ux uy uz";
      need(3, usage.c_str());
      double *dst = kw == "gravity" ? prm_.gravity : init_u_;
      for (int d = 0; d < 3; d++) dst[d] = parse_number(kw.c_str(), arg[iarg + 1 + d], usage.c_str());
      if (kw == "init_u") have_init_u_ = true;
      iarg += 4;
    } else if (kw == "bc") {
      if (iarg + 1 >= narg) fail(std::string("bc SIDE must be ") + SIDES + " (usage: bc SIDE TYPE [U])");
      const int s = side_index(arg[iarg + 1]);
      if (s < 0) fail(std::string("bc SIDE must be ") + SIDES + " (got '" + arg[iarg + 1] + "')");
      if (iarg + 2 >= narg) fail(std::string("bc ") + SIDE_NAME[s] + ": TYPE must be " + BCS);
      const std::string type = arg[iarg + 2];
      inlet_var_[s].clear();
      prm_.inlet_u[s] = 0.0;
      if (type == "noslip") prm_.bc[s] = SPHDEM_CFD_NOSLIP;
      else if (type == "slip") prm_.bc[s] = SPHDEM_CFD_SLIP;
      else if (type == "outlet") prm_.bc[s] = SPHDEM_CFD_OUTLET;
      else if (type == "inlet") {
        prm_.bc[s] = SPHDEM_CFD_INLET;
        if (iarg + 3 >= narg)
          fail(std::string("bc ") + SIDE_NAME[s] + " inlet needs the superficial velocity U (a number or v_name)");
        const std::string u = arg[iarg + 3];
        if (u.compare(0, 2, "v_") == 0 && u.size() > 2) {
          inlet_var_[s] = u.substr(2);
        } else {
          double v;
          if (!sphdem_compat::to_double(u.c_str(), &v))
            fail(std::string("bc ") + SIDE_NAME[s] + " inlet U expects a number or v_name (an equal-style " +
                 "variable), got '" + u + "'");
          prm_.inlet_u[s] = v;
        }
        iarg += 1;
      } else {
        fail(std::string("bc ") + SIDE_NAME[s] + ": TYPE must be " + BCS + " (got '" + type + "')");
      }
      iarg += 3;
    } else if (kw == "patch") {
      const char *usage = "patch SIDE A0 A1 B0 B1 U (a rectangle on an inlet side, the other two axes in x,y,z order)";
      need(6, usage);
      const int s = side_index(arg[iarg + 1]);
      if (s < 0) fail(std::string("patch SIDE must be ") + SIDES + " (got '" + arg[iarg + 1] + "')");
      if (prm_.npatch >= SPHDEM_CFD_MAX_PATCH)
        fail("at most " + std::to_string(SPHDEM_CFD_MAX_PATCH) + " patch keywords are allowed");
      sphdem_cfd_patch &pt = prm_.patch[prm_.npatch++];
      pt.side = s;
      pt.lo[0] = parse_number("patch", arg[iarg + 2], usage);
      pt.hi[0] = parse_number("patch", arg[iarg + 3], usage);
      pt.lo[1] = parse_number("patch", arg[iarg + 4], usage);
      pt.hi[1] = parse_number("patch", arg[iarg + 5], usage);
      pt.u = parse_number("patch", arg[iarg + 6], usage);
      if (!(pt.hi[0] > pt.lo[0] && pt.hi[1] > pt.lo[1]))
        fail(std::string("patch: need A1 > A0 and B1 > B0 (usage: ") + usage + ")");
      iarg += 7;
    } else if (kw == "every" || kw == "maxiter") {
      const std::string usage = kw + " N";
      need(1, usage.c_str());
      const long n = integer(kw, arg[iarg + 1], 1, usage.c_str());
      if (kw == "every") every_ = n;
      else prm_.maxiter = (int)n;
      iarg += 2;
    } else if (kw == "drag") {
      prm_.drag = sphdem_args::choice(bad, kw, iarg, narg, arg,
                                      {{"gidaspow", SPHDEM_CFD_DRAG_GIDASPOW}, {"wenyu", SPHDEM_CFD_DRAG_WENYU},
                                       {"none", SPHDEM_CFD_DRAG_NONE}}, DRAGS);
      iarg += 2;
    } else if (kw == "voidage") {
      prm_.voidage = sphdem_args::choice(bad, kw, iarg, narg, arg,
                                         {{"centroid", SPHDEM_CFD_VOID_CENTROID}, {"smooth", SPHDEM_CFD_VOID_SMOOTH}},
                                         "centroid or smooth");
      iarg += 2;
    } else if (kw == "solver") {
      prm_.solver = sphdem_args::choice(bad, kw, iarg, narg, arg,
                                        {{"mg", SPHDEM_CFD_SOLVER_MG}, {"line", SPHDEM_CFD_SOLVER_LINE}}, "mg or line");
      iarg += 2;
    } else if (kw == "ddt_eps" || kw == "pressure_force") {
      (kw == "ddt_eps" ? prm_.ddt_eps : prm_.pressure_force) = sphdem_args::yes_no(bad, kw, iarg, narg, arg);
      iarg += 2;
    } else if (kw == "device") {
      device_ = (sphdem_device)sphdem_args::choice(
          bad, kw, iarg, narg, arg,
          {{"auto", SPHDEM_DEVICE_AUTO}, {"gpu", SPHDEM_DEVICE_GPU}, {"cpu", SPHDEM_DEVICE_CPU}}, "auto, gpu or cpu");
      iarg += 2;
    } else if (kw == "vtk") {
      const char *usage = "vtk N PREFIX (a file PREFIX_<step>.vti every N gas steps, PREFIX.pvd)";
      need(2, usage);
      vtk_every_ = integer("vtk", arg[iarg + 1], 1, usage);
      vtk_prefix_ = arg[iarg + 2];
      iarg += 3;
    } else {
      fail("unknown keyword '" + kw + "'; keywords are " + KEYWORDS);
    }
    if (dup)
      fail("keyword " + key + " is given twice (give each keyword once" +
           std::string(kw == "bc" ? ", each side once)" : ")"));
  }

  if (!have_grid || !have_rho || !have_mu) {
    std::string missing;
    if (!have_grid) missing += " grid";
    if (!have_rho) missing += " rho";
    if (!have_mu) missing += " mu";
    fail("missing required keyword(s):" + missing + " (syntax: " + SYNTAX + ")");
  }
  bool outlet = false;
  for (int s = 0; s < 6; s++) outlet = outlet || prm_.bc[s] == SPHDEM_CFD_OUTLET;
  if (!outlet)
    fail("no side is an outlet: give at least one 'bc SIDE outlet' (SIDE: " + std::string(SIDES) +
         "); the gas leaves the box there at p = 0, the other sides default to noslip walls");
  for (int k = 0; k < prm_.npatch; k++)
    if (prm_.bc[prm_.patch[k].side] != SPHDEM_CFD_INLET)
      fail(std::string("patch on side ") + SIDE_NAME[prm_.patch[k].side] + " needs 'bc " +
           SIDE_NAME[prm_.patch[k].side] + " inlet U' (a patch is a spout on an inlet side)");
  if (!have_box_)
    for (int d = 0; d < 3; d++) {
      prm_.boxlo[d] = domain->boxlo[d];
      prm_.boxhi[d] = domain->boxhi[d];
    }
  /* grains move in the simulation box: a gas box reaching outside it (along an axis that is not shrink-wrapped)
   * has gas cells no grain can reach and walls where there are none */
  for (int d = 0; d < 3 && have_box_; d++) {
    if (domain->boundary[d][0] >= 2 || domain->boundary[d][1] >= 2) continue; /* shrink-wrapped */
    const double tol = 1e-9 * (domain->boxhi[d] - domain->boxlo[d]);
    if (prm_.boxlo[d] < domain->boxlo[d] - tol || prm_.boxhi[d] > domain->boxhi[d] + tol) {
      char m[384];
      snprintf(m, sizeof m, "box: the gas box %g %g along %c reaches outside the simulation box %g %g; the gas box "
               "must lie inside it", prm_.boxlo[d], prm_.boxhi[d], "xyz"[d], domain->boxlo[d], domain->boxhi[d]);
      fail(m);
    }
  }
  char msg[512] = "";
  if (sphdem_cfd_params_check(&prm_, msg, sizeof msg) != SPHDEM_OK) fail(msg);
}

/* ---- run set-up ---------------------------------------------------------------------------------- */

void FixCFDGrid::init() {
  /* a bad per-atom restart record is seen by the rank that holds the atom: every rank stops with it */
  const std::string bad_record = sphdem_mpi::first_failure(world, !restart_error_.empty(), restart_error_);
  if (!bad_record.empty()) fail(bad_record);
  /* the gas has walls, inlets and outlets on all six sides, no periodic boundary */
  for (int d = 0; d < 3; d++)
    if (domain->periodicity[d])
      fail(std::string("the simulation box is periodic along ") + "xyz"[d] + " but the gas grid is not (its sides " +
           SIDE_NAME[2 * d] + " and " + SIDE_NAME[2 * d + 1] + " are " + BC_NAME[prm_.bc[2 * d]] + " and " +
           BC_NAME[prm_.bc[2 * d + 1]] + "): grains crossing it would leave the gas; use boundary f along " +
           "xyz"[d]);
  /* two gas fixes on the same grains add the gas force twice */
  for (int k = 0; k < modify->nfix; k++) {
    Fix *f = modify->fix[k];
    if (f == this || std::strcmp(f->style, "cfd/grid") != 0) continue;
    int hit = 0, any = 0;
    for (int i = 0; i < atom->nlocal; i++)
      if ((atom->mask[i] & groupbit) && (atom->mask[i] & f->groupbit)) hit = 1;
    MPI_Allreduce(&hit, &any, 1, MPI_INT, MPI_MAX, world);
    if (any)
      fail(std::string("fix ") + f->id + " (style cfd/grid) acts on the same grains as fix " + id + " (groups " +
           group->names[f->igroup] + " and " + group->names[igroup] + "): the gas force would be added twice; one "
           "gas fix per grain");
  }
  if (!atom->radius_flag) fail("the atom style must define a per-atom radius (atom_style sphere or granular)");
  if (update->dt <= 0) fail("the timestep must be > 0");
  for (int s = 0; s < 6; s++) {
    inlet_ivar_[s] = -1;
    if (inlet_var_[s].empty()) continue;
    std::string name = inlet_var_[s];
    const int iv = input->variable->find(&name[0]);
    const std::string what = std::string("bc ") + SIDE_NAME[s] + " inlet v_" + inlet_var_[s];
    if (iv < 0) fail(what + ": variable " + inlet_var_[s] + " does not exist");
    if (!input->variable->equalstyle(iv)) fail(what + ": variable " + inlet_var_[s] + " is not equal-style");
    inlet_ivar_[s] = iv;
  }
  if (group->count(igroup) == 0) {
    if (comm->me == 0)
      sphdem_compat::warning(error, FLERR, std::string("Fix cfd/grid: the grain group ") + group->names[igroup] +
                                               " has no atoms: the gas flows alone until grains are inserted");
    return;
  }
  /* the drag is explicit and held over a gas step: the Stokes relaxation time rho_p d^2 / (18 mu) of a grain must
   * exceed half the gas step (the dense-bed laws are stiffer still); a gas denser than 1000 grain densities is not
   * a gas-solid bed (its drag overflows the grain velocities) */
  if (prm_.drag != SPHDEM_CFD_DRAG_NONE && atom->rmass) {
    const double pi = 3.14159265358979323846, dtg = (double)every_ * update->dt;
    double tmin = INFINITY, rhomax = 0.0;
    for (int i = 0; i < atom->nlocal; i++) {
      if (!(atom->mask[i] & groupbit) || !(atom->radius[i] > 0)) continue;
      const double r = atom->radius[i];
      const double rhop = atom->rmass[i] / (4.0 / 3.0 * pi * r * r * r);
      tmin = std::min(tmin, sphdem_stokes_time(rhop, 2.0 * r, prm_.mu_g));
      rhomax = std::max(rhomax, rhop);
    }
    sphdem_mpi::min(world, &tmin, 1); /* over every rank's grains: every rank takes the same decision */
    sphdem_mpi::max(world, &rhomax, 1);
    char m[512];
    if (rhomax > 0 && prm_.rho_g > 1000.0 * rhomax) {
      snprintf(m, sizeof m, "rho %g: the gas density is over 1000 times the grain density (largest %g); rho is the "
               "gas density", prm_.rho_g, rhomax);
      fail(m);
    }
    if (tmin < 0.5 * dtg) {
      snprintf(m, sizeof m, "mu %g: the Stokes relaxation time rho_p d^2 / (18 mu) of the grains is %g s, below half "
               "the gas step %g s: the explicit drag is unstable. Lower mu, the timestep or every", prm_.mu_g, tmin, dtg);
      fail(m);
    }
  }
}

/* Inlet velocities given as v_name: evaluated before each gas step; the core's parameters are updated
 * when a value changed (or always with force, before the context exists). */
void FixCFDGrid::update_inlets(bool force) {
  bool changed = false;
  bool any = false;
  for (int s = 0; s < 6; s++) {
    if (inlet_ivar_[s] < 0) continue;
    if (!any) modify->clearstep_compute();
    any = true;
    const double u = input->variable->compute_equal(inlet_ivar_[s]);
    if (!std::isfinite(u))
      fail(std::string("bc ") + SIDE_NAME[s] + " inlet v_" + inlet_var_[s] + " evaluated to a non-finite value");
    if (u != prm_.inlet_u[s]) changed = true;
    prm_.inlet_u[s] = u;
  }
  if (any) modify->addstep_compute(update->ntimestep + every_);
  if (ctx_ && (changed || force)) check(sphdem_cfd_set_params(ctx_, &prm_), "set_params");
}

void FixCFDGrid::setup(int) {
  if (!ctx_) {
    update_inlets(false);
    char msg[512] = "";
    if (sphdem_cfd_params_check(&prm_, msg, sizeof msg) != SPHDEM_OK) fail(msg);
    /* each rank holds its block of the grid (set_subdomain below); a device or memory failure may be
     * one rank's alone: every rank stops with the first such message */
    if (comm->nprocs > 1 && device_ != SPHDEM_DEVICE_CPU) { /* one GPU per rank on its node, shared when fewer */
      const std::string map = sphdem_mpi::select_gpus(world);
      if (comm->me == 0 && !map.empty()) sphdem_compat::logmesg(lmp, "Fix cfd/grid: GPUs: " + map + "\n");
    }
    int rc = sphdem_cfd_create(&ctx_, &prm_, device_, msg, sizeof msg);
    if (rc != SPHDEM_OK) ctx_ = nullptr;
    std::string why = rc == SPHDEM_OK ? std::string()
                      : *msg          ? std::string(msg)
                                      : std::string("cannot create the gas grid: ") + sphdem_strerror(rc);
    if (rc == SPHDEM_OK && comm->nprocs > 1) {
      sphdem_comm c = sphdem_mpi::comm(&world);
      c.user = &red_;
      c.allreduce = reduce_cb;
      c.exchange = exchange_cb;
      rc = sphdem_cfd_set_comm(ctx_, &c);
      if (rc != SPHDEM_OK) why = std::string("set_comm: ") + sphdem_cfd_last_error(ctx_);
    }
    if (comm->nprocs > 1) { /* the grid decomposed along the engine's subdomains */
      why = sphdem_mpi::first_failure(world, rc != SPHDEM_OK, why);
      if (!why.empty()) fail(why);
      why = subdomain();
      if (why.empty()) {
        rc = sphdem_cfd_set_subdomain(ctx_, slo_, shi_);
        if (rc != SPHDEM_OK) {
          char pg[96];
          snprintf(pg, sizeof pg, "processors grid %d x %d x %d (this rank at %d %d %d): ", comm->procgrid[0],
                   comm->procgrid[1], comm->procgrid[2], comm->myloc[0], comm->myloc[1], comm->myloc[2]);
          why = pg + std::string(sphdem_cfd_last_error(ctx_));
        }
      } else {
        rc = SPHDEM_ERR_ARG;
      }
    }
    why = sphdem_mpi::first_failure(world, rc != SPHDEM_OK, why);
    if (!why.empty()) fail(why);
    if (have_pending_) { /* a restart file: its gas state wins over init_u */
      const int64_t ns = sphdem_cfd_state_size(ctx_);
      if (ns != (int64_t)pending_state_.size())
        fail("the gas state in the restart file has " + std::to_string(pending_state_.size()) +
             " values, this grid needs " + std::to_string(ns) + " (re-issue the fix with the grid, box and bc "
             "of the run that wrote it)");
      check(sphdem_cfd_set_state(ctx_, pending_state_.data()), "set_state");
      pending_state_.clear();
      have_pending_ = false;
    } else if (have_init_u_) {
      check(sphdem_cfd_set_velocity(ctx_, init_u_), "set_velocity");
    }
  } else {
    update_inlets(true); /* a later run: timestep or variables may have changed */
  }
  if (!keep_stats_ && sphdem_cfd_stats_get(ctx_, &stats_) != SPHDEM_OK) std::memset(&stats_, 0, sizeof stats_);
  keep_stats_ = false;
  sphdem_cfd_timers_reset(ctx_);
  host_time_ = 0.0;
  red_.seconds = 0.0;
  red_.calls = 0;
  red_.values = 0;
  red_.xseconds = 0.0;
  red_.xcalls = 0;
  red_.xvalues = 0;
  ngas_run_ = 0;

  /* the held forces (an earlier run or a restart file) act from the first step on */
  const int *mask = atom->mask;
  double **f = atom->f;
  double rmax = 0.0;
  for (int i = 0; i < nloop(); i++) {
    if (!(mask[i] & groupbit)) continue;
    for (int d = 0; d < 3; d++) f[i][d] += fa_[i][C_FDRAG + d] + fa_[i][C_FPG + d];
    rmax = std::max(rmax, atom->radius[i]);
  }
  sphdem_mpi::max(world, &rmax, 1);
  double lcells[2] = {(double)sphdem_cfd_local_cells(ctx_), (double)sphdem_cfd_device_bytes(ctx_)};
  if (comm->nprocs > 1) sphdem_mpi::max(world, lcells, 2);

  if (comm->me == 0 && !announced_) {
    double hc[3];
    for (int d = 0; d < 3; d++) hc[d] = (prm_.boxhi[d] - prm_.boxlo[d]) / prm_.nc[d];
    const double hmin = std::min(hc[0], std::min(hc[1], hc[2]));
    char dia[128] = "no grains yet";
    if (rmax > 0) snprintf(dia, sizeof dia, "%.3g grain diameters (largest d %g)", hmin / (2 * rmax), 2 * rmax);
    char line[1024];
    snprintf(line, sizeof line,
             "Fix cfd/grid: %s backend; grid %d x %d x %d cells of %g x %g x %g (smallest = %s); gas step %g "
             "(every %ld x timestep); drag %s; pressure solver %s; bc %s %s %s %s %s %s; %.0f device bytes\n",
             sphdem_cfd_backend(ctx_) == SPHDEM_DEVICE_GPU ? "GPU" : "CPU", prm_.nc[0], prm_.nc[1], prm_.nc[2],
             hc[0], hc[1], hc[2], dia, every_ * update->dt, every_, DRAG_NAME[prm_.drag],
             prm_.solver == SPHDEM_CFD_SOLVER_LINE ? "line" : "mg", BC_NAME[prm_.bc[0]],
             BC_NAME[prm_.bc[1]], BC_NAME[prm_.bc[2]], BC_NAME[prm_.bc[3]], BC_NAME[prm_.bc[4]],
             BC_NAME[prm_.bc[5]], (double)sphdem_cfd_device_bytes(ctx_));
    sphdem_compat::logmesg(lmp, line);
    if (comm->nprocs > 1) {
      snprintf(line, sizeof line,
               "Fix cfd/grid: grid decomposed over the %d x %d x %d processor grid: the largest rank stores %.0f of "
               "the %.0f cells (its block and a 2-cell halo), %.0f device bytes\n",
               comm->procgrid[0], comm->procgrid[1], comm->procgrid[2], lcells[0],
               (double)prm_.nc[0] * prm_.nc[1] * prm_.nc[2], lcells[1]);
      sphdem_compat::logmesg(lmp, line);
    }
    announced_ = true;
  }
}

int FixCFDGrid::nloop() const { return sphdem_grains::nloop(atom, igroup); }

/* ---- the gas step ---------------------------------------------------------------------------------- */

void FixCFDGrid::gas_step() {
  const double t0 = wall_seconds();
  update_inlets(false);
  const size_t n = sphdem_grains::gather(atom, groupbit, nloop(), gidx_, gx_, gv_, grad_, nullptr);
  gfd_.resize(3 * n);
  gfp_.resize(3 * n);
  const double t1 = wall_seconds();
  const double dt_gas = (double)every_ * update->dt;
  std::string gerr;
  const auto gv = grains_.hand_group(lmp, sphdem_cfd_backend(ctx_), groupbit, nloop(), gidx_, n, gx_, gv_, grad_,
                                     nullptr, gerr);
  if (!gv.g) sphdem_compat::error_all(error, FLERR, "Fix cfd/grid: grain store: " + gerr);
  const int rc = sphdem_cfd_step_store(ctx_, dt_gas, gv.g, gv.n, gv.idx, gfd_.data(), gfp_.data());
  /* the core agrees on failures of its deposit stages itself; the same stop on every rank for any other */
  std::string why;
  if (rc != SPHDEM_OK) {
    char where[128];
    snprintf(where, sizeof where, "gas step at timestep " BIGINT_FORMAT " (gas dt %g): ", update->ntimestep, dt_gas);
    const char *m = sphdem_cfd_last_error(ctx_);
    why = std::string(where) + (m && *m ? m : sphdem_strerror(rc));
  }
  if (comm->nprocs > 1) why = sphdem_mpi::first_failure(world, rc != SPHDEM_OK, why);
  if (!why.empty()) fail(why);
  const double t2 = wall_seconds();
  for (size_t k = 0; k < n; k++) {
    double *row = fa_[gidx_[k]];
    for (int d = 0; d < 3; d++) {
      row[C_FDRAG + d] = gfd_[3 * k + d];
      row[C_FPG + d] = gfp_[3 * k + d];
    }
  }
  check(sphdem_cfd_stats_get(ctx_, &stats_), "stats_get");
  ngas_steps_++;
  ngas_run_++;
  if (vtk_every_ > 0 && ngas_steps_ % vtk_every_ == 0) write_vtk();
  host_time_ += (t1 - t0) + (wall_seconds() - t2);
}

/* ---- every engine step: add the held forces ------------------------------------------------------- */

void FixCFDGrid::post_force(int) {
  if (update->ntimestep % every_ == 0) gas_step();
  const int *mask = atom->mask;
  double **f = atom->f;
  for (int i = 0; i < nloop(); i++) {
    if (!(mask[i] & groupbit)) continue;
    for (int d = 0; d < 3; d++) f[i][d] += fa_[i][C_FDRAG + d] + fa_[i][C_FPG + d];
  }
}

void FixCFDGrid::post_run() {
  advance_clock(); /* before a timestep command of the next run changes dt */
  print_timers();
}

/* simulation time: the engines' update->atime is not kept in restart files, this clock is */
void FixCFDGrid::advance_clock() {
  time_ += (double)(update->ntimestep - clock_step_) * update->dt;
  clock_step_ = update->ntimestep;
}

/* One line: the core's time per phase of this run and the fix's own share (gather, scatter, VTK). */
void FixCFDGrid::print_timers() {
  if (!ctx_ || comm->me != 0) return;
  double t[SPHDEM_CFD_NTIMERS];
  sphdem_cfd_timers(ctx_, t);
  double total = host_time_;
  for (int k = 0; k < SPHDEM_CFD_NTIMERS; k++) total += t[k];
  std::string line = "Fix cfd/grid: gas time " + std::to_string(stats_.nsteps) + " gas steps so far;";
  char buf[128];
  for (int k = 0; k < SPHDEM_CFD_NTIMERS; k++) {
    snprintf(buf, sizeof buf, " %s %.4g s (%.1f%%)%s", TIMER_NAME[k], t[k], total > 0 ? 100 * t[k] / total : 0.0,
             k + 1 < SPHDEM_CFD_NTIMERS ? "," : "");
    line += buf;
  }
  snprintf(buf, sizeof buf, "; fix host side %.4g s (%.1f%%); total %.4g s this run", host_time_,
           total > 0 ? 100 * host_time_ / total : 0.0, total);
  line += buf;
  if (comm->nprocs > 1) {
    snprintf(buf, sizeof buf, "; sums over %d ranks (rank 0) %.4g s in %ld reductions of %.4g MB", comm->nprocs,
             red_.seconds, red_.calls, 8e-6 * (double)red_.values);
    line += buf;
    snprintf(buf, sizeof buf, "; halo exchange (rank 0) %.4g s in %ld messages, %.4g MB sent (%.4g kB per gas step)",
             red_.xseconds, red_.xcalls, 8e-6 * (double)red_.xvalues,
             ngas_run_ > 0 ? 8e-3 * (double)red_.xvalues / (double)ngas_run_ : 0.0);
    line += buf;
  }
  line += "\n";
  sphdem_compat::logmesg(lmp, line);
}

/* ---- VTK output ------------------------------------------------------------------------------------- */

/* PREFIX_<step>.vti (VTK XML ImageData, ASCII cell data) and PREFIX.pvd listing every file with its time.
 * An existing PREFIX.pvd (a run continued from a restart file) keeps its entries of earlier times. */
void FixCFDGrid::write_vtk() {
  advance_clock();
  const int nx = prm_.nc[0], ny = prm_.nc[1], nz = prm_.nc[2];
  const size_t nc = (size_t)nx * ny * nz;
  /* the whole grid gathered from the ranks' blocks (collective), written by rank 0 */
  std::vector<double> eps(nc), p(nc), u(3 * nc);
  const int frc = sphdem_cfd_get_fields(ctx_, eps.data(), p.data(), u.data());
  if (comm->nprocs > 1) {
    const std::string why =
        sphdem_mpi::first_failure(world, frc != SPHDEM_OK, std::string("get_fields: ") + sphdem_cfd_last_error(ctx_));
    if (!why.empty()) fail(why);
  } else if (frc != SPHDEM_OK) {
    fail_one(std::string("get_fields: ") + sphdem_cfd_last_error(ctx_));
  }
  if (comm->me != 0) return;
  const double time = time_;

  const std::string file = vtk_prefix_ + "_" + std::to_string((long long)update->ntimestep) + ".vti";
  FILE *fp = fopen(file.c_str(), "w");
  if (!fp) fail_one("vtk: cannot open " + file + " for writing");
  double h[3];
  for (int d = 0; d < 3; d++) h[d] = (prm_.boxhi[d] - prm_.boxlo[d]) / prm_.nc[d];
  fprintf(fp, "<?xml version=\"1.0\"?>\n");
  fprintf(fp, "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
  fprintf(fp, "  <ImageData WholeExtent=\"0 %d 0 %d 0 %d\" Origin=\"%.17g %.17g %.17g\" Spacing=\"%.17g %.17g %.17g\">\n",
          nx, ny, nz, prm_.boxlo[0], prm_.boxlo[1], prm_.boxlo[2], h[0], h[1], h[2]);
  fprintf(fp, "    <FieldData>\n");
  fprintf(fp, "      <DataArray type=\"Float64\" Name=\"TIME\" NumberOfTuples=\"1\" format=\"ascii\">%.17g</DataArray>\n",
          time);
  fprintf(fp, "    </FieldData>\n");
  fprintf(fp, "    <Piece Extent=\"0 %d 0 %d 0 %d\">\n", nx, ny, nz);
  fprintf(fp, "      <CellData Scalars=\"voidage\" Vectors=\"velocity\">\n");
  auto scalars = [&](const char *name, const std::vector<double> &a, int ncomp) {
    fprintf(fp, "        <DataArray type=\"Float64\" Name=\"%s\" NumberOfComponents=\"%d\" format=\"ascii\">\n", name,
            ncomp);
    for (size_t k = 0; k < a.size(); k++) fprintf(fp, "%.10g%c", a[k], (k + 1) % (size_t)(6 * ncomp) ? ' ' : '\n');
    fprintf(fp, "\n        </DataArray>\n");
  };
  scalars("voidage", eps, 1);
  scalars("pressure", p, 1);
  scalars("velocity", u, 3);
  fprintf(fp, "      </CellData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n");
  if (fclose(fp) != 0) fail_one("vtk: error writing " + file);

  const std::string pvd = vtk_prefix_ + ".pvd";
  if (!pvd_loaded_) { /* entries of earlier times from a previous run (restart) */
    std::ifstream in(pvd);
    std::string l;
    while (std::getline(in, l)) {
      const size_t a = l.find("timestep=\""), b = l.find("file=\"");
      if (a == std::string::npos || b == std::string::npos) continue;
      const double t = std::atof(l.c_str() + a + 10);
      const size_t e = l.find('"', b + 6);
      if (e == std::string::npos) continue;
      if (t < time * (1 - 1e-12) - 1e-300) pvd_.emplace_back(t, l.substr(b + 6, e - b - 6));
    }
    pvd_loaded_ = true;
  }
  const size_t slash = file.find_last_of('/');
  pvd_.emplace_back(time, slash == std::string::npos ? file : file.substr(slash + 1));
  FILE *fq = fopen(pvd.c_str(), "w");
  if (!fq) fail_one("vtk: cannot open " + pvd + " for writing");
  fprintf(fq, "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n"
              "  <Collection>\n");
  for (const auto &e : pvd_)
    fprintf(fq, "    <DataSet timestep=\"%.17g\" group=\"\" part=\"0\" file=\"%s\"/>\n", e.first, e.second.c_str());
  fprintf(fq, "  </Collection>\n</VTKFile>\n");
  if (fclose(fq) != 0) fail_one("vtk: error writing " + pvd);
}

/* ---- output ------------------------------------------------------------------------------------------ */

double FixCFDGrid::compute_vector(int n) {
  const sphdem_cfd_stats &s = stats_;
  switch (n) {
    case 0: return s.dp;
    case 1: return (double)s.iters;
    case 2: return s.residual;
    case 3: return s.eps_min;
    case 4: return s.eps_mean;
    case 5: return s.umax;
    case 6: return s.cfl;
    case 7: return s.mass_err;
    default: break;
  }
  if (n >= 8 && n < 11) return s.f_grains[n - 8];
  if (n >= 11 && n < 14) return s.f_gas[n - 11];
  if (n >= 14 && n < 17) return s.f_bound[n - 14];
  if (n >= 17 && n < 20) return s.f_pg[n - 17];
  return 0.0;
}

double FixCFDGrid::memory_usage() {
  return (double)atom->nmax * NCOL * sizeof(double) +
         (double)(gx_.capacity() + gv_.capacity() + grad_.capacity() + gfd_.capacity() + gfp_.capacity() +
                  pending_state_.capacity()) *
             sizeof(double) +
         (double)gidx_.capacity() * sizeof(int);
}

/* global restart state: tag, gas steps, state size, time, its step, the gas state (face velocities,
 * pressure, voidage), the statistics of the last gas step */
void FixCFDGrid::write_restart(FILE *fp) {
  enum { NHEAD = 5 };
  advance_clock();
  std::vector<double> list(NHEAD);
  if (ctx_) {
    const int64_t ns = sphdem_cfd_state_size(ctx_);
    if (ns < 0) check((int)-ns, "state_size");
    list.resize(NHEAD + (size_t)ns);
    if (ns > 0) check(sphdem_cfd_get_state(ctx_, list.data() + NHEAD), "get_state");
  } else if (have_pending_) { /* read from a restart file, no run since */
    list.insert(list.end(), pending_state_.begin(), pending_state_.end());
  }
  list[0] = RESTART_TAG;
  list[1] = (double)ngas_steps_;
  list[2] = (double)(list.size() - NHEAD);
  list[3] = time_;
  list[4] = (double)clock_step_;
  /* the statistics of the last gas step, so the global vector goes on unchanged after a restart */
  std::vector<double> st(NSTATS, 0.0);
  std::memcpy(st.data(), &stats_, sizeof stats_);
  list.insert(list.end(), st.begin(), st.end());
  if (comm->me == 0) {
    int size = (int)(list.size() * sizeof(double));
    fwrite(&size, sizeof(int), 1, fp);
    fwrite(list.data(), sizeof(double), list.size(), fp);
  }
}

void FixCFDGrid::restart(char *buf) {
  double head[5];
  std::memcpy(head, buf, sizeof head);
  if (head[0] != RESTART_TAG) fail("the restart data of this fix are not from fix cfd/grid of this version");
  /* the state size of this grid: the face velocities, then pressure and voidage per cell */
  const double nx = prm_.nc[0], ny = prm_.nc[1], nz = prm_.nc[2];
  const double want = (nx + 1) * ny * nz + nx * (ny + 1) * nz + nx * ny * (nz + 1) + 2 * nx * ny * nz;
  if (head[2] != want) {
    char m[384];
    snprintf(m, sizeof m, "the gas state in the restart file has %.17g values, this grid needs %.0f (re-issue the "
             "fix with the grid of the run that wrote it; or the restart file is corrupted)", head[2], want);
    fail(m);
  }
  ngas_steps_ = (int64_t)head[1];
  const size_t ns = (size_t)head[2];
  time_ = head[3];
  clock_step_ = (int64_t)head[4];
  pending_state_.resize(ns);
  if (ns) std::memcpy(pending_state_.data(), buf + sizeof head, ns * sizeof(double));
  have_pending_ = ns > 0;
  std::memcpy(&stats_, buf + sizeof head + ns * sizeof(double), sizeof stats_);
  keep_stats_ = true;
  if (ctx_) { /* not reached in practice: restart data arrive when the fix is created */
    check(sphdem_cfd_set_state(ctx_, pending_state_.data()), "set_state");
    have_pending_ = false;
  }
}

