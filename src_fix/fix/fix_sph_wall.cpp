/* fix_sph_wall.cpp - fix sph/wall: parses the keywords, builds the dummy-wall points (behind an STL mesh:
 * gpu/geom/wallgen.c; outside a region: the engine's Region::match and surface distance) and creates them as atoms
 * (sphdem_create_atoms.h). Runs once, in the constructor; the fix does nothing during runs. */
#include "fix_sph_wall.h"

#include <cmath>
#include <cstring>
#include <string>

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
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
    "fix ID group-ID sph/wall (mesh FILE | region REGION-ID) spacing DX layers N type T (mass M | density RHO0) "
    "[diameter D] [scale S] [move DX DY DZ] [orient X Y Z] [flip yes|no]";
const char *const KEYWORDS = "mesh, region, spacing, layers, type, mass, density, diameter, scale, move, orient, flip";
}  // namespace

void FixSPHWall::fail(const std::string &msg) {
  sphdem_compat::error_all(error, FLERR, std::string("Fix sph/wall: ") + msg);
}

FixSPHWall::FixSPHWall(LAMMPS *lmp, int narg, char **arg) : Fix(lmp, narg, arg), created_(0), warned_(false) {
  scalar_flag = 1;
  global_freq = 1;
  extscalar = 0;
  auto failf = [this](const std::string &m) { fail(m); };
  auto num = [&](int i, const char *kw) -> double {
    if (i >= narg) fail(std::string(kw) + " needs a value (usage: " + SYNTAX + ")");
    return sphdem_args::number(failf, kw, arg[i], SYNTAX);
  };
  std::string mesh_file, region_id;
  sphdem_atoms::ParticleKeywords pk;
  double scale = 1.0, move[3] = {0, 0, 0}, orient[3] = {0, 0, 0};
  long layers = 0;
  bool have_layers = false, have_orient = false, have_scale = false, have_move = false;
  int flip = 0;
  for (int i = 3; i < narg;) {
    const std::string kw = arg[i];
    if (pk.parse(kw, i, narg, arg, atom->ntypes, num, failf)) continue;
    if (kw == "mesh" || kw == "region") {
      if (i + 1 >= narg) fail(kw + " needs a " + (kw == "mesh" ? "file name" : "region ID") + " (usage: " + SYNTAX + ")");
      if (!mesh_file.empty() || !region_id.empty()) fail("give one of mesh FILE and region REGION-ID, once");
      (kw == "mesh" ? mesh_file : region_id) = arg[i + 1];
      i += 2;
    } else if (kw == "layers") {
      if (i + 1 >= narg || !sphdem_compat::to_int(arg[i + 1], &layers))
        fail(std::string("layers expects an integer >= 1, got '") + (i + 1 < narg ? arg[i + 1] : "") + "'");
      if (layers < 1) fail("layers must be >= 1 (got " + std::to_string(layers) + ")");
      have_layers = true, i += 2;
    } else if (kw == "scale") {
      scale = num(i + 1, "scale"), have_scale = true, i += 2;
      if (!(scale > 0)) fail("scale must be > 0");
    } else if (kw == "move" || kw == "orient") {
      double *v = kw == "move" ? move : orient;
      for (int d = 0; d < 3; d++) v[d] = num(i + 1 + d, kw.c_str());
      (kw == "move" ? have_move : have_orient) = true;
      i += 4;
    } else if (kw == "flip") {
      flip = sphdem_args::yes_no(failf, kw, i, narg, arg), i += 2;
    } else {
      fail("unknown keyword '" + kw + "' (allowed: " + KEYWORDS + "; usage: " + SYNTAX + ")");
    }
  }
  if (mesh_file.empty() && region_id.empty()) fail(std::string("give mesh FILE or region REGION-ID (usage: ") + SYNTAX + ")");
  if (!pk.have_dx) fail("spacing DX is required");
  if (!have_layers) fail("layers N is required");
  pk.require(failf);
  if (have_orient && flip) fail("orient and flip yes exclude each other (orient sets every normal)");
  if (!region_id.empty() && (have_scale || have_move || have_orient || flip))
    fail("scale, move, orient and flip apply to a mesh only");
  if (!domain->box_exist) fail("create the simulation box first (create_box or read_data)");
  const std::string style_problem = sphdem_atoms::atom_style_problem(atom);
  if (!style_problem.empty()) fail(style_problem);
  const int dim = domain->dimension;
  if (!mesh_file.empty() && dim == 2) fail("mesh is for 3D only (dimension 2): use region REGION-ID");
  pk.defaults(dim);
  const double dx = pk.dx, mass = pk.mass, diameter = pk.diameter;
  const long type = pk.type;

  sphdem_points pts = {nullptr, 0, 0};
  std::string source;
  if (!mesh_file.empty()) {
    char msg[512] = "";
    sphdem_mesh mesh;
    /* every rank reads the file: the points are the same everywhere and each keeps its own */
    int rc = sphdem_stl_read(mesh_file.c_str(), &mesh, msg, sizeof msg);
    if (rc != SPHDEM_OK) fail(msg);
    sphdem_mesh_transform(&mesh, scale, move);
    long turned = 0;
    if (have_orient) turned = sphdem_mesh_orient(&mesh, orient);
    if (flip) sphdem_mesh_flip(&mesh);
    const double origin[3] = {0.5 * dx, 0.5 * dx, 0.5 * dx};
    rc = sphdem_wall_from_mesh(&mesh, dx, (int)layers, origin, &pts, msg, sizeof msg);
    long nfacet = mesh.nfacet, ndeg = mesh.ndegenerate, ndis = mesh.ndisagree;
    facets_.assign(mesh.f, mesh.f + mesh.nfacet);
    sphdem_mesh_free(&mesh);
    if (rc != SPHDEM_OK) fail(msg);
    source = "mesh " + mesh_file + " (" + std::to_string(nfacet) + " facets";
    if (ndeg) source += ", " + std::to_string(ndeg) + " of zero area skipped";
    if (have_orient) source += ", " + std::to_string(turned) + " turned to face the orient point";
    else if (ndis) source += ", " + std::to_string(ndis) + " with a written normal against the winding (the winding counts)";
    if (flip) source += ", flipped";
    source += ")";
    /* nothing beyond a periodic boundary */
    const int per[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
    long kept = 0, dropped = 0;
    for (long i = 0; i < pts.n; i++) {
      bool in = true;
      for (int d = 0; d < 3; d++)
        if (per[d] && (pts.x[3 * i + d] < domain->boxlo[d] || pts.x[3 * i + d] >= domain->boxhi[d])) in = false;
      if (!in) {
        dropped++;
        continue;
      }
      std::memmove(pts.x + 3 * kept, pts.x + 3 * i, 3 * sizeof(double));
      kept++;
    }
    pts.n = kept;
    if (dropped) source += "; " + std::to_string(dropped) + " points beyond a periodic boundary left out";
  } else {
    int ireg = domain->find_region(region_id.c_str());
    if (ireg < 0) fail("region " + region_id + " does not exist");
    Region *reg = domain->regions[ireg];
    reg->init();
    reg->prematch();
    if (reg->dynamic_check() && comm->me == 0)
      sphdem_compat::warning(error, FLERR, "Fix sph/wall: region " + region_id + " moves; the walls are made at its "
                             "present place and move only with a fix move on group " + group->names[igroup]);
    const double cut = layers * dx;
    double lo[3], hi[3];
    for (int d = 0; d < 3; d++) lo[d] = domain->boxlo[d], hi[d] = domain->boxhi[d];
    bool clipped = false;
    if (reg->bboxflag && reg->interior) {
      const double elo[3] = {reg->extent_xlo, reg->extent_ylo, reg->extent_zlo};
      const double ehi[3] = {reg->extent_xhi, reg->extent_yhi, reg->extent_zhi};
      for (int d = 0; d < dim; d++) {
        if (elo[d] - cut < lo[d] - 1e-9 * dx || ehi[d] + cut > hi[d] + 1e-9 * dx) clipped = true;
        lo[d] = std::fmax(lo[d], elo[d] - cut);
        hi[d] = std::fmin(hi[d], ehi[d] + cut);
      }
    }
    sphdem_atoms::ScLattice L{dx, false, {0, 0, 0}};
    bool oom = false;
    sphdem_atoms::for_lattice(L, lo, hi, dim, [&](double *x) {
      if (sphdem_compat::region_match_closed(reg, x[0], x[1], x[2])) return;
      double xn[3] = {x[0], x[1], x[2]};
      int n = reg->interior ? reg->surface_exterior(xn, cut) : reg->surface_interior(xn, cut);
      if (n > 0 && sphdem_points_push(&pts, x[0], x[1], x[2]) != SPHDEM_OK) oom = true;
    });
    if (oom) fail("out of memory for the wall points");
    source = "region " + region_id;
    region_id_ = region_id;
    const int per[3] = {domain->xperiodic, domain->yperiodic, domain->zperiodic};
    bool nonper_clip = false;
    for (int d = 0; d < dim; d++) nonper_clip = nonper_clip || !per[d];
    if (clipped && nonper_clip && comm->me == 0)
      sphdem_compat::warning(error, FLERR, "Fix sph/wall: the " + std::to_string(layers) + " layers around region " +
                             region_id + " reach beyond the simulation box; the walls end at the box");
  }
  if (pts.n == 0) {
    sphdem_points_free(&pts);
    fail("no wall point from " + source + " (is the " + (mesh_file.empty() ? "region" : "mesh") +
         " inside the simulation box, and the spacing right?)");
  }
  sphdem_atoms::Result r = sphdem_atoms::create(lmp, pts, (int)type, diameter, mass, groupbit);
  sphdem_points_free(&pts);
  created_ = r.created;
  if (r.created != r.generated) {
    char b[160];
    std::snprintf(b, sizeof b, "%lld of the %lld wall points lie outside the simulation box (points: ",
                  r.generated - r.created, r.generated);
    fail(b + sphdem_atoms::bbox_text(r) + "); enlarge the box (create_box) to hold the walls");
  }
  if (comm->me == 0) {
    char b[512];
    std::snprintf(b, sizeof b,
                  "fix sph/wall %s: created %lld atoms (IDs %lld-%lld) of type %ld in group %s from %s: %ld layers at "
                  "spacing %g, diameter %g, mass %g\n  bounding box of the wall atoms: %s\n",
                  id, r.created, r.first_tag, r.first_tag + r.created - 1, type, group->names[igroup], source.c_str(),
                  layers, dx, diameter, mass, sphdem_atoms::bbox_text(r).c_str());
    sphdem_compat::logmesg(lmp, b);
  }
}

int FixSPHWall::setmask() { return 0; }

/* walls behind a moving mesh stand still unless a fix move moves them too */
void FixSPHWall::init() {
  if (warned_ || comm->me != 0) return;
  bool mesh_moves = false, walls_move = false;
  for (int m = 0; m < modify->nfix; m++) {
    const char *st = modify->fix[m]->style;
    if (!std::strcmp(st, "move/mesh")) mesh_moves = true;
    if (!std::strcmp(st, "move") && (modify->fix[m]->igroup == igroup || modify->fix[m]->igroup == 0)) walls_move = true;
  }
  if (mesh_moves && !walls_move) {
    sphdem_compat::warning(error, FLERR, std::string("Fix sph/wall ") + id + ": a fix move/mesh moves a mesh but no "
                           "fix move acts on group " + group->names[igroup] +
                           "; its wall particles stay in place (give them the mesh's motion with fix move)");
    warned_ = true;
  }
}

double FixSPHWall::compute_scalar() { return (double)created_; }
