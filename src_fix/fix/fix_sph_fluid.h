/* fix_sph_fluid.h - fix sph/fluid: the engine side of the sphdem SPH fluid (parse, map atoms, call sphdem.h). */
#ifdef FIX_CLASS
FixStyle(sph/fluid,FixSPHFluid)
#else

#ifndef SPHDEM_FIX_SPH_FLUID_H
#define SPHDEM_FIX_SPH_FLUID_H

#include <cstdint>
#include <string>
#include <vector>

#include "fix.h"
#include "sphdem.h"
#include "sphdem_compat.h"
#include "sphdem_peratom.h"

namespace LAMMPS_NS {

/* What fix sph/couple gives the fluid fix it couples to. The fluid fix drives the calls, so the
 * grains are uploaded right before each fluid rate evaluation and their forces fetched right after,
 * whatever the order of the fixes' post_force hooks (doc/fix_sph_couple.md, "Order of operations"). */
class SPHCoupler {
 public:
  virtual void couple_setup(sphdem_ctx ctx) = 0;        /* sphdem_couple_set, at each run set-up */
  virtual bool couple_forces_valid() = 0;               /* held forces exist for every grain */
  virtual void couple_before_rates(sphdem_ctx ctx) = 0; /* upload the grains */
  virtual void couple_after_rates(sphdem_ctx ctx) = 0;  /* fetch and hold the grain forces */
  /* > 0: the porosity enters the fluid density (superficial); fresh fluid particles then start at
   * rho = eps rho_start and m = eps m (eps floored at this value) so their intrinsic density is rho_start */
  virtual double couple_superficial_floor() const = 0;
  virtual int couple_groupbit() const = 0; /* the grains (their moves also ask for neighbour builds) */
  /* many ranks: the owned grains' values (ncomp 4 each, upload order) to their ghost copies; collective */
  virtual void couple_exchange_grains(int nown, int nghost, const double *own, double *ghost) = 0;

 protected:
  /* Never deleted through this base: a protected non-virtual destructor leaves the exception
   * specification of the coupling fix's destructor to Fix alone (current LAMMPS declares
   * ~Pointers() noexcept(false), older LAMMPS and LIGGGHTS a non-throwing one). */
  ~SPHCoupler() = default;
};

class FixSPHFluid : public Fix {
 public:
  FixSPHFluid(class LAMMPS *, int, char **);
  ~FixSPHFluid() override;
  int setmask() override;
  void init() override;
  void setup_pre_neighbor() override;
  void setup(int) override;
  void initial_integrate(int) override;
  void post_force(int) override;
  void final_integrate() override;
  void end_of_step() override;
  void pre_exchange() override;
  void pre_neighbor() override;
  void post_run() override;
  double compute_vector(int) override;
  double memory_usage() override;
  sphdem_ctx context() const { return ctx_; } /* for compute sph/probe; null before setup */
  const sphdem_params &params() const { return prm_; }
  int wall_groupbit() const { return wall_groupbit_; }
  long every() const { return every_; }
  /* fix sph/couple registers itself in its init() (after this fix's init, which forgets the last
   * coupler); false when another coupler is already attached */
  bool attach_coupler(SPHCoupler *c);
  /* a coupler that finds the coupled state broken during a run stops through here: the failure dump (keyword
   * failure_dump) is written and named after msg, which carries the coupler's own prefix */
  [[noreturn]] void fail_with_dump(const std::string &msg);

  SPHDEM_PERATOM_METHODS(sa_, NCOL, "sph/fluid", "sph/fluid:sa")
  SPHDEM_FORWARD_COMM_METHODS
  int sphdem_pack_forward(int n, int *list, double *buf, int pbc_flag, int *pbc);
  void sphdem_unpack_forward(int n, int first, double *buf);
  /* many ranks: the ghost fluid and walls enter the core (the communication cutoff is set for them) */
  bool many_ranks() const { return multi_; }
  /* fix sph/couple (in its init, after this fix's): the coupling passes reach `extra` deeper */
  void require_ghost_band(double reach); /* many ranks: ghosts within at least reach + skin */

 private:
  /* per-atom array columns: f_ID[1] density, f_ID[2] pressure, f_ID[3] porosity, then state kept
   * for restarts */
  /* f_ID[4] viscosity, f_ID[5] shear rate, f_ID[6] lambda (multiphase; 0 otherwise) */
  enum { C_RHO = 0, C_P = 1, C_EPS = 2, C_MU = 3, C_GDOT = 4, C_LAM = 5, C_STATE = 6,
         C_WALLV = C_STATE + SPHDEM_NSTATE, C_VALID = C_WALLV + 3, NCOL };
  static const int NOUT = 6; /* visible columns */

  sphdem_params prm_;
  sphdem_mp_params mp_;            /* multiphase (keyword phase); mp_.enabled 0 otherwise */
  std::vector<int> type_phase_;    /* atom type -> phase index, -1 = none */
  std::vector<int> fphase_;        /* phases of the uploaded fluid */
  sphdem_device device_;
  sphdem_ctx ctx_;
  int wall_igroup_, wall_groupbit_;
  std::string wall_group_;
  long sync_every_, check_every_;
  bool hydrostatic_;
  bool hydro_auto_ = false; /* hydrostatic auto: ZSURF from the highest fluid particle + dx/2 at the first set-up */
  bool mass_scaled_; /* hydrostatic init scaled per-atom masses by rho/rho0 */
  double zsurf_;
  bool walls_move_;
  bool host_current_;   /* host x, v, rho, p, state of the fluid equal the device copy */
  bool mapping_dirty_;
  bool announced_;

  /* sub-cycling (keyword every): the fluid advances on the steps where fluid_step_ is set, by
   * dt_fluid_ = (step - last_fluid_step_) * dt, i.e. every_ * dt, shorter at the end of a run */
  long every_;
  bool rk4_;            /* integrator rk4: whole Runge-Kutta steps in initial_integrate */
  bool ghost_;          /* ghost mirror: fixed ghost walls with MLS interpolation at mirror points */
  double ghost_lo_[3], ghost_hi_[3];
  std::vector<double> wxi_;
  bigint last_fluid_step_;
  bool fluid_step_;
  double dt_fluid_;
  bigint nfluid_steps_; /* fluid steps since the start of the run */

  SPHCoupler *coupler_;
  bool couple_on_;      /* the coupling is enabled in the core */

  double **sa_;         /* per-atom array, NCOL columns */
  int nmax_;            /* rows allocated in sa_ */

  /* local indices of fluid and wall atoms in upload order, and the staging buffers */
  std::vector<int> fidx_, widx_;
  std::vector<int> fresh_; /* upload positions k of fluid atoms whose state was not valid at the last upload */
  std::vector<int64_t> ftag_;
  std::vector<double> fx_, fv_, frho_, fp_, fmass_, fstate_, feps_, fmu_, fgd_, flam_;
  std::vector<double> wx_, wv_, wa_, wmass_;

  /* many ranks (DESIGN: the engine's decomposition): fidx_/widx_ hold the owned atoms first, then the ghost
   * atoms of the fluid and wall groups; the core computes every pair sum over both and integrates the owned.
   * Per fluid step one forward communication of GCOMM values per atom (v, rho, drho, a, mass; walls: v, the
   * wall acceleration) brings the ghosts' state (x through the engine's own forward communication). */
  /* per atom: v (3), rho, drho, a (3; walls: the wall acceleration), mass, porosity */
  enum { G_V = 0, G_RHO = 3, G_DRHO = 4, G_A = 5, G_MASS = 8, G_EPS = 9, GCOMM = 10 };
  bool multi_ = false;
  size_t nfown_ = 0, nwown_ = 0; /* owned entries at the front of fidx_ / widx_ */
  std::vector<double> gcomm_; /* GCOMM values per local + ghost atom */
  std::vector<double> xhold_; /* owned atoms' positions at the last neighbour build */
  /* the owned fluid and wall atoms (positions k in fidx_ / widx_) that the engine sends to other ranks, found
   * by the first forward communication after each neighbour build (its send lists are fixed until the next):
   * only their values travel between the core and the host each step and in the core's exchanges */
  std::vector<int> frows_, wrows_;
  std::vector<char> sent_;    /* per local atom: in a send list */
  bool record_sends_ = false, wrows_new_ = false;
  void make_rows();
  void download_rows();
  double cut_need_ = 0.0;     /* the communication cutoff the ghost fluid needs */
  sphdem_comm comm_;
  int ghost_levels() const;
  void fill_gcomm(bool fluid, bool walls, bool rows_only = false);
  void ghost_state_to_core();
  /* sphdem_set_exchange's function: the owners' values of a field to the ghosts (forward communication) */
  static int exchange_cb(void *user, int what, int ncomp, int nown, int nghost, const double *own, double *ghost);
  int exchange(int what, int ncomp, int nown, int nghost, const double *own, double *ghost);
  int exchange_walls(int ncomp, int nown, int nghost, const double *own, double *ghost);
  int exchange_slots(const std::vector<int> &idx, const std::vector<int> &rows, size_t nown, const int *slot, bool ok,
                     int ncomp, const double *own, double *ghost);
  void check_displacement();
  void fail_any(bool bad, const std::string &msg); /* collective: every rank stops with the first message */

  sphdem_stats stats_;
  bigint stats_step_;
  bigint run_step0_;
  double run_t0_;

  [[noreturn]] void fail(const std::string &msg);
  /* a blow-up: the failure dump (keyword failure_dump), then the message naming it */
  [[noreturn]] void blowup(const std::string &msg, bool from_device = true);
  std::string write_failure_dump(bool from_device);
  void check_scene(bool fresh); /* set-up checks of the uploaded fluid: masses against rho0 dx^dim, spacing */
  /* set-up checks of the scene around the fix (collective): other fixes acting on fluid or wall atoms, the
   * granular pair style acting on them without a neigh_modify exclusion */
  void check_other_fixes();
  void check_pair_exclusions();
  void resolve_hydrostatic_auto(); /* hydrostatic auto: the free surface from the fluid atoms (collective) */
  std::string terms_line() const;  /* the physical terms that are on, for the set-up line */
  void note_unused_walls();        /* a note when no wall atom is within 2h of a fluid particle (collective) */
  bool failure_dump_;         /* failure_dump yes (default) | FILE; no = off */
  std::string failure_file_;  /* FILE, empty = sphdem_failure.<step>.dump */
  bool have_dx_;
  bool scene_checked_;
  std::string restart_error_; /* a corrupted per-atom restart record, reported by init() */
  void check(int rc, const char *what);
  double parse_number(const char *kw, const char *s, const char *usage);
  void parse_args(int, char **);
  void box_to_params();
  void build_map();
  void parse_phase(int &iarg, int narg, char **arg);
  void seed_porosity();
  bool upload_fluid();
  void upload_walls(bool each_step);
  void rates();
  void start_superficial();
  void download();
  bool output_step() const;
  std::string stats_message(int rc, const sphdem_stats &s) const;
};

}  // namespace LAMMPS_NS

#endif
#endif
