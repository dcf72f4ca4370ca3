/* pair_gran_gpu.cpp - pair_style gran/gpu (LIGGGHTS syntax): the stock "model hertz|hooke|hooke/hysteresis
 * tangential history [rolling_friction ...] [cohesion ...]" contacts computed by the sphdem DEM core (CPU or CUDA), with the shear
 * history kept there per pair keyed by the two atom tags. Material from fix property/global
 * (youngsModulus, poissonsRatio, coefficientRestitution, coefficientFriction,
 * coefficientRollingFriction; hooke/hysteresis: coefficientMaxElasticStiffness, coefficientAdhesionStiffness,
 * coefficientPlasticityDepth), one material or one per atom type. No physics here. */
#include "pair_gran_gpu.h"

#include <algorithm>
#include <cstring>
#include <map>
#include <utility>

#include "atom.h"
#include "comm.h"
#include "compute.h"
#include "domain.h"
#include "fix.h"
#include "fix_check_timestep_gran.h"
#include "fix_heat_gran_conduction.h"
#include "fix_property_atom.h"
#include "fix_property_global.h"
#include "fix_scalar_transport_equation.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neighbor.h"
#include "properties.h"
#include "pair_gran_gpu_register.h"
#include "sphdem_compat.h"
#include "update.h"

using namespace LAMMPS_NS;

static const char *const USAGE =
    "model hertz|hooke|hooke/hysteresis tangential history [rolling_friction cdt|epsd|epsd2|off] [limitForce on|off] "
    "[tangential_damping on|off] [ktToKnUser on|off (hooke, hooke/hysteresis)] "
    "[cohesion sjkr|sjkr2|off] [surface default] [device auto|cpu|gpu] [algo pair|particle] [timers on|off]";

/* Stock styles that take the granular pair style for a PairGran (force->pair_match("gran", 0) matches
 * gran/gpu too) and read its per-contact data or contact models: refused by name, before they could
 * use this style as what it is not. fix multisphere: rigid clumps, whose contacts use the body masses. */
namespace {
struct Refused {
  const char *style;
  int compute;
  const char *why;
};
const Refused kRefused[] = {
    {"contact/atom/gran", 1, "it reads the contact list of the stock pair style gran (compute contact/atom works)"},
    {"contactproperty/atom", 0, "it stores per-contact data of the stock pair style gran"},
    {"continuum/weighted", 0, "it needs the contact forces of the stock pair style gran"},
    {"fiber/spring/simple", 0, "it needs the stock pair style gran"},
    {"multicontact/halfspace", 0, "it needs the multicontact data of the stock pair style gran"},
    {"multisphere", 0, "rigid multisphere clumps are not supported (the contacts would need the clump masses)"},
    {"multisphere/nointegration", 0, "rigid multisphere clumps are not supported"},
    {"multisphere/break", 0, "rigid multisphere clumps are not supported"},
    {"concave", 0, "rigid multisphere clumps are not supported"},
};
const Refused *refused(const char *style, int compute) {
  for (const Refused &r : kRefused)
    if (r.compute == compute && std::strcmp(r.style, style) == 0) return &r;
  return nullptr;
}
bool uses_gran_gpu(LAMMPS *lmp) { return lmp->force->pair_style && lmp->force->pair_match("gran/gpu", 1); }
[[noreturn]] void refuse(LAMMPS *lmp, const Refused *r) {
  sphdem_compat::error_all(lmp->error, __FILE__, __LINE__,
                           std::string(r->compute ? "Compute " : "Fix ") + r->style +
                               " cannot be used with pair_style gran/gpu: " + r->why);
  throw 0; /* not reached */
}
std::map<std::string, sphdem_compat::FixCreator> g_stock_fix;
std::map<std::string, sphdem_compat::ComputeCreator> g_stock_compute;
Fix *guarded_fix(LAMMPS *lmp, int narg, char **arg) {
  const Refused *r = narg > 2 ? refused(arg[2], 0) : nullptr;
  if (r && uses_gran_gpu(lmp)) refuse(lmp, r);
  return g_stock_fix.at(arg[2])(lmp, narg, arg);
}
Compute *guarded_compute(LAMMPS *lmp, int iarg, int narg, char **arg) {
  const Refused *r = narg > 2 ? refused(arg[2], 1) : nullptr;
  if (r && uses_gran_gpu(lmp)) refuse(lmp, r);
  return g_stock_compute.at(arg[2])(lmp, iarg, narg, arg);
}

/* fix check/timestep/gran: the stock fix looks the pair style up by its exact name 'gran' (and only checks
 * that one exists); everything it checks comes from the material fixes and the grains. While its init runs,
 * the style answers to 'gran'. */
class FixCheckTimestepGranGPU : public FixCheckTimestepGran {
 public:
  FixCheckTimestepGranGPU(LAMMPS *lmp, int narg, char **arg) : FixCheckTimestepGran(lmp, narg, arg) {}
  void init() override {
    char *name = force->pair_style;
    char gran[] = "gran";
    const bool gpu = name && std::strcmp(name, "gran/gpu") == 0;
    if (gpu) force->pair_style = gran;
    FixCheckTimestepGran::init();
    force->pair_style = name;
  }
};
Fix *check_timestep_gran_creator(LAMMPS *lmp, int narg, char **arg) { return new FixCheckTimestepGranGPU(lmp, narg, arg); }

/* fix heat/gran and heat/gran/conduction: the stock fix (its keywords, the transport equation it sets up, the
 * heat exchanged with walls by fix wall/gran), with the conduction between grains computed by the DEM core from
 * its contacts (sphdem_dem_heat) when the pair style is gran/gpu; with another pair style it is the stock fix. The
 * stock fix reads the stock style's neighbour and history lists, which gran/gpu does not have. */
class FixHeatGranCondGPU : public FixHeatGranCond {
 public:
  FixHeatGranCondGPU(LAMMPS *lmp, int narg, char **arg) : FixHeatGranCond(lmp, narg, arg) {}
  void init() override {
    gpu_ = uses_gran_gpu(lmp);
    if (!gpu_) {
      FixHeatGranCond::init();
      return;
    }
    /* the stock checks and look-ups, without the stock pair style */
    if (modify->n_fixes_style(style) > 1) error->fix_error(FLERR, this, "cannot have more than one fix of this style");
    if (area_correction_flag_)
      error->fix_error(FLERR, this, "'area_correction yes' is not supported with pair_style gran/gpu (use 'no')");
    if (store_contact_data_)
      error->fix_error(FLERR, this, "'store_contact_data yes' is not supported with pair_style gran/gpu (use 'no')");
    pair_gran = nullptr;
    history_flag = 1;
    fix_ste = modify->find_fix_scalar_transport_equation("heattransfer");
    if (!fix_ste) error->fix_error(FLERR, this, "needs a fix transportequation/scalar to work with");
    fix_temp = static_cast<FixPropertyAtom *>(modify->find_fix_property("Temp", "property/atom", "scalar", 0, 0, style));
    fix_heatFlux =
        static_cast<FixPropertyAtom *>(modify->find_fix_property("heatFlux", "property/atom", "scalar", 0, 0, style));
    fix_heatSource =
        static_cast<FixPropertyAtom *>(modify->find_fix_property("heatSource", "property/atom", "scalar", 0, 0, style));
    fix_directionalHeatFlux = static_cast<FixPropertyAtom *>(
        modify->find_fix_property("directionalHeatFlux", "property/atom", "vector", 0, 0, style));
    const int nt = atom->get_properties()->max_type();
    FixPropertyGlobal *k = static_cast<FixPropertyGlobal *>(
        modify->find_fix_property("thermalConductivity", "property/global", "peratomtype", nt, 0, style));
    k_type_.assign(nt + 1, 0.0);
    for (int t = 1; t <= nt; t++) {
      k_type_[t] = k->compute_vector(t - 1);
      if (!(k_type_[t] >= 0.0))
        error->fix_error(FLERR, this, "thermalConductivity must not be < 0 (pair_style gran/gpu)");
    }
    updatePtrs();
  }
  void post_force(int vflag) override {
    if (!gpu_) {
      FixHeatGranCond::post_force(vflag);
      return;
    }
    updatePtrs();
    const int nall = atom->nlocal + atom->nghost, *type = atom->type;
    k_.resize(std::max(nall, 1));
    for (int i = 0; i < nall; i++) k_[i] = k_of(type[i]);
    /* a contact of two grains outside the group conducts nothing (the stock fix skips it) */
    const int *mask = atom->mask;
    if (igroup != 0) {
      member_.resize(std::max(nall, 1));
      for (int i = 0; i < nall; i++) member_[i] = (mask[i] & groupbit) != 0;
    }
    const int area = core_area();
    std::string err;
    PairGranGPUBase *pair = static_cast<PairGranGPUBase *>(force->pair);
    const int *member = igroup != 0 ? member_.data() : nullptr;
    if (!pair->heat_now(Temp, k_.data(), member, area, fixed_contact_area_, heatFlux, directionalHeatFlux, err))
      error->one(FLERR, (std::string("Fix ") + style + " with pair_style gran/gpu: " + err).c_str());
  }

  /* compute pair/gran/local heatFlux (after prepare_output): the flow into i through its contact with j (rsq =
   * |x_i - x_j|^2), with the temperatures as they are, as the stock fix gives it to that compute */
  void prepare_output() { updatePtrs(); }
  double contact_flux(int i, int j, double rsq) const {
    const int *type = atom->type;
    return (Temp[j] - Temp[i]) * sphdem_dem_heat_conductance(rsq, atom->radius[i], atom->radius[j], k_of(type[i]),
                                                             k_of(type[j]), core_area(), fixed_contact_area_);
  }

 private:
  bool gpu_ = false;
  std::vector<double> k_type_, k_; /* conductivity per type (1..), per atom of the step */
  std::vector<int> member_;        /* per atom of the step: in the fix group */
  double k_of(int t) const { return t >= 1 && t < (int)k_type_.size() ? k_type_[t] : 0.0; }
  int core_area() const {
    return area_calculation_mode_ == 1 ? SPHDEM_DEM_HEAT_AREA_CONSTANT      /* stock CONSTANT */
           : area_calculation_mode_ == 2 ? SPHDEM_DEM_HEAT_AREA_PROJECTION /* stock PROJECTION */
                                         : SPHDEM_DEM_HEAT_AREA_OVERLAP;
  }
};
Fix *heat_gran_creator(LAMMPS *lmp, int narg, char **arg) { return new FixHeatGranCondGPU(lmp, narg, arg); }

/* compute pair/gran/local with pair_style gran/gpu: the stock keywords and columns, one row per touching pair of two
 * grains, the contacts evaluated again by the DEM core with the atoms as they are at the output (as the stock
 * compute has the stock style evaluate them: nothing added, the history not advanced). Rows as the stock compute
 * writes them: the pair's first atom is the one the stock half neighbour list puts first (the lower index of two
 * own atoms; the own atom of a pair with a ghost, kept on the rank whose atom has the higher tag, as the stock
 * compute keeps it with newton off; of a pair through a periodic boundary on one rank, the atom of higher tag, as
 * the stock list holds it with the other's image). */
class ComputePairGranLocalGPU : public Compute {
 public:
  ComputePairGranLocalGPU(LAMMPS *lmp, int &iarg, int narg, char **arg) : Compute(lmp, iarg, narg, arg) {
    local_flag = 1;
    const std::pair<const char *, int *> flags[] = {
        {"pos", &pos_},       {"vel", &vel_},       {"id", &id_},          {"force", &f_},
        {"force_normal", &fn_}, {"force_tangential", &ft_}, {"torque", &tq_}, {"torque_normal", &tqn_},
        {"torque_tangential", &tqt_}, {"history", &hist_}, {"contactArea", &area_}, {"delta", &delta_},
        {"contactPoint", &cp_}};
    bool any = false;
    for (; iarg < narg; iarg++) {
      const std::string kw = arg[iarg];
      if (kw == "verbose") {
        verbose_ = true;
        continue;
      }
      any = true;
      if (kw == "ms_id") bad("ms_id is not available with pair_style gran/gpu (fix multisphere is not supported with it)");
      if (kw == "heatFlux") {
        heat_ = 1;
        continue;
      }
      int *flag = nullptr;
      std::string names;
      for (const auto &f : flags) {
        if (kw == f.first) flag = f.second;
        names += std::string(f.first) + ", ";
      }
      if (!flag) bad("unknown keyword '" + kw + "' (" + names + "heatFlux, verbose)");
      *flag = 1;
    }
    if (!any) pos_ = vel_ = id_ = f_ = tq_ = hist_ = area_ = 1; /* the stock defaults */
    if (update->ntimestep > 0 && !modify->fix_restart_in_progress()) bad("define it before the first run (as the stock compute)");
  }
  ~ComputePairGranLocalGPU() override { memory->destroy(array_); }
  void init() override {
    pair_ = dynamic_cast<PairGranGPU *>(force->pair_match("gran/gpu", 1));
    if (!pair_) bad("the pair style is no longer gran/gpu");
    nhist_ = 3 + (pair_->hysteresis() ? 1 : 0) + (pair_->rolling_history() ? 3 : 0);
    /* heatFlux: the flow of fix heat/gran (heat/gran/conduction) through each contact, the last column (the stock
     * compute's checks: the fix defined before this compute, the same group) */
    heat_fix_ = nullptr;
    if (heat_) {
      for (int k = 0; k < modify->nfix; k++)
        if (std::strcmp(modify->fix[k]->style, "heat/gran") == 0 ||
            std::strcmp(modify->fix[k]->style, "heat/gran/conduction") == 0)
          heat_fix_ = dynamic_cast<FixHeatGranCondGPU *>(modify->fix[k]);
      if (!heat_fix_) bad("heatFlux needs fix heat/gran or heat/gran/conduction, defined before this compute");
      if (heat_fix_->groupbit != groupbit)
        bad("heatFlux: the group of this compute and of fix heat/gran must be the same (as the stock compute)");
    }
    const int nv = 6 * pos_ + 6 * vel_ + 3 * id_ + 3 * (f_ + fn_ + ft_ + tq_ + tqn_ + tqt_) + nhist_ * hist_ + area_ +
                   delta_ + 3 * cp_ + heat_;
    if (nv != nvalues_) { /* (another model between runs: rows of another width) */
      memory->destroy(array_);
      array_local = array_ = nullptr;
      nmax_ = 0;
    }
    nvalues_ = nv;
    size_local_cols = nvalues_;
  }
  void post_create() override { init(); }
  void compute_local() override;
  double memory_usage() override { return (double)nmax_ * nvalues_ * sizeof(double); }

 private:
  int pos_ = 0, vel_ = 0, id_ = 0, f_ = 0, fn_ = 0, ft_ = 0, tq_ = 0, tqn_ = 0, tqt_ = 0, hist_ = 0, area_ = 0,
      delta_ = 0, cp_ = 0, heat_ = 0;
  FixHeatGranCondGPU *heat_fix_ = nullptr;
  bool verbose_ = false;
  int nvalues_ = 0, nhist_ = 3, nmax_ = 0;
  double **array_ = nullptr;
  PairGranGPU *pair_ = nullptr;
  std::vector<int32_t> ij_;
  std::vector<double> ft_buf_, hist_buf_, roll_buf_;
  [[noreturn]] void bad(const std::string &why) {
    sphdem_compat::error_all(error, __FILE__, __LINE__, std::string("Compute ") + id + " pair/gran/local: " + why);
    throw 0; /* not reached */
  }
};

/* the normal part (along n, |n| = 1) of a, or what is left of it */
static void split3(const double *a, const double *n, double *nrm, double *tan) {
  const double an = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
  for (int d = 0; d < 3; d++) nrm[d] = an * n[d], tan[d] = a[d] - nrm[d];
}

void ComputePairGranLocalGPU::compute_local() {
  invoked_local = update->ntimestep;
  std::string err;
  const int64_t np = pair_->contacts_now(ij_, ft_buf_, hist_buf_, roll_buf_, err);
  if (np < 0) {
    sphdem_compat::error_one(error, __FILE__, __LINE__, std::string("Compute ") + id + " pair/gran/local: " + err);
    return;
  }
  if (np > nmax_) {
    memory->destroy(array_);
    nmax_ = (int)np + (int)(np / 4) + 16;
    memory->create(array_, nmax_, std::max(nvalues_, 1), "pair/gran/local:array");
    array_local = array_;
  }
  const int nlocal = atom->nlocal, *mask = atom->mask;
  double **x = atom->x, **v = atom->v, *radius = atom->radius;
  const tagint *tag = atom->tag;
  if (heat_) heat_fix_->prepare_output();
  int rows = 0;
  for (int64_t k = 0; k < np; k++) {
    const int a = ij_[2 * k], b = ij_[2 * k + 1];
    if (!(mask[a] & groupbit) || !(mask[b] & groupbit)) continue;
    if (a >= nlocal && b >= nlocal) continue;
    /* the separation a - b as the core took it: through a periodic boundary by the minimum image (two own atoms,
     * or an atom of another rank along an axis the ranks do not cut) where it differs from x_a - x_b */
    const double *F = &ft_buf_[SPHDEM_DEM_CONTACT_DOUBLES * k], *dab = F + 9;
    const bool through = dab[0] != x[a][0] - x[b][0] || dab[1] != x[a][1] - x[b][1] || dab[2] != x[a][2] - x[b][2];
    const bool split = a >= nlocal || b >= nlocal; /* one atom is another rank's (or a periodic image) */
    const bool a_first = split ? a < nlocal : through ? tag[a] > tag[b] : a < b;
    const int i = a_first ? a : b, j = a_first ? b : a;
    if (split && tag[i] <= tag[j]) continue; /* the other rank's row */
    const double s = a_first ? 1.0 : -1.0;
    const double *Ti = F + (a_first ? 3 : 6);
    const double del[3] = {s * dab[0], s * dab[1], s * dab[2]}; /* x_i - x_j */
    const double xj[3] = {x[i][0] - del[0], x[i][1] - del[1], x[i][2] - del[2]}; /* j as the stock list sees it */
    const double rsq = del[0] * del[0] + del[1] * del[1] + del[2] * del[2], r = std::sqrt(rsq);
    const double nrm[3] = {-del[0] / r, -del[1] / r, -del[2] / r}; /* from i to j */
    const double fi[3] = {s * F[0], s * F[1], s * F[2]};
    double *row = array_[rows++];
    int c = 0;
    auto put3 = [&](const double *a) {
      for (int d = 0; d < 3; d++) row[c++] = a[d];
    };
    if (pos_) {
      double xi_w[3] = {x[i][0], x[i][1], x[i][2]}, xj_w[3] = {xj[0], xj[1], xj[2]};
      domain->remap(xi_w);
      domain->remap(xj_w);
      put3(xi_w);
      put3(xj_w);
    }
    if (vel_) {
      put3(v[i]);
      put3(v[j]);
    }
    if (id_) {
      row[c++] = (double)tag[i];
      row[c++] = (double)tag[j];
      row[c++] = through ? 1.0 /* (the stock list's j is then an image outside the box) */
                 : (i < nlocal && j < nlocal) ? 0.0
                 : (domain->is_periodic_ghost(i) || domain->is_periodic_ghost(j)) ? 1.0 : 0.0;
    }
    double fn[3], ft[3], tn[3], tt[3];
    split3(fi, nrm, fn, ft);
    split3(Ti, nrm, tn, tt);
    if (f_) put3(fi);
    if (fn_) put3(fn);
    if (ft_) put3(ft);
    if (tq_) put3(Ti);
    if (tqn_) put3(tn);
    if (tqt_) put3(tt);
    if (hist_) { /* the stock order: the normal model's (largest overlap), the shear, the rolling torque; from i's side */
      const double *h = &hist_buf_[SPHDEM_DEM_HIST_DOUBLES * k], *rl = &roll_buf_[3 * k];
      const double sh[3] = {s * h[0], s * h[1], s * h[2]}, sr[3] = {s * rl[0], s * rl[1], s * rl[2]};
      if (pair_->hysteresis()) row[c++] = h[4];
      put3(sh);
      if (pair_->rolling_history()) put3(sr);
    }
    const double ri = radius[i], rj = radius[j];
    if (area_) row[c++] = -M_PI / 4 * ((r - ri - rj) * (r + ri - rj) * (r - ri + rj) * (r + ri + rj)) / rsq;
    if (delta_) row[c++] = ri + rj - r;
    if (cp_) {
      const double cp[3] = {(x[i][0] * rj + xj[0] * ri) / (ri + rj), (x[i][1] * rj + xj[1] * ri) / (ri + rj),
                            (x[i][2] * rj + xj[2] * ri) / (ri + rj)};
      put3(cp);
    }
    if (heat_) { /* through a periodic boundary on one rank: the image of j next to i, whose temperature the stock
                  * compute reads (the engine sends it at the next step: at the output it is that of the step's start) */
      const int jt = through && atom->sametag ? domain->closest_image(i, j) : j;
      row[c++] = heat_fix_->contact_flux(i, jt, rsq);
    }
  }
  size_local_rows = rows;
  if (verbose_ && screen)
    fprintf(screen, "compute %s pair/gran/local: %d touching pairs on this rank\n", id, rows);
}

Compute *pair_gran_local_creator(LAMMPS *lmp, int iarg, int narg, char **arg) {
  if (uses_gran_gpu(lmp)) return new ComputePairGranLocalGPU(lmp, iarg, narg, arg);
  return g_stock_compute.at("pair/gran/local")(lmp, iarg, narg, arg);
}
}  // namespace

PairGranGPU::PairGranGPU(LAMMPS *lmp)
    : PairGranGPUBase(lmp, "gran/gpu"), rolling_(0), limit_force_(0), hooke_(0), kt_to_kn_(0), tangential_damping_(1),
      cohesion_(0), nmat_(0) {}

void PairGranGPU::settings(int narg, char **arg) {
  bool model = false, tangential = false;
  for (int k = 0; k < narg; k++) {
    std::string kw = arg[k];
    std::string val = k + 1 < narg ? arg[k + 1] : "";
    if (k + 1 >= narg) fail("keyword '" + kw + "' needs a value (usage: " + USAGE + ")");
    k++;
    if (kw == "model") {
      if (val == "hertz") hooke_ = 0;
      else if (val == "hooke") hooke_ = 1;
      else if (val == "hooke/hysteresis") hooke_ = 2;
      else fail("model '" + val + "' is not supported (hertz, hooke or hooke/hysteresis)");
      model = true;
    } else if (kw == "ktToKnUser") {
      if (val == "on") kt_to_kn_ = 1;
      else if (val == "off") kt_to_kn_ = 0;
      else fail("ktToKnUser must be on or off (got '" + val + "')");
    } else if (kw == "tangential") {
      if (val != "history") fail("tangential '" + val + "' is not supported (only history)");
      tangential = true;
    } else if (kw == "rolling_friction") {
      if (val == "cdt") rolling_ = 1;
      else if (val == "epsd2") rolling_ = 2;
      else if (val == "epsd") rolling_ = 3;
      else if (val == "off") rolling_ = 0;
      else fail("rolling_friction '" + val + "' is not supported (cdt, epsd, epsd2 or off)");
    } else if (kw == "limitForce") {
      if (val == "on") limit_force_ = 1;
      else if (val == "off") limit_force_ = 0;
      else fail("limitForce must be on or off (got '" + val + "')");
    } else if (kw == "tangential_damping") {
      if (val == "on") tangential_damping_ = 1;
      else if (val == "off") tangential_damping_ = 0;
      else fail("tangential_damping must be on or off (got '" + val + "')");
    } else if (kw == "cohesion") {
      if (val == "sjkr") cohesion_ = SPHDEM_DEM_COH_SJKR;
      else if (val == "sjkr2") cohesion_ = SPHDEM_DEM_COH_SJKR2;
      else if (val == "off") cohesion_ = SPHDEM_DEM_COH_NONE;
      else fail("cohesion '" + val + "' is not supported (sjkr, sjkr2 or off)");
    } else if (kw == "tangential_reduce") {
      if (val != "off") fail("tangential_reduce '" + val + "' is not supported (only off, the default)");
    } else if (kw == "surface") {
      if (val != "default") fail("surface '" + val + "' is not supported (only default)");
    } else if (!common_keyword(kw, val)) { /* device, algo, timers */
      fail("unsupported keyword '" + kw + "' (usage: " + USAGE + ")");
    }
  }
  if (!model) fail("needs 'model hertz', 'model hooke' or 'model hooke/hysteresis' (usage: " + std::string(USAGE) + ")");
  if (kt_to_kn_ && !hooke_) fail("ktToKnUser is a keyword of model hooke");
  /* model hooke/hysteresis takes the words of model hooke, as the stock style, and like it ignores
   * limitForce and ktToKnUser (its force has no limit, k_t = k_n) */
  if (!tangential) fail("needs 'tangential history' (usage: " + std::string(USAGE) + ")");
}

void PairGranGPU::coeff(int narg, char **arg) {
  if (narg != 2 || std::strcmp(arg[0], "*") != 0 || std::strcmp(arg[1], "*") != 0)
    fail("use pair_coeff * * (the material comes from fix property/global)");
  if (!allocated) allocate();
  for (int i = 1; i <= atom->ntypes; i++)
    for (int j = i; j <= atom->ntypes; j++) setflag[i][j] = 1;
}

/* The per-type (peratomtype: nt values) or per-type-pair (peratomtypepair: nt x nt, row-major) values
 * of a fix property/global; returns whether they differ between atom types. A type pair's value must
 * not depend on the order of the two types (the core evaluates a pair in the order of its atom tags). */
bool PairGranGPU::material(const char *name, const char *kind, std::vector<double> &out) {
  const int nt = atom->ntypes;
  const bool pair = std::strcmp(kind, "peratomtypepair") == 0;
  Fix *f = modify->find_fix_property(name, "property/global", kind, nt, pair ? nt : 0, "pair gran/gpu");
  FixPropertyGlobal *g = static_cast<FixPropertyGlobal *>(f);
  if (!g) fail(std::string("needs fix property/global ") + name + " " + kind);
  out.assign(pair ? (size_t)nt * nt : (size_t)nt, 0.0);
  bool differ = false;
  for (int i = 0; i < nt; i++)
    for (int j = 0; j < (pair ? nt : 1); j++) {
      const double v = pair ? g->compute_array(i, j) : g->compute_vector(i);
      out[pair ? (size_t)i * nt + j : (size_t)i] = v;
      differ |= v != out[0];
    }
  if (pair)
    for (int i = 0; i < nt; i++)
      for (int j = 0; j < i; j++)
        if (out[(size_t)i * nt + j] != out[(size_t)j * nt + i])
          fail(std::string(name) + " (fix property/global) is not symmetric: atom types " + std::to_string(j + 1) +
               " " + std::to_string(i + 1) + " have " + std::to_string(out[(size_t)j * nt + i]) + ", types " +
               std::to_string(i + 1) + " " + std::to_string(j + 1) + " " + std::to_string(out[(size_t)i * nt + j]));
  return differ;
}

/* Several materials: the core gets the table of every type pair and each grain's type in its flags. */
void PairGranGPU::apply_materials() {
  if (!dem_) return;
  sphdem_dem_materials t = {0, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr};
  if (nmat_)
    t = {nmat_, mat_E_.data(), mat_nu_.data(), mat_en_.data(), mat_mu_.data(), rolling_ ? mat_mur_.data() : nullptr,
         cohesion_ ? mat_ced_.data() : nullptr, rolling_ == 3 ? mat_rvd_.data() : nullptr,
         hooke_ == 2 ? mat_k2_.data() : nullptr, hooke_ == 2 ? mat_kc_.data() : nullptr,
         hooke_ == 2 ? mat_phif_.data() : nullptr};
  if (sphdem_dem_set_materials(dem_, &t)) fail(std::string("material: ") + sphdem_dem_last_error(dem_));
}

void PairGranGPU::init_style() {
  check_atoms("atom_style granular or sphere");
  if (force->nktv2p != 1.0) fail("needs units si or cgs (nktv2p = 1)");
  freeze_group_bit_ = 0;
  for (int i = 0; i < modify->ncompute; i++)
    if (const Refused *r = refused(modify->compute[i]->style, 1)) refuse(lmp, r);
    else if (std::strcmp(modify->compute[i]->style, "pair/gran/local") == 0 &&
             !dynamic_cast<ComputePairGranLocalGPU *>(modify->compute[i]))
      fail(std::string("compute ") + modify->compute[i]->id + " pair/gran/local was created for another pair style: "
           "define it after pair_style gran/gpu");
  for (int i = 0; i < modify->nfix; i++) {
    Fix *f = modify->fix[i];
    if (const Refused *r = refused(f->style, 0)) refuse(lmp, r);
    if (f->rigid_flag) fail(std::string("rigid bodies (fix ") + f->id + ") are not supported");
    if (std::strcmp(f->style, "freeze") == 0) freeze_group_bit_ = f->groupbit;
  }
  hand_rolling_ = rolling_ == 2 || rolling_ == 3; /* epsd2, epsd: a rolling torque per contact */
  if (neighbor->contactDistanceFactor != 1.0)
    fail("contact_distance_factor " + std::to_string(neighbor->contactDistanceFactor) +
         " (neigh_modify, or a cohesion model) is not supported: only 1");
  /* the cutoff of the stock style (PairGran::init_style/init_one): per type the largest radius of the
   * grains, frozen ones apart, and of the particles that fixes will insert (Fix::max_rad) */
  const int nt = atom->ntypes;
  std::vector<double> dyn(nt + 1, 0.0), frz(nt + 1, 0.0);
  for (int i = 0; i < modify->nfix; i++) {
    if (!modify->fix[i]->use_rad_for_cut_neigh_and_ghost()) continue;
    for (int t = 1; t <= nt; t++) dyn[t] = std::max(dyn[t], modify->fix[i]->max_rad(t));
  }
  reduce_maxrad(dyn, frz);
  sync_params();
  create_core();
  apply_materials();
  restore_history();
}

/* Restart: the keywords (as parsed), pair_coeff flags and the core's contact history (pair keys made
 * of atom tags). The material stays in the fix property/global commands, given again after read_restart. */
void PairGranGPU::write_restart(FILE *fp) {
  /* sixth value: bit 0 ktToKnUser, bit 1 tangential_damping off, bits 2-3 the cohesion model (files
   * without them read as damping on, no cohesion) */
  int iv[6] = {rolling_, limit_force_, device_, algo_, hooke_, kt_to_kn_ | (tangential_damping_ ? 0 : 2) | (cohesion_ << 2)};
  fwrite(iv, sizeof(int), 6, fp);
  write_restart_tail(fp);
}

void PairGranGPU::read_restart(FILE *fp, const int, const int) {
  begin_read_restart();
  int iv[6];
  read_restart_tail(fp, read_head(fp, iv, sizeof(int), 6));
  rolling_ = iv[0], limit_force_ = iv[1], device_ = iv[2], algo_ = iv[3], hooke_ = iv[4], kt_to_kn_ = iv[5] & 1;
  tangential_damping_ = (iv[5] & 2) ? 0 : 1;
  cohesion_ = (iv[5] >> 2) & 3;
}

void PairGranGPU::sync_params() {
  sphdem_dem_params p;
  sphdem_dem_params_default(&p);
  p.model = hooke_ == 2 ? SPHDEM_DEM_HOOKE_HYSTERESIS_LIGGGHTS : hooke_ ? SPHDEM_DEM_HOOKE_LIGGGHTS : SPHDEM_DEM_HERTZ_LIGGGHTS;
  if (hooke_) {
    Fix *f = modify->find_fix_property("characteristicVelocity", "property/global", "scalar", 0, 0, "pair gran/gpu");
    FixPropertyGlobal *g = static_cast<FixPropertyGlobal *>(f);
    if (!g) fail(std::string(hooke_ == 2 ? "model hooke/hysteresis" : "model hooke") +
                 " needs fix property/global characteristicVelocity scalar V");
    p.charvel = g->compute_scalar();
    p.kt_to_kn = hooke_ == 2 ? 0 : kt_to_kn_;
  }
  p.algo = algo_;
  /* one material (every value equal between the types) in the params; several in a table of type pairs */
  bool several = material("youngsModulus", "peratomtype", mat_E_);
  several |= material("poissonsRatio", "peratomtype", mat_nu_);
  several |= material("coefficientRestitution", "peratomtypepair", mat_en_);
  several |= material("coefficientFriction", "peratomtypepair", mat_mu_);
  mat_mur_.assign(mat_mu_.size(), 0.0);
  if (rolling_) several |= material("coefficientRollingFriction", "peratomtypepair", mat_mur_);
  mat_ced_.assign(mat_mu_.size(), 0.0);
  if (cohesion_) several |= material("cohesionEnergyDensity", "peratomtypepair", mat_ced_);
  nmat_ = several ? atom->ntypes : 0;
  p.E = mat_E_[0];
  p.nu = mat_nu_[0];
  p.en = mat_en_[0];
  p.mu = mat_mu_[0];
  p.mu_r = *std::max_element(mat_mur_.begin(), mat_mur_.end()); /* > 0: rolling friction on */
  p.no_tangential_damping = tangential_damping_ ? 0 : 1;
  p.rolling_model = rolling_ == 2 ? SPHDEM_DEM_ROLL_EPSD2 : rolling_ == 3 ? SPHDEM_DEM_ROLL_EPSD : SPHDEM_DEM_ROLL_CDT;
  mat_rvd_.assign(mat_mu_.size(), 0.0);
  if (rolling_ == 3) {
    if (domain->dimension == 2) fail("rolling_friction epsd is supported in 3D only");
    several |= material("coefficientRollingViscousDamping", "peratomtypepair", mat_rvd_);
    nmat_ = several ? atom->ntypes : 0;
  }
  p.rvd = mat_rvd_[0];
  for (int k = 0; k < (int)mat_rvd_.size() && nmat_; k++) if (!(mat_rvd_[k] >= 0.0)) p.rvd = mat_rvd_[k];
  /* hooke/hysteresis: its three type-pair values as the stock style's property registry names them */
  mat_k2_.assign(mat_mu_.size(), 0.0);
  mat_kc_.assign(mat_mu_.size(), 0.0);
  mat_phif_.assign(mat_mu_.size(), 0.0);
  if (hooke_ == 2) {
    several |= material("coefficientMaxElasticStiffness", "peratomtypepair", mat_k2_);
    several |= material("coefficientAdhesionStiffness", "peratomtypepair", mat_kc_);
    several |= material("coefficientPlasticityDepth", "peratomtypepair", mat_phif_);
    nmat_ = several ? atom->ntypes : 0;
  }
  p.kn2kcmax = mat_k2_[0];
  p.kn2kc = mat_kc_[0];
  p.phif = mat_phif_[0];
  for (size_t k = 0; k < mat_k2_.size() && nmat_ && hooke_ == 2; k++) {
    if (!(mat_k2_[k] > 1.0)) p.kn2kcmax = mat_k2_[k];
    if (!(mat_kc_[k] >= 0.0)) p.kn2kc = mat_kc_[k];
    if (!(mat_phif_[k] >= 0.0)) p.phif = mat_phif_[k];
  }
  p.cohesion = cohesion_;
  p.ced = mat_ced_[0];
  for (int k = 0; k < (int)mat_ced_.size() && nmat_; k++) if (!(mat_ced_[k] >= 0.0)) p.ced = mat_ced_[k];
  /* the params' checks name the first offending value; a table is checked per type (below) */
  for (int k = 0; k < (int)mat_E_.size() && nmat_; k++) p.E = mat_E_[k] > 0.0 ? p.E : mat_E_[k];
  for (int k = 0; k < (int)mat_nu_.size() && nmat_; k++) if (!(mat_nu_[k] >= 0.0 && mat_nu_[k] <= 0.5)) p.nu = mat_nu_[k];
  for (int k = 0; k < (int)mat_en_.size() && nmat_; k++) if (!(mat_en_[k] > 0.05 && mat_en_[k] <= 1.0)) p.en = mat_en_[k];
  for (int k = 0; k < (int)mat_mu_.size() && nmat_; k++) if (!(mat_mu_[k] >= 0.0)) p.mu = mat_mu_[k];
  for (int k = 0; k < (int)mat_mur_.size() && nmat_; k++) if (!(mat_mur_[k] >= 0.0)) p.mu_r = mat_mur_[k];
  p.limit_damping = hooke_ == 2 ? 0 : limit_force_; /* hooke/hysteresis ignores limitForce (as the stock) */
  p.keep_history = 1; /* as LIGGGHTS: a separated pair keeps its history until the next list build */
  set_box(p);
  char msg[512];
  if (sphdem_dem_params_check(&p, msg, sizeof msg)) {
    /* the core names its fields; the script names the values of fix property/global */
    static const char *const names[][2] = {{"E:", "youngsModulus"}, {"nu:", "poissonsRatio"},
                                           {"en:", "coefficientRestitution"}, {"mu:", "coefficientFriction"},
                                           {"mu_r:", "coefficientRollingFriction"}, {"charvel:", "characteristicVelocity"},
                                           {"kn2kcmax:", "coefficientMaxElasticStiffness"},
                                           {"kn2kc:", "coefficientAdhesionStiffness"},
                                           {"phif:", "coefficientPlasticityDepth"}};
    std::string m = msg;
    for (const auto &n : names)
      if (m.compare(0, std::strlen(n[0]), n[0]) == 0) {
        m = std::string(n[1]) + " (fix property/global):" + m.substr(std::strlen(n[0]));
        break;
      }
    fail("material: " + m);
  }
  push_params(p);
  apply_materials();
}

void PairGranGPU::compute(int eflag, int vflag) {
  if (eflag || vflag) ev_setup(eflag, vflag);
  else evflag = vflag_fdotr = vflag_global = vflag_atom = 0;
  /* compute stress/atom: half of r_ab F_ab of each pair to each atom, from the step's own contacts (the LIGGGHTS laws
   * evaluated again with the kept history would add the tangential damping to a sliding contact once more) */
  if (vflag_atom && sphdem_dem_keep_step_history(dem_))
    fail("per-atom virial: " + std::string(sphdem_dem_last_error(dem_)));
  compute_grains(nmat_ != 0, true);
  if (vflag_atom) add_virial_atom(true);
}

static Pair *pair_gran_gpu_creator(LAMMPS *lmp) { return new PairGranGPU(lmp); }

void sphdem_register_pair_gran_gpu(LAMMPS *lmp) {
  (*lmp->force->pair_map)["gran/gpu"] = &pair_gran_gpu_creator;
  sphdem_compat::FixCreatorMap &fixes = *sphdem_compat::fix_map(lmp->modify);
  sphdem_compat::ComputeCreatorMap &computes = *sphdem_compat::compute_map(lmp->modify);
  fixes["check/timestep/gran"] = &check_timestep_gran_creator;
  fixes["heat/gran"] = &heat_gran_creator;
  fixes["heat/gran/conduction"] = &heat_gran_creator;
  auto pgl = computes.find("pair/gran/local");
  if (pgl != computes.end() && pgl->second != &pair_gran_local_creator) {
    g_stock_compute["pair/gran/local"] = pgl->second;
    pgl->second = &pair_gran_local_creator;
  }
  for (const Refused &r : kRefused) {
    if (r.compute) {
      auto it = computes.find(r.style);
      if (it == computes.end() || it->second == &guarded_compute) continue;
      g_stock_compute[r.style] = it->second;
      it->second = &guarded_compute;
    } else {
      auto it = fixes.find(r.style);
      if (it == fixes.end() || it->second == &guarded_fix) continue;
      g_stock_fix[r.style] = it->second;
      it->second = &guarded_fix;
    }
  }
}
