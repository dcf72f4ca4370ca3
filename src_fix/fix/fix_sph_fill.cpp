/* fix_sph_fill.cpp - fix sph/fill: the sc lattice inside a region, less the points near the atoms of the exclude
 * groups (gpu/geom/wallgen.c, sphdem_points_exclude), created as atoms (sphdem_create_atoms.h); prints the count
 * and the top of the fluid. Runs once, in the constructor; the fix does nothing during runs. */
#include "fix_sph_fill.h"

#include <mpi.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_sph_wall.h"
#include "group.h"
#include "modify.h"
#include "region.h"
#include "sphdem_args.h"
#include "sphdem_compat.h"
#include "sphdem_create_atoms.h"
#include "sphdem_geom.h"

using namespace LAMMPS_NS;

namespace {
const char *const SYNTAX =
    "fix ID group-ID sph/fill region REGION-ID spacing DX type T (mass M | density RHO0) [diameter D] "
    "[inside WALL-FIX-ID] [exclude GROUP-ID [GROUP-ID ...]] [gap G] [origin OX OY OZ]";
const char *const KEYWORDS = "region, spacing, type, mass, density, diameter, inside, exclude, gap, origin";
bool is_keyword(const char *s) {
  for (const char *k : {"region", "spacing", "type", "mass", "density", "diameter", "inside", "exclude", "gap", "origin"})
    if (!std::strcmp(s, k)) return true;
  return false;
}
}  // namespace

void FixSPHFill::fail(const std::string &msg) {
  sphdem_compat::error_all(error, FLERR, std::string("Fix sph/fill: ") + msg);
}

FixSPHFill::FixSPHFill(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg), created_(0), top_(0.0) {
  scalar_flag = 1;
  vector_flag = 1;
  size_vector = 2;
  global_freq = 1;
  extscalar = 0;
  extvector = 0;
  auto failf = [this](const std::string &m) { fail(m); };
  auto num = [&](int i, const char *kw) -> double {
    if (i >= narg) fail(std::string(kw) + " needs a value (usage: " + SYNTAX + ")");
    return sphdem_args::number(failf, kw, arg[i], SYNTAX);
  };
  std::string region_id, inside_id;
  std::vector<int> exclude;
  sphdem_atoms::ParticleKeywords pk;
  double gap = 0, origin[3] = {0, 0, 0};
  bool have_gap = false, have_origin = false;
  for (int i = 3; i < narg;) {
    const std::string kw = arg[i];
    if (pk.parse(kw, i, narg, arg, atom->ntypes, num, failf)) continue;
    if (kw == "region") {
      if (i + 1 >= narg) fail(std::string("region needs a region ID (usage: ") + SYNTAX + ")");
      region_id = arg[i + 1], i += 2;
    } else if (kw == "inside") {
      if (i + 1 >= narg) fail(std::string("inside needs the ID of a fix sph/wall (usage: ") + SYNTAX + ")");
      inside_id = arg[i + 1], i += 2;
    } else if (kw == "gap") {
      gap = num(i + 1, "gap"), have_gap = true, i += 2;
      if (!(gap >= 0)) fail("gap must be >= 0");
    } else if (kw == "origin") {
      for (int d = 0; d < 3; d++) origin[d] = num(i + 1 + d, "origin");
      have_origin = true, i += 4;
    } else if (kw == "exclude") {
      i++;
      int before = (int)exclude.size();
      /* group IDs up to the next keyword */
      while (i < narg && !is_keyword(arg[i])) {
        int g = sphdem_compat::find_group(group, arg[i]);
        if (g < 0) fail(std::string("exclude: group ") + arg[i] + " does not exist");
        exclude.push_back(g);
        i++;
      }
      if ((int)exclude.size() == before) fail("exclude needs at least one group ID");
    } else {
      fail("unknown keyword '" + kw + "' (allowed: " + KEYWORDS + "; usage: " + SYNTAX + ")");
    }
  }
  if (region_id.empty()) fail(std::string("region REGION-ID is required (usage: ") + SYNTAX + ")");
  pk.require(failf);
  if (!domain->box_exist) fail("create the simulation box first (create_box or read_data)");
  const std::string style_problem = sphdem_atoms::atom_style_problem(atom);
  if (!style_problem.empty()) fail(style_problem);
  const int dim = domain->dimension;
  pk.defaults(dim);
  const double dx = pk.dx, mass = pk.mass, diameter = pk.diameter;
  const long type = pk.type;
  if (!have_gap) gap = 0.0;
  const FixSPHWall *walls = nullptr;
  if (!inside_id.empty()) {
    for (int m = 0; m < modify->nfix && !walls; m++)
      if (inside_id == modify->fix[m]->id) {
        if (std::strcmp(modify->fix[m]->style, "sph/wall"))
          fail("inside: fix " + inside_id + " is a fix " + modify->fix[m]->style + ", not a fix sph/wall");
        walls = static_cast<const FixSPHWall *>(modify->fix[m]);
      }
    if (!walls) fail("inside: no fix with ID " + inside_id + " (define the fix sph/wall before the fill)");
  }
  int ireg = domain->find_region(region_id.c_str());
  if (ireg < 0) fail("region " + region_id + " does not exist");
  Region *reg = domain->regions[ireg];
  reg->init();
  reg->prematch();

  /* search: the region's bounding box (where it has one) within the simulation box */
  double lo[3], hi[3];
  for (int d = 0; d < 3; d++) lo[d] = domain->boxlo[d], hi[d] = domain->boxhi[d];
  if (reg->bboxflag) {
    const double elo[3] = {reg->extent_xlo, reg->extent_ylo, reg->extent_zlo};
    const double ehi[3] = {reg->extent_xhi, reg->extent_yhi, reg->extent_zhi};
    for (int d = 0; d < dim; d++) lo[d] = std::fmax(lo[d], elo[d]), hi[d] = std::fmin(hi[d], ehi[d]);
  }
  sphdem_atoms::ScLattice L{dx, have_origin, {origin[0], origin[1], origin[2]}};
  sphdem_points pts = {nullptr, 0, 0};
  bool oom = false;
  sphdem_atoms::for_lattice(L, lo, hi, dim, [&](double *x) {
    if (sphdem_compat::region_match_closed(reg, x[0], x[1], x[2]) && sphdem_points_push(&pts, x[0], x[1], x[2]) != SPHDEM_OK) oom = true;
  });
  if (oom) fail("out of memory for the fluid points");
  const long long in_region = pts.n;

  /* the fluid side of the walls of a fix sph/wall: its mesh (sphdem_points_clip_mesh) or its region */
  long long outside = 0;
  if (walls && !walls->facets().empty()) {
    sphdem_mesh mesh = {const_cast<sphdem_facet *>(walls->facets().data()), (long)walls->facets().size(), 0, 0};
    long c = sphdem_points_clip_mesh(&pts, &mesh, dx, gap);
    if (c < 0) fail("out of memory keeping the points inside the mesh of fix " + inside_id);
    outside = c;
  } else if (walls) {
    int iw = domain->find_region(walls->region_id().c_str());
    if (iw < 0) fail("inside: the region " + walls->region_id() + " of fix " + inside_id + " no longer exists");
    Region *wr = domain->regions[iw];
    wr->init();
    wr->prematch();
    long kept = 0;
    for (long i = 0; i < pts.n; i++) {
      double *x = pts.x + 3 * i, xn[3] = {x[0], x[1], x[2]};
      bool in = sphdem_compat::region_match_closed(wr, x[0], x[1], x[2]);
      if (in && gap > 0) in = (wr->interior ? wr->surface_interior(xn, gap) : wr->surface_exterior(xn, gap)) == 0;
      if (!in) continue;
      if (kept != i) std::memmove(pts.x + 3 * kept, x, 3 * sizeof(double));
      kept++;
    }
    outside = pts.n - kept;
    pts.n = kept;
  }

  /* the atoms of the exclude groups, from every rank */
  long long removed = 0;
  if (!exclude.empty()) {
    int mask_any = 0;
    for (int g : exclude) mask_any |= group->bitmask[g];
    std::vector<double> mine;
    for (int i = 0; i < atom->nlocal; i++)
      if (atom->mask[i] & mask_any) {
        mine.push_back(atom->x[i][0]);
        mine.push_back(atom->x[i][1]);
        mine.push_back(atom->x[i][2]);
        mine.push_back(atom->radius[i]);
      }
    int n = (int)mine.size(), nprocs = comm->nprocs;
    std::vector<int> counts(nprocs), displs(nprocs);
    MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
    long long total = 0;
    for (int p = 0; p < nprocs; p++) displs[p] = (int)total, total += counts[p];
    std::vector<double> all((size_t)total + 1);
    MPI_Allgatherv(mine.data(), n, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, world);
    long r = sphdem_points_exclude(&pts, all.data(), (long)(total / 4), gap, 1e-6 * dx);
    if (r < 0) fail("out of memory excluding the points near the exclude groups");
    removed = r;
  }
  if (pts.n == 0) {
    sphdem_points_free(&pts);
    fail("no lattice point of spacing " + std::to_string(dx) + " lies in region " + region_id +
         (outside ? " on the fluid side of the walls" : "") + (removed ? " away from the exclude groups" : "") + " inside the simulation box");
  }
  const int up = dim == 2 ? 1 : 2;
  double top = -HUGE_VAL;
  for (long i = 0; i < pts.n; i++) top = std::fmax(top, pts.x[3 * i + up]);
  top_ = top + 0.5 * dx;
  sphdem_atoms::Result r = sphdem_atoms::create(lmp, pts, (int)type, diameter, mass, groupbit);
  sphdem_points_free(&pts);
  created_ = r.created;
  if (r.created != r.generated) {
    char b[160];
    std::snprintf(b, sizeof b, "%lld of the %lld fluid points were not created (outside the simulation box?)",
                  r.generated - r.created, r.generated);
    fail(b);
  }
  if (comm->me == 0) {
    char b[640];
    std::snprintf(b, sizeof b,
                  "fix sph/fill %s: created %lld atoms (IDs %lld-%lld) of type %ld in group %s in region %s at "
                  "spacing %g (%lld lattice points in the region, %lld outside the walls, %lld near the exclude groups "
                  "left out), diameter %g, "
                  "mass %g\n  bounding box of the fluid atoms: %s\n  top of the fluid (highest %s + spacing/2): %.10g "
                  "(f_%s; for fix sph/fluid ... hydrostatic)\n",
                  id, r.created, r.first_tag, r.first_tag + r.created - 1, type, group->names[igroup],
                  region_id.c_str(), dx, in_region, outside, removed, diameter, mass, sphdem_atoms::bbox_text(r).c_str(),
                  dim == 2 ? "y" : "z", top_, id);
    sphdem_compat::logmesg(lmp, b);
  }
}

int FixSPHFill::setmask() { return 0; }

double FixSPHFill::compute_scalar() { return top_; }

double FixSPHFill::compute_vector(int i) { return i == 0 ? (double)created_ : top_; }
