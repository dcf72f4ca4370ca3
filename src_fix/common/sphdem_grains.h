/* sphdem_grains.h - the grains of a fix group gathered into the flat arrays the core reads (fix sph/couple,
 * fix cfd/grid): local indices, positions, velocities, radii, and the angular velocities when asked. */
#ifndef SPHDEM_GRAINS_H
#define SPHDEM_GRAINS_H

#include <vector>

#include "atom.h"

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

}  // namespace sphdem_grains

#endif
