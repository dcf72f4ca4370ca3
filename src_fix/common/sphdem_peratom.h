/* sphdem_peratom.h - the per-atom array plumbing shared by the fixes that keep NCOL doubles per atom (fix
 * sph/couple, fix cfd/grid): migration with the atoms and the per-atom restart record. */
#ifndef SPHDEM_PERATOM_H
#define SPHDEM_PERATOM_H

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

}  // namespace sphdem_peratom

#endif
