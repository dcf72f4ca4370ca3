/* fix_sph_fluid.cpp - fix sph/fluid: parses keywords into sphdem_params, keeps the fluid atoms on the
 * device between steps (DESIGN.md §3), downloads them only when the engine reads them. No physics here. */
#include "fix_sph_fluid.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "group.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "output.h"
#include "sphdem_args.h"
#include "sphdem_compat.h"
#include "sphdem_mpi.h"
#include "sphdem_peratom.h"
#include "update.h"

using namespace LAMMPS_NS;
using namespace FixConst;

namespace {
const char *const SYNTAX =
    "fix ID group sph/fluid rho0 V h V c0 V [dx V] [gamma V] [gravity gx gy gz] "
    "[visc none|morris MU|artificial ALPHA] [tensile EPS [N]] [xsph EPS] [delta D [hydrostatic|plain]] "
    "[repulsion D [R0]] "
    "[wall GROUP-ID] [wall_clamp yes|no] [isolated KSUM] [skin V] [cfl V] [rho_err_max V] [device auto|cpu|gpu] "
    "[sync N] [check N] "
    "[hydrostatic ZSURF|auto] [every N] [phase TYPE RHO0 newtonian MU|hb TAU_Y K N GDOT_CUT [c0 C] ...] [eos tait|linear] "
    "[p0 P0] [diffusion none|molteni|renorm [DELTA]] [shifting yes|no] [les CS] [integrator verlet|rk4] [precision double|mixed|single] "
    "[ghost mirror XLO XHI YLO YHI [ZLO ZHI]] [failure_dump yes|no|FILE]";
const char *const KEYWORDS =
    "rho0, h, c0, dx, gamma, gravity, visc, tensile, xsph, delta, repulsion, wall, wall_clamp, isolated, skin, cfl, "
    "rho_err_max, device, sync, check, hydrostatic, every, phase, eos, p0, diffusion, shifting, les, integrator, precision, ghost, "
    "failure_dump";

/* x rounded down to 3 significant digits: a suggested time step that is below x as printed */
double round_down3(double x) {
  if (!(x > 0) || !std::isfinite(x)) return x;
  const double scale = std::pow(10.0, std::floor(std::log10(x)) - 2.0);
  double r = std::floor(x / scale) * scale;
  while (r > x) r -= scale;
  return r;
}

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

/* ---------------------------------------------------------------------------------------------- */

FixSPHFluid::FixSPHFluid(LAMMPS *lmp, int narg, char **arg)
    : Fix(lmp, narg, arg), device_(SPHDEM_DEVICE_AUTO), ctx_(nullptr), wall_igroup_(-1),
      wall_groupbit_(0), sync_every_(0), check_every_(10), hydrostatic_(false), mass_scaled_(false), zsurf_(0.0),
      walls_move_(false), host_current_(true), mapping_dirty_(true), announced_(false), every_(1), rk4_(false), ghost_(false),
      last_fluid_step_(0), fluid_step_(false), dt_fluid_(0.0), nfluid_steps_(0), coupler_(nullptr),
      couple_on_(false), sa_(nullptr), nmax_(0), stats_step_(-1), run_step0_(0), run_t0_(0.0), failure_dump_(true),
      have_dx_(false), scene_checked_(false) {
  std::memset(&stats_, 0, sizeof stats_);
  std::memset(&comm_, 0, sizeof comm_);
  comm_forward = GCOMM;
  parse_args(narg, arg);

  time_integrate = 1;
  force_reneighbor = 1;
  next_reneighbor = -1;
  sphdem_peratom::start(this, atom, NOUT, 4, false);
}

FixSPHFluid::~FixSPHFluid() {
  sphdem_peratom::stop(this, atom, memory, sa_);
  sphdem_destroy(&ctx_);
}

int FixSPHFluid::setmask() {
  return INITIAL_INTEGRATE | POST_FORCE | FINAL_INTEGRATE | END_OF_STEP | PRE_EXCHANGE | PRE_NEIGHBOR |
         POST_RUN;
}

void FixSPHFluid::fail(const std::string &msg) {
  sphdem_compat::error_all(error, FLERR, std::string("Fix sph/fluid: ") + msg);
}

/* Every non-OK core code ends the run with the core's message. */
void FixSPHFluid::check(int rc, const char *what) {
  if (rc == SPHDEM_OK) return;
  const std::string m = std::string("Fix sph/fluid: ") + what + ": " + sphdem_last_error(ctx_) + " (" +
                        sphdem_strerror(rc) + ")";
  if (multi_) sphdem_compat::error_one(error, FLERR, m); /* may fail on this rank alone: stops every rank */
  sphdem_compat::error_all(error, FLERR, m);
}

void FixSPHFluid::fail_any(bool bad, const std::string &msg) {
  if (!multi_) {
    if (bad) fail(msg);
    return;
  }
  const std::string first = sphdem_mpi::first_failure(world, bad, msg);
  if (!first.empty()) fail(first);
}

/* ---- arguments --------------------------------------------------------------------------------- */

double FixSPHFluid::parse_number(const char *kw, const char *s, const char *usage) {
  return sphdem_args::number([this](const std::string &m) { fail(m); }, kw, s, usage);
}

void FixSPHFluid::parse_args(int narg, char **arg) {
  sphdem_params_default(&prm_);
  sphdem_mp_params_default(&mp_);
  mp_.nphase = 0;
  type_phase_.assign(atom->ntypes + 1, -1);
  bool have_eos = false, mp_kw = false;
  std::string mp_kw_name;
  prm_.dim = domain->dimension;
  if (domain->triclinic) fail("triclinic boxes are not supported");
  bool have_rho0 = false, have_h = false, have_c0 = false, have_dx = false, have_skin = false;
  bool have_r0 = false;

  int iarg = 3;
  std::vector<std::string> seen; /* keywords given so far (phase may repeat) */
  /* a keyword needs n values after it */
  auto need = [&](int n, const char *usage) {
    if (iarg + n >= narg) fail(std::string("missing value(s) for ") + arg[iarg] + " (usage: " + usage + ")");
  };
  /* an optional trailing number after the required values */
  auto optional_number = [&](int pos, double *out) {
    return pos < narg && sphdem_compat::to_double(arg[pos], out);
  };
  /* KW V [OPT]: the value and an optional trailing number (then *have is set, if given) */
  auto value_and_optional = [&](const char *usage, double *v, double *opt, bool *have) {
    need(1, usage);
    *v = parse_number(arg[iarg], arg[iarg + 1], usage);
    iarg += 2;
    double o;
    if (!optional_number(iarg, &o)) return;
    *opt = o, iarg++;
    if (have) *have = true;
  };
  auto bad = [this](const std::string &m) { fail(m); };

  while (iarg < narg) {
    const std::string kw = arg[iarg];
    /* a repeated keyword is refused after its values were checked */
    const bool dup = kw != "phase" && std::find(seen.begin(), seen.end(), kw) != seen.end();
    seen.push_back(kw);
    if (kw == "hydrostatic" && iarg + 1 < narg && std::string(arg[iarg + 1]) == "auto") {
      hydrostatic_ = true, hydro_auto_ = true; /* ZSURF from the fluid atoms at the first set-up */
      iarg += 2;
    } else if (kw == "rho0" || kw == "h" || kw == "c0" || kw == "dx" || kw == "gamma" || kw == "skin" ||
        kw == "cfl" || kw == "rho_err_max" || kw == "xsph" || kw == "hydrostatic" || kw == "isolated") {
      const std::string usage = kw + (kw == "hydrostatic" ? " ZSURF|auto" : kw == "xsph" ? " EPS" : " V");
      need(1, usage.c_str());
      double v = parse_number(kw.c_str(), arg[iarg + 1], usage.c_str());
      if (kw == "rho0") prm_.rho0 = v, have_rho0 = true;
      else if (kw == "h") prm_.h = v, have_h = true;
      else if (kw == "c0") prm_.c0 = v, have_c0 = true;
      else if (kw == "dx") prm_.dx = v, have_dx = true;
      else if (kw == "gamma") prm_.gamma = v;
      else if (kw == "skin") prm_.skin = v, have_skin = true;
      else if (kw == "cfl") prm_.cfl = v;
      else if (kw == "rho_err_max") prm_.rho_err_max = v;
      else if (kw == "isolated") prm_.isolated = v;
      else if (kw == "xsph") prm_.xsph_eps = v;
      else hydrostatic_ = true, zsurf_ = v;
      iarg += 2;
    } else if (kw == "gravity") {
      const char *usage = "gravity gx gy gz";
      need(3, usage);
      for (int d = 0; d < 3; d++) prm_.gravity[d] = parse_number("gravity", arg[iarg + 1 + d], usage);
      iarg += 4;
    } else if (kw == "visc") {
      const char *usage = "visc none | morris MU | artificial ALPHA";
      if (iarg + 1 >= narg) fail("visc must be none, morris MU or artificial ALPHA");
      const std::string model = arg[iarg + 1];
      if (model == "none") {
        prm_.visc = SPHDEM_VISC_NONE;
        iarg += 2;
      } else if (model == "morris" || model == "artificial") {
        need(2, usage);
        double v = parse_number(model == "morris" ? "visc morris" : "visc artificial", arg[iarg + 2], usage);
        if (model == "morris") prm_.visc = SPHDEM_VISC_MORRIS, prm_.mu = v;
        else prm_.visc = SPHDEM_VISC_ARTIFICIAL, prm_.alpha = v;
        iarg += 3;
      } else {
        fail("visc must be none, morris MU or artificial ALPHA (got '" + model + "')");
      }
    } else if (kw == "tensile") {
      value_and_optional("tensile EPS [N]", &prm_.tensile_eps, &prm_.tensile_n, nullptr);
    } else if (kw == "delta") {
      const char *usage = "delta D [hydrostatic|plain]";
      need(1, usage);
      prm_.delta = parse_number("delta", arg[iarg + 1], usage);
      prm_.delta_hydro = 1;
      iarg += 2;
      if (iarg < narg && (std::string(arg[iarg]) == "hydrostatic" || std::string(arg[iarg]) == "plain"))
        prm_.delta_hydro = std::string(arg[iarg]) == "hydrostatic", iarg++;
    } else if (kw == "repulsion") {
      value_and_optional("repulsion D [R0]", &prm_.rep_D, &prm_.rep_r0, &have_r0);
    } else if (kw == "wall") {
      need(1, "wall GROUP-ID");
      wall_group_ = arg[iarg + 1];
      wall_igroup_ = sphdem_compat::find_group(group, arg[iarg + 1]);
      if (wall_igroup_ < 0) fail("wall group '" + wall_group_ + "' does not exist (usage: wall GROUP-ID)");
      wall_groupbit_ = group->bitmask[wall_igroup_];
      iarg += 2;
    } else if (kw == "wall_clamp") {
      prm_.wall_clamp = sphdem_args::yes_no(bad, kw, iarg, narg, arg);
      iarg += 2;
    } else if (kw == "device") {
      device_ = (sphdem_device)sphdem_args::choice(
          bad, kw, iarg, narg, arg,
          {{"auto", SPHDEM_DEVICE_AUTO}, {"cpu", SPHDEM_DEVICE_CPU}, {"gpu", SPHDEM_DEVICE_GPU}}, "auto, cpu or gpu");
      iarg += 2;
    } else if (kw == "sync" || kw == "check" || kw == "every") {
      const std::string usage = kw + " N";
      need(1, usage.c_str());
      const long nmin = kw == "every" ? 1 : 0;
      long n;
      if (!sphdem_compat::to_int(arg[iarg + 1], &n) || n < nmin)
        fail(kw + " expects an integer N >= " + std::to_string(nmin) + ", got '" + arg[iarg + 1] +
             "' (usage: " + usage + ")");
      (kw == "sync" ? sync_every_ : kw == "check" ? check_every_ : every_) = n;
      iarg += 2;
    } else if (kw == "phase") {
      parse_phase(iarg, narg, arg);
    } else if (kw == "eos") {
      if (iarg + 1 >= narg) fail("eos must be tait or linear");
      const std::string v = arg[iarg + 1];
      if (v != "tait" && v != "linear") fail("eos must be tait or linear (got '" + v + "')");
      mp_.eos = v == "tait" ? SPHDEM_EOS_TAIT : SPHDEM_EOS_LINEAR;
      have_eos = true;
      if (!mp_kw) mp_kw_name = kw;
      mp_kw = true;
      iarg += 2;
    } else if (kw == "p0" || kw == "les") {
      const std::string usage = kw + (kw == "p0" ? " P0" : " CS");
      need(1, usage.c_str());
      double v = parse_number(kw.c_str(), arg[iarg + 1], usage.c_str());
      (kw == "p0" ? mp_.p0 : mp_.cs_les) = v;
      if (!mp_kw) mp_kw_name = kw;
      mp_kw = true;
      iarg += 2;
    } else if (kw == "diffusion") {
      if (iarg + 1 >= narg) fail("diffusion must be none, molteni or renorm, then an optional DELTA");
      const std::string v = arg[iarg + 1];
      if (v == "none") mp_.diffusion = SPHDEM_DIFF_NONE;
      else if (v == "molteni") mp_.diffusion = SPHDEM_DIFF_MOLTENI;
      else if (v == "renorm") mp_.diffusion = SPHDEM_DIFF_RENORM;
      else fail("diffusion must be none, molteni or renorm (got '" + v + "')");
      iarg += 2;
      double d;
      if (optional_number(iarg, &d)) mp_.delta = d, iarg++;
      if (!mp_kw) mp_kw_name = kw;
      mp_kw = true;
    } else if (kw == "ghost") {
      const int nv = 2 * domain->dimension;
      const char *usage = domain->dimension == 2 ? "ghost mirror XLO XHI YLO YHI" : "ghost mirror XLO XHI YLO YHI ZLO ZHI";
      if (iarg + 1 >= narg || std::string(arg[iarg + 1]) != "mirror")
        fail(std::string("ghost must be followed by mirror and the fluid box (usage: ") + usage + ")");
      if (iarg + 1 + nv >= narg) fail(std::string("missing value(s) for ghost mirror (usage: ") + usage + ")");
      for (int d = 0; d < 3; d++) ghost_lo_[d] = -1e300, ghost_hi_[d] = 1e300;
      for (int d = 0; d < domain->dimension; d++) {
        ghost_lo_[d] = parse_number("ghost mirror", arg[iarg + 2 + 2 * d], usage);
        ghost_hi_[d] = parse_number("ghost mirror", arg[iarg + 3 + 2 * d], usage);
        if (!(ghost_hi_[d] > ghost_lo_[d])) fail(std::string("ghost mirror: HI must exceed LO (usage: ") + usage + ")");
      }
      ghost_ = true;
      iarg += 2 + nv;
    } else if (kw == "precision") {
      if (iarg + 1 >= narg) fail("precision must be double, mixed or single");
      const std::string v = arg[iarg + 1];
      if (v != "double" && v != "mixed" && v != "single")
        fail("precision must be double, mixed or single (got '" + v + "')");
      prm_.precision = v == "double" ? SPHDEM_PREC_DOUBLE : v == "mixed" ? SPHDEM_PREC_MIXED : SPHDEM_PREC_SINGLE;
      iarg += 2;
    } else if (kw == "integrator") {
      if (iarg + 1 >= narg) fail("integrator must be verlet or rk4");
      const std::string v = arg[iarg + 1];
      if (v != "verlet" && v != "rk4") fail("integrator must be verlet or rk4 (got '" + v + "')");
      rk4_ = v == "rk4";
      iarg += 2;
    } else if (kw == "failure_dump") {
      if (iarg + 1 >= narg) fail("failure_dump must be yes, no or a file name");
      const std::string v = arg[iarg + 1];
      if (v == "no") failure_dump_ = false;
      else if (v == "yes") failure_dump_ = true, failure_file_.clear();
      else if (v.find('.') != std::string::npos || v.find('/') != std::string::npos)
        failure_dump_ = true, failure_file_ = v;
      else
        fail("failure_dump must be yes, no or a file name (got '" + v + "'; a file name holds a '.' or a '/', "
             "e.g. failure.dump)");
      iarg += 2;
    } else if (kw == "shifting") {
      if (iarg + 1 >= narg) fail("shifting must be yes or no");
      const std::string v = arg[iarg + 1];
      if (v != "yes" && v != "no") fail("shifting must be yes or no (got '" + v + "')");
      mp_.shifting = v == "yes";
      if (!mp_kw) mp_kw_name = kw;
      mp_kw = true;
      iarg += 2;
    } else {
      fail("unknown keyword '" + kw + "'; keywords are " + KEYWORDS);
    }
    if (dup) fail("keyword " + kw + " is given twice (give each keyword once)");
  }
  if (mp_.nphase > 0) {
    mp_.enabled = 1;
    if (!have_eos) mp_.eos = SPHDEM_EOS_LINEAR; /* Shi & Huang eq 4 */
  } else {
    mp_.nphase = 1;
    if (mp_kw) { /* one fluid with the delta-plus terms: phase 0 from rho0 and visc (sphdem_mp_single_phase) */
      mp_.enabled = 1;
      mp_.single = 1;
      std::fill(type_phase_.begin(), type_phase_.end(), 0); /* every atom type is the one fluid */
      if (!have_eos) mp_.eos = SPHDEM_EOS_TAIT; /* the plain fluid's EOS */
    }
  }

  if (!have_rho0 || !have_h || !have_c0) {
    std::string missing;
    if (!have_rho0) missing += " rho0";
    if (!have_h) missing += " h";
    if (!have_c0) missing += " c0";
    fail("missing required keyword(s):" + missing + " (syntax: " + SYNTAX + ")");
  }
  have_dx_ = have_dx;
  if (!have_dx) prm_.dx = prm_.h / 1.3;
  if (!have_skin) prm_.skin = 0.3 * prm_.dx;
  if (prm_.rep_D > 0 && !have_r0) prm_.rep_r0 = prm_.dx;
  if (hydrostatic_ && prm_.gravity[0] == 0 && prm_.gravity[1] == 0 && prm_.gravity[2] == 0)
    fail(std::string("hydrostatic ") + (hydro_auto_ ? "auto" : "ZSURF") + " needs a non-zero gravity (gravity gx gy gz)");
  if (wall_igroup_ == igroup) fail("the wall group must differ from the fluid group");

  if (prm_.dim == 2 && prm_.gravity[2] != 0.0) {
    char m[256];
    snprintf(m, sizeof m, "gravity along z (gz = %g) in a 2D run (dimension 2): the fluid moves in the x-y plane; "
             "give gravity gx gy 0", prm_.gravity[2]);
    fail(m);
  }

  box_to_params();
  char msg[512];
  if (sphdem_params_check(&prm_, msg, sizeof msg) != SPHDEM_OK) fail(msg);
  /* a kernel wider than the box: the smoothing length is about 1.3 particle spacings */
  double lmax = 0.0;
  int dmax = 0;
  for (int d = 0; d < prm_.dim; d++)
    if (prm_.boxhi[d] - prm_.boxlo[d] > lmax) lmax = prm_.boxhi[d] - prm_.boxlo[d], dmax = d;
  if (2.0 * prm_.h > lmax) {
    snprintf(msg, sizeof msg, "h %g: the kernel support 2h exceeds the box (largest extent %g along %c); h is the "
             "smoothing length, about 1.3 particle spacings dx", prm_.h, lmax, "xyz"[dmax]);
    fail(msg);
  }
  if (have_dx && (prm_.h < 0.5 * prm_.dx || prm_.h > 8.0 * prm_.dx)) {
    snprintf(msg, sizeof msg, "h %g and dx %g: h/dx = %g must be in [0.5, 8] (usual: 1.2 to 2)", prm_.h, prm_.dx,
             prm_.h / prm_.dx);
    fail(msg);
  }
  if (sphdem_mp_params_check(&mp_, &prm_, msg, sizeof msg) != SPHDEM_OK) fail(msg);
}

/* phase TYPE RHO0 newtonian MU | phase TYPE RHO0 hb TAU_Y K N GDOT_CUT: fluid atoms of TYPE form the next
 * phase (Shi & Huang 2022); the first phase keyword switches the fix to the multiphase equations. */
void FixSPHFluid::parse_phase(int &iarg, int narg, char **arg) {
  const char *usage = "phase TYPE RHO0 newtonian MU [c0 C] | phase TYPE RHO0 hb TAU_Y K N GDOT_CUT [c0 C]";
  if (iarg + 4 >= narg) fail(std::string("missing value(s) for phase (usage: ") + usage + ")");
  long t;
  if (!sphdem_compat::to_int(arg[iarg + 1], &t) || t < 1 || t > atom->ntypes)
    fail("phase TYPE must be an atom type 1.." + std::to_string(atom->ntypes) + ", got '" + arg[iarg + 1] +
         "' (usage: " + usage + ")");
  if (type_phase_[t] >= 0) fail("atom type " + std::to_string(t) + " is given two phase keywords");
  if (mp_.nphase >= SPHDEM_MAX_PHASES) fail("at most " + std::to_string(SPHDEM_MAX_PHASES) + " phases");
  sphdem_phase &f = mp_.phase[mp_.nphase];
  f.rho0 = parse_number("phase RHO0", arg[iarg + 2], usage);
  const std::string model = arg[iarg + 3];
  if (model == "newtonian") {
    f.K = parse_number("phase newtonian MU", arg[iarg + 4], usage);
    f.tau_y = 0.0, f.N = 1.0, f.gdot_cut = 0.0;
    iarg += 5;
  } else if (model == "hb") {
    if (iarg + 7 >= narg) fail(std::string("missing value(s) for phase ... hb (usage: ") + usage + ")");
    f.tau_y = parse_number("phase hb TAU_Y", arg[iarg + 4], usage);
    f.K = parse_number("phase hb K", arg[iarg + 5], usage);
    f.N = parse_number("phase hb N", arg[iarg + 6], usage);
    f.gdot_cut = parse_number("phase hb GDOT_CUT", arg[iarg + 7], usage);
    iarg += 8;
  } else {
    fail("phase rheology must be newtonian MU or hb TAU_Y K N GDOT_CUT (got '" + model + "')");
  }
  f.c0 = 0.0; /* the fluid's c0 */
  if (iarg < narg && std::string(arg[iarg]) == "c0") {
    if (iarg + 1 >= narg) fail(std::string("missing value for phase ... c0 (usage: ") + usage + ")");
    f.c0 = parse_number("phase c0", arg[iarg + 1], usage);
    if (!(f.c0 > 0)) fail(std::string("phase c0 must be > 0 (usage: ") + usage + ")");
    iarg += 2;
  }
  type_phase_[t] = mp_.nphase++;
}

void FixSPHFluid::box_to_params() {
  for (int d = 0; d < 3; d++) {
    prm_.boxlo[d] = domain->boxlo[d];
    prm_.boxhi[d] = domain->boxhi[d];
    prm_.periodic[d] = domain->periodicity[d];
    if (multi_ && prm_.periodic[d]) {
      /* many ranks: the engine's ghost images are the periodic neighbours; owned atoms may be outside the box
       * by up to half a skin until the next neighbour build */
      const double L = domain->boxhi[d] - domain->boxlo[d];
      prm_.periodic[d] = 0;
      prm_.boxlo[d] -= L;
      prm_.boxhi[d] += L;
    }
  }
}

/* How many pair sums deep one rate evaluation reaches: the rates (1); the wall state or the kernel sums that the
 * rates read at the neighbours (+1); the delta-plus gradients and shifting read at the neighbours and themselves
 * built on the wall state (+1); mirror ghost walls interpolate at a mirror point up to two supports inside (+2). */
void FixSPHFluid::require_ghost_band(double reach) {
  if (!multi_) return;
  cut_need_ = std::max(cut_need_, reach + neighbor->skin);
  const double cut = sphdem_compat::comm_cutoff_for_band(cut_need_, neighbor->skin,
                                                         atom->radius_flag && !domain->triclinic);
  if (comm->cutghostuser < cut) comm->cutghostuser = cut;
}

/* Kernel supports (2h) of ghosts each rank needs beyond its subdomain: its own fluid's neighbours; the ghost walls'
 * state comes from their owners for the plain fluid (sphdem_set_exchange), while the delta-plus fluid and mirror
 * ghost walls evaluate the ghost walls (and their own gradients) here, and isolated's kernel sums of neighbours
 * reach one support further. */
int FixSPHFluid::ghost_levels() const {
  int levels = 1;
  if ((wall_groupbit_ && (mp_.enabled || ghost_)) || prm_.isolated > 0.0) levels++;
  if (mp_.enabled) levels++;
  if (ghost_) levels += 2;
  return levels;
}

/* ---- run set-up ---------------------------------------------------------------------------------- */

void FixSPHFluid::init() {
  multi_ = comm->nprocs > 1;
  if (multi_) {
    /* the ghost fluid and walls must reach as deep as the chain of pair sums of one rate evaluation */
    cut_need_ = 2.0 * prm_.h * ghost_levels() + neighbor->skin;
    const double cut = sphdem_compat::comm_cutoff_for_band(cut_need_, neighbor->skin,
                                                           atom->radius_flag && !domain->triclinic);
    if (comm->cutghostuser < cut) comm->cutghostuser = cut;
  }
  if (!atom->rmass_flag && !atom->mass)
    fail("the atom style must define a per-atom mass (rmass) or per-type masses");
  if (update->dt <= 0) fail("the timestep must be > 0");
  coupler_ = nullptr; /* a fix sph/couple defined after this one attaches itself in its init() */
  int bad_restart = !restart_error_.empty(), any_bad = 0;
  MPI_Allreduce(&bad_restart, &any_bad, 1, MPI_INT, MPI_MAX, world);
  if (any_bad) fail(bad_restart ? restart_error_ : std::string("a restart record on another rank is corrupted"));
  if (group->count(igroup) == 0)
    fail(std::string("the fluid group ") + group->names[igroup] + " has no atoms (the group of fix " + id +
         " holds the fluid particles)");

  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  int overlap = 0;
  for (int i = 0; i < nlocal && wall_groupbit_; i++)
    if ((mask[i] & groupbit) && (mask[i] & wall_groupbit_)) overlap = 1;
  int any = 0;
  MPI_Allreduce(&overlap, &any, 1, MPI_INT, MPI_MAX, world);
  if (any)
    fail(std::string("the wall group ") + wall_group_ + " overlaps the fluid group " + group->names[igroup] +
         "; an atom is either fluid or wall");

  check_other_fixes();
  check_pair_exclusions();
}

namespace {
bool starts_with(const std::string &s, const char *p) { return s.compare(0, std::strlen(p), p) == 0; }
}  // namespace

/* Stock commands given to group all also act on the fluid and wall atoms (they are ordinary atoms). Each fix whose
 * group holds fluid or wall atoms (the group bitmasks over the local atoms, reduced) is judged by its kind:
 * - a time integrator (time_integrate: nve, nve/sphere, nve/limit, rigid, move, ...): on fluid atoms an error (this
 *   fix integrates them); on wall atoms the walls move (uploaded each step), with a warning unless the fix is a
 *   prescribed motion (move) or a rigid body;
 * - adapt: an error (it changes diameters, masses or pair coefficients of the fluid and walls);
 * - wall/gran*: an error on the fluid (the fluid does not see granular walls: its walls are wall particles), a
 *   warning on the walls (contacts computed and not used);
 * - gravity on the fluid: the fluid reads no forces of other fixes; an error without the gravity keyword (the
 *   fluid would feel no gravity), a warning with it;
 * - an insertion fix whose fill counts the atoms in its region (LIGGGHTS insert/pack, insert/rate/region): a warning
 *   when fluid atoms lie in that region. Collective. */
void FixSPHFluid::check_other_fixes() {
  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  std::string grains = "GRAINS"; /* the group to name: that of a fix sph/couple of this fluid, if any */
  for (int k = 0; k < modify->nfix; k++)
    if (std::string(modify->fix[k]->style) == "sph/couple") grains = group->names[modify->fix[k]->igroup];
  const std::string me = std::string("fix sph/fluid ") + id + " (group " + group->names[igroup] +
                         (wall_groupbit_ ? ", walls " + wall_group_ : std::string()) + ")";
  walls_move_ = false;
  for (int k = 0; k < modify->nfix; k++) {
    Fix *f = modify->fix[k];
    if (f == this) continue;
    const std::string style = f->style, fid = f->id;
    const bool integ = f->time_integrate != 0, adapt = style == "adapt", wallgran = starts_with(style, "wall/gran");
    const bool grav = style == "gravity", insert = starts_with(style, "insert/");
    if (!integ && !adapt && !wallgran && !grav && !insert) continue;
    int hit[2] = {0, 0}, all[2];
    for (int i = 0; i < nlocal; i++) {
      if (!(mask[i] & f->groupbit)) continue;
      if (mask[i] & groupbit) hit[0] = 1;
      if (mask[i] & wall_groupbit_) hit[1] = 1;
    }
    MPI_Allreduce(hit, all, 2, MPI_INT, MPI_MAX, world);
    const std::string which = "fix " + fid + " (style " + style + ", group " + group->names[f->igroup] + ")";
    const std::string instead = " Apply it to the grains only: fix " + fid + " " + grains + " " + style + " ...";
    auto warn = [&](const std::string &m) {
      if (comm->me == 0) sphdem_compat::warning(error, FLERR, "Fix sph/fluid: " + m);
    };
    if (insert) {
      Region *reg = sphdem_compat::insertion_region(f);
      if (!reg) continue; /* no region to inspect, or one whose fill does not count the atoms in it */
      double nin = 0.0;
      for (int i = 0; i < nlocal; i++)
        if ((mask[i] & groupbit) && reg->match(atom->x[i][0], atom->x[i][1], atom->x[i][2])) nin += 1.0;
      sphdem_mpi::sum(world, &nin, 1);
      if (nin > 0)
        warn(which + " fills a region that holds " + std::to_string((long long)nin) + " fluid atoms of " + me +
             ": its fill (volumefraction_region, particles_in_region) counts the fluid atoms too and may insert few "
             "or no grains. Insert the grains into a region clear of the fluid, or before the fluid atoms exist");
      continue;
    }
    if (!all[0] && !all[1]) continue;
    if (integ) {
      if (all[0])
        sphdem_compat::error_all(error, FLERR,
                                 "Fix sph/fluid integrates its own group; fix " + fid + " (style " + style +
                                     ") also integrates atoms of group " + group->names[f->igroup] + ", the fluid "
                                     "group " + group->names[igroup] + " of fix " + id + " among them." + instead);
      walls_move_ = true;
      if (style != "move" && !starts_with(style, "rigid"))
        warn(which + " integrates wall atoms of " + me + ": the walls then move under the forces on them "
             "(gravity, contacts). If the walls are to stay in place, apply it to the grains only: fix " + fid + " " +
             grains + " " + style + " ...; walls that move on a prescribed path take fix move");
      continue;
    }
    const std::string on = all[0] && all[1] ? "the fluid and wall atoms" : all[0] ? "the fluid atoms" : "the wall atoms";
    if (adapt)
      sphdem_compat::error_all(error, FLERR,
                               "Fix sph/fluid: " + which + " acts on " + on + " of " + me + ": it changes their "
                               "diameter and mass (the SPH particle mass) or pair coefficients." + instead);
    if (wallgran && all[0])
      sphdem_compat::error_all(error, FLERR,
                               "Fix sph/fluid: " + which + " acts on the fluid atoms of " + me + ": a granular wall "
                               "does not hold the fluid (fix sph/fluid reads no forces of other fixes; the fluid's "
                               "walls are wall particles, keyword wall)." + instead);
    if (wallgran) {
      warn(which + " acts on the wall atoms of " + me + ": contacts with wall particles are computed and not used." +
           instead);
      continue;
    }
    if (grav && all[0]) {
      const bool have_g = prm_.gravity[0] != 0 || prm_.gravity[1] != 0 || prm_.gravity[2] != 0;
      const std::string m = which + " acts on the fluid atoms of " + me + ", but fix sph/fluid reads no forces of "
                            "other fixes for its fluid: ";
      if (!have_g)
        sphdem_compat::error_all(error, FLERR,
                                 "Fix sph/fluid: " + m + "the fluid would feel no gravity. Give it to fix " + id +
                                     " with its keyword gravity gx gy gz." + instead);
      warn(m + "it has no effect there (the fluid's gravity is the keyword gravity)." + instead);
    }
  }
}

/* The granular pair style of the engine acting on fluid or wall atoms. The atoms are judged by class (type and
 * group mask; the classes of all ranks gathered) against neigh_modify's exclusions as given (exclude type, exclude
 * group, include). Fluid against other atoms (the grains) not excluded: an error (the grains would collide with
 * the fluid particles as with solid spheres); fluid against fluid or walls, walls against walls: a warning
 * (contacts computed and not used). Collective. */
void FixSPHFluid::check_pair_exclusions() {
  if (!force->pair || !force->pair_style) return;
  const std::string pstyle = force->pair_style;
  if (pstyle.find("gran") == std::string::npos) return;
  const sphdem_compat::NeighborExclusions ex = sphdem_compat::neighbor_exclusions(neighbor);
  const int nlocal = atom->nlocal;
  std::vector<int> mine; /* (type, mask) pairs, distinct */
  for (int i = 0; i < nlocal; i++) {
    const int t = atom->type[i], m = atom->mask[i];
    bool seen = false;
    for (size_t c = 0; c < mine.size() && !seen; c += 2) seen = mine[c] == t && mine[c + 1] == m;
    if (!seen) mine.push_back(t), mine.push_back(m);
  }
  int n = (int)mine.size(), nr = comm->nprocs;
  std::vector<int> lens(nr), offs(nr, 0);
  MPI_Allgather(&n, 1, MPI_INT, lens.data(), 1, MPI_INT, world);
  for (int r = 1; r < nr; r++) offs[r] = offs[r - 1] + lens[r - 1];
  std::vector<int> cls((size_t)offs[nr - 1] + (size_t)lens[nr - 1]);
  MPI_Allgatherv(mine.data(), n, MPI_INT, cls.data(), lens.data(), offs.data(), MPI_INT, world);
  const int incbit = ex.include ? group->bitmask[ex.include] : 0;
  auto excluded = [&](int ta, int ma, int tb, int mb) {
    if (incbit && (!(ma & incbit) || !(mb & incbit))) return true;
    for (int k = 0; k < ex.ntype; k++)
      if ((ex.t1[k] == ta && ex.t2[k] == tb) || (ex.t1[k] == tb && ex.t2[k] == ta)) return true;
    for (int k = 0; k < ex.ngroup; k++) {
      const int b1 = group->bitmask[ex.g1[k]], b2 = group->bitmask[ex.g2[k]];
      if (((ma & b1) && (mb & b2)) || ((ma & b2) && (mb & b1))) return true;
    }
    return false;
  };
  int grain_type = 0, fluid_type = 0, fluid_self = 0, fluid_wall = 0, wall_self = 0;
  for (size_t a = 0; a < cls.size(); a += 2) {
    const int ta = cls[a], ma = cls[a + 1];
    const bool fa = ma & groupbit, wa = ma & wall_groupbit_;
    if (!fa && !wa) continue;
    for (size_t b = 0; b < cls.size(); b += 2) {
      const int tb = cls[b], mb = cls[b + 1];
      if (excluded(ta, ma, tb, mb)) continue;
      const bool fb = mb & groupbit, wb = mb & wall_groupbit_;
      if (fa && !fb && !wb) grain_type = tb, fluid_type = ta;
      else if (fa && fb) fluid_self = ta;
      else if ((fa && wb) || (wa && fb)) fluid_wall = 1;
      else if (wa && wb) wall_self = ta;
    }
  }
  const std::string fg = group->names[igroup];
  const std::string how = "neigh_modify exclude group " + fg + " all";
  if (grain_type > 0) {
    char m[1024];
    snprintf(m, sizeof m, "Fix sph/fluid: pair_style %s acts between the fluid atoms of fix %s (group %s, e.g. type %d) "
             "and other atoms (e.g. type %d): the grains would collide with the fluid particles as with solid spheres. "
             "Exclude the fluid from the pair style: add the line '%s'%s (or neigh_modify include GROUP with "
             "atom_modify first GROUP, GROUP = the grains and DEM wall particles)",
             pstyle.c_str(), id, fg.c_str(), fluid_type, grain_type, how.c_str(),
             wall_self ? (" and 'neigh_modify exclude group " + wall_group_ + " " + wall_group_ + "'").c_str() : "");
    sphdem_compat::error_all(error, FLERR, m);
  }
  if ((fluid_self || fluid_wall || wall_self) && comm->me == 0) {
    std::string lines;
    if (fluid_self || fluid_wall) lines = "'" + how + "'";
    if (wall_self) lines += std::string(lines.empty() ? "" : " and ") + "'neigh_modify exclude group " + wall_group_ +
                            " " + wall_group_ + "'";
    const std::string what = std::string(fluid_self ? "fluid-fluid " : "") + (fluid_wall ? "fluid-wall " : "") +
                             (wall_self ? "wall-wall " : "");
    sphdem_compat::warning(error, FLERR,
                           "Fix sph/fluid: pair_style " + pstyle + " computes " + what + "contacts of fix " + id +
                               " that nothing uses (the fluid takes no engine forces; its walls hold it): add " +
                               lines + " (engine neighbour lists and contacts over the fluid cost time and memory)");
  }
}

void FixSPHFluid::setup_pre_neighbor() {
  /* setup() follows in the same run set-up and rebuilds the mapping and uploads everything */
  mapping_dirty_ = true;
}

void FixSPHFluid::setup(int) {
  box_to_params();
  if (!ctx_) {
    char msg[512] = "";
    if (multi_ && device_ != SPHDEM_DEVICE_CPU) { /* one GPU per rank on its node, shared when fewer */
      const std::string map = sphdem_mpi::select_gpus(world);
      if (comm->me == 0 && !map.empty()) sphdem_compat::logmesg(lmp, "Fix sph/fluid: GPUs: " + map + "\n");
    }
    int rc = sphdem_create(&ctx_, &prm_, device_, msg, sizeof msg);
    if (rc != SPHDEM_OK) fail(std::string(msg) + " (" + sphdem_strerror(rc) + ")");
  } else {
    check(sphdem_set_params(ctx_, &prm_), "set_params");
  }
  if (multi_) comm_ = sphdem_mpi::comm(&world);
  check(sphdem_set_comm(ctx_, multi_ ? &comm_ : nullptr), "set_comm");
  check(sphdem_set_exchange(ctx_, multi_ ? &FixSPHFluid::exchange_cb : nullptr, this), "set_exchange");
  if (rk4_ && coupler_) fail("integrator rk4 cannot be used with fix sph/couple (grains need velocity Verlet)");
  if (mp_.enabled) {
    if (coupler_ && mp_.single) fail(std::string("fix sph/couple: ") + SPHDEM_MP_COUPLE_WHY);
    if (coupler_) fail("the multiphase fluid (keyword phase) cannot be coupled to grains (fix sph/couple) yet");
    if (mp_.single) sphdem_mp_single_phase(&prm_, &mp_);
    check(sphdem_mp_set(ctx_, &mp_), "mp_set");
  }
  if (coupler_) {
    coupler_->couple_setup(ctx_);
    couple_on_ = true;
  } else if (couple_on_) { /* the fix sph/couple of an earlier run was removed */
    sphdem_couple_params off;
    sphdem_couple_params_default(&off);
    off.enabled = 0;
    check(sphdem_couple_set(ctx_, &off), "couple_set");
    couple_on_ = false;
  }

  build_map();
  if (hydro_auto_) resolve_hydrostatic_auto();
  upload_walls(false);
  const bool valid = upload_fluid();
  /* the rates are computed when the per-atom state or the held grain forces were not valid */
  if (!valid || (coupler_ && !coupler_->couple_forces_valid())) rates();
  else if (coupler_) seed_porosity();
  if (!valid && coupler_ && coupler_->couple_superficial_floor() > 0) start_superficial();
  host_current_ = false;
  download();              /* host rho, p and state columns now match the device */
  if (!scene_checked_) check_scene(!valid);

  sphdem_stats s;
  const double dt_nominal = (double)every_ * update->dt; /* the fluid step of the stability check */
  int rc = sphdem_stats_get(ctx_, dt_nominal, &s);
  if (rc == SPHDEM_ERR_UNSTABLE) fail(stats_message(rc, s)); /* the time step, nothing blew up yet */
  if (rc != SPHDEM_OK) blowup(stats_message(rc, s));
  stats_ = s;
  stats_step_ = update->ntimestep;

  if (!announced_) note_unused_walls();
  if (comm->me == 0 && !announced_) {
    const char *note = sphdem_backend_note(ctx_);
    const size_t n = (size_t)s.nfluid;
    char line[768];
    char stepnote[128] = "";
    if (every_ > 1) snprintf(stepnote, sizeof stepnote, "; fluid step %g = every %ld x", dt_nominal, every_);
    snprintf(line, sizeof line,
             "Fix sph/fluid: %s backend%s%s%s; %zu fluid + %zu wall particles; %.0f device bytes per fluid "
             "particle; stable dt %g (timestep %g%s)\n",
             sphdem_backend(ctx_) == SPHDEM_DEVICE_GPU ? "GPU" : "CPU", *note ? " (" : "", note,
             *note ? ")" : "", n, (size_t)s.nwall,
             fidx_.empty() ? 0.0 : (double)sphdem_device_bytes(ctx_) / (double)fidx_.size(),
             s.dt_stable, update->dt, stepnote);
    sphdem_compat::logmesg(lmp, line);
    sphdem_compat::logmesg(lmp, "Fix sph/fluid: terms: " + terms_line() + "\n");
    if (multi_) {
      const double fluid_reach = 2.0 * prm_.h * ghost_levels();
      char reach[96];
      if (cut_need_ - neighbor->skin > fluid_reach * (1 + 1e-12)) /* the coupling's support is the wider */
        snprintf(reach, sizeof reach, "2 hc %g (the coupling; %d x 2h = %g)", cut_need_ - neighbor->skin,
                 ghost_levels(), fluid_reach);
      else
        snprintf(reach, sizeof reach, "%d x 2h", ghost_levels());
      snprintf(line, sizeof line,
               "Fix sph/fluid: %d MPI ranks (processors %d %d %d); ghost fluid and walls within %g = %s + "
               "neighbor skin %g (communication cutoff %g)\n",
               comm->nprocs, comm->procgrid[0], comm->procgrid[1], comm->procgrid[2], cut_need_, reach,
               neighbor->skin, comm->cutghostuser);
      sphdem_compat::logmesg(lmp, line);
    }
  }
  announced_ = true; /* on every rank: note_unused_walls is collective */
  run_step0_ = update->ntimestep;
  run_t0_ = wall_seconds();
  sphdem_timers_reset(ctx_); /* the split printed at the end of the run covers the run only */
  last_fluid_step_ = update->ntimestep;
  nfluid_steps_ = 0;
  fluid_step_ = false;
}

/* hydrostatic auto: the free surface from the fluid atoms over all ranks (sphdem_free_surface: the highest fluid
 * particle against gravity plus half a particle spacing). Resolved once, at the first set-up; printed. Collective. */
void FixSPHFluid::resolve_hydrostatic_auto() {
  std::vector<double> x(3 * nfown_);
  for (size_t k = 0; k < nfown_; k++)
    for (int d = 0; d < 3; d++) x[3 * k + d] = atom->x[fidx_[k]][d];
  sphdem_comm all = sphdem_mpi::comm(&world); /* every rank, also where the fix runs without ghosts */
  int axis = 0, up = 1;
  const int rc = sphdem_free_surface(&prm_, (int)nfown_, x.data(), &all, &zsurf_, &axis, &up);
  if (rc != SPHDEM_OK)
    sphdem_compat::error_all(error, FLERR, std::string("Fix sph/fluid: free_surface: ") + sphdem_strerror(rc));
  hydro_auto_ = false;
  if (comm->me == 0) {
    char line[256];
    snprintf(line, sizeof line, "Fix sph/fluid: hydrostatic auto: free surface at %c = %.10g (the %s fluid particle "
             "%s dx/2, dx %g)\n", "xyz"[axis], zsurf_, up > 0 ? "highest" : "lowest", up > 0 ? "+" : "-", prm_.dx);
    sphdem_compat::logmesg(lmp, line);
  }
}

/* "Model no more than a scene needs": the terms that are on, one line at the first set-up. */
std::string FixSPHFluid::terms_line() const {
  char b[256];
  std::string t;
  auto add = [&t](const std::string &s) { t += (t.empty() ? "" : "; ") + s; };
  if (prm_.visc == SPHDEM_VISC_MORRIS) snprintf(b, sizeof b, "visc morris %g", prm_.mu), add(b);
  else if (prm_.visc == SPHDEM_VISC_ARTIFICIAL) snprintf(b, sizeof b, "visc artificial %g", prm_.alpha), add(b);
  else add("visc none");
  if (mp_.enabled && !mp_.single) snprintf(b, sizeof b, "%d phases (phase)", mp_.nphase), add(b);
  add(prm_.gravity[0] != 0 || prm_.gravity[1] != 0 || prm_.gravity[2] != 0
          ? (snprintf(b, sizeof b, "gravity %g %g %g", prm_.gravity[0], prm_.gravity[1], prm_.gravity[2]), b)
          : "gravity off");
  add(prm_.tensile_eps > 0 ? (snprintf(b, sizeof b, "tensile %g %g", prm_.tensile_eps, prm_.tensile_n), b)
                           : "tensile off");
  add(prm_.xsph_eps > 0 ? (snprintf(b, sizeof b, "xsph %g", prm_.xsph_eps), b) : "xsph off");
  add(prm_.delta > 0 ? (snprintf(b, sizeof b, "delta %g %s", prm_.delta, prm_.delta_hydro ? "hydrostatic" : "plain"), b)
                     : "delta off");
  if (mp_.enabled) {
    add(mp_.shifting ? "shifting yes" : "shifting no");
    const char *dn = mp_.diffusion == SPHDEM_DIFF_MOLTENI ? "molteni" : mp_.diffusion == SPHDEM_DIFF_RENORM ? "renorm"
                                                                                                             : "none";
    add(mp_.diffusion != SPHDEM_DIFF_NONE ? (snprintf(b, sizeof b, "diffusion %s %g", dn, mp_.delta), b)
                                          : "diffusion none");
    add(mp_.cs_les > 0 ? (snprintf(b, sizeof b, "les %g", mp_.cs_les), b) : "les off");
  } else {
    add("shifting, diffusion, les off");
  }
  add(wall_groupbit_ ? "walls " + wall_group_ + (ghost_ ? " (ghost mirror)" : walls_move_ ? " (moving)" : "")
                     : std::string("walls none"));
  add(prm_.rep_D > 0 ? (snprintf(b, sizeof b, "repulsion %g %g", prm_.rep_D, prm_.rep_r0), b) : "repulsion off");
  if (prm_.isolated > 0) snprintf(b, sizeof b, "isolated %g", prm_.isolated), add(b);
  add(coupler_ ? "coupling on (fix sph/couple)" : "coupling off");
  snprintf(b, sizeof b, "integrator %s; every %ld", rk4_ ? "rk4" : "verlet", every_);
  add(b);
  snprintf(b, sizeof b, "precision %s", prm_.precision == SPHDEM_PREC_MIXED ? "mixed"
                                        : prm_.precision == SPHDEM_PREC_SINGLE ? "single" : "double");
  add(b);
  return t;
}

/* A wall group none of whose atoms is within 2h of a fluid particle at the first set-up: the wall state costs a
 * pass each step for nothing (it may be meant for later, e.g. a gate the fluid reaches): a warning. Cells of 2h
 * over the owned and ghost fluid; periodic axes wrap on one rank (many ranks: the ghosts are the images). */
void FixSPHFluid::note_unused_walls() {
  if (!wall_groupbit_) return;
  const double r = 2.0 * prm_.h, r2 = r * r;
  int nc[3] = {1, 1, 1};
  for (int d = 0; d < prm_.dim; d++) {
    nc[d] = (int)std::floor((prm_.boxhi[d] - prm_.boxlo[d]) / r);
    if (nc[d] < 3) nc[d] = 1; /* one cell along d: the stencil visits it alone */
  }
  const int st[3] = {nc[0] > 1, nc[1] > 1, nc[2] > 1};
  auto cell = [&](const double *x, int *c) {
    for (int d = 0; d < 3; d++) {
      c[d] = d < prm_.dim ? (int)std::floor((x[d] - prm_.boxlo[d]) / r) : 0;
      c[d] = std::min(std::max(c[d], 0), nc[d] - 1);
    }
  };
  std::vector<std::vector<int>> cells((size_t)nc[0] * nc[1] * nc[2]);
  double **x = atom->x;
  for (int i : fidx_) {
    int c[3];
    cell(x[i], c);
    cells[((size_t)c[2] * nc[1] + c[1]) * nc[0] + c[0]].push_back(i);
  }
  int near = 0, nwall = (int)nwown_;
  for (size_t k = 0; k < nwown_ && !near; k++) {
    const int w = widx_[k];
    int c[3];
    cell(x[w], c);
    for (int dz = -st[2]; dz <= st[2] && !near; dz++)
      for (int dy = -st[1]; dy <= st[1] && !near; dy++)
        for (int dx = -st[0]; dx <= st[0] && !near; dx++) {
          int q[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
          bool skip = false;
          for (int d = 0; d < 3; d++) {
            if (q[d] >= 0 && q[d] < nc[d]) continue;
            if (prm_.periodic[d]) q[d] = (q[d] + nc[d]) % nc[d];
            else skip = true;
          }
          if (skip) continue;
          for (int i : cells[((size_t)q[2] * nc[1] + q[1]) * nc[0] + q[0]]) {
            double d2 = 0.0;
            for (int d = 0; d < prm_.dim; d++) {
              double s = x[i][d] - x[w][d];
              const double L = prm_.boxhi[d] - prm_.boxlo[d];
              if (prm_.periodic[d]) s -= L * std::round(s / L);
              d2 += s * s;
            }
            if (d2 < r2) {
              near = 1;
              break;
            }
          }
        }
  }
  if (multi_) {
    double v[2] = {(double)near, (double)nwall};
    sphdem_mpi::sum(world, v, 2);
    near = v[0] > 0, nwall = (int)v[1];
  }
  if (!near && comm->me == 0)
    sphdem_compat::warning(error, FLERR,
                           "Fix sph/fluid: none of the " + std::to_string(nwall) + " atoms of the wall group " +
                               wall_group_ + " is within 2h of a fluid particle of fix " + id +
                               ": the wall term is on and unused at set-up (fine if the fluid reaches the walls later; "
                               "otherwise drop the keyword wall, or check the wall atoms' positions)");
}

bool FixSPHFluid::attach_coupler(SPHCoupler *c) {
  if (coupler_ && coupler_ != c) return false;
  coupler_ = c;
  return true;
}

/* ---- mapping and transfers -------------------------------------------------------------------------- */

void FixSPHFluid::build_map() {
  const int nlocal = atom->nlocal;
  const int *mask = atom->mask;
  fidx_.clear();
  widx_.clear();
  for (int i = 0; i < nlocal; i++) {
    if (mask[i] & groupbit) fidx_.push_back(i);
    else if (mask[i] & wall_groupbit_) widx_.push_back(i);
  }
  nfown_ = fidx_.size();
  nwown_ = widx_.size();
  if (multi_) {
    const int nall = nlocal + atom->nghost;
    for (int i = nlocal; i < nall; i++) {
      if (mask[i] & groupbit) fidx_.push_back(i);
      else if (mask[i] & wall_groupbit_) widx_.push_back(i);
    }
  }
  if (multi_) { /* the next forward communication finds the atoms in the send lists */
    record_sends_ = true;
    sent_.assign((size_t)nlocal, 0);
  }
  /* the positions of this neighbour build (the engine's pre_exchange download made the fluid's current), for
   * check_displacement on one rank and on many alike */
  xhold_.resize(3 * (size_t)nlocal);
  for (int i = 0; i < nlocal; i++)
    for (int d = 0; d < 3; d++) xhold_[3 * (size_t)i + d] = atom->x[i][d];
  mapping_dirty_ = false;
}

static double atom_mass(Atom *atom, int i) { return atom->rmass ? atom->rmass[i] : atom->mass[atom->type[i]]; }

/* Upload the fluid from the host. rho and state come from the per-atom array where it is valid
 * (an earlier run or a restart); otherwise rho is the core's initial density (rho0, hydrostatic or
 * layered), the rates are zero and the function returns false: the caller computes them. */
bool FixSPHFluid::upload_fluid() {
  const size_t n = fidx_.size();
  double **x = atom->x, **v = atom->v;
  ftag_.resize(n);
  fx_.resize(3 * n);
  fv_.resize(3 * n);
  frho_.resize(n);
  fmass_.resize(n);
  fstate_.resize(SPHDEM_NSTATE * n);

  bool all_valid = true, scaled_any = false;
  fresh_.clear();
  if (mp_.enabled) {
    fphase_.resize(n);
    std::string bad;
    for (size_t k = 0; k < n && bad.empty(); k++) {
      const int t = atom->type[fidx_[k]];
      if (type_phase_[t] < 0)
        bad = "fluid atom " + std::to_string((long long)atom->tag[fidx_[k]]) + " has type " + std::to_string(t) +
              ", which no phase keyword names (phase TYPE RHO0 ...)";
      else fphase_[k] = type_phase_[t];
    }
    fail_any(!bad.empty(), bad);
  }
  for (size_t k = 0; k < nfown_; k++) {
    const int i = fidx_[k];
    ftag_[k] = (int64_t)atom->tag[i];
    for (int d = 0; d < 3; d++) fx_[3 * k + d] = x[i][d], fv_[3 * k + d] = v[i][d];
    fmass_[k] = atom_mass(atom, i);
    if (sa_[i][C_VALID] > 0) {
      frho_[k] = sa_[i][C_RHO];
      for (int s = 0; s < SPHDEM_NSTATE; s++) fstate_[SPHDEM_NSTATE * k + s] = sa_[i][C_STATE + s];
    } else {
      all_valid = false;
      fresh_.push_back((int)k);
    }
  }
  std::vector<double> rho(fresh_.size());
  const int rc = sphdem_initial_density_ranks(&prm_, mp_.enabled ? &mp_ : nullptr, hydrostatic_, zsurf_,
                                              (int)nfown_, fx_.data(), mp_.enabled ? fphase_.data() : nullptr,
                                              (int)fresh_.size(), fresh_.data(), rho.data(), multi_ ? &comm_ : nullptr);
  if (rc != SPHDEM_OK) {
    const std::string m = std::string("Fix sph/fluid: initial_density: ") + sphdem_strerror(rc);
    if (multi_) sphdem_compat::error_one(error, FLERR, m);
    sphdem_compat::error_all(error, FLERR, m);
  }
  for (size_t j = 0; j < fresh_.size(); j++) {
    const int k = fresh_[j], i = fidx_[k];
    frho_[k] = rho[j];
    /* keep each particle's SPH volume m/rho equal to its lattice volume m0/rho0 (once per fix) */
    if (hydrostatic_ && !mass_scaled_ && atom->rmass) {
      atom->rmass[i] *= sphdem_volume_mass_factor(&prm_, mp_.enabled ? &mp_ : nullptr, mp_.enabled ? fphase_[k] : 0,
                                                  frho_[k]);
      fmass_[k] = atom->rmass[i];
      scaled_any = true;
    }
  }
  if (multi_) { /* a fresh atom anywhere: every rank computes the rates (a collective evaluation) */
    double mine[2] = {all_valid ? 1.0 : 0.0, scaled_any ? 1.0 : 0.0};
    double lo = mine[0], hi = mine[1];
    sphdem_mpi::min(world, &lo, 1);
    sphdem_mpi::max(world, &hi, 1);
    all_valid = lo > 0.5;
    scaled_any = hi > 0.5;
  }
  if (scaled_any) mass_scaled_ = true;
  /* a state that went bad between two checks (the last download): the regular blow-up message */
  long long bad_tag = -1;
  double bad_rho = 0.0;
  for (size_t k = 0; k < nfown_ && bad_tag < 0; k++) {
    if (frho_[k] > 0 && std::isfinite(frho_[k]) && std::isfinite(fx_[3 * k] + fx_[3 * k + 1] + fx_[3 * k + 2]) &&
        std::isfinite(fv_[3 * k] + fv_[3 * k + 1] + fv_[3 * k + 2]))
      continue;
    bad_tag = (long long)ftag_[k], bad_rho = frho_[k];
  }
  double any_bad = bad_tag >= 0 ? 1.0 : 0.0;
  if (multi_) sphdem_mpi::max(world, &any_bad, 1);
  if (any_bad > 0.5) {
    sphdem_stats s;
    const int rc = sphdem_stats_get(ctx_, 0.0, &s);
    if (rc != SPHDEM_OK) blowup(stats_message(rc, s), false); /* the device holds the previous upload's order */
    char m[512];
    snprintf(m, sizeof m, "fluid atom %lld has density %g (must be > 0), position or velocity not finite at step "
             BIGINT_FORMAT ": the fluid blew "
             "up after the last check (check %ld; check 1 stops at the first bad step). Likely causes: a time step "
             "above the stable one, c0 too low for the flow, or particles entering the walls",
             bad_tag, bad_rho, update->ntimestep, check_every_);
    std::string msg = m;
    if (multi_) msg = sphdem_mpi::first_failure(world, bad_tag >= 0, msg);
    blowup(msg, false);
  }
  if (multi_) { /* the ghosts: positions from the engine, the rest from their owners */
    fill_gcomm(true, false);
    for (size_t k = nfown_; k < n; k++) {
      const int i = fidx_[k];
      const double *g = &gcomm_[(size_t)GCOMM * i];
      ftag_[k] = (int64_t)atom->tag[i];
      for (int d = 0; d < 3; d++) fx_[3 * k + d] = x[i][d], fv_[3 * k + d] = g[d];
      frho_[k] = g[G_RHO];
      fstate_[SPHDEM_NSTATE * k] = g[G_DRHO];
      for (int d = 0; d < 3; d++) fstate_[SPHDEM_NSTATE * k + 1 + d] = g[G_A + d];
      fmass_[k] = g[G_MASS];
    }
  }
  check(sphdem_set_fluid(ctx_, (int)n, ftag_.data(), fx_.data(), fv_.data(), frho_.data(), fmass_.data(),
                         all_valid ? fstate_.data() : nullptr),
        "set_fluid");
  if (multi_) {
    check(sphdem_set_ghosts(ctx_, (int)(n - nfown_), -1), "set_ghosts");
    check(sphdem_set_exchange_rows(ctx_, 0, (int)frows_.size(), frows_.data()), "set_exchange_rows");
  }
  if (mp_.enabled) check(sphdem_set_fluid_phase(ctx_, (int)n, fphase_.data()), "set_fluid_phase");
  return all_valid;
}

/* Many ranks: the owned entries of the forward-communication buffer from the staging arrays (fluid: v, rho,
 * drho, a, mass of the last upload or download; walls: v, acceleration, mass of the last staging), then the
 * engine's forward communication fills the ghosts' entries. Collective. */
void FixSPHFluid::fill_gcomm(bool fluid, bool walls, bool rows_only) {
  const size_t nall = (size_t)(atom->nlocal + atom->nghost);
  if (gcomm_.size() < (size_t)GCOMM * nall) gcomm_.resize((size_t)GCOMM * nall, 0.0);
  rows_only = rows_only && !record_sends_;
  const size_t nf = fluid ? (rows_only ? frows_.size() : nfown_) : 0;
  for (size_t r = 0; r < nf; r++) {
    const size_t k = rows_only ? (size_t)frows_[r] : r;
    double *g = &gcomm_[(size_t)GCOMM * fidx_[k]];
    for (int d = 0; d < 3; d++) g[G_V + d] = fv_[3 * k + d], g[G_A + d] = fstate_[SPHDEM_NSTATE * k + 1 + d];
    g[G_RHO] = frho_[k];
    g[G_DRHO] = fstate_[SPHDEM_NSTATE * k];
    g[G_MASS] = fmass_[k];
    g[G_EPS] = sa_[fidx_[k]][C_EPS];
  }
  if (walls)
    for (size_t k = 0; k < nwown_; k++) {
      double *g = &gcomm_[(size_t)GCOMM * widx_[k]];
      for (int d = 0; d < 3; d++) g[G_V + d] = wv_[3 * k + d], g[G_A + d] = wa_[3 * k + d];
      g[G_RHO] = g[G_DRHO] = g[G_EPS] = 0.0;
      g[G_MASS] = wmass_[k];
    }
  comm->forward_comm_fix(this);
  if (record_sends_) make_rows();
}

/* The owned fluid and wall atoms in this build's send lists (recorded by the forward communication just made). */
void FixSPHFluid::make_rows() {
  record_sends_ = false;
  frows_.clear();
  wrows_.clear();
  for (size_t k = 0; k < nfown_; k++)
    if (sent_[(size_t)fidx_[k]]) frows_.push_back((int)k);
  for (size_t k = 0; k < nwown_; k++)
    if (sent_[(size_t)widx_[k]]) wrows_.push_back((int)k);
  wrows_new_ = true;
}

int FixSPHFluid::sphdem_pack_forward(int n, int *list, double *buf, int, int *) {
  int m = 0;
  if (record_sends_) /* ghosts sent on (a later swap) are not this rank's */
    for (int j = 0; j < n; j++)
      if ((size_t)list[j] < sent_.size()) sent_[(size_t)list[j]] = 1;
  for (int j = 0; j < n; j++) {
    const double *g = &gcomm_[(size_t)GCOMM * list[j]];
    for (int c = 0; c < GCOMM; c++) buf[m++] = g[c];
  }
  return m;
}

void FixSPHFluid::sphdem_unpack_forward(int n, int first, double *buf) {
  const size_t need = (size_t)GCOMM * (size_t)(first + n);
  if (gcomm_.size() < need) gcomm_.resize(need, 0.0);
  int m = 0;
  for (int i = first; i < first + n; i++)
    for (int c = 0; c < GCOMM; c++) gcomm_[(size_t)GCOMM * i + c] = buf[m++];
}

/* Many ranks, each fluid step: the ghosts' new state (their owners' after the half kick and drift) into the
 * core, positions from the engine's forward communication. Collective. */
void FixSPHFluid::ghost_state_to_core() {
  const size_t n = fidx_.size(), ng = n - nfown_;
  fill_gcomm(true, false, true); /* the rows sent: download_rows made theirs current */
  std::vector<double> gx(3 * ng), gv(3 * ng), gr(ng), gs(SPHDEM_NSTATE * ng, 0.0);
  double **x = atom->x;
  for (size_t j = 0; j < ng; j++) {
    const int i = fidx_[nfown_ + j];
    const double *g = &gcomm_[(size_t)GCOMM * i];
    for (int d = 0; d < 3; d++) gx[3 * j + d] = x[i][d], gv[3 * j + d] = g[G_V + d], gs[SPHDEM_NSTATE * j + 1 + d] = g[G_A + d];
    gr[j] = g[G_RHO];
    gs[SPHDEM_NSTATE * j] = g[G_DRHO];
  }
  check(sphdem_update_ghosts(ctx_, (int)ng, gx.data(), gv.data(), gr.data(), gs.data()), "update_ghosts");
}

int FixSPHFluid::exchange_cb(void *user, int what, int ncomp, int nown, int nghost, const double *own,
                             double *ghost) {
  return static_cast<FixSPHFluid *>(user)->exchange(what, ncomp, nown, nghost, own, ghost);
}

/* Many ranks, inside a rate evaluation (the core's exchange points): the owned fluid's values of one field into
 * their slots of the forward-communication buffer, the engine's forward communication, the ghosts' values back.
 * The grains' exchange goes to the coupling fix. Collective: the communication runs even when a count is off. */
int FixSPHFluid::exchange(int what, int ncomp, int nown, int nghost, const double *own, double *ghost) {
  if (what == SPHDEM_XCHG_GRAIN) {
    if (!coupler_) return 1;
    coupler_->couple_exchange_grains(nown, nghost, own, ghost);
    return 0;
  }
  if (what == SPHDEM_XCHG_WALL) return exchange_walls(ncomp, nown, nghost, own, ghost);
  int slot[7] = {-1, -1, -1, -1, -1, -1, -1};
  if (what == SPHDEM_XCHG_RATES && (ncomp == 4 || ncomp == 7)) { /* drho, a (, u in the velocity slots) */
    const int s7[7] = {G_DRHO, G_A, G_A + 1, G_A + 2, G_V, G_V + 1, G_V + 2};
    for (int c = 0; c < ncomp; c++) slot[c] = s7[c];
  }
  else if (what == SPHDEM_XCHG_ACC && ncomp == 3) slot[0] = G_A, slot[1] = G_A + 1, slot[2] = G_A + 2;
  else if (what == SPHDEM_XCHG_EPS && ncomp == 1) slot[0] = G_EPS;
  const bool ok = slot[0] >= 0 && (size_t)nown == nfown_ && (size_t)nghost == fidx_.size() - nfown_;
  return exchange_slots(fidx_, frows_, nfown_, slot, ok, ncomp, own, ghost);
}

/* The values of the sent rows of the atoms idx[0..nown) (the core hands those only: sphdem_set_exchange_rows) into
 * their slots of the forward-communication buffer, the engine's forward communication, the ghosts' (idx[nown..])
 * back; ok false: the communication only (it is collective), and 1. */
int FixSPHFluid::exchange_slots(const std::vector<int> &idx, const std::vector<int> &rows, size_t nown,
                                const int *slot, bool ok, int ncomp, const double *own, double *ghost) {
  const size_t nall = (size_t)(atom->nlocal + atom->nghost);
  if (gcomm_.size() < (size_t)GCOMM * nall) gcomm_.resize((size_t)GCOMM * nall, 0.0);
  if (ok)
    for (int k : rows)
      for (int c = 0; c < ncomp; c++) gcomm_[(size_t)GCOMM * idx[k] + slot[c]] = own[(size_t)ncomp * k + c];
  comm->forward_comm_fix(this);
  if (!ok) return 1;
  for (size_t j = 0; nown + j < idx.size(); j++)
    for (int c = 0; c < ncomp; c++) ghost[(size_t)ncomp * j + c] = gcomm_[(size_t)GCOMM * idx[nown + j] + slot[c]];
  return 0;
}

/* The wall state (pressure, density, extrapolated velocity, porosity) in the wall atoms' slots of the same buffer
 * (its wall entries are refilled before each other use). Collective; nothing without walls (on every rank). */
int FixSPHFluid::exchange_walls(int ncomp, int nown, int nghost, const double *own, double *ghost) {
  if (!wall_groupbit_) return nown == 0 && nghost == 0 ? 0 : 1;
  static const int slot[6] = {G_DRHO, G_RHO, G_V, G_V + 1, G_V + 2, G_EPS};
  const bool ok = (ncomp == 5 || ncomp == 6) && (size_t)nown == nwown_ && (size_t)nghost == widx_.size() - nwown_;
  return exchange_slots(widx_, wrows_, nwown_, slot, ok, ncomp, own, ghost);
}

/* After the drift of each fluid step: an owned atom that moved more than skin/2 since the last neighbour build asks
 * the engine for a neighbour build on this step (collective). Many ranks: the ghost fluid and walls reach
 * cut_need_ = levels 2h + skin beyond each subdomain, enough while no owned atom has moved that far. One rank:
 * the same request, so that the engine reneighbours on the same steps as on many ranks. Without it the engine's
 * own displacement check saw the fluid only when the host rows were refreshed (output steps: a step later, or
 * never), and the build steps depended on the rank count; with LIGGGHTS' tangential history a pair that separated
 * keeps its displacement until the next build, so a contact resumed before or after a build differed. */
void FixSPHFluid::check_displacement() {
  double d2max = 0.0;
  const int n = std::min(atom->nlocal, (int)(xhold_.size() / 3));
  auto take = [&](int i, const double *xi) {
    double d2 = 0.0;
    for (int d = 0; d < 3; d++) d2 += (xi[d] - xhold_[3 * (size_t)i + d]) * (xi[d] - xhold_[3 * (size_t)i + d]);
    if (!(d2 <= d2max)) d2max = std::isfinite(d2) ? d2 : 1e300;
  };
  if (!multi_ && !force->pair) return; /* one rank without grains: the build steps change nothing */
  /* the fluid's move since the build (its upload then) from the core, without a download of every position; the
   * host rows of the fluid are stale between builds */
  check(sphdem_fluid_moved(ctx_, &d2max), "fluid_moved");
  if (!std::isfinite(d2max)) d2max = 1e300;
  if (multi_) { /* walls and grains from the engine's arrays (one rank: the engine's own check sees them) */
    double **x = atom->x;
    const int bits = wall_groupbit_ | (coupler_ ? coupler_->couple_groupbit() : 0);
    for (int i = 0; i < n; i++)
      if (!(atom->mask[i] & groupbit) && (atom->mask[i] & bits)) take(i, x[i]);
    sphdem_mpi::max(world, &d2max, 1);
  }
  if (d2max > 0.25 * neighbor->skin * neighbor->skin) next_reneighbor = update->ntimestep;
}

/* Superficial coupling: the fluid density variable is eps rho_f (He 2018 eq 6). Fluid particles created
 * on a full lattice among grains would start with an intrinsic density rho/eps > rho0, i.e. a large
 * pressure in a packed bed. Fresh particles (no valid state) therefore start at rho = eps rho and, with
 * per-atom masses, m = eps m (their volume m/rho stays the lattice volume; once per particle: the
 * state is valid afterwards), using the porosity of the first rate evaluation; then the rates again. */
void FixSPHFluid::start_superficial() {
  double any = fresh_.empty() ? 0.0 : 1.0;
  if (multi_) sphdem_mpi::max(world, &any, 1); /* collective below: the ghosts take their owners' new values */
  if (any == 0.0) return;
  const double floor = coupler_->couple_superficial_floor();
  const size_t n = fidx_.size();
  feps_.resize(n);
  check(sphdem_get_porosity(ctx_, feps_.data()), "get_porosity");
  if (atom->rmass)
    for (int k : fresh_) fmass_[k] = atom->rmass[fidx_[k]];
  const int rc = sphdem_superficial_start(floor, (int)fresh_.size(), fresh_.data(), feps_.data(), frho_.data(),
                                          atom->rmass ? fmass_.data() : nullptr);
  if (rc != SPHDEM_OK) /* the arrays are this fix's own: a bug, on this rank */
    sphdem_compat::error_one(error, FLERR, std::string("Fix sph/fluid: superficial_start: ") + sphdem_strerror(rc));
  if (atom->rmass)
    for (int k : fresh_) atom->rmass[fidx_[k]] = fmass_[k];
  if (!atom->rmass && comm->me == 0)
    sphdem_compat::warning(error, FLERR,
                           "Fix sph/fluid: per-type masses: the fluid density starts at eps rho, the masses are "
                           "not scaled by the porosity (use an atom style with per-atom mass, e.g. sphere)");
  if (multi_) {
    fill_gcomm(true, false);
    for (size_t k = nfown_; k < n; k++) frho_[k] = gcomm_[(size_t)GCOMM * fidx_[k] + G_RHO], fmass_[k] = gcomm_[(size_t)GCOMM * fidx_[k] + G_MASS];
  }
  /* x, v are unchanged since the upload; the state stays zero (it was not valid) */
  check(sphdem_set_fluid(ctx_, (int)n, ftag_.data(), fx_.data(), fv_.data(), frho_.data(), fmass_.data(), nullptr),
        "set_fluid");
  if (multi_) {
    check(sphdem_set_ghosts(ctx_, (int)(n - nfown_), -1), "set_ghosts");
    check(sphdem_set_exchange_rows(ctx_, 0, (int)frows_.size(), frows_.data()), "set_exchange_rows");
  }
  if (mp_.enabled) check(sphdem_set_fluid_phase(ctx_, (int)n, fphase_.data()), "set_fluid_phase");
  rates();
}

/* A continued coupled run whose stored rates and grain forces are valid (a restart file, or the run before)
 * starts without a rate evaluation; the core then learns the porosity from the per-atom column, so that the
 * set-up density check and the outputs see the intrinsic density. Skipped when a value is not a porosity. */
void FixSPHFluid::seed_porosity() {
  std::vector<double> eps(fidx_.size());
  for (size_t k = 0; k < fidx_.size(); k++) {
    /* the ghosts' porosity came from their owners with the last upload */
    eps[k] = k < nfown_ ? sa_[fidx_[k]][C_EPS] : gcomm_[(size_t)GCOMM * fidx_[k] + G_EPS];
    if (!(eps[k] > 0.0 && eps[k] <= 1.0)) return;
  }
  check(sphdem_couple_seed_porosity(ctx_, (int)eps.size(), eps.data()), "couple_seed_porosity");
}

/* One rate evaluation; the coupled grains are uploaded before it and their forces fetched after. */
void FixSPHFluid::rates() {
  if (coupler_) coupler_->couple_before_rates(ctx_);
  const int rc = sphdem_compute_rates(ctx_);
  if (rc != SPHDEM_OK && nfluid_steps_ > 0) /* during a run: the fluid went wrong */
    blowup(std::string("compute_rates: ") + sphdem_last_error(ctx_) + " (" + sphdem_strerror(rc) + ")");
  check(rc, "compute_rates");
  if (coupler_) coupler_->couple_after_rates(ctx_);
  host_current_ = false;
}

/* Upload the wall particles (host-authoritative). Each fluid step for moving walls: acceleration is the
 * finite difference of the wall velocity over the fluid step, the previous velocity kept in the
 * per-atom array. */
void FixSPHFluid::upload_walls(bool each_step) {
  const size_t n = widx_.size();
  double **x = atom->x, **v = atom->v;
  wx_.resize(3 * n);
  wv_.resize(3 * n);
  wa_.resize(3 * n);
  wmass_.resize(n);
  const double inv_dt = each_step ? 1.0 / dt_fluid_ : 0.0;
  for (size_t k = 0; k < nwown_; k++) {
    const int i = widx_[k];
    wmass_[k] = atom_mass(atom, i);
    for (int d = 0; d < 3; d++) {
      wx_[3 * k + d] = x[i][d];
      wv_[3 * k + d] = v[i][d];
      wa_[3 * k + d] = each_step ? (v[i][d] - sa_[i][C_WALLV + d]) * inv_dt : 0.0;
      sa_[i][C_WALLV + d] = v[i][d];
    }
  }
  if (multi_) { /* ghost walls: positions from the engine, velocity and acceleration from their owners */
    fill_gcomm(false, true);
    for (size_t k = nwown_; k < n; k++) {
      const int i = widx_[k];
      const double *g = &gcomm_[(size_t)GCOMM * i];
      for (int d = 0; d < 3; d++) wx_[3 * k + d] = x[i][d], wv_[3 * k + d] = g[G_V + d], wa_[3 * k + d] = g[G_A + d];
      wmass_[k] = g[G_MASS];
    }
  }
  check(sphdem_set_walls(ctx_, (int)n, wx_.data(), wv_.data(), wa_.data(), wmass_.data()), "set_walls");
  if (multi_) check(sphdem_set_ghosts(ctx_, -1, (int)(n - nwown_)), "set_ghosts");
  if (multi_ && wrows_new_) { /* the rows stay with the walls' upload order, which changes at builds only */
    check(sphdem_set_exchange_rows(ctx_, 1, (int)wrows_.size(), wrows_.data()), "set_exchange_rows");
    wrows_new_ = false;
  }
  if (!ghost_) return;
  /* fixed ghost walls (Shi & Huang §3.4): each wall particle's interpolation point is its mirror image
   * across the faces of the fluid box it lies outside of */
  wxi_.resize(3 * n);
  int inside = -1;
  std::string bad;
  if (sphdem_mirror_points((int)n, wx_.data(), ghost_lo_, ghost_hi_, wxi_.data(), &inside) != SPHDEM_OK) {
    if (inside < 0) bad = "mirror_points: invalid argument";
    else {
      const size_t k = (size_t)inside;
      char m[256];
      snprintf(m, sizeof m, "ghost mirror: wall atom %lld at (%g, %g, %g) lies inside the fluid box; mirror ghosts "
               "need every wall atom outside it (use the Adami walls, i.e. no ghost keyword, for other shapes)",
               (long long)atom->tag[widx_[k]], wx_[3 * k], wx_[3 * k + 1], wx_[3 * k + 2]);
      bad = m;
    }
  }
  fail_any(!bad.empty(), bad);
  check(sphdem_set_wall_mirror(ctx_, (int)n, wxi_.data()), "set_wall_mirror");
}

/* Many ranks, each fluid step: x, v, rho, drho and a of the owned fluid in the send lists (the rest of the host rows
 * stay as they were until download(): pre_exchange, output steps, the end of a run), x and v into the engine's
 * arrays for its forward communication. */
void FixSPHFluid::download_rows() {
  if (host_current_ || !ctx_) return;
  check(sphdem_get_fluid_rows(ctx_, fx_.data(), fv_.data(), frho_.data(), fstate_.data()), "get_fluid_rows");
  double **x = atom->x, **v = atom->v;
  for (int k : frows_) {
    const int i = fidx_[(size_t)k];
    for (int d = 0; d < 3; d++) x[i][d] = fx_[3 * (size_t)k + d], v[i][d] = fv_[3 * (size_t)k + d];
  }
}

/* Device -> host: x, v and the per-atom columns of the fluid, in the order of the last upload. */
void FixSPHFluid::download() {
  if (host_current_ || !ctx_) return;
  const size_t n = fidx_.size();
  fx_.resize(3 * n);
  fv_.resize(3 * n);
  frho_.resize(n);
  fp_.resize(n);
  fstate_.resize(SPHDEM_NSTATE * n);
  check(sphdem_get_fluid(ctx_, fx_.data(), fv_.data(), frho_.data(), fp_.data(), fstate_.data()), "get_fluid");
  /* the porosity exists after a coupled rate evaluation; before the first one of a continued run the
   * column keeps its previous (restart) values */
  bool have_eps = false;
  if (couple_on_) {
    feps_.resize(n);
    const int rc = sphdem_get_porosity(ctx_, feps_.data());
    if (rc != SPHDEM_ERR_STATE) check(rc, "get_porosity");
    have_eps = rc == SPHDEM_OK;
  }
  bool have_mp = false;
  if (mp_.enabled) {
    fmu_.resize(n), fgd_.resize(n), flam_.resize(n);
    const int rc = sphdem_mp_get_fields(ctx_, fmu_.data(), fgd_.data(), flam_.data(), nullptr);
    if (rc != SPHDEM_ERR_STATE) check(rc, "mp_get_fields");
    have_mp = rc == SPHDEM_OK;
  }
  double **x = atom->x, **v = atom->v;
  for (size_t k = 0; k < nfown_; k++) { /* the ghosts' rows belong to their owners */
    const int i = fidx_[k];
    for (int d = 0; d < 3; d++) x[i][d] = fx_[3 * k + d], v[i][d] = fv_[3 * k + d];
    sa_[i][C_RHO] = frho_[k];
    sa_[i][C_P] = fp_[k];
    if (have_eps) sa_[i][C_EPS] = feps_[k];
    else if (!couple_on_) sa_[i][C_EPS] = 1.0;
    if (have_mp) {
      sa_[i][C_MU] = fmu_[k];
      sa_[i][C_GDOT] = fgd_[k];
      sa_[i][C_LAM] = flam_[k];
    }
    for (int s = 0; s < SPHDEM_NSTATE; s++) sa_[i][C_STATE + s] = fstate_[SPHDEM_NSTATE * k + s];
    sa_[i][C_VALID] = 1.0;
  }
  host_current_ = true;
}

/* ---- time step ---------------------------------------------------------------------------------------- */

/* Sub-cycling (every N): the fluid advances on the steps N, 2N, ... after the run's start, and on
 * the run's last step (a shorter fluid step), so fluid and engine times agree at every fluid step
 * and at the end of each run. With N = 1 every step is a fluid step of length dt. */
void FixSPHFluid::initial_integrate(int) {
  const bigint step = update->ntimestep;
  fluid_step_ = step - last_fluid_step_ >= every_ || step == update->laststep;
  if (!fluid_step_) return;
  dt_fluid_ = (double)(step - last_fluid_step_) * update->dt;
  host_current_ = false;
  if (rk4_) { /* the whole step here: four rate evaluations with the walls as they are now */
    if (walls_move_) upload_walls(true);
    check(sphdem_step_rk4(ctx_, dt_fluid_), "step_rk4");
    if (multi_) download_rows(); /* the engine's forward communication reads the moved fluid it sends */
    check_displacement();
    return;
  }
  check(sphdem_kick(ctx_, 0.5 * dt_fluid_), "kick");
  check(sphdem_drift(ctx_, dt_fluid_), "drift");
  if (multi_) download_rows(); /* the engine's forward communication reads the moved fluid it sends */
  check_displacement();
}

void FixSPHFluid::post_force(int) {
  if (!fluid_step_ || rk4_) return;
  if (walls_move_) upload_walls(true);
  if (multi_) ghost_state_to_core();
  rates();
}

void FixSPHFluid::final_integrate() {
  if (!fluid_step_) return;
  if (!rk4_) check(sphdem_kick(ctx_, 0.5 * dt_fluid_), "kick");
  host_current_ = false;
  const bigint step = update->ntimestep, prev = last_fluid_step_;
  last_fluid_step_ = step;
  nfluid_steps_++;
  /* check when a multiple of check_every_ lies in (prev, step] (with every 1: step % check == 0) */
  if ((check_every_ > 0 && step / check_every_ != prev / check_every_) || step == update->laststep) {
    int rc = sphdem_stats_get(ctx_, (double)every_ * update->dt, &stats_);
    stats_step_ = step;
    if (rc != SPHDEM_OK) {
      const std::string msg = stats_message(rc, stats_);
      blowup(msg);
    }
  }
}

/* The core's message of a failed check; with sub-cycling the time step it judged is the fluid step. */
std::string FixSPHFluid::stats_message(int rc, const sphdem_stats &s) const {
  std::string msg = sphdem_last_error(ctx_);
  if (rc == SPHDEM_ERR_UNSTABLE && every_ > 1) {
    char note[256];
    snprintf(note, sizeof note,
             " With every %ld the fluid step is %ld x timestep: set the timestep to %g or less, or lower every.",
             every_, every_, round_down3(s.dt_stable / (double)every_));
    msg += note;
  }
  return msg;
}

/* ---- blow-up evidence ------------------------------------------------------------------------------ */

void FixSPHFluid::blowup(const std::string &msg, bool from_device) {
  std::string m = "Fix sph/fluid: " + msg;
  if (failure_dump_) {
    const std::string file = write_failure_dump(from_device);
    if (!file.empty())
      m += " The state of step " + std::to_string((long long)update->ntimestep) + " (fluid, walls, grains) is in " +
           file + " (tools/dump2vtk.py converts it for ParaView; failure_dump no turns this off).";
    else
      m += " (the failure dump could not be written)";
  }
  sphdem_compat::error_all(error, FLERR, m);
}

void FixSPHFluid::fail_with_dump(const std::string &msg) {
  if (!failure_dump_) sphdem_compat::error_all(error, FLERR, msg);
  const std::string file = write_failure_dump(true);
  sphdem_compat::error_all(error, FLERR, msg + (file.empty() ? std::string(" (the failure dump could not be written)")
                                                            : " The state of step " +
                                                                  std::to_string((long long)update->ntimestep) +
                                                                  " (fluid, walls, grains) is in " + file +
                                                                  " (tools/dump2vtk.py converts it for ParaView; "
                                                                  "failure_dump no turns this off)."));
}

/* The failure step as a 'dump custom' text file: every local atom with id type x y z vx vy vz density
 * pressure porosity. Fluid: the device state as it is, non-finite values included (from_device: the
 * device holds the fluid in the order of fidx_), else the host copy of the last download; walls: the wall
 * state of the last rate evaluation from the device (porosity 1), else 0; other atoms (grains): the
 * material density m/V, pressure 0, porosity 0. Returns the file name, empty when it could not be written. */
std::string FixSPHFluid::write_failure_dump(bool from_device) {
  const int nlocal = atom->nlocal;
  std::vector<double> rho(nlocal, 0.0), p(nlocal, 0.0), eps(nlocal, 0.0);
  std::vector<char> done(nlocal, 0);
  double **x = atom->x, **v = atom->v;
  std::vector<double> xx(3 * (size_t)nlocal), vv(3 * (size_t)nlocal);
  for (int i = 0; i < nlocal; i++)
    for (int d = 0; d < 3; d++) xx[3 * i + d] = x[i][d], vv[3 * i + d] = v[i][d];
  const size_t n = fidx_.size(), nw = widx_.size();
  for (int i : fidx_)
    if (i < nlocal) rho[i] = sa_[i][C_RHO], p[i] = sa_[i][C_P], eps[i] = sa_[i][C_EPS], done[i] = 1;
  for (int i : widx_)
    if (i < nlocal) done[i] = 1; /* wall density and pressure 0 unless the device has them (below) */
  sphdem_stats st; /* the device's particle counts (the error code does not matter here) */
  std::memset(&st, 0, sizeof st);
  if (from_device && ctx_) sphdem_stats_get(ctx_, 0.0, &st);
  if (from_device && ctx_ && n > 0 && (multi_ || st.nfluid == (int64_t)n)) {
    std::vector<double> fx(3 * n), fv(3 * n), frho(n), fp(n), fe(n, 1.0);
    if (sphdem_get_fluid(ctx_, fx.data(), fv.data(), frho.data(), fp.data(), nullptr) == SPHDEM_OK) {
      if (couple_on_ && sphdem_get_porosity(ctx_, fe.data()) != SPHDEM_OK) fe.assign(n, 1.0);
      for (size_t k = 0; k < n; k++) {
        const int i = fidx_[k];
        if (i >= nlocal) continue;
        for (int d = 0; d < 3; d++) xx[3 * i + d] = fx[3 * k + d], vv[3 * i + d] = fv[3 * k + d];
        rho[i] = frho[k], p[i] = fp[k], eps[i] = fe[k], done[i] = 1;
      }
    }
  }
  if (from_device && ctx_ && nw > 0 && (multi_ || st.nwall == (int64_t)nw)) {
    std::vector<double> wp(nw, 0.0), wr(nw, 0.0);
    if (sphdem_get_wall_state(ctx_, wp.data(), wr.data()) != SPHDEM_OK) wp.assign(nw, 0.0), wr.assign(nw, 0.0);
    for (size_t k = 0; k < nw; k++) {
      const int i = widx_[k];
      if (i >= nlocal) continue;
      rho[i] = wr[k], p[i] = wp[k], eps[i] = 1.0, done[i] = 1;
    }
  }
  const double pi = 3.14159265358979323846;
  for (int i = 0; i < nlocal; i++) {
    if (done[i] || !atom->radius_flag || !atom->rmass || !(atom->radius[i] > 0)) continue;
    const double r = atom->radius[i];
    const double vol = domain->dimension == 2 ? pi * r * r : 4.0 / 3.0 * pi * r * r * r;
    rho[i] = atom->rmass[i] / vol;
  }
  std::string file = failure_file_;
  if (file.empty()) file = "sphdem_failure." + std::to_string((long long)update->ntimestep) + ".dump";
  /* every rank's atoms, one file written by rank 0 (collective on many ranks) */
  std::string lines;
  char row[512];
  for (int i = 0; i < nlocal; i++) {
    snprintf(row, sizeof row, "%lld %d %.10g %.10g %.10g %.10g %.10g %.10g %.10g %.10g %.10g\n",
             (long long)atom->tag[i], atom->type[i], xx[3 * i], xx[3 * i + 1], xx[3 * i + 2], vv[3 * i],
             vv[3 * i + 1], vv[3 * i + 2], rho[i], p[i], eps[i]);
    lines += row;
  }
  long long natoms = nlocal;
  if (multi_) {
    int len = (int)lines.size(), nr = comm->nprocs;
    std::vector<int> lens(nr), offs(nr, 0);
    MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, world);
    std::string all;
    if (comm->me == 0) {
      for (int r = 1; r < nr; r++) offs[r] = offs[r - 1] + lens[r - 1];
      all.resize((size_t)offs[nr - 1] + (size_t)lens[nr - 1]);
    }
    MPI_Gatherv(lines.data(), len, MPI_CHAR, comm->me == 0 ? &all[0] : nullptr, lens.data(), offs.data(), MPI_CHAR,
                0, world);
    double na = (double)nlocal;
    sphdem_mpi::sum(world, &na, 1);
    natoms = (long long)na;
    lines.swap(all);
  }
  int ok = 1;
  if (comm->me == 0) {
    FILE *fp = fopen(file.c_str(), "w");
    if (!fp) ok = 0;
    else {
      fprintf(fp, "ITEM: TIMESTEP\n" BIGINT_FORMAT "\nITEM: NUMBER OF ATOMS\n%lld\nITEM: BOX BOUNDS %s %s %s\n",
              update->ntimestep, natoms, domain->periodicity[0] ? "pp" : "ff", domain->periodicity[1] ? "pp" : "ff",
              domain->periodicity[2] ? "pp" : "ff");
      for (int d = 0; d < 3; d++) fprintf(fp, "%.17g %.17g\n", domain->boxlo[d], domain->boxhi[d]);
      fprintf(fp, "ITEM: ATOMS id type x y z vx vy vz density pressure porosity\n");
      fputs(lines.c_str(), fp);
      ok = fclose(fp) == 0;
    }
  }
  if (multi_) MPI_Bcast(&ok, 1, MPI_INT, 0, world);
  return ok ? file : "";
}

/* Set-up checks of the uploaded scene (once per fix): the particle masses against rho0 dx^dim (a wrong rho0,
 * h or dx gives forces scaled by orders of magnitude: the fluid free-falls or explodes), then, for a fresh
 * start (atoms without a state from a restart file or an earlier run, where a flow may have brought particles
 * close), particles on top of each other or of wall particles (the core's cell search, closer than 0.5 dx). */
void FixSPHFluid::check_scene(bool fresh) {
  scene_checked_ = true;
  double sum = 0.0, cnt = (double)nfown_;
  for (size_t k = 0; k < nfown_; k++) {
    const int i = fidx_[k];
    const double rho0 = mp_.enabled ? mp_.phase[type_phase_[atom->type[i]]].rho0 : prm_.rho0;
    sum += atom_mass(atom, i) / rho0;
  }
  if (multi_) {
    double v[2] = {sum, cnt};
    sphdem_mpi::sum(world, v, 2);
    sum = v[0], cnt = v[1];
  }
  const double n = cnt;
  if (n == 0) return;
  const double vol = std::pow(prm_.dx, prm_.dim);
  const double ratio = sum / (double)n / vol;
  char msg[768];
  if (!(ratio >= 0.02 && ratio <= 50.0)) {
    snprintf(msg, sizeof msg,
             "the fluid particle masses do not match rho0 dx^%d: mean particle mass / rho0 = %g, dx^%d = %g (dx %g%s), "
             "a ratio of %g (expected near 1). Check rho0, h, dx and the atoms' mass (in 2D the mass is per unit "
             "depth, rho0 dx^2)",
             prm_.dim, sum / (double)n, prm_.dim, vol, prm_.dx, have_dx_ ? "" : " = h/1.3, give dx", ratio);
    fail(msg);
  }
  if (!fresh) return;
  double r[8];
  check(sphdem_check_spacing(ctx_, 0.5 * prm_.dx, r), "check_spacing");
  msg[0] = 0;
  if (r[0] > 0)
    snprintf(msg, sizeof msg,
             "%.0f pairs of fluid particles closer than 0.5 dx (%g), e.g. atoms %.0f and %.0f at distance %g: atoms "
             "created twice or on top of each other (check the regions of create_atoms)",
             r[0], 0.5 * prm_.dx, r[2], r[3], r[4]);
  fail_any(r[0] > 0, msg);
  if (r[1] > 0 && multi_) { /* the wall of the pair may be a ghost: name it by its tag only */
    snprintf(msg, sizeof msg,
             "fluid-wall pairs closer than 0.5 dx (%g), e.g. fluid atom %.0f at distance %g from a wall atom: fluid "
             "created inside the walls (check the regions of create_atoms)", 0.5 * prm_.dx, r[5], r[7]);
  }
  if (multi_) fail_any(r[1] > 0, msg);
  if (r[1] > 0) {
    const int w = (int)r[6];
    const long long wt = w >= 0 && w < (int)widx_.size() ? (long long)atom->tag[widx_[w]] : -1;
    snprintf(msg, sizeof msg,
             "%.0f fluid-wall pairs closer than 0.5 dx (%g), e.g. fluid atom %.0f and wall atom %lld at distance %g: "
             "fluid created inside the walls (check the regions of create_atoms)",
             r[1], 0.5 * prm_.dx, r[5], wt, r[7]);
    fail(msg);
  }
}

bool FixSPHFluid::output_step() const {
  const bigint step = update->ntimestep;
  return step == output->next || (sync_every_ > 0 && step % sync_every_ == 0);
}

void FixSPHFluid::end_of_step() {
  if (output_step()) download();
}

void FixSPHFluid::pre_exchange() { download(); }

void FixSPHFluid::pre_neighbor() {
  /* atoms were exchanged and maybe sorted: new local indices; the box may have changed */
  box_to_params();
  check(sphdem_set_params(ctx_, &prm_), "set_params");
  build_map();
  if (!upload_fluid()) rates(); /* new fluid atoms without a valid state */
  if (!walls_move_) upload_walls(false); /* moving walls are uploaded in post_force anyway */
}

void FixSPHFluid::post_run() {
  download();
  /* where the fluid's time went in this run (the engine's own breakdown counts all of it under Modify) */
  const bigint steps = update->ntimestep - run_step0_;
  if (comm->me == 0 && ctx_ && steps > 0) {
    double t[SPHDEM_NTIMERS];
    sphdem_timers(ctx_, t);
    double tot = 0.0;
    for (int k = 0; k < SPHDEM_NTIMERS; k++) tot += t[k];
    char line[512];
    snprintf(line, sizeof line,
             "Fix sph/fluid timing (s, this run): sort %.4g, walls %.4g, rates %.4g, coupling %.4g, integrate %.4g, "
             "transfer %.4g, reduce %.4g; total %.4g over %ld fluid steps\n",
             t[SPHDEM_T_SORT], t[SPHDEM_T_WALL], t[SPHDEM_T_RATES], t[SPHDEM_T_COUPLE], t[SPHDEM_T_INTEGRATE],
             t[SPHDEM_T_TRANSFER], t[SPHDEM_T_REDUCE], tot, (long)nfluid_steps_);
    sphdem_compat::logmesg(lmp, line);
    if (multi_) {
      snprintf(line, sizeof line,
               "Fix sph/fluid: rank 0 moves the boundary slice between the core and the host each fluid step: %zu of "
               "%zu owned fluid atoms (those other ranks see), %zu ghost fluid atoms\n",
               frows_.size(), nfown_, fidx_.size() - nfown_);
      sphdem_compat::logmesg(lmp, line);
    }
  }
}

/* ---- output ------------------------------------------------------------------------------------------ */

double FixSPHFluid::compute_vector(int n) {
  if (!ctx_) return 0.0;
  if (stats_step_ != update->ntimestep) {
    sphdem_stats_get(ctx_, 0.0, &stats_); /* errors are reported by the periodic check */
    stats_step_ = update->ntimestep;
  }
  switch (n) {
    case 0: return stats_.dt_stable;
    case 1: return stats_.rho_err;
    case 2: return stats_.ke;
    case 3: {
      const double dt_wall = wall_seconds() - run_t0_;
      const double steps = (double)nfluid_steps_;
      return dt_wall > 0 ? steps * (double)stats_.nfluid / dt_wall : 0.0;
    }
  }
  return 0.0;
}

double FixSPHFluid::memory_usage() {
  return (double)atom->nmax * NCOL * sizeof(double) +
         (double)(fx_.capacity() + fv_.capacity() + frho_.capacity() + fp_.capacity() + fmass_.capacity() +
                  fstate_.capacity() + wx_.capacity() + wv_.capacity() + wa_.capacity() + wmass_.capacity()) *
             sizeof(double);
}
