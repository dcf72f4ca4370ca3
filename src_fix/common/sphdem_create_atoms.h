/* sphdem_create_atoms.h - atom creation shared by fix sph/wall and fix sph/fill: the lattice of the sc lattice
 * `lattice sc DX origin 0.5 0.5 0.5`, and adding a list of points (the same list on every rank) as atoms of one
 * type, diameter and mass, with global IDs maxtag+1.. in list order, each rank keeping those in its subdomain. */
#ifndef SPHDEM_CREATE_ATOMS_H
#define SPHDEM_CREATE_ATOMS_H

#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "group.h"
#include "modify.h"
#include "sphdem_compat.h"
#include "sphdem_geom.h"

namespace sphdem_atoms {

/* "" when the atom style can take the created atoms (per-atom radius and mass: sphere; LIGGGHTS: granular too) */
inline std::string atom_style_problem(LAMMPS_NS::Atom *atom) {
  const std::string st = atom->atom_style ? atom->atom_style : "";
  if ((st == "sphere" || st == "granular") && atom->radius_flag && atom->rmass_flag && atom->tag_enable) return "";
  return "needs atom_style sphere (LIGGGHTS: sphere or granular), whose atoms have a diameter and a mass of their "
         "own (atom_style is " + st + ")";
}

/* The particle keywords both fixes take: spacing DX, type T, mass M | density RHO0, diameter D. parse() consumes
 * arg[i] (and its value) when it is one of them, advancing i, and returns false otherwise; finish() checks that the
 * required ones were given and fills the defaults (diameter DX, mass RHO0 DX^dim). NUM(i, kw) reads arg[i] as a
 * number, FAIL(msg) stops with the fix's message. */
struct ParticleKeywords {
  double dx = 0, mass = 0, density = 0, diameter = 0;
  long type = 0;
  bool have_dx = false, have_type = false, have_mass = false, have_density = false, have_diameter = false;

  template <class Num, class Fail>
  bool parse(const std::string &kw, int &i, int narg, char **arg, int ntypes, Num num, Fail fail) {
    if (kw == "spacing") {
      dx = num(i + 1, "spacing"), have_dx = true, i += 2;
      if (!(dx > 0)) fail("spacing must be > 0 (got " + std::string(arg[i - 1]) + ")");
    } else if (kw == "type") {
      if (i + 1 >= narg || !sphdem_compat::to_int(arg[i + 1], &type))
        fail(std::string("type expects an atom type, got '") + (i + 1 < narg ? arg[i + 1] : "") + "'");
      if (type < 1 || type > ntypes)
        fail("type must be 1 .. " + std::to_string(ntypes) + " (got " + std::to_string(type) + ")");
      have_type = true, i += 2;
    } else if (kw == "mass" || kw == "density" || kw == "diameter") {
      double &v = kw == "mass" ? mass : kw == "density" ? density : diameter;
      v = num(i + 1, kw.c_str()), i += 2;
      (kw == "mass" ? have_mass : kw == "density" ? have_density : have_diameter) = true;
      if (!(v > 0)) fail(kw + " must be > 0");
    } else {
      return false;
    }
    return true;
  }
  /* the checks after the keyword loop that come before the engine-state checks */
  template <class Fail>
  void require(Fail fail) const {
    if (!have_dx) fail("spacing DX is required");
    if (!have_type) fail("type T is required");
    if (have_mass == have_density) fail("give one of mass M and density RHO0");
  }
  void defaults(int dim) {
    if (!have_diameter) diameter = dx;
    if (have_density) mass = density * std::pow(dx, dim);
  }
};

/* the lattice indices i0..i1 of the points o + i dx in [lo, hi) */
inline void lattice_range(double lo, double hi, double o, double dx, long &i0, long &i1) {
  i0 = (long)std::ceil((lo - o) / dx - 1e-9);
  i1 = (long)std::floor((hi - o) / dx + 1e-9);
  while (o + i0 * dx < lo - 1e-9 * dx) i0++;
  while (i1 >= i0 && o + i1 * dx >= hi - 1e-9 * dx) i1--;
}

/* point i of the lattice along one axis: (i + 1/2) dx as `lattice sc DX origin 0.5 0.5 0.5` (or origin + i dx) */
struct ScLattice {
  double dx;
  bool have_origin;
  double origin[3];
  double at(int d, long i) const { return have_origin ? origin[d] + i * dx : ((double)i + 0.5) * dx; }
  double offset(int d) const { return have_origin ? origin[d] : 0.5 * dx; }
};

/* calls f(x) for the lattice points in [lo, hi) (z = 0 only in 2D), z slowest, x fastest */
template <class F> void for_lattice(const ScLattice &L, const double lo[3], const double hi[3], int dim, F f) {
  long r[3][2];
  for (int d = 0; d < 3; d++) lattice_range(lo[d], hi[d], L.offset(d), L.dx, r[d][0], r[d][1]);
  if (dim == 2) r[2][0] = r[2][1] = 0;
  for (long k = r[2][0]; k <= r[2][1]; k++)
    for (long j = r[1][0]; j <= r[1][1]; j++)
      for (long i = r[0][0]; i <= r[0][1]; i++) {
        double x[3] = {L.at(0, i), L.at(1, j), dim == 2 ? 0.0 : L.at(2, k)};
        f(x);
      }
}

/* [lo, hi) of a search: clipped to the box along periodic axes (no point beyond a periodic boundary) */
inline void clip_periodic(LAMMPS_NS::Domain *domain, double lo[3], double hi[3]) {
  const int per[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
  for (int d = 0; d < 3; d++)
    if (per[d]) {
      lo[d] = std::fmax(lo[d], domain->boxlo[d]);
      hi[d] = std::fmin(hi[d], domain->boxhi[d]);
    }
}

struct Result {
  long long generated = 0, created = 0;
  long long first_tag = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0}; /* bounding box of the points */
};

/* Collective. Every rank passes the same points. Creates them as atoms of `type` with the given diameter and mass in
 * group bit `groupbit` (and all), IDs maxtag+1 .. in list order; sets radius and mass directly; runs set_arrays of
 * the fixes that keep per-atom state for created atoms; updates natoms and the atom map. */
inline Result create(LAMMPS_NS::LAMMPS *lmp, const sphdem_points &pts, int type, double diameter, double mass,
                     int groupbit) {
  using namespace LAMMPS_NS;
  Atom *atom = lmp->atom;
  Domain *domain = lmp->domain;
  Result res;
  res.generated = pts.n;
  for (int d = 0; d < 3; d++) {
    res.lo[d] = pts.n ? HUGE_VAL : 0.0;
    res.hi[d] = pts.n ? -HUGE_VAL : 0.0;
  }
  for (long i = 0; i < pts.n; i++)
    for (int d = 0; d < 3; d++) {
      res.lo[d] = std::fmin(res.lo[d], pts.x[3 * i + d]);
      res.hi[d] = std::fmax(res.hi[d], pts.x[3 * i + d]);
    }
  long long maxtag = 0, mine = 0;
  for (int i = 0; i < atom->nlocal; i++)
    if ((long long)atom->tag[i] > mine) mine = atom->tag[i];
  MPI_Allreduce(&mine, &maxtag, 1, MPI_LONG_LONG, MPI_MAX, lmp->world);
  res.first_tag = maxtag + 1;

  /* ghost atoms are overwritten by new ones (as create_atoms does) */
  atom->nghost = 0;
  const int nlocal_before = atom->nlocal;
  /* only the points near this subdomain go to data_atoms, which takes those inside it */
  double slo[3], shi[3];
  for (int d = 0; d < 3; d++) {
    double eps = 1e-6 * (domain->boxhi[d] - domain->boxlo[d]);
    slo[d] = domain->sublo[d] - eps;
    shi[d] = domain->subhi[d] + eps;
  }
  const double rad = 0.5 * diameter;
  /* the data file's density: what gives this mass in data_atom (overwritten below anyway) */
  const double dens = rad > 0 ? mass / (4.0 * M_PI / 3.0 * rad * rad * rad) : mass;
  const long chunk = 4096;
  std::string buf;
  char line[256];
  int nlines = 0;
  auto flush = [&]() {
    if (!nlines) return;
    std::vector<char> b(buf.begin(), buf.end());
    b.push_back('\0');
    sphdem_compat::data_atoms(atom, nlines, b.data());
    buf.clear();
    nlines = 0;
  };
  for (long i = 0; i < pts.n; i++) {
    const double *x = pts.x + 3 * i;
    if (x[0] < slo[0] || x[0] > shi[0] || x[1] < slo[1] || x[1] > shi[1] || x[2] < slo[2] || x[2] > shi[2]) continue;
    std::snprintf(line, sizeof line, "%lld %d %.17g %.17g %.17g %.17g %.17g\n", maxtag + 1 + i, type, diameter, dens,
                  x[0], x[1], x[2]);
    buf += line;
    if (++nlines == chunk) flush();
  }
  flush();
  const int nlocal = atom->nlocal;
  double *density = sphdem_compat::atom_density(atom);
  for (int i = nlocal_before; i < nlocal; i++) {
    atom->radius[i] = rad;
    atom->rmass[i] = mass;
    atom->mask[i] |= groupbit;
    if (density) density[i] = dens;
  }
  for (int m = 0; m < lmp->modify->nfix; m++) {
    Fix *fix = lmp->modify->fix[m];
    if (!fix->create_attribute) continue;
    sphdem_compat::pre_set_arrays(fix);
    for (int i = nlocal_before; i < nlocal; i++) fix->set_arrays(i);
  }
  long long made = nlocal - nlocal_before;
  MPI_Allreduce(&made, &res.created, 1, MPI_LONG_LONG, MPI_SUM, lmp->world);
  atom->natoms += res.created;
  if (atom->map_style) {
    atom->map_init();
    atom->map_set();
  }
  return res;
}

/* "xlo xhi ylo yhi zlo zhi" of a bounding box, for the set-up line */
inline std::string bbox_text(const Result &r) {
  char s[256];
  std::snprintf(s, sizeof s, "%g %g  %g %g  %g %g", r.lo[0], r.hi[0], r.lo[1], r.hi[1], r.lo[2], r.hi[2]);
  return s;
}

}  // namespace sphdem_atoms

#endif
