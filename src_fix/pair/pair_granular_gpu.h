/* pair_granular_gpu.h - pair_style granular/gpu (LAMMPS): the words of the stock pair_style granular
 * (29 Sep 2021), per type pair, the contacts computed by the sphdem DEM core (CPU or CUDA). */
#ifdef PAIR_CLASS
PairStyle(granular/gpu,PairGranularGPU)
#else

#ifndef SPHDEM_PAIR_GRANULAR_GPU_H
#define SPHDEM_PAIR_GRANULAR_GPU_H

#include <vector>

#include "pair_gran_gpu_base.h"

namespace LAMMPS_NS {

class PairGranularGPU : public PairGranGPUBase {
 public:
  explicit PairGranularGPU(class LAMMPS *);
  ~PairGranularGPU() override;
  void compute(int, int) override;
  /* compute pair/local: the stock values of a pair (fforce the normal force over the distance; svector the
   * tangential force and its magnitude, the rolling force and its magnitude, the twisting torque, x_i - x_j) */
  double single(int, int, int, int, double, double, double, double &) override;
  void settings(int, char **) override;
  void coeff(int, char **) override;
  void init_style() override;
  double init_one(int, int) override;
  void write_restart(FILE *) override;
  void read_restart(FILE *) override;

 protected:
  double cutoff_global_;                  /* pair_style granular/gpu cutoff; < 0: from the radii */
  /* per type pair (i, j in 1..ntypes, (ntypes + 1)^2, row-major): the coefficients as the stock style keeps
   * them after pair_coeff and its mixing, Young's modulus and Poisson ratio of the material models, the
   * pair's cutoff keyword (< 0: none) */
  std::vector<sphdem_dem_granular> coef_;
  std::vector<double> emod_, poiss_, cut_type_;
  bool table_sent_;                       /* the core has the current table */
  /* rolling or twisting on: the stock history transfer is followed (sphdem_dem_flip_history), which needs the
   * engine's half list and, per pair that may touch, whether its lower tag came first at the last build */
  bool track_order_;
  std::vector<uint64_t> order_prev_, order_now_; /* (key << 1) | (lower tag first), sorted; many ranks: the
                                                    pairs with one of this rank's atoms */
  std::vector<uint64_t> flips_;
  std::vector<int64_t> order_owned_;             /* many ranks: the tags owned at the last build, sorted */
  bool order_owned_set_;
  std::vector<uint64_t> gorder_;                 /* many ranks, rank 0: every rank's order_prev_, for write_restart */
  bool gathered_order_;

  void sync_params() override;
  void list_built() override;
  sphdem_dem_granular &at(int i, int j) { return coef_[(size_t)i * (atom->ntypes + 1) + j]; }
  void send_table();
  void follow_list_order();
  void merge_rank_orders(std::vector<uint64_t> &boundary);
  void gather_order();
  void gather_more() override {
    if (track_order_) gather_order();
  }
};

}  // namespace LAMMPS_NS

#endif
#endif
