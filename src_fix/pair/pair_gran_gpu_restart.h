/* pair_gran_gpu_restart.h - restart-file part shared by the GPU granular pair styles of both engines:
 * pair_coeff flags and the DEM core's tag-keyed contact history, written by write_restart and read
 * back into a pending copy that init_style hands to the core once it exists. Many ranks: rank 0 writes the
 * history gathered from every rank and reads the file; every rank gets all of it and its core carries the
 * pairs it has. */
#ifndef SPHDEM_PAIR_GRAN_GPU_RESTART_H
#define SPHDEM_PAIR_GRAN_GPU_RESTART_H

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "sphdem.h"

namespace sphdem_restart {

/* wall contacts a grain can have in the history: one per core wall (sphdem_dem_set_walls allows 16) */
constexpr int SPHDEM_DEM_MAX_WALL_CONTACTS = 16;

/* fread of n items; false when the file ends early */
inline bool read_items(FILE *fp, void *p, size_t size, size_t n) { return !n || fread(p, size, n, fp) == n; }

/* setflag[i][j] for 1 <= i <= j <= ntypes */
inline void write_setflag(FILE *fp, int **setflag, int ntypes) {
  for (int i = 1; i <= ntypes; i++)
    for (int j = i; j <= ntypes; j++) fwrite(&setflag[i][j], sizeof(int), 1, fp);
}
inline bool read_setflag(FILE *fp, int **setflag, int ntypes) {
  for (int i = 1; i <= ntypes; i++)
    for (int j = i; j <= ntypes; j++)
      if (!read_items(fp, &setflag[i][j], sizeof(int), 1) || (setflag[i][j] != 0 && setflag[i][j] != 1)) return false;
  return true;
}

/* Bytes from the current position to the end of the file (-1 if the stream cannot seek). */
inline long long bytes_left(FILE *fp) {
  long here = ftell(fp);
  if (here < 0 || fseek(fp, 0, SEEK_END) != 0) return -1;
  long end = ftell(fp);
  if (fseek(fp, here, SEEK_SET) != 0 || end < here) return -1;
  return (long long)(end - here);
}

/* The contact history: count; when it is > 0, the values per pair (a number below 2^32, so that it cannot be
 * taken for a key, whose high half is an atom tag >= 1), keys, then that many doubles per pair (displacement
 * xyz, touch flag, largest overlap of hooke/hysteresis). Files written before the values-per-pair field
 * have keys right after the count and 4 values per pair (no largest overlap: 0, no hysteresis then). */
constexpr uint64_t SPHDEM_HIST_LEGACY_DOUBLES = 4;
/* With a rolling history (granular/gpu rolling sds: the rolling displacement; gran/gpu rolling_friction epsd,
 * epsd2: the rolling spring torque) its 3 values follow each pair's SPHDEM_DEM_HIST_DOUBLES. */
constexpr uint64_t SPHDEM_HIST_ROLL_DOUBLES = SPHDEM_DEM_HIST_DOUBLES + 3;
/* the core's whole pair list, its history and (where the core keeps one, else empty) its rolling history; false
 * when the core cannot give them */
inline bool get_history(sphdem_dem dem, std::vector<uint64_t> &keys, std::vector<double> &hist,
                        std::vector<double> *roll = nullptr) {
  int64_t np = dem ? sphdem_dem_get_history(dem, nullptr, nullptr, 0) : 0;
  if (np < 0) return false;
  keys.resize((size_t)np);
  hist.resize((size_t)np * SPHDEM_DEM_HIST_DOUBLES);
  if (np > 0 && sphdem_dem_get_history(dem, keys.data(), hist.data(), np) != np) return false;
  if (roll) {
    roll->clear();
    const int64_t nr = np > 0 ? sphdem_dem_get_rolling(dem, nullptr, 0) : 0;
    if (nr < 0) return false;
    if (nr == np && np > 0) {
      roll->resize((size_t)np * 3);
      if (sphdem_dem_get_rolling(dem, roll->data(), np) != np) return false;
    }
  }
  return true;
}
/* a pair key whose second half is a wall code (sphdem_dem_get_history) */
inline bool wall_key(uint64_t key) { return (key & 0xffffffffu) > 0xffffffffu - SPHDEM_DEM_MAX_WALL_CONTACTS; }
/* a pair with a history to keep (a pair whose values are all 0 is a pair with none) */
inline bool has_history(const double *h) {
  for (int q = 0; q < SPHDEM_DEM_HIST_DOUBLES; q++)
    if (h[q] != 0.0) return true;
  return false;
}
inline void write_history(FILE *fp, const std::vector<uint64_t> &keys, const std::vector<double> &hist,
                          const std::vector<double> &roll = std::vector<double>()) {
  const int64_t np = (int64_t)keys.size();
  fwrite(&np, sizeof(int64_t), 1, fp);
  if (np > 0) {
    const bool with_roll = roll.size() == 3 * (size_t)np;
    const uint64_t per = with_roll ? SPHDEM_HIST_ROLL_DOUBLES : SPHDEM_DEM_HIST_DOUBLES;
    fwrite(&per, sizeof(uint64_t), 1, fp);
    fwrite(keys.data(), sizeof(uint64_t), (size_t)np, fp);
    if (!with_roll) {
      fwrite(hist.data(), sizeof(double), (size_t)np * SPHDEM_DEM_HIST_DOUBLES, fp);
      return;
    }
    for (size_t k = 0; k < (size_t)np; k++) {
      fwrite(&hist[k * SPHDEM_DEM_HIST_DOUBLES], sizeof(double), SPHDEM_DEM_HIST_DOUBLES, fp);
      fwrite(&roll[3 * k], sizeof(double), 3, fp);
    }
  }
}
inline bool write_history(FILE *fp, sphdem_dem dem) {
  std::vector<uint64_t> keys;
  std::vector<double> hist, roll;
  if (!get_history(dem, keys, hist, &roll)) return false;
  write_history(fp, keys, hist, roll);
  return true;
}

struct PendingHistory {
  bool have = false;
  std::vector<uint64_t> keys;
  std::vector<double> hist;
  std::vector<double> roll; /* 3 per pair when the file has a rolling history, else empty */
  std::string error; /* why read() failed */

  /* the message for a failed read: what read() found, else the caller's text */
  std::string error_or(const std::string &fallback) const { return error.empty() ? fallback : error; }

  /* The pair count is checked before anything is allocated: against the bytes left in the file and
   * against natoms (at most natoms (natoms - 1) / 2 grain pairs plus the wall contacts; natoms < 0:
   * not known). Every key is checked for its two tags. */
  bool read(FILE *fp, int64_t natoms = -1) {
    error.clear();
    int64_t np = 0;
    if (!read_items(fp, &np, sizeof(int64_t), 1)) return fail("restart file ends before the contact-history count");
    /* values per pair: the field after a count > 0, or the keys of a file written before it (legacy: 4) */
    uint64_t per = SPHDEM_DEM_HIST_DOUBLES;
    if (np > 0) {
      uint64_t field = 0;
      if (!read_items(fp, &field, sizeof(uint64_t), 1))
        return fail("restart file ends inside the contact history (" + std::to_string(np) + " pairs)");
      if (field < ((uint64_t)1 << 32)) {
        per = field;
        if (per != SPHDEM_DEM_HIST_DOUBLES && per != SPHDEM_HIST_LEGACY_DOUBLES && per != SPHDEM_HIST_ROLL_DOUBLES)
          return fail("restart file: " + std::to_string(per) + " contact-history values per pair; this version "
                      "reads " + std::to_string(SPHDEM_HIST_LEGACY_DOUBLES) + ", " +
                      std::to_string(SPHDEM_DEM_HIST_DOUBLES) + " or " + std::to_string(SPHDEM_HIST_ROLL_DOUBLES) +
                      " (corrupt restart file)");
      } else {
        per = SPHDEM_HIST_LEGACY_DOUBLES;
        if (fseek(fp, -(long)sizeof(uint64_t), SEEK_CUR) != 0)
          return fail("restart file: cannot step back over the first contact-history key");
      }
    }
    const long long per_pair = (long long)(sizeof(uint64_t) + per * sizeof(double));
    const long long left = bytes_left(fp);
    if (np < 0 || (left >= 0 && np > left / per_pair))
      return fail("restart file: contact-history count " + std::to_string(np) + " does not fit the " +
                  std::to_string(left) + " bytes left in the file (corrupt or truncated restart file)");
    if (natoms >= 0) {
      const double most = 0.5 * (double)natoms * (double)(natoms > 0 ? natoms - 1 : 0) +
                          (double)natoms * SPHDEM_DEM_MAX_WALL_CONTACTS;
      if ((double)np > most)
        return fail("restart file: contact-history count " + std::to_string(np) + " exceeds what " +
                    std::to_string(natoms) + " atoms can have (corrupt restart file)");
    }
    keys.resize((size_t)np);
    hist.assign((size_t)np * SPHDEM_DEM_HIST_DOUBLES, 0.0);
    std::vector<double> raw((size_t)np * per);
    if (!read_items(fp, keys.data(), sizeof(uint64_t), keys.size()) ||
        !read_items(fp, raw.data(), sizeof(double), raw.size()))
      return fail("restart file ends inside the contact history (" + std::to_string(np) + " pairs)");
    const size_t nh = per < SPHDEM_DEM_HIST_DOUBLES ? per : SPHDEM_DEM_HIST_DOUBLES;
    for (size_t k = 0; k < keys.size(); k++) /* legacy pairs: largest overlap 0 */
      for (size_t v = 0; v < nh; v++) hist[k * SPHDEM_DEM_HIST_DOUBLES + v] = raw[k * per + v];
    roll.clear();
    if (per == SPHDEM_HIST_ROLL_DOUBLES) {
      roll.resize(3 * keys.size());
      for (size_t k = 0; k < keys.size(); k++)
        for (size_t v = 0; v < 3; v++) {
          roll[3 * k + v] = raw[k * per + SPHDEM_DEM_HIST_DOUBLES + v];
          if (!std::isfinite(roll[3 * k + v]))
            return fail("restart file: contact-history pair " + std::to_string(k) + " has a rolling history that no "
                        "contact has (corrupt restart file)");
        }
    }
    for (size_t k = 0; k < keys.size(); k++) {
      const uint64_t ta = keys[k] >> 32, tb = keys[k] & 0xffffffffu;
      const bool wall = tb > 0xffffffffu - SPHDEM_DEM_MAX_WALL_CONTACTS;
      if (ta < 1 || ta > 2147483647u || (!wall && (tb < 1 || tb <= ta)))
        return fail("restart file: contact-history pair " + std::to_string(k) + " has atom tags " +
                    std::to_string(ta) + ", " + std::to_string(tb) + " (corrupt restart file)");
    }
    /* per pair: displacement xyz (finite), touch flag (0, +-1 or +-an image code: a whole number), largest
     * overlap (hooke/hysteresis, >= 0) or twist angle (granular/gpu, signed): finite */
    const int H = SPHDEM_DEM_HIST_DOUBLES;
    for (size_t k = 0; k < keys.size(); k++) {
      const double *h = &hist[k * H];
      const bool good = std::isfinite(h[0]) && std::isfinite(h[1]) && std::isfinite(h[2]) && std::isfinite(h[3]) &&
                        h[3] == std::floor(h[3]) && (H < 5 || std::isfinite(h[4]));
      if (!good)
        return fail("restart file: contact-history pair " + std::to_string(k) + " has values that no contact has "
                    "(corrupt restart file)");
    }
    have = true;
    return true;
  }
  bool fail(const std::string &why) {
    error = why;
    have = false;
    keys.clear();
    hist.clear();
    roll.clear();
    keys.shrink_to_fit();
    hist.shrink_to_fit();
    return false;
  }
  /* hand the history to the core (once); SPHDEM_OK when there is nothing to hand over */
  int apply(sphdem_dem dem) {
    if (!have) return SPHDEM_OK;
    const bool with_roll = !roll.empty() && roll.size() == 3 * keys.size();
    int rc = sphdem_dem_set_history_rolling(dem, (int64_t)keys.size(), keys.data(), hist.data(),
                                            with_roll ? roll.data() : nullptr);
    have = false;
    keys.clear();
    hist.clear();
    roll.clear();
    return rc;
  }
};

}  // namespace sphdem_restart

#endif
