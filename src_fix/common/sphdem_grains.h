/* sphdem_grains.h - the grains the shims hand to the core: a fix group gathered into flat arrays (fix sph/couple,
 * fix cfd/grid), and the grain store of each shim (Store), handed once a step and found by the other shims of
 * the same engine instance, so that the coupling, the DEM contacts and the gas grid upload the grains once. */
#ifndef SPHDEM_GRAINS_H
#define SPHDEM_GRAINS_H

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "atom.h"
#include "neighbor.h"
#include "sphdem.h"
#include "update.h"

namespace sphdem_grains {

/* the local atoms to loop over: the first nfirst when the group is that of atom_modify first */
inline int nloop(const LAMMPS_NS::Atom *atom, int igroup) {
  return (atom->firstgroup >= 0 && igroup == atom->firstgroup) ? atom->nfirst : atom->nlocal;
}

/* The grains of groupbit among the first nloop local atoms: idx their local indices (upload order), x and v
 * 3 per grain, radius one, omega 3 per grain (when not NULL). Returns their count. */
inline size_t gather(LAMMPS_NS::Atom *atom, int groupbit, int nloop, std::vector<int> &idx, std::vector<double> &x,
                     std::vector<double> &v, std::vector<double> &radius, std::vector<double> *omega) {
  const int *mask = atom->mask;
  idx.clear();
  for (int i = 0; i < nloop; i++)
    if (mask[i] & groupbit) idx.push_back(i);
  const size_t n = idx.size();
  x.resize(3 * n);
  v.resize(3 * n);
  radius.resize(n);
  if (omega) omega->resize(3 * n);
  double **ax = atom->x, **av = atom->v, **om = atom->omega;
  for (size_t k = 0; k < n; k++) {
    const int i = idx[k];
    radius[k] = atom->radius[i];
    for (int d = 0; d < 3; d++) {
      x[3 * k + d] = ax[i][d];
      v[3 * k + d] = av[i][d];
      if (omega) (*omega)[3 * k + d] = om[i][d];
    }
  }
  return n;
}

/* The stamp of the grains of this moment of the run: step, run, setup flag, neighbour-list builds (the atom
 * order), own and ghost count. Within one force stage and the post_force of the same step the engine neither
 * moves nor reorders atoms, so a store with this stamp holds the grains as they are now. */
inline void stamp_now(LAMMPS_NS::LAMMPS *lmp, int nown, int nghost, int64_t st[SPHDEM_GRAINS_STAMP]) {
  st[0] = (int64_t)lmp->update->ntimestep, st[1] = (int64_t)lmp->update->firststep;
  st[2] = lmp->update->setupflag, st[3] = (int64_t)lmp->neighbor->ncalls, st[4] = nown, st[5] = nghost;
}

static_assert(sizeof(int) == sizeof(int32_t), "local indices are passed to the core as int32");

/* The grain store of one shim (pair style or fix): created on the core's backend at the first put, destroyed
 * with the shim. Every store is listed for the shims of its engine instance: a fix group whose grains a current
 * store already holds reads them from there (the pair style's store holds every atom, own then ghosts). */
class Store {
 public:
  struct View {
    sphdem_grain_store g = nullptr;
    int n = 0;
    const int32_t *idx = nullptr; /* indices into g, or NULL: the first n */
    bool shared = false;          /* another shim's store */
  };
  Store() = default;
  Store(const Store &) = delete;
  Store &operator=(const Store &) = delete;
  ~Store() {
    auto &r = list();
    r.erase(std::remove(r.begin(), r.end(), this), r.end());
    sphdem_grains_destroy(&g_);
  }
  /* the pair styles: every atom [0, nown + nghost), read in place (x, v, omega as n x 3 blocks, radius, rmass) */
  sphdem_grain_store put_atoms(LAMMPS_NS::LAMMPS *lmp, int dev, int nown, int nghost, std::string &err) {
    LAMMPS_NS::Atom *atom = lmp->atom;
    const int n = nown + nghost;
    const double *x = n ? atom->x[0] : nullptr, *v = n ? atom->v[0] : nullptr, *w = n ? atom->omega[0] : nullptr;
    if (!put(lmp, dev, ATOMS, 0, 0, nown, nghost, x, v, w, atom->radius, atom->rmass, err)) return nullptr;
    return g_;
  }
  /* a fix group's grains: gidx their local indices (nown own, then ghosts), x, v, radius (and omega when not
   * NULL) gathered in that order by the caller. A current store of another shim that holds them all, else
   * this store with the caller's arrays. */
  View hand_group(LAMMPS_NS::LAMMPS *lmp, int dev, int groupbit, int nloop, const std::vector<int> &gidx, size_t nown,
                  const std::vector<double> &x, const std::vector<double> &v, const std::vector<double> &radius,
                  const std::vector<double> *omega, std::string &err) {
    View out;
    const int n = (int)gidx.size(), nghost = n - (int)nown;
    int64_t st[SPHDEM_GRAINS_STAMP];
    stamp_now(lmp, 0, 0, st);
    const int top = n ? *std::max_element(gidx.begin(), gidx.end()) : -1;
    for (Store *s : list()) {
      if (s == this || !s->g_ || s->lmp_ != lmp || s->dev_ != dev || !s->current(st)) continue;
      if (omega && !s->omega_) continue;
      if (s->kind_ == ATOMS && s->nown_ == lmp->atom->nlocal && top < s->nown_ + s->nghost_) {
        out.g = s->g_, out.n = n, out.idx = reinterpret_cast<const int32_t *>(gidx.data()), out.shared = true;
        return out;
      }
      if (s->kind_ == GROUP && s->groupbit_ == groupbit && s->nloop_ == nloop && s->nown_ == (int)nown &&
          (s->nghost_ == nghost || nghost == 0)) {
        out.g = s->g_, out.n = n, out.shared = true;
        return out;
      }
    }
    if (put(lmp, dev, GROUP, groupbit, nloop, (int)nown, nghost, x.data(), v.data(), omega ? omega->data() : nullptr,
            radius.data(), nullptr, err)) {
      out.g = g_, out.n = n;
    }
    return out;
  }
  /* host-to-device grain uploads of every store of the process so far */
  static int64_t uploads_total() { return sphdem_grains_uploads(nullptr); }

 private:
  enum Kind { ATOMS, GROUP };
  static std::vector<Store *> &list() {
    static std::vector<Store *> all;
    return all;
  }
  bool current(const int64_t st[SPHDEM_GRAINS_STAMP]) const {
    for (int k = 0; k < 4; k++)
      if (stamp_[k] != st[k]) return false;
    return true;
  }
  bool put(LAMMPS_NS::LAMMPS *lmp, int dev, Kind kind, int groupbit, int nloop, int nown, int nghost, const double *x,
           const double *v, const double *omega, const double *radius, const double *mass, std::string &err) {
    if (g_ && dev_ != dev) sphdem_grains_destroy(&g_);
    if (!g_) {
      char msg[256] = "";
      if (sphdem_grains_create(&g_, (sphdem_device)dev, msg, sizeof msg) != SPHDEM_OK) {
        err = msg;
        return false;
      }
      dev_ = dev;
      auto &r = list();
      if (std::find(r.begin(), r.end(), this) == r.end()) r.push_back(this);
    }
    lmp_ = lmp, kind_ = kind, groupbit_ = groupbit, nloop_ = nloop, nown_ = nown, nghost_ = nghost;
    omega_ = omega != nullptr;
    stamp_now(lmp, nown, nghost, stamp_);
    if (sphdem_grains_put(g_, stamp_, nown, nghost, x, v, omega, radius, mass) != SPHDEM_OK) {
      err = sphdem_grains_last_error(g_);
      stamp_[0] = -1; /* not current */
      return false;
    }
    return true;
  }
  sphdem_grain_store g_ = nullptr;
  LAMMPS_NS::LAMMPS *lmp_ = nullptr;
  int dev_ = 0;
  Kind kind_ = GROUP;
  int groupbit_ = 0, nloop_ = 0, nown_ = 0, nghost_ = 0;
  bool omega_ = false;
  int64_t stamp_[SPHDEM_GRAINS_STAMP] = {-1, 0, 0, 0, 0, 0};
};

}  // namespace sphdem_grains

#endif
