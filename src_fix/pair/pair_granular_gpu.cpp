/* pair_granular_gpu.cpp - pair_style granular/gpu (LAMMPS): the words of the stock pair_style granular
 * (LAMMPS 29 Sep 2021) read into a table of type-pair coefficients, mixed as the stock style mixes them, and
 * handed to the sphdem DEM core, whose sub-model bodies (dem_bodies.h) compute the contacts. Contact history
 * (tangential, rolling, twisting) is kept in the core keyed by the two atom tags. No physics here. */
#include "pair_granular_gpu.h"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <cstring>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "fix.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neighbor.h"
#include "sphdem_compat.h"
#include "update.h"
#include "utils.h"

using namespace LAMMPS_NS;

namespace {
const char *const NORMAL_WORDS = "hooke, hertz, hertz/material, dmt";
const char *const DAMPING_WORDS = "velocity, mass_velocity, viscoelastic, tsuji";
const char *const TANGENTIAL_WORDS = "linear_nohistory, linear_history, mindlin";
const char *const ROLLING_WORDS = "none, sds";
const char *const TWISTING_WORDS = "none, marshall, sds";
const char *const KEYWORDS = "hooke, hertz, hertz/material, dmt, damping, tangential, rolling, twisting, cutoff, "
                             "limit_damping";

/* the stock style's effective moduli (PairGranular::mix_stiffnessE, mix_stiffnessG) */
double mix_E(double Ei, double Ej, double pi, double pj) { return 1 / ((1 - pi * pi) / Ei + (1 - pj * pj) / Ej); }
double mix_G(double Ei, double Ej, double pi, double pj) {
  return 1 / ((2 * (2 - pi) * (1 + pi) / Ei) + (2 * (2 - pj) * (1 + pj) / Ej));
}
/* x^n by repeated squaring, in the order of LAMMPS' MathSpecial::powint (the tsuji polynomial) */
double powint(double x, int n) {
  double y = 1.0, w = x;
  for (int k = n; k != 0; k >>= 1, w *= w)
    if (k & 1) y *= w;
  return y;
}
/* tsuji: the damping coefficient alpha(e) of the restitution coefficient e (the stock polynomial fit) */
double tsuji_alpha(double e) {
  return 1.2728 - 4.2783 * e + 11.087 * (e * e) - 22.348 * (e * e * e) + 27.467 * powint(e, 4) -
         18.022 * powint(e, 5) + 4.8218 * powint(e, 6);
}
bool material_model(int normal) { return normal == SPHDEM_GRAN_HERTZ_MATERIAL || normal == SPHDEM_GRAN_DMT; }
}  // namespace

PairGranularGPU::PairGranularGPU(LAMMPS *lmp) : PairGranGPUBase(lmp, "granular/gpu"), cutoff_global_(-1.0), table_sent_(false), track_order_(false),
      order_owned_set_(false), gathered_order_(false) {
  single_enable = 1;
  single_extra = 12;
  svector = new double[12];
}

PairGranularGPU::~PairGranularGPU() { delete[] svector; }

/* compute pair/local: the stock single() values (29 Sep 2021) of the touching pair i, j from the core's contact (the
 * force on i and the torques on i and j): fforce = F_n / r; svector the tangential force fs and |fs|, the rolling
 * force fr and |fr|, the twisting torque M_t, and x_i - x_j. The stock style puts the torques on i and j as
 * -(r_i - delta/2) (n x fs) + R_eff (n x fr) + M_t n and -(r_j - delta/2) (n x fs) - R_eff (n x fr) - M_t n, so
 * half their difference, with (r_i - r_j)/2 (n x fs) added back, is M_t n + R_eff (n x fr) (fr lies in the
 * tangent plane). */
double PairGranularGPU::single(int i, int j, int itype, int jtype, double rsq, double, double, double &fforce) {
  fforce = 0.0;
  for (int k = 0; k < single_extra; k++) svector[k] = 0.0;
  const double ri = atom->radius[i], rj = atom->radius[j], radsum = ri + rj;
  if (rsq >= radsum * radsum) return 0.0;
  bool i_is_a;
  const double *c = single_contact(i, j, i_is_a);
  const double s = i_is_a ? 1.0 : -1.0;
  const double *Ti = i_is_a ? c + 3 : c + 6, *Tj = i_is_a ? c + 6 : c + 3;
  double **x = atom->x;
  const double del[3] = {x[i][0] - x[j][0], x[i][1] - x[j][1], x[i][2] - x[j][2]};
  const double r = std::sqrt(rsq), n[3] = {del[0] / r, del[1] / r, del[2] / r};
  const double fi[3] = {s * c[0], s * c[1], s * c[2]};
  const double fn = fi[0] * n[0] + fi[1] * n[1] + fi[2] * n[2];
  double fs[3], w[3];
  for (int d = 0; d < 3; d++) fs[d] = fi[d] - fn * n[d];
  const double q[3] = {n[1] * fs[2] - n[2] * fs[1], n[2] * fs[0] - n[0] * fs[2], n[0] * fs[1] - n[1] * fs[0]};
  for (int d = 0; d < 3; d++) w[d] = 0.5 * (Ti[d] - Tj[d] + (ri - rj) * q[d]);
  const sphdem_dem_granular &m = at(itype, jtype);
  const double mt = m.twisting != SPHDEM_GRAN_TWIST_NONE ? w[0] * n[0] + w[1] * n[1] + w[2] * n[2] : 0.0;
  double fr[3] = {0.0, 0.0, 0.0};
  if (m.rolling != SPHDEM_GRAN_ROLL_NONE) {
    const double reff = ri * rj / radsum, u[3] = {w[0] - mt * n[0], w[1] - mt * n[1], w[2] - mt * n[2]};
    fr[0] = (u[1] * n[2] - u[2] * n[1]) / reff; /* (u x n) / R_eff */
    fr[1] = (u[2] * n[0] - u[0] * n[2]) / reff;
    fr[2] = (u[0] * n[1] - u[1] * n[0]) / reff;
  }
  fforce = fn / r;
  for (int d = 0; d < 3; d++) svector[d] = fs[d], svector[4 + d] = fr[d], svector[9 + d] = del[d];
  svector[3] = std::sqrt(fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]);
  svector[7] = std::sqrt(fr[0] * fr[0] + fr[1] * fr[1] + fr[2] * fr[2]);
  svector[8] = mt;
  return 0.0;
}

/* pair_style granular/gpu [cutoff] [device auto|cpu|gpu] [algo pair|particle] [timers on|off] */
void PairGranularGPU::settings(int narg, char **arg) {
  cutoff_global_ = -1.0;
  int k = 0;
  double c;
  if (narg > 0 && sphdem_compat::to_double(arg[0], &c)) {
    if (!(c > 0.0)) fail("the global cutoff must be > 0 (got " + std::string(arg[0]) + ")");
    cutoff_global_ = c;
    k = 1;
  }
  for (; k < narg; k++) {
    std::string kw = arg[k];
    if (k + 1 < narg && common_keyword(kw, arg[k + 1])) {
      k++;
    } else {
      fail("unsupported argument '" + kw + "' (usage: pair_style granular/gpu [cutoff] [device auto|cpu|gpu] "
           "[algo pair|particle] [timers on|off]; the models go in pair_coeff)");
    }
  }
  if (dem_) sync_params();
}

/* pair_coeff I J <normal> ... tangential <model> ... [damping ...] [rolling ...] [twisting ...] [cutoff c]
 * [limit_damping], the stock words and their order-free parsing */
void PairGranularGPU::coeff(int narg, char **arg) {
  if (narg < 2) fail("pair_coeff needs two type ranges and the models");
  if (!allocated) allocate();
  const int nt = atom->ntypes;
  if (coef_.size() != (size_t)(nt + 1) * (nt + 1)) {
    coef_.assign((size_t)(nt + 1) * (nt + 1), sphdem_dem_granular());
    emod_.assign(coef_.size(), 0.0);
    poiss_.assign(coef_.size(), 0.0);
    cut_type_.assign(coef_.size(), -1.0);
  }
  int ilo, ihi, jlo, jhi;
  utils::bounds(FLERR, arg[0], 1, nt, ilo, ihi, error);
  utils::bounds(FLERR, arg[1], 1, nt, jlo, jhi, error);
  sphdem_dem_granular C;
  std::memset(&C, 0, sizeof C);
  C.normal = C.tangential = -1;
  C.damping = SPHDEM_GRAN_DAMP_VISCOELASTIC; /* the stock default */
  C.rolling = SPHDEM_GRAN_ROLL_NONE;
  C.twisting = SPHDEM_GRAN_TWIST_NONE;
  double E = 0.0, nu = 0.0, cutoff_one = -1.0;
  bool kt_null = false;
  auto need = [&](int iarg, int n, const std::string &what, const std::string &usage) {
    if (iarg + n >= narg) fail("pair_coeff: " + what + " needs " + std::to_string(n) + " values (" + usage + ")");
  };
  auto num = [&](int k, const std::string &what) {
    double v;
    if (!sphdem_compat::to_double(arg[k], &v)) fail("pair_coeff: " + what + " '" + arg[k] + "' is not a number");
    return v;
  };
  int iarg = 2;
  while (iarg < narg) {
    const std::string w = arg[iarg];
    if (w == "hooke" || w == "hertz") {
      need(iarg, 2, w, w + " k_n damping");
      C.normal = w == "hooke" ? SPHDEM_GRAN_HOOKE : SPHDEM_GRAN_HERTZ;
      C.kn = num(iarg + 1, w + " k_n");
      C.damp = num(iarg + 2, w + " damping");
      iarg += 3;
    } else if (w == "hertz/material") {
      need(iarg, 3, w, "hertz/material E damping poisson");
      C.normal = SPHDEM_GRAN_HERTZ_MATERIAL;
      E = num(iarg + 1, "hertz/material E");
      C.damp = num(iarg + 2, "hertz/material damping");
      nu = num(iarg + 3, "hertz/material poisson");
      iarg += 4;
    } else if (w == "dmt") {
      need(iarg, 4, w, "dmt E damping poisson cohesion");
      C.normal = SPHDEM_GRAN_DMT;
      E = num(iarg + 1, "dmt E");
      C.damp = num(iarg + 2, "dmt damping");
      nu = num(iarg + 3, "dmt poisson");
      C.cohesion = num(iarg + 4, "dmt cohesion");
      iarg += 5;
    } else if (w == "jkr") {
      fail("pair_coeff: normal model 'jkr' is not supported by granular/gpu (its contacts reach beyond touching); "
           "supported normal models: " + std::string(NORMAL_WORDS) + "; use the stock pair_style granular for jkr");
    } else if (w == "damping") {
      need(iarg, 1, w, std::string("damping ") + DAMPING_WORDS);
      const std::string m = arg[iarg + 1];
      if (m == "velocity") C.damping = SPHDEM_GRAN_DAMP_VELOCITY;
      else if (m == "mass_velocity") C.damping = SPHDEM_GRAN_DAMP_MASS_VELOCITY;
      else if (m == "viscoelastic") C.damping = SPHDEM_GRAN_DAMP_VISCOELASTIC;
      else if (m == "tsuji") C.damping = SPHDEM_GRAN_DAMP_TSUJI;
      else fail("pair_coeff: unknown damping model '" + m + "' (allowed: " + DAMPING_WORDS + ")");
      iarg += 2;
    } else if (w == "tangential") {
      need(iarg, 1, w, std::string("tangential ") + TANGENTIAL_WORDS);
      const std::string m = arg[iarg + 1];
      if (m == "linear_nohistory") {
        need(iarg, 3, "tangential linear_nohistory", "tangential linear_nohistory x_gamma_t mu_s");
        C.tangential = SPHDEM_GRAN_TANG_LINEAR_NOHISTORY;
        C.kt = 0.0;
        C.damp_t = num(iarg + 2, "tangential x_gamma_t");
        C.mu = num(iarg + 3, "tangential mu_s");
        iarg += 4;
      } else if (m == "linear_history" || m == "mindlin") {
        need(iarg, 4, "tangential " + m, "tangential " + m + " k_t" + (m == "mindlin" ? "|NULL" : "") + " x_gamma_t mu_s");
        C.tangential = m == "mindlin" ? SPHDEM_GRAN_TANG_MINDLIN : SPHDEM_GRAN_TANG_LINEAR_HISTORY;
        kt_null = m == "mindlin" && std::strcmp(arg[iarg + 2], "NULL") == 0;
        C.kt = kt_null ? 0.0 : num(iarg + 2, "tangential k_t");
        C.damp_t = num(iarg + 3, "tangential x_gamma_t");
        C.mu = num(iarg + 4, "tangential mu_s");
        iarg += 5;
      } else if (m == "mindlin_rescale" || m == "mindlin/force" || m == "mindlin_rescale/force") {
        fail("pair_coeff: tangential model '" + m + "' is not supported by granular/gpu (supported: " +
             TANGENTIAL_WORDS + "); use the stock pair_style granular for it");
      } else {
        fail("pair_coeff: unknown tangential model '" + m + "' (allowed: " + TANGENTIAL_WORDS + ")");
      }
    } else if (w == "rolling") {
      need(iarg, 1, w, std::string("rolling ") + ROLLING_WORDS);
      const std::string m = arg[iarg + 1];
      if (m == "none") {
        C.rolling = SPHDEM_GRAN_ROLL_NONE;
        iarg += 2;
      } else if (m == "sds") {
        need(iarg, 4, "rolling sds", "rolling sds k_roll gamma_roll mu_roll");
        C.rolling = SPHDEM_GRAN_ROLL_SDS;
        C.kr = num(iarg + 2, "rolling k_roll");
        C.damp_r = num(iarg + 3, "rolling gamma_roll");
        C.mu_r = num(iarg + 4, "rolling mu_roll");
        iarg += 5;
      } else {
        fail("pair_coeff: unknown rolling model '" + m + "' (allowed: " + ROLLING_WORDS + ")");
      }
    } else if (w == "twisting") {
      need(iarg, 1, w, std::string("twisting ") + TWISTING_WORDS);
      const std::string m = arg[iarg + 1];
      if (m == "none" || m == "marshall") {
        C.twisting = m == "none" ? SPHDEM_GRAN_TWIST_NONE : SPHDEM_GRAN_TWIST_MARSHALL;
        iarg += 2;
      } else if (m == "sds") {
        need(iarg, 4, "twisting sds", "twisting sds k_twist gamma_twist mu_twist");
        C.twisting = SPHDEM_GRAN_TWIST_SDS;
        C.ktw = num(iarg + 2, "twisting k_twist");
        C.damp_tw = num(iarg + 3, "twisting gamma_twist");
        C.mu_tw = num(iarg + 4, "twisting mu_twist");
        iarg += 5;
      } else {
        fail("pair_coeff: unknown twisting model '" + m + "' (allowed: " + TWISTING_WORDS + ")");
      }
    } else if (w == "cutoff") {
      need(iarg, 1, w, "cutoff value");
      cutoff_one = num(iarg + 1, "cutoff");
      iarg += 2;
    } else if (w == "limit_damping") {
      C.limit_damping = 1;
      iarg += 1;
    } else {
      fail("pair_coeff: unknown keyword '" + w + "' (allowed: " + KEYWORDS + ")");
    }
  }
  if (C.normal < 0) fail(std::string("pair_coeff: no normal model (give one of ") + NORMAL_WORDS + ")");
  if (C.tangential < 0) fail(std::string("pair_coeff: no tangential model (give tangential with one of ") + TANGENTIAL_WORDS + ")");
  if (kt_null && !material_model(C.normal))
    fail("pair_coeff: mindlin with k_t NULL needs a normal model with material properties (hertz/material or dmt)");
  if (C.limit_damping && C.normal == SPHDEM_GRAN_DMT) fail("pair_coeff: limit_damping cannot be used with the dmt model");
  if (C.damping == SPHDEM_GRAN_DAMP_TSUJI) C.damp = tsuji_alpha(C.damp); /* damping tsuji: the value is e */
  if (material_model(C.normal)) C.kn = 4.0 / 3.0 * mix_E(E, E, nu, nu);
  if (kt_null) C.kt = 8 * mix_G(E, E, nu, nu);
  int count = 0;
  for (int i = ilo; i <= ihi; i++)
    for (int j = (jlo > i ? jlo : i); j <= jhi; j++) {
      at(i, j) = at(j, i) = C;
      const size_t ij = (size_t)i * (nt + 1) + j, ji = (size_t)j * (nt + 1) + i;
      emod_[ij] = emod_[ji] = E;
      poiss_[ij] = poiss_[ji] = nu;
      cut_type_[ij] = cut_type_[ji] = cutoff_one;
      setflag[i][j] = 1;
      count++;
    }
  if (count == 0) fail("incorrect args for pair coefficients");
  table_sent_ = false;
}

void PairGranularGPU::init_style() {
  check_atoms("atom_style sphere");
  if (!comm->ghost_velocity) fail("requires ghost atoms store velocity: comm_modify vel yes (as the stock pair_style granular)");
  scan_rigid_freeze();
  /* the stock style evaluates the tangential law of every pair through its history branch when any pair keeps
   * a tangential history: a linear_nohistory pair then divides by k_t = 0 */
  const int nt = atom->ntypes;
  bool hist = false, nohist = false;
  for (int i = 1; i <= nt; i++)
    for (int j = i; j <= nt; j++)
      if (setflag[i][j]) (at(i, j).tangential == SPHDEM_GRAN_TANG_LINEAR_NOHISTORY ? nohist : hist) = true;
  if (hist && nohist)
    fail("tangential linear_nohistory together with linear_history or mindlin in one run is not supported (the stock "
         "style then treats linear_nohistory as a history model with k_t = 0)");
  /* rolling and twisting: the engine's half list gives the pair order that the stock history transfer follows */
  bool roll_twist = false;
  for (int i = 1; i <= nt; i++)
    for (int j = i; j <= nt; j++)
      if (setflag[i][j] && (at(i, j).rolling != SPHDEM_GRAN_ROLL_NONE || at(i, j).twisting != SPHDEM_GRAN_TWIST_NONE))
        roll_twist = true;
  if (roll_twist && ghosts_ && !force->newton_pair)
    fail("rolling and twisting models on more than one MPI rank need newton on (the default): with newton off the "
         "stock style keeps two histories for a pair split between two ranks, one per rank, whose signs its "
         "history transfer can make differ");
  if (roll_twist && !force->newton_pair && (domain->periodicity[0] || domain->periodicity[1] || domain->periodicity[2]))
    fail("rolling and twisting models with newton off in a periodic box are not supported (the stock style then keeps "
         "two histories for a pair across the boundary, one per atom, whose signs its history transfer can make "
         "differ); use newton on (the default)");
  track_order_ = roll_twist;
  /* (rolling, twisting: the order of each pair's atoms in every rank's list is followed; compute pair/local asks
   * each rank for the pairs of its own list: a pair split between two ranks is then evaluated on both) */
  ghost_once_ok_ = !roll_twist && !pair_local_present();
  bool rolling = false; /* rolling sds keeps a rolling displacement per contact: it goes with the hand-over */
  for (int i = 1; i <= nt; i++)
    for (int j = i; j <= nt; j++)
      if (setflag[i][j] && at(i, j).rolling != SPHDEM_GRAN_ROLL_NONE) rolling = true;
  hand_rolling_ = rolling;
  if (track_order_) neighbor->request(this, instance_me); /* order_prev_ is kept from run to run, as the history */
  /* the radii per type (stock init_style): the grains, frozen ones apart, and what fix pour / deposit insert */
  std::vector<double> dyn(nt + 1, 0.0), frz(nt + 1, 0.0);
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (std::strncmp(f->style, "pour", 4) != 0 && std::strncmp(f->style, "deposit", 7) != 0) continue;
    for (int t = 1; t <= nt; t++) {
      int itype = t;
      const double *r = (const double *)f->extract("radius", itype);
      if (r && *r > 0.0) dyn[t] = *r;
    }
  }
  reduce_maxrad(dyn, frz);
  sync_params();
  create_core();
  restore_history();
  table_sent_ = false;
}

/* The cutoff of a type pair (stock PairGranular::init_one): the largest contact distance of the two types'
 * radii, the pair's cutoff keyword, or the global cutoff. Unset pairs are refused (no mixing). */
double PairGranularGPU::init_one(int i, int j) {
  const int nt = atom->ntypes;
  if (setflag[i][j] == 0)
    fail("type pair " + std::to_string(i) + " " + std::to_string(j) + " has no pair_coeff: granular/gpu does not mix "
         "coefficients (the stock 2021 pair_style granular leaves the models of a mixed pair unset and drops the 4/3 "
         "of E*, so its mixed pairs differ from the same values given explicitly); give pair_coeff " +
         std::to_string(i) + " " + std::to_string(j) + " (or pair_coeff * * before the per-type lines)");
  const double ct = cut_type_[(size_t)i * (nt + 1) + j];
  if (ct < 0.0 && cutoff_global_ < 0.0) {
    const double *d = maxrad_dynamic_.data(), *z = maxrad_frozen_.data();
    if ((d[i] > 0.0 && d[j] > 0.0) || (d[i] > 0.0 && z[j] > 0.0) || (z[i] > 0.0 && d[j] > 0.0))
      return PairGranGPUBase::init_one(i, j);
    double cutmax = 0.0; /* no radius known for one of the types: the largest contact distance of any */
    for (int k = 1; k <= nt; k++) cutmax = std::fmax(cutmax, std::fmax(2.0 * d[k], 2.0 * z[k]));
    return cutmax;
  }
  return ct > 0.0 ? ct : cutoff_global_;
}

void PairGranularGPU::send_table() {
  const int nt = atom->ntypes;
  std::vector<sphdem_dem_granular> t((size_t)nt * nt);
  for (int i = 1; i <= nt; i++)
    for (int j = 1; j <= nt; j++) t[(size_t)(i - 1) * nt + (j - 1)] = at(i, j);
  if (sphdem_dem_set_granular(dem_, nt, t.data())) fail(std::string("DEM core: ") + sphdem_dem_last_error(dem_));
  table_sent_ = true;
}

/* At an engine list build: the pairs (within r_i + r_j + skin) whose first atom in the half list changed since
 * the previous build get their rolling and twisting history negated, as LAMMPS' fix neigh/history does. Many
 * ranks (newton on: each pair is in one rank's list): the ranks exchange the order of the pairs their lists
 * share with another rank's atom, and the previous order of the pairs of atoms that changed rank. */
void PairGranularGPU::follow_list_order() {
  const double skin = neighbor->skin;
  double **x = atom->x, *rad = atom->radius;
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal;
  order_now_.clear();
  std::vector<uint64_t> boundary; /* many ranks: the pairs of this list with another rank's atom */
  for (int ii = 0; ii < list->inum; ii++) {
    const int i = list->ilist[ii];
    const int *jl = list->firstneigh[i];
    for (int jj = 0; jj < list->numneigh[i]; jj++) {
      const int j = jl[jj] & NEIGHMASK;
      const uint64_t ti = (uint64_t)tag[i], tj = (uint64_t)tag[j];
      if (ti == tj) continue;
      const double dx = x[i][0] - x[j][0], dy = x[i][1] - x[j][1], dz = x[i][2] - x[j][2], c = rad[i] + rad[j] + skin;
      if (dx * dx + dy * dy + dz * dz >= c * c) continue;
      const uint64_t key = ti < tj ? (ti << 32) | tj : (tj << 32) | ti;
      const uint64_t e = (key << 1) | (ti < tj ? 1u : 0u);
      order_now_.push_back(e);
      if (ghosts_ && j >= nlocal && image_of_[j - nlocal] < 0) boundary.push_back(e);
    }
  }
  if (ghosts_) merge_rank_orders(boundary);
  std::sort(order_now_.begin(), order_now_.end());
  flips_.clear();
  size_t a = 0, b = 0;
  while (a < order_prev_.size() && b < order_now_.size()) {
    const uint64_t ka = order_prev_[a] >> 1, kb = order_now_[b] >> 1;
    if (ka < kb) a++;
    else if (kb < ka) b++;
    else {
      if ((order_prev_[a] & 1u) != (order_now_[b] & 1u)) flips_.push_back(ka);
      a++, b++;
    }
  }
  order_prev_.swap(order_now_);
  if (!flips_.empty() && sphdem_dem_flip_history(dem_, (int64_t)flips_.size(), flips_.data()))
    fail(std::string("DEM core: ") + sphdem_dem_last_error(dem_));
}

namespace {
/* entries (key << 1 | bit) sorted by key, each key once (the first) */
void sort_unique_keys(std::vector<uint64_t> &v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end(), [](uint64_t a, uint64_t b) { return (a >> 1) == (b >> 1); }), v.end());
}
/* one of the pair's two tags in sorted */
bool pair_of(const std::vector<int64_t> &sorted, uint64_t e) {
  const uint64_t key = e >> 1;
  return std::binary_search(sorted.begin(), sorted.end(), (int64_t)(key >> 32)) ||
         std::binary_search(sorted.begin(), sorted.end(), (int64_t)(key & 0xffffffffu));
}
/* every rank's v, concatenated on every rank */
std::vector<uint64_t> all_of(MPI_Comm world, int nprocs, const std::vector<uint64_t> &v) {
  const int n = (int)v.size();
  std::vector<int> cnt(nprocs), dsp(nprocs);
  MPI_Allgather(&n, 1, MPI_INT, cnt.data(), 1, MPI_INT, world);
  int total = 0;
  for (int r = 0; r < nprocs; r++) dsp[r] = total, total += cnt[r];
  std::vector<uint64_t> all((size_t)total);
  MPI_Allgatherv(v.data(), n, MPI_UINT64_T, all.data(), cnt.data(), dsp.data(), MPI_UINT64_T, world);
  return all;
}
}  // namespace

/* Many ranks, collective. order_now_ gets the pairs of other ranks' lists that hold one of this rank's atoms (a
 * pair split between two ranks is in the list of one of them; both hold its history); order_prev_ gets the
 * previous order of the pairs whose atom joined this rank, from the rank it left. */
void PairGranularGPU::merge_rank_orders(std::vector<uint64_t> &boundary) {
  const int nlocal = atom->nlocal;
  std::vector<int64_t> now((size_t)nlocal);
  for (int i = 0; i < nlocal; i++) now[i] = (int64_t)atom->tag[i];
  std::sort(now.begin(), now.end());
  std::vector<uint64_t> gone; /* the previous order of the pairs of atoms that left this rank */
  if (order_owned_set_) {
    std::vector<int64_t> left;
    std::set_difference(order_owned_.begin(), order_owned_.end(), now.begin(), now.end(), std::back_inserter(left));
    if (!left.empty())
      for (uint64_t e : order_prev_)
        if (pair_of(left, e)) gone.push_back(e);
  }
  const std::vector<uint64_t> rb = all_of(world, comm->nprocs, boundary), rg = all_of(world, comm->nprocs, gone);
  for (uint64_t e : rb)
    if (pair_of(now, e)) order_now_.push_back(e);
  sort_unique_keys(order_now_);
  bool added = false;
  for (uint64_t e : rg)
    if (pair_of(now, e)) order_prev_.push_back(e), added = true;
  if (added) sort_unique_keys(order_prev_); /* (a pair held here already keeps the entry it had: the same) */
  order_owned_.swap(now);
  order_owned_set_ = true;
}

/* Many ranks, collective: every rank's pair order to rank 0 (each pair once), for write_restart. */
void PairGranularGPU::gather_order() {
  const int n = (int)order_prev_.size(), nr = comm->nprocs;
  std::vector<int> cnt(nr), dsp(nr);
  MPI_Gather(&n, 1, MPI_INT, cnt.data(), 1, MPI_INT, 0, world);
  int total = 0;
  for (int r = 0; r < nr; r++) dsp[r] = total, total += cnt[r];
  gorder_.assign(comm->me == 0 ? (size_t)total : 0, 0);
  MPI_Gatherv(order_prev_.data(), n, MPI_UINT64_T, gorder_.data(), cnt.data(), dsp.data(), MPI_UINT64_T, 0, world);
  if (comm->me == 0) sort_unique_keys(gorder_);
  gathered_order_ = true;
}

void PairGranularGPU::list_built() {
  if (track_order_) follow_list_order();
}

void PairGranularGPU::sync_params() {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = SPHDEM_DEM_GRANULAR;
  p.algo = algo_;
  set_box(p);
  push_params(p);
}

void PairGranularGPU::compute(int eflag, int vflag) {
  ev_init(eflag, vflag);
  if (!table_sent_) send_table();
  compute_grains(true, false); /* (the list order is followed in list_built, after the history hand-over) */
  if (vflag_atom) add_virial_atom(); /* compute stress/atom (and centroid/stress/atom: the same for pair forces) */
}

/* Restart: the global cutoff and keywords, every type pair's coefficients, the pair order of the last list
 * build, then pair_coeff flags and the core's contact history (tangential, twisting and the rolling
 * displacements). */
void PairGranularGPU::write_restart(FILE *fp) {
  const int nt = atom->ntypes;
  double d[1] = {cutoff_global_};
  int iv[2] = {device_, algo_};
  fwrite(d, sizeof(double), 1, fp);
  fwrite(iv, sizeof(int), 2, fp);
  fwrite(coef_.data(), sizeof(sphdem_dem_granular), coef_.size(), fp);
  fwrite(emod_.data(), sizeof(double), emod_.size(), fp);
  fwrite(poiss_.data(), sizeof(double), poiss_.size(), fp);
  fwrite(cut_type_.data(), sizeof(double), cut_type_.size(), fp);
  (void)nt;
  /* the pair order of the last list build, for the history transfer of the first build after the restart */
  const std::vector<uint64_t> &order = ghosts_ && gathered_order_ ? gorder_ : order_prev_;
  const int64_t no = (int64_t)order.size();
  fwrite(&no, sizeof(int64_t), 1, fp);
  fwrite(order.data(), sizeof(uint64_t), order.size(), fp);
  write_restart_tail(fp);
}

void PairGranularGPU::read_restart(FILE *fp) {
  begin_read_restart();
  const int nt = atom->ntypes;
  const size_t m = (size_t)(nt + 1) * (nt + 1);
  coef_.assign(m, sphdem_dem_granular());
  emod_.assign(m, 0.0);
  poiss_.assign(m, 0.0);
  cut_type_.assign(m, -1.0);
  double d[1];
  int iv[2];
  const bool ok = read_head(fp, d, sizeof(double), 1) && read_head(fp, iv, sizeof(int), 2) &&
                  read_head(fp, coef_.data(), sizeof(sphdem_dem_granular), m) && read_head(fp, emod_.data(), sizeof(double), m) &&
                  read_head(fp, poiss_.data(), sizeof(double), m) && read_head(fp, cut_type_.data(), sizeof(double), m);
  int64_t no = 0;
  bool ok2 = ok && read_head(fp, &no, sizeof(int64_t), 1) && no >= 0 && no <= (int64_t)1 << 40;
  if (ok2) {
    order_prev_.resize((size_t)no);
    ok2 = read_head(fp, order_prev_.data(), sizeof(uint64_t), (size_t)no);
  }
  order_owned_set_ = false; /* every rank has the whole order of the file */
  gathered_order_ = false;
  read_restart_tail(fp, ok2);
  cutoff_global_ = d[0];
  device_ = iv[0], algo_ = iv[1];
  table_sent_ = false;
}

/* ---- registration (LAMMPS only; called by sphdem_register_pair_gran_gpu) ------------------------------- */

static Pair *pair_granular_gpu_creator(LAMMPS *lmp) { return new PairGranularGPU(lmp); }

void sphdem_register_pair_granular_gpu(LAMMPS *lmp) {
  (*lmp->force->pair_map)["granular/gpu"] = &pair_granular_gpu_creator;
}
