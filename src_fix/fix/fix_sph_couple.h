/* fix_sph_couple.h - fix sph/couple: the engine side of the unresolved SPH-DEM coupling (He 2018 §2.3):
 * uploads the grains to the core of a fix sph/fluid and adds the fluid force on them to atom->f. */
#ifdef FIX_CLASS
FixStyle(sph/couple,FixSPHCouple)
#else

#ifndef SPHDEM_FIX_SPH_COUPLE_H
#define SPHDEM_FIX_SPH_COUPLE_H

#include <cstdio>
#include <string>
#include <vector>

#include "fix.h"
#include "fix_sph_fluid.h"
#include "sphdem.h"
#include "sphdem_grains.h"
#include "sphdem_peratom.h"

namespace LAMMPS_NS {

class FixSPHCouple : public Fix, public SPHCoupler {
 public:
  FixSPHCouple(class LAMMPS *, int, char **);
  ~FixSPHCouple() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  double compute_vector(int) override;
  double memory_usage() override;
  void write_restart(FILE *) override;
  void restart(char *) override;

  SPHDEM_PERATOM_METHODS(ca_, NCOL, "sph/couple", "sph/couple:ca")
  SPHDEM_FORWARD_COMM_METHODS
  int sphdem_pack_forward(int n, int *list, double *buf, int pbc_flag, int *pbc);
  void sphdem_unpack_forward(int n, int first, double *buf);

  /* SPHCoupler: called by the fluid fix */
  void couple_setup(sphdem_ctx ctx) override;
  bool couple_forces_valid() override;
  void couple_before_rates(sphdem_ctx ctx) override;
  void couple_after_rates(sphdem_ctx ctx) override;
  double couple_superficial_floor() const override { return cp_.superficial ? cp_.eps_min : 0.0; }
  int couple_groupbit() const override { return groupbit; }
  void couple_exchange_grains(int nown, int nghost, const double *own, double *ghost) override;

 private:
  /* per-atom array: f_ID[1-3] fluid force, [4-6] its drag part, [7-9] its pressure-gradient/viscous
   * part, [10-12] fluid torque; then a flag: the forces are valid (held between fluid steps) */
  enum { C_F = 0, C_FDRAG = 3, C_FPG = 6, C_TORQUE = 9, NOUT = 12, C_VALID = 12, NCOL = 13 };
  /* global vector (0-based here): momentum exchange rate = force on the grains, on the fluid, net
   * (3 each, at the last fluid step); min porosity; momentum given to the grains since the fix was
   * defined (time integral of the held forces, 3); number of coupled grains; kinetic energy of the grains of the
   * group (translational + rotational, translational, rotational: the engine's thermo ke counts the fluid too) */
  enum { V_FGRAIN = 0, V_FFLUID = 3, V_FNET = 6, V_EPSMIN = 9, V_PGRAIN = 10, V_NGRAIN = 13, V_KE = 14, V_KET = 15,
         V_KER = 16, NVEC = 17 };

  std::string fluid_id_;
  FixSPHFluid *fluid_;
  sphdem_couple_params cp_;   /* as given; hc and mu resolved against the fluid fix in init() */
  bool have_mu_, have_hc_;

  double **ca_;
  int nmax_;

  std::vector<int> gidx_;     /* local indices of the grains in upload order (many ranks: owned, then ghosts) */
  size_t ngown_ = 0;          /* owned grains at the front of gidx_ */
  std::vector<double> gcomm_; /* many ranks: v, omega of every local and ghost atom (forward communication) */
  std::vector<double> gx_, gv_, grad_, gom_, gf_, gfd_, gfp_, gt_;
  sphdem_grains::Store grains_; /* the grains handed to the core (or read from another shim's current store) */

  sphdem_couple_stats cstats_;
  bool stats_dirty_;          /* cstats_ predates the last rate evaluation (fetched on demand: O(fluid)) */
  double pgrain_[3];          /* time integral of the held forces on the grains */
  std::string restart_error_; /* a corrupted per-atom restart record, reported by init() */

  [[noreturn]] void fail(const std::string &msg);
  void check(sphdem_ctx ctx, int rc, const char *what);
  double parse_number(const char *kw, const char *s, const char *usage);
  void parse_args(int, char **);
  int nloop() const;
  void check_grain_size(); /* set-up: the largest grain against the coupling length hc (collective) */
  void note_reach();       /* set-up: a note when no grain is within 2 hc of any fluid particle (collective) */
  void grain_ke(double ke[3]) const; /* collective: translational + rotational, translational, rotational */
};

}  // namespace LAMMPS_NS

#endif
#endif
