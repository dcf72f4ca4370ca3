/* fix_cfd_grid.h - fix cfd/grid: the engine side of the coarse-grid gas phase of CFD-DEM (Yu 2024 §2.1-2.4):
 * uploads the grains of its group to the gas core (sphdem_cfd_*), holds the gas forces on them between
 * gas steps and adds them to atom->f every step. */
#ifdef FIX_CLASS
FixStyle(cfd/grid,FixCFDGrid)
#else

#ifndef SPHDEM_FIX_CFD_GRID_H
#define SPHDEM_FIX_CFD_GRID_H

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "fix.h"
#include "sphdem.h"
#include "sphdem_grains.h"
#include "sphdem_peratom.h"

namespace LAMMPS_NS {

class FixCFDGrid : public Fix {
 public:
  FixCFDGrid(class LAMMPS *, int, char **);
  ~FixCFDGrid() override;
  int setmask() override;
  void init() override;
  void setup(int) override;
  void post_force(int) override;
  void post_run() override;
  double compute_vector(int) override;
  double memory_usage() override;
  void write_restart(FILE *) override;
  void restart(char *) override;

  SPHDEM_PERATOM_METHODS(fa_, NCOL, "cfd/grid", "cfd/grid:fa")

 private:
  /* per-atom array: f_ID[1-3] drag force, [4-6] pressure-gradient force (held between gas steps) */
  enum { C_FDRAG = 0, C_FPG = 3, NCOL = 6 };
  /* global vector (1-based in scripts): 1 dp, 2 iters, 3 residual, 4 eps_min, 5 eps_mean, 6 umax, 7 cfl,
   * 8 mass_err, 9-11 f_grains, 12-14 f_gas, 15-17 f_bound, 18-20 f_pg */
  enum { NVEC = 20 };

  sphdem_cfd_params prm_;
  sphdem_device device_;
  bool have_box_;
  long every_;
  std::string inlet_var_[6];   /* bc SIDE inlet v_name: equal-style variable (name without v_) */
  int inlet_ivar_[6];
  bool have_init_u_;
  double init_u_[3];
  long vtk_every_;             /* gas steps between VTK files; 0 = none */
  std::string vtk_prefix_;
  std::vector<std::pair<double, std::string>> pvd_;  /* (time, file) of the collection */
  bool pvd_loaded_;

  sphdem_cfd ctx_;
  bool announced_;
  std::vector<double> pending_state_;  /* gas state read from a restart file, set at the next setup */
  bool have_pending_;
  double **fa_;
  int nmax_;
  int64_t ngas_steps_;         /* gas steps since the fix was defined (restart-kept) */
  int64_t ngas_run_ = 0;       /* gas steps this run */
  double time_;                /* simulation time at engine step clock_step_ (restart-kept: the engines do */
  int64_t clock_step_;         /* not keep the elapsed time in restart files); the times of the VTK files */

  std::vector<int> gidx_;
  std::vector<double> gx_, gv_, grad_, gfd_, gfp_;
  sphdem_grains::Store grains_; /* the grains handed to the core (or read from another shim's current store) */
  sphdem_cfd_stats stats_;
  bool keep_stats_;            /* stats_ came from a restart file: keep them at the next setup */
  double host_time_;           /* fix-side time of the gas steps (gather, scatter, VTK) this run */
  /* many ranks: each rank holds its block of the grid and a halo; the core's reductions and halo exchanges with
   * the face neighbours of the engine's processor grid go through these callbacks, timed */
  struct Reduce {
    MPI_Comm *world;
    double seconds;            /* in MPI_Allreduce this run */
    long calls;
    long long values;
    int neigh[3][2];           /* the engine's comm->procneigh */
    double xseconds;           /* in MPI_Sendrecv of the halo exchange this run */
    long xcalls;
    long long xvalues;         /* doubles sent */
  } red_;
  int slo_[3], shi_[3];        /* this rank's gas cells [slo, shi) per axis */
  std::string restart_error_;  /* a corrupted restart record, reported by init() */

  [[noreturn]] void fail(const std::string &msg);
  [[noreturn]] void fail_one(const std::string &msg); /* a failure seen by this rank alone (rank 0's files) */
  static int reduce_cb(void *user, double *buf, int n, int op);
  static int exchange_cb(void *user, int axis, int dir, const double *send, int nsend, double *recv, int nrecv);
  std::string subdomain();
  void check(int rc, const char *what);
  double parse_number(const char *kw, const char *s, const char *usage);
  void parse_args(int, char **);
  void update_inlets(bool force);
  void gas_step();
  void write_vtk();
  void print_timers();
  void advance_clock();
  int nloop() const;
};

}  // namespace LAMMPS_NS

#endif
#endif
