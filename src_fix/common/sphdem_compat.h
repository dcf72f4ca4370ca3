/* sphdem_compat.h - every LAMMPS vs LIGGGHTS API difference the sphdem shims meet (ENGINES.md).
 * The shim sources are compiled twice, with -DSPHDEM_ENGINE_LAMMPS or -DSPHDEM_ENGINE_LIGGGHTS;
 * nothing outside this header may test those macros. */
#ifndef SPHDEM_COMPAT_H
#define SPHDEM_COMPAT_H

#if defined(SPHDEM_ENGINE_LAMMPS) == defined(SPHDEM_ENGINE_LIGGGHTS)
#error "define exactly one of SPHDEM_ENGINE_LAMMPS and SPHDEM_ENGINE_LIGGGHTS"
#endif

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

/* The fmt stand-in (src_fix/launch/fmt_standin) only declares what the LAMMPS headers name. */
#include "atom.h"
#include "comm.h"
#include "compute.h"
#include "error.h"
#include "fix.h"
#include "force.h"
#include "group.h"
#include "lammps.h"
#include "modify.h"
#include "neighbor.h"
#include "pointers.h"
#ifdef SPHDEM_ENGINE_LAMMPS
#include "utils.h"
#else
#include "fix_insert_pack.h"
#endif
#include "region.h"

namespace sphdem_compat {

#ifdef SPHDEM_ENGINE_LAMMPS
constexpr const char *engine_name = "LAMMPS";
#else
constexpr const char *engine_name = "LIGGGHTS";
#endif

/* Region::match with open faces ignored. LAMMPS: a region with open faces (`open N`, meant for fix
 * wall/gran/region) matches every point; the walls and the fill need its closed shape (inside() tested against
 * the region's side). A moving region with open faces keeps match() (its inverse transform is not public). */
inline bool region_match_closed(LAMMPS_NS::Region *r, double x, double y, double z) {
#ifdef SPHDEM_ENGINE_LAMMPS
  if (r->openflag && !r->dynamic_check()) return (r->inside(x, y, z) != 0) == (r->interior != 0);
#endif
  return r->match(x, y, z) != 0;
}

/* Errors. LAMMPS: only the std::string overloads exist without fmt (a string literal would pick
 * the fmt template). LIGGGHTS: const char * only, and Error::all is not marked noreturn. */
[[noreturn]] inline void error_end(LAMMPS_NS::Error *e, bool all, const char *file, int line, const std::string &msg) {
#ifdef SPHDEM_ENGINE_LAMMPS
  if (all) e->all(std::string(file), line, msg);
  e->one(std::string(file), line, msg);
#else
  if (all) e->all(file, line, msg.c_str());
  else e->one(file, line, msg.c_str());
  std::exit(1); /* not reached: LIGGGHTS' Error::all and Error::one end the run */
#endif
}
/* every rank stops with msg (error->all) / one rank does (error->one) */
[[noreturn]] inline void error_all(LAMMPS_NS::Error *e, const char *file, int line, const std::string &msg) {
  error_end(e, true, file, line, msg);
}
[[noreturn]] inline void error_one(LAMMPS_NS::Error *e, const char *file, int line, const std::string &msg) {
  error_end(e, false, file, line, msg);
}

inline void warning(LAMMPS_NS::Error *e, const char *file, int line, const std::string &msg) {
#ifdef SPHDEM_ENGINE_LAMMPS
  e->warning(std::string(file), line, msg);
#else
  e->warning(file, line, msg.c_str());
#endif
}

/* One message to screen and log file (call on rank 0). */
inline void logmesg(LAMMPS_NS::LAMMPS *lmp, const std::string &msg) {
#ifdef SPHDEM_ENGINE_LAMMPS
  LAMMPS_NS::utils::logmesg(lmp, msg);
#else
  if (lmp->screen) fputs(msg.c_str(), lmp->screen);
  if (lmp->logfile) fputs(msg.c_str(), lmp->logfile);
#endif
}

/* The engine's own number parser (ends the run with the engine's generic message on bad input). */
inline double numeric(LAMMPS_NS::LAMMPS *lmp, const char *file, int line, const char *s) {
#ifdef SPHDEM_ENGINE_LAMMPS
  return LAMMPS_NS::utils::numeric(file, line, s, false, lmp);
#else
  return lmp->force->numeric(file, line, s);
#endif
}

/* Strict parser for keyword values, so the caller can name the keyword in its message:
 * true when all of s is one finite number. */
inline bool to_double(const char *s, double *out) {
  if (!s || !*s) return false;
  char *end = nullptr;
  errno = 0;
  double v = std::strtod(s, &end);
  if (errno != 0 || *end != '\0' || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

inline bool to_int(const char *s, long *out) {
  if (!s || !*s) return false;
  char *end = nullptr;
  errno = 0;
  long v = std::strtol(s, &end, 10);
  if (errno != 0 || *end != '\0') return false;
  *out = v;
  return true;
}

inline int find_group(LAMMPS_NS::Group *g, const char *name) { return g->find(name); }

/* Atom creation (fix sph/wall, fix sph/fill; src_fix/common/sphdem_create_atoms.h). data_atoms: n lines of a data
 * file's Atoms section in buf, each ending in a newline; each rank keeps the atoms in its subdomain (LAMMPS: no
 * id/molecule/type offsets, no shift). */
inline void data_atoms(LAMMPS_NS::Atom *atom, int n, char *buf) {
#ifdef SPHDEM_ENGINE_LAMMPS
  atom->data_atoms(n, buf, 0, 0, 0, 0, nullptr);
#else
  atom->data_atoms(n, buf);
#endif
}
/* the per-atom density of LIGGGHTS' granular atom styles; nullptr in LAMMPS (which has none) */
inline double *atom_density(LAMMPS_NS::Atom *atom) {
#ifdef SPHDEM_ENGINE_LAMMPS
  (void)atom;
  return nullptr;
#else
  return atom->density_flag ? atom->density : nullptr;
#endif
}
/* the subdomains are not a regular processor grid (LAMMPS comm_style tiled; LIGGGHTS has only the grid) */
inline bool comm_tiled(LAMMPS_NS::Comm *comm) {
#ifdef SPHDEM_ENGINE_LAMMPS
  return comm->style != 0 || comm->layout == LAMMPS_NS::Comm::LAYOUT_TILED;
#else
  (void)comm;
  return false;
#endif
}
/* before the set_arrays(i) calls for atoms created after set-up (LIGGGHTS' pre_set_arrays; nothing in LAMMPS) */
inline void pre_set_arrays(LAMMPS_NS::Fix *f) {
#ifdef SPHDEM_ENGINE_LAMMPS
  (void)f;
#else
  f->pre_set_arrays();
#endif
}

/* Style registration. Modify::fix_map is public in LAMMPS and private in LIGGGHTS; there the
 * pointer-to-member comes from an explicit instantiation, where access checks do not apply
 * ([temp.explicit]). The creator signature is the same in both engines. */
typedef LAMMPS_NS::Fix *(*FixCreator)(LAMMPS_NS::LAMMPS *, int, char **);
typedef std::map<std::string, FixCreator> FixCreatorMap;

#ifdef SPHDEM_ENGINE_LIGGGHTS
namespace detail {
struct ModifyFixMapTag {
  typedef FixCreatorMap *LAMMPS_NS::Modify::*type;
  friend type member_of(ModifyFixMapTag);
};
template <typename Tag, typename Tag::type M> struct Expose {
  friend typename Tag::type member_of(Tag) { return M; }
};
template struct Expose<ModifyFixMapTag, &LAMMPS_NS::Modify::fix_map>;
}  // namespace detail
#endif

inline FixCreatorMap *fix_map(LAMMPS_NS::Modify *modify) {
#ifdef SPHDEM_ENGINE_LAMMPS
  return modify->fix_map;
#else
  return modify->*member_of(detail::ModifyFixMapTag());
#endif
}

template <typename T> LAMMPS_NS::Fix *fix_creator(LAMMPS_NS::LAMMPS *lmp, int narg, char **arg) {
  return new T(lmp, narg, arg);
}

/* Computes: LIGGGHTS constructs them as T(lmp, int &iarg, narg, arg) through a creator taking iarg
 * (the first own argument); LAMMPS as T(lmp, narg, arg). Modify::compute_map is private in LIGGGHTS. */
#ifdef SPHDEM_ENGINE_LAMMPS
typedef LAMMPS_NS::Compute *(*ComputeCreator)(LAMMPS_NS::LAMMPS *, int, char **);
template <typename T> LAMMPS_NS::Compute *compute_creator(LAMMPS_NS::LAMMPS *lmp, int narg, char **arg) {
  return new T(lmp, narg, arg);
}
#else
typedef LAMMPS_NS::Compute *(*ComputeCreator)(LAMMPS_NS::LAMMPS *, int, int, char **);
template <typename T>
LAMMPS_NS::Compute *compute_creator(LAMMPS_NS::LAMMPS *lmp, int iarg, int narg, char **arg) {
  return new T(lmp, iarg, narg, arg);
}
namespace detail {
struct ModifyComputeMapTag {
  typedef std::map<std::string, ComputeCreator> *LAMMPS_NS::Modify::*type;
  friend type member_of(ModifyComputeMapTag);
};
template struct Expose<ModifyComputeMapTag, &LAMMPS_NS::Modify::compute_map>;
}  // namespace detail
#endif
typedef std::map<std::string, ComputeCreator> ComputeCreatorMap;

inline ComputeCreatorMap *compute_map(LAMMPS_NS::Modify *modify) {
#ifdef SPHDEM_ENGINE_LAMMPS
  return modify->compute_map;
#else
  return modify->*member_of(detail::ModifyComputeMapTag());
#endif
}

/* The pair exclusions of neigh_modify as given (exclude type I J, exclude group G1 G2 as group indices, the
 * include group; the number of molecule exclusions). Public in LAMMPS, protected in LIGGGHTS (same names). */
struct NeighborExclusions {
  int ntype = 0, ngroup = 0, nmol = 0, include = 0;
  const int *t1 = nullptr, *t2 = nullptr, *g1 = nullptr, *g2 = nullptr;
};
#ifdef SPHDEM_ENGINE_LIGGGHTS
namespace detail {
#define SPHDEM_NEIGHBOR_TAG(TAG, T, MEMBER)                                       \
  struct TAG {                                                                     \
    typedef T LAMMPS_NS::Neighbor::*type;                                          \
    friend type member_of(TAG);                                                    \
  };                                                                               \
  template struct Expose<TAG, &LAMMPS_NS::Neighbor::MEMBER>;
SPHDEM_NEIGHBOR_TAG(NexTypeTag, int, nex_type)
SPHDEM_NEIGHBOR_TAG(Ex1TypeTag, int *, ex1_type)
SPHDEM_NEIGHBOR_TAG(Ex2TypeTag, int *, ex2_type)
SPHDEM_NEIGHBOR_TAG(NexGroupTag, int, nex_group)
SPHDEM_NEIGHBOR_TAG(Ex1GroupTag, int *, ex1_group)
SPHDEM_NEIGHBOR_TAG(Ex2GroupTag, int *, ex2_group)
SPHDEM_NEIGHBOR_TAG(NexMolTag, int, nex_mol)
#undef SPHDEM_NEIGHBOR_TAG
}  // namespace detail
#endif
inline NeighborExclusions neighbor_exclusions(LAMMPS_NS::Neighbor *n) {
  NeighborExclusions e;
#ifdef SPHDEM_ENGINE_LAMMPS
  e.ntype = n->nex_type, e.t1 = n->ex1_type, e.t2 = n->ex2_type;
  e.ngroup = n->nex_group, e.g1 = n->ex1_group, e.g2 = n->ex2_group, e.nmol = n->nex_mol;
#else
  using namespace detail;
  e.ntype = n->*member_of(NexTypeTag()), e.t1 = n->*member_of(Ex1TypeTag()), e.t2 = n->*member_of(Ex2TypeTag());
  e.ngroup = n->*member_of(NexGroupTag()), e.g1 = n->*member_of(Ex1GroupTag()), e.g2 = n->*member_of(Ex2GroupTag());
  e.nmol = n->*member_of(NexMolTag());
#endif
  e.include = n->includegroup;
  return e;
}

/* The insertion region of an insertion fix whose fill counts the atoms already in its region (LIGGGHTS insert/pack
 * and insert/rate/region: volumefraction_region, particles_in_region); nullptr for every other fix (LAMMPS' pour
 * and deposit test overlaps only). FixInsertPack::ins_region is protected: the explicit-instantiation idiom. */
#ifdef SPHDEM_ENGINE_LIGGGHTS
namespace detail {
struct InsRegionTag {
  typedef LAMMPS_NS::Region *LAMMPS_NS::FixInsertPack::*type;
  friend type member_of(InsRegionTag);
};
template struct Expose<InsRegionTag, &LAMMPS_NS::FixInsertPack::ins_region>;
}  // namespace detail
#endif
inline LAMMPS_NS::Region *insertion_region(LAMMPS_NS::Fix *f) {
#ifdef SPHDEM_ENGINE_LIGGGHTS
  const std::string style = f->style;
  if (style != "insert/pack" && style != "insert/rate/region") return nullptr;
  return static_cast<LAMMPS_NS::FixInsertPack *>(f)->*member_of(detail::InsRegionTag());
#else
  (void)f;
  return nullptr;
#endif
}

/* The communication cutoff (comm->cutghostuser) that brings every ghost atom within `band` of a subdomain.
 * LAMMPS: the band itself. LIGGGHTS: with per-atom radii and an orthogonal box its granular border optimisation
 * sends only atoms within cutoff/2 + skin/2 + radius (comm.cpp, Comm::decide), so twice the band less the skin. */
inline double comm_cutoff_for_band(double band, double skin, bool radius_and_orthogonal) {
#ifdef SPHDEM_ENGINE_LAMMPS
  (void)skin;
  (void)radius_and_orthogonal;
  return band;
#else
  return radius_and_orthogonal ? 2.0 * band - skin : band;
#endif
}

}  // namespace sphdem_compat

/* Fix methods whose signatures differ. Declare them in a class body with these macros and
 * implement the engine-neutral sphdem_* methods they forward to. */
#ifdef SPHDEM_ENGINE_LAMMPS
#define SPHDEM_RESTART_FILE_ARG const char *
#define SPHDEM_FORWARD_COMM_METHODS                                                            \
  int pack_forward_comm(int n, int *list, double *buf, int pbc_flag, int *pbc) override {      \
    return sphdem_pack_forward(n, list, buf, pbc_flag, pbc);                                   \
  }                                                                                            \
  void unpack_forward_comm(int n, int first, double *buf) override { sphdem_unpack_forward(n, first, buf); }
#else
#define SPHDEM_RESTART_FILE_ARG char *
/* LIGGGHTS' (older LAMMPS') Comm::forward_comm_fix takes pack_comm's return value as the count per atom */
#define SPHDEM_FORWARD_COMM_METHODS                                                            \
  int pack_comm(int n, int *list, double *buf, int pbc_flag, int *pbc) override {              \
    sphdem_pack_forward(n, list, buf, pbc_flag, pbc);                                          \
    return comm_forward;                                                                       \
  }                                                                                            \
  void unpack_comm(int n, int first, double *buf) override { sphdem_unpack_forward(n, first, buf); }
#endif

#endif
