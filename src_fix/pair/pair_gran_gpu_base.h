/* pair_gran_gpu_base.h - the engine-neutral part of the GPU granular pair styles (LAMMPS
 * gran/hooke|hertz/history/gpu, LIGGGHTS gran/gpu): the DEM core context, the grain upload and the
 * force download, the run timers, the restart of the contact history and the messages. Each engine's
 * style derives from it and keeps its own arguments and their mapping to sphdem_dem_params. */
#ifndef SPHDEM_PAIR_GRAN_GPU_BASE_H
#define SPHDEM_PAIR_GRAN_GPU_BASE_H

#include <cstdio>
#include <string>
#include <unordered_map>
#include <vector>

#include <mpi.h>

#include "pair.h"
#include "pair_gran_gpu_restart.h"
#include "pair_gran_gpu_timers.h"
#include "sphdem_grains.h"
#include "sphdem_tagmap.h"
#include "sphdem.h"

namespace LAMMPS_NS {

class PairGranGPUBase : public Pair {
 public:
  PairGranGPUBase(class LAMMPS *, const std::string &style);
  ~PairGranGPUBase() override;
  /* the largest contact distance of the type pair (stock init_one); 0 before init_style. LIGGGHTS scales
   * it by contact_distance_factor, which init_style of gran/gpu admits only at 1 */
  double init_one(int, int) override;
  double memory_usage() override;
  /* The touching pairs of two grains evaluated again with the atoms as they are now, nothing added and the history
   * not advanced (LIGGGHTS' compute pair/gran/local; sphdem_dem_contacts): per pair the atom indices (ij, 2 each:
   * the core's grain order, own atoms then ghosts), the force on the first, the torques on the first and the
   * second and x_first - x_second as the core took it (ft, SPHDEM_DEM_CONTACT_DOUBLES each), the history (SPHDEM_DEM_HIST_DOUBLES each) and the rolling torques (roll, 3 each). This
   * rank's pairs only. Returns their number, or -1 with err set. step: the contacts exactly as the last evaluation
   * made them (sphdem_dem_step_contacts; that evaluation was asked to keep its history; hist and roll are not
   * given). */
  int64_t contacts_now(std::vector<int32_t> &ij, std::vector<double> &ft, std::vector<double> &hist,
                       std::vector<double> &roll, std::string &err, bool step = false);
  /* Heat conduction through the touching pairs of two grains (sphdem_dem_heat; LIGGGHTS fix heat/gran/conduction):
   * temp, cond and member (may be NULL) per atom (own atoms and ghosts), area one of SPHDEM_DEM_HEAT_AREA_* (area_value for CONSTANT).
   * Each own atom's heat flow is added to heat[i] and its directional flux to dir[i] (may be NULL); a periodic
   * image's share goes to the atom it is an image of; another rank's atom's share is left to that rank, which
   * evaluates the pair too. Returns false with err set. */
  bool heat_now(const double *temp, const double *cond, const int *member, int area, double area_value, double *heat,
                double **dir, std::string &err);

 protected:
  std::string style_;       /* the style name, for messages */
  int device_;              /* sphdem_device (keyword device) */
  int algo_;                /* sphdem_dem_algo (keyword algo) */
  int freeze_group_bit_;
  std::vector<double> maxrad_dynamic_, maxrad_frozen_; /* per type (1..ntypes), as the stock style */
  sphdem_dem dem_;
  sphdem_dem_params prm_;
  double box_lo_[3], box_hi_[3];
  int box_per_[3];
  std::vector<int64_t> tags_;
  std::vector<double> fbuf_, tbuf_;
  std::vector<int> flags_;
  sphdem_pair_timers::RunTimers timers_;           /* keyword timers on */
  sphdem_grains::Store grains_;                    /* every atom of the step, read by the core (and by fix
                                                      sph/couple, fix cfd/grid when their grains are there) */
  sphdem_restart::PendingHistory pending_history_; /* from read_restart, handed to the core in init_style */
  /* Many MPI ranks: the core gets the owned atoms and then the ghost atoms (flags SPHDEM_DEM_GHOST or
   * SPHDEM_DEM_IMAGE). LAMMPS with newton on: a pair split between two ranks is evaluated once, on the rank of
   * its atom of lower tag, which keeps its history and writes the other atom's share to the ghost row for the
   * engine's reverse communication (as the stock styles evaluate it once). Else every rank evaluates each pair
   * that has one of its own atoms and adds the force to its own atoms only, so a pair split between two ranks
   * is evaluated on both (same atom order, the same operands unless one atom is seen through a periodic shift)
   * and both keep its history. */
  bool ghosts_;
  bool ghost_once_ok_;                /* false: evaluate split pairs on both ranks even with newton on */
  bool hand_rolling_;                 /* the core keeps rolling torques per contact: they go with the hand-over */
  std::vector<int> image_of_;         /* per ghost (index - nlocal): the own atom it is a periodic image of, -1, or
                                         SKIPPED (an image along an axis of core_per_) */
  static constexpr int SKIPPED = -2;
  /* Many ranks: the periodic axes the ranks do not cut (processors grid 1 along them; a box at least twice the
   * neighbour cutoff), which the core treats by the minimum image as on one rank; the engine's ghost images
   * along them are given to the core as SPHDEM_DEM_SKIP. Cut axes: the ghost atoms are the periodic images. */
  int core_per_[3];
  std::vector<int> images_;           /* the ghosts (indices) that are periodic images of own atoms */
  int nall_mapped_;                   /* atoms when image_of_ was made */
  std::vector<int64_t> owned_prev_;   /* tags owned at the last engine list build (history hand-over) */
  sphdem_tagmap::TagMap prev_map_;    /* and their map */
  bool owned_prev_set_;
  sphdem_tagmap::TagMap own_now_;     /* the owned tags of this evaluation (own_map) */
  bool own_map_valid_;
  std::vector<int64_t> left_, arrived_; /* hand-over: tags that left and joined this rank since the last build */
  std::vector<int> hand_ranks_;       /* hand_ranks(), for the decomposition of hand_key_ */
  std::vector<uint64_t> hkeys_, hsk_; /* hand-over buffers, kept from one list build to the next */
  std::vector<double> hhist_, hroll_, hsh_;
  int hand_key_[7];
  bool hand_key_valid_ = false;
  std::vector<double> cuts_;          /* the brick decomposition's cuts at the last build (cuts_moved) */
  std::vector<uint64_t> gkeys_;       /* rank 0: the history of every rank, gathered at the end of each run and on */
  std::vector<double> ghist_;         /* the steps of restart files, for write_restart */
  std::vector<double> groll_;         /* and their rolling history (3 per pair, hand_rolling_) */
  /* the gathering's scratch, kept between runs (no fresh pages for each gathering): this rank's list, its pairs
   * with a history, and on rank 0 the gathered keys, values and their order */
  std::vector<uint64_t> gscr_keys_, gscr_sk_, gscr_rk_;
  std::vector<double> gscr_hist_, gscr_roll_, gscr_sh_, gscr_rh_;
  std::vector<int> gscr_order_;
  bool gathered_;
  /* many ranks: the failure check of the evaluations. A failure is kept (check_pending_, the first message) and
   * reduced every kCheckEvery steps without a wait (the reduction completed when the next one starts), at once on
   * the set-up, restart and last steps, and at the start of each step of an engine list build (before the atoms'
   * hand-over), so that a rank whose evaluation failed stops within kCheckEvery steps or at the next list build.
   * A reduction at every step costs each step a round trip between the ranks (about 13 us on 2 ranks of a 2-core
   * host, a tenth of a step of 5000 grains a rank). */
  static constexpr int kCheckEvery = 10;
  MPI_Request check_req_;
  int check_mine_, check_any_, check_pending_;
  std::string check_msg_, check_pending_msg_;

  /* the engine's arguments -> sphdem_dem_params; ends with set_box and push_params */
  virtual void sync_params() = 0;
  /* at each engine list build, after the history hand-over between ranks and before the core's own build
   * (collective on many ranks) */
  virtual void list_built() {}
  /* this step writes a restart file (the engine's restart command): the history of every rank goes to rank 0 */
  bool restart_step() const;
  /* many ranks: the history changed since it was last gathered (a step ran); write_restart's init gathers it */
  bool history_dirty_ = false;
  /* many ranks, collective: the history (and a style's own per-pair data, gather_more) of every rank to rank 0 */
  void gather_for_restart();
  virtual void gather_more() {}

  [[noreturn]] void fail(const std::string &msg);     /* every rank calls it (the engine's collective stop) */
  [[noreturn]] void fail_one(const std::string &msg); /* this rank alone: the engine's one-rank stop */
  void allocate();
  /* keywords device, algo, timers: true when kw is one of them (a bad value ends the run) */
  bool common_keyword(const std::string &kw, const std::string &val);
  /* many ranks: image_of_ from the atoms' tags and positions (after each exchange of ghost atoms) */
  void map_ghosts(int nlocal, int nall);
  /* the map of the owned tags, made once per evaluation */
  const sphdem_tagmap::TagMap &own_map(int nlocal);
  /* many ranks, at the engine's list builds: core_per_ from the processors grid, the box and the cutoff (the
   * core's parameters follow when they change) */
  void update_core_periodic();
  /* many ranks, collective, at the engine's list builds (after atoms changed rank): the history of the pairs of
   * atoms that left a rank (and their rolling torques, hand_rolling_) goes to the rank they joined, where the
   * core's next build carries it */
  void hand_over_history();
  /* the ranks whose atoms can join this rank at an exchange and which this rank's atoms can join (sorted; empty
   * where the decomposition is tiled: the hand-over then goes to every rank) */
  const std::vector<int> &hand_ranks();
  bool cuts_moved();
  /* the engine's neigh_modify exclude as the core's exclusion classes (set_exclusions): each atom's class is
   * excl_tcls_[type] << excl_bits_.size() | (its membership of the groups excl_bits_, a bit each) */
  bool excl_on_ = false;
  std::vector<int> excl_tcls_, excl_bits_;
  void setup_exclusions();
  int exclusion_class(int i) const;
  /* many ranks: this rank's evaluation failed (bad, why) or not; every rank stops with the message of the
   * lowest failed rank, at once (now) or later (the failure kept; the reduction started here on the steps of
   * kCheckEvery, completed at the next start) */
  void check_ranks(bool bad, const std::string &why, bool now);
  void finish_check(); /* the reduction of the last check_ranks: stops every rank when one failed */
  /* many ranks, collective: the history of every rank to rank 0 (each pair once), for write_restart */
  void gather_history();
  /* single() (compute pair/local): the contact of the touching atoms i, j as the core evaluates it now (contacts_now,
   * taken once per step and atom count): its SPHDEM_DEM_CONTACT_DOUBLES values (the force on a, the torques on a
   * and on b, x_a - x_b), and whether i is its grain a; stops this rank where the core has no such contact */
  const double *single_contact(int i, int j, bool &i_is_a);
  bool pair_local_present() const; /* a compute pair/local is defined (it calls single() on each rank's own list) */
  bigint single_step_ = -1; /* the step and atom count of the contacts below */
  int single_n_ = -1;
  std::unordered_map<uint64_t, int64_t> single_map_; /* (lower tag << 32 | higher tag) -> contact */
  std::vector<int32_t> single_ij_;
  std::vector<double> single_ft_, single_hist_, single_roll_;
  /* read_restart: rank 0 reads n items, every rank gets them; false (on every rank) when the file ends */
  bool read_head(FILE *fp, void *p, size_t size, size_t n);
  /* the checks of init_style common to both engines; atom_styles names the styles that fit */
  void check_atoms(const char *atom_styles);
  /* rigid bodies refused (fix rigid*: the pair styles keep no body bookkeeping); the group of fix freeze kept in
   * freeze_group_bit_ (its grains feel no force, as with the stock styles) */
  void scan_rigid_freeze();
  /* the largest radius per type of the local grains (frozen ones apart) added to dyn/frz (nt + 1 each,
   * the inserting fixes already in dyn), reduced over the ranks into maxrad_dynamic_/maxrad_frozen_ */
  void reduce_maxrad(std::vector<double> &dyn, std::vector<double> &frz);
  void set_box(sphdem_dem_params &p);  /* skin and box of the engine into p (and remembered) */
  void push_params(const sphdem_dem_params &p);
  void create_core();                  /* once: the DEM core, and a line saying where it runs */
  void restore_history();              /* the contact history of read_restart, once the core exists */
  void write_restart_tail(FILE *fp);   /* pair_coeff flags and the contact history */
  void begin_read_restart();
  void read_restart_tail(FILE *fp, bool head_read);
  /* One evaluation: grains to the core, forces and torques added to the atoms, the virial, the timers.
   * material_types: the grain's type is its material (several materials); follow_list_builds: the core
   * rebuilds its pair list on the engine's neighbour-list builds. */
  void compute_grains(bool material_types, bool follow_list_builds);
  /* The per-atom virial (vatom, 1/2 r_ab F_ab to each atom of a pair, as the stock styles' ev_tally_xyz) of the
   * evaluation just made, from the core's contacts evaluated again with the same atoms (sphdem_dem_contacts): for
   * the laws whose evaluation with the kept history gives the step's force again (LAMMPS gran/hooke|hertz/history
   * and granular; unit_dem test_contacts). Own atoms get their shares; another rank's atom's share goes to its ghost row only
   * where this rank alone evaluates the pair (newton on, split pairs once: the engine's reverse communication),
   * a periodic image's to the atom itself otherwise. step: from the step's own contacts (sphdem_dem_step_contacts;
   * sphdem_dem_keep_step_history before the evaluation), for laws whose evaluation with the kept history does not
   * give the step's force again (LIGGGHTS gran/gpu). */
  void add_virial_atom(bool step = false);
  std::vector<double> heat_q_, heat_dq_; /* heat_now: the core's sums per atom */
  bool last_once_ = false; /* the last evaluation gave split pairs' shares to the ghost rows (compute_grains) */
};

}  // namespace LAMMPS_NS

#endif
