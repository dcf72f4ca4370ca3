/* sphdem_peratom.h - the per-atom array plumbing shared by the fixes that keep NCOL doubles per atom (fix
 * sph/fluid, sph/couple, cfd/grid): migration with the atoms and the per-atom restart record. */
#ifndef SPHDEM_PERATOM_H
#define SPHDEM_PERATOM_H

#include <string>

#include "atom.h"
#include "fix.h"
#include "memory.h"

namespace sphdem_peratom {

/* rows [from, to) set to zero (new rows after a grow, a new atom) */
inline void zero(double **a, int from, int to, int ncol) {
  for (int i = from; i < to; i++)
    for (int c = 0; c < ncol; c++) a[i][c] = 0.0;
}
inline void copy(double **a, int i, int j, int ncol) {
  for (int c = 0; c < ncol; c++) a[j][c] = a[i][c];
}
inline int pack(double *const *a, int i, double *buf, int ncol) {
  for (int c = 0; c < ncol; c++) buf[c] = a[i][c];
  return ncol;
}
inline int unpack(double **a, int i, const double *buf, int ncol) {
  for (int c = 0; c < ncol; c++) a[i][c] = buf[c];
  return ncol;
}
/* restart record: its length (ncol + 1) first, as the engines expect */
inline int pack_restart(double *const *a, int i, double *buf, int ncol) {
  buf[0] = ncol + 1;
  return 1 + pack(a, i, buf + 1, ncol);
}
/* The lengths in an atom's extra array up to the nth fix record: NULL when the nth record has length
 * ncol + 1 and the earlier ones are plausible, else what is wrong (a corrupted restart file). */
inline const char *check_restart(const double *extra, int nth, int ncol) {
  int m = 0;
  for (int k = 0; k < nth; k++) {
    const double len = extra[m];
    if (!(len >= 1 && len <= 1e6)) return "has an earlier fix record of impossible length";
    m += static_cast<int>(len);
  }
  if (extra[m] != (double)(ncol + 1)) return "has the wrong length";
  return nullptr;
}
/* the nth fix record of atom nlocal in the engine's extra array; false (row untouched) when its lengths are
 * not those of this fix (check_restart) */
inline bool unpack_restart(double **a, double **extra, int nlocal, int nth, int ncol) {
  if (check_restart(extra[nlocal], nth, ncol)) return false;
  int m = 0;
  for (int k = 0; k < nth; k++) m += static_cast<int>(extra[nlocal][m]);
  unpack(a, nlocal, extra[nlocal] + m + 1, ncol);
  return true;
}

/* The flags and callbacks of a fix that keeps a per-atom array (ncols_out columns shown as f_ID[i]) and a
 * global vector of nvec values; at the end of its constructor (grows the array). stop() in its destructor. */
inline void start(LAMMPS_NS::Fix *f, LAMMPS_NS::Atom *atom, int ncols_out, int nvec, bool global_restart) {
  f->nevery = 1;
  f->peratom_flag = 1;
  f->size_peratom_cols = ncols_out;
  f->peratom_freq = 1;
  f->vector_flag = 1;
  f->size_vector = nvec;
  f->global_freq = 1;
  f->extvector = 0;
  f->restart_peratom = 1;
  f->restart_global = global_restart ? 1 : 0;
  f->create_attribute = 1;
  f->grow_arrays(atom->nmax);
  atom->add_callback(0);
  atom->add_callback(1);
}
inline void stop(LAMMPS_NS::Fix *f, LAMMPS_NS::Atom *atom, LAMMPS_NS::Memory *memory, double **&a) {
  atom->delete_callback(f->id, 0);
  atom->delete_callback(f->id, 1);
  memory->destroy(a);
}

/* why the record of atom tag is refused, for the error that init() reports */
inline std::string restart_message(long long tag, const double *extra, int nth, int ncol, const char *style) {
  return "the restart record of atom " + std::to_string(tag) + " " + check_restart(extra, nth, ncol) + " (fix " +
         style + " writes " + std::to_string(ncol + 1) + " values per atom; a corrupted restart file, or one written by "
         "another version)";
}

}  // namespace sphdem_peratom

/* In a fix class body: the per-atom callbacks (grow, copy, exchange, restart) of the member array ARRAY
 * (double **, NCOLS columns, rows counted in the member int nmax_), allocated under the name NAME; a
 * corrupted restart record is kept in the member std::string restart_error_ for init() to report. */
#define SPHDEM_PERATOM_METHODS(ARRAY, NCOLS, STYLE, NAME)                                                     \
  void grow_arrays(int nmax) override {                                                                     \
    memory->grow(ARRAY, nmax, NCOLS, NAME);                                                                 \
    sphdem_peratom::zero(ARRAY, nmax_ < nmax ? nmax_ : nmax, nmax, NCOLS);                                  \
    nmax_ = nmax;                                                                                           \
    array_atom = ARRAY;                                                                                     \
  }                                                                                                         \
  void copy_arrays(int i, int j, int) override { sphdem_peratom::copy(ARRAY, i, j, NCOLS); }                \
  void set_arrays(int i) override { sphdem_peratom::zero(ARRAY, i, i + 1, NCOLS); }                         \
  int pack_exchange(int i, double *buf) override { return sphdem_peratom::pack(ARRAY, i, buf, NCOLS); }     \
  int unpack_exchange(int nlocal, double *buf) override {                                                   \
    return sphdem_peratom::unpack(ARRAY, nlocal, buf, NCOLS);                                               \
  }                                                                                                         \
  int pack_restart(int i, double *buf) override { return sphdem_peratom::pack_restart(ARRAY, i, buf, NCOLS); } \
  void unpack_restart(int nlocal, int nth) override { /* a refused row stays zero (not valid) */            \
    if (!sphdem_peratom::unpack_restart(ARRAY, atom->extra, nlocal, nth, NCOLS) && restart_error_.empty())  \
      restart_error_ =                                                                                      \
          sphdem_peratom::restart_message((long long)atom->tag[nlocal], atom->extra[nlocal], nth, NCOLS, STYLE); \
  }                                                                                                         \
  int size_restart(int) override { return NCOLS + 1; }                                                      \
  int maxsize_restart() override { return NCOLS + 1; }

#endif
