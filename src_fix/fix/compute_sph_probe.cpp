/* compute_sph_probe.cpp - compute sph/probe: kernel-interpolated fluid fields at fixed points, read
 * from the fluid fix's device state (no host sync). Global array: one row per point. */
#include "compute_sph_probe.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "comm.h"
#include "domain.h"
#include "fix_sph_fluid.h"
#include "memory.h"
#include "modify.h"
#include "sphdem.h"
#include "sphdem_compat.h"
#include "sphdem_mpi.h"
#include "update.h"

using namespace LAMMPS_NS;

static const char *const USAGE =
    "compute ID group sph/probe FLUID-FIX-ID x y z [x y z ...] | compute ID group sph/probe FLUID-FIX-ID file FILE";

#ifdef SPHDEM_ENGINE_LAMMPS
ComputeSPHProbe::ComputeSPHProbe(LAMMPS *lmp, int narg, char **arg) : Compute(lmp, narg, arg), npts_(0), fix_(nullptr) {
  parse(3, narg, arg);
}
#else
ComputeSPHProbe::ComputeSPHProbe(LAMMPS *lmp, int &iarg, int narg, char **arg)
    : Compute(lmp, iarg, narg, arg), npts_(0), fix_(nullptr) {
  parse(iarg, narg, arg);
  iarg = narg;
}
#endif

ComputeSPHProbe::~ComputeSPHProbe() { memory->destroy(array); }

void ComputeSPHProbe::fail(const std::string &msg) {
  sphdem_compat::error_all(error, __FILE__, __LINE__, "Compute sph/probe: " + msg + " (usage: " + USAGE + ")");
}

void ComputeSPHProbe::parse(int first, int narg, char **arg) {
  if (first >= narg) fail("missing the ID of the fix sph/fluid");
  fix_id_ = arg[first];
  std::vector<double> v;
  if (first + 1 < narg && std::strcmp(arg[first + 1], "file") == 0) {
    if (first + 2 >= narg) fail("file needs a file name");
    std::ifstream in(arg[first + 2]);
    if (!in) fail(std::string("cannot open point file '") + arg[first + 2] + "'");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      double x, y, z;
      if (!(ss >> x >> y >> z)) fail("each line of the point file needs x y z (got '" + line + "')");
      v.push_back(x), v.push_back(y), v.push_back(z);
    }
    if (first + 3 < narg) fail("unexpected arguments after the point file");
  } else {
    for (int k = first + 1; k < narg; k++) {
      double x;
      if (!sphdem_compat::to_double(arg[k], &x)) fail(std::string("point coordinate '") + arg[k] + "' is not a number");
      v.push_back(x);
    }
    if (v.size() % 3) fail("point coordinates must come in x y z triples");
  }
  if (v.empty()) fail("no probe points given");
  /* a point outside the box holds no fluid: a typo or the wrong units */
  for (size_t k = 0; k < v.size() / 3; k++)
    for (int d = 0; d < 3; d++) {
      const double x = v[3 * k + d], lo = domain->boxlo[d], hi = domain->boxhi[d];
      if (x >= lo && x <= hi) continue;
      char m[256];
      snprintf(m, sizeof m, "point %zu (%g, %g, %g) lies outside the simulation box along %c (%g to %g)", k + 1,
               v[3 * k], v[3 * k + 1], v[3 * k + 2], "xyz"[d], lo, hi);
      fail(m);
    }
  pts_ = v;
  npts_ = (int)(v.size() / 3);
  out_.resize((size_t)SPHDEM_NPROBE * npts_);
  array_flag = 1;
  size_array_rows = npts_;
  size_array_cols = SPHDEM_NPROBE;
  extarray = 0;
  memory->create(array, npts_, SPHDEM_NPROBE, "sph/probe:array");
}

void ComputeSPHProbe::init() {
  int ifix = modify->find_fix(fix_id_.c_str());
  if (ifix < 0) fail("fix ID '" + fix_id_ + "' does not exist");
  fix_ = dynamic_cast<FixSPHFluid *>(modify->fix[ifix]);
  if (!fix_) fail("fix '" + fix_id_ + "' is not a fix sph/fluid");
}

void ComputeSPHProbe::compute_array() {
  invoked_array = update->ntimestep;
  sphdem_ctx ctx = fix_ ? fix_->context() : nullptr;
  if (!ctx) fail("fix '" + fix_id_ + "' has no fluid on the device yet (probe after the run's setup)");
  if (!fix_->many_ranks()) {
    int rc = sphdem_probe(ctx, npts_, pts_.data(), out_.data());
    if (rc != SPHDEM_OK) fail(sphdem_last_error(ctx));
  } else {
    /* many ranks: each point is sampled by the rank whose subdomain holds it (its fluid and ghost fluid cover
     * the point's support; a point outside the box goes to the nearest subdomain), the others add zeros */
    std::vector<double> mine;
    std::vector<int> idx;
    for (int k = 0; k < npts_; k++) {
      bool in = true;
      for (int d = 0; d < domain->dimension; d++) {
        const double c = pts_[3 * k + d];
        if (c < domain->sublo[d] && comm->myloc[d] > 0) in = false;
        if (c >= domain->subhi[d] && comm->myloc[d] < comm->procgrid[d] - 1) in = false;
      }
      if (!in) continue;
      idx.push_back(k);
      for (int d = 0; d < 3; d++) mine.push_back(pts_[3 * k + d]);
    }
    std::vector<double> got((size_t)SPHDEM_NPROBE * idx.size() + 1);
    int rc = sphdem_probe(ctx, (int)idx.size(), mine.data(), got.data());
    std::string m = rc == SPHDEM_OK ? std::string() : std::string(sphdem_last_error(ctx));
    m = sphdem_mpi::first_failure(world, rc != SPHDEM_OK, m);
    if (!m.empty()) fail(m);
    std::fill(out_.begin(), out_.end(), 0.0);
    for (size_t j = 0; j < idx.size(); j++)
      for (int c = 0; c < SPHDEM_NPROBE; c++) out_[(size_t)SPHDEM_NPROBE * idx[j] + c] = got[SPHDEM_NPROBE * j + c];
    sphdem_mpi::sum(world, out_.data(), (int)out_.size());
  }
  for (int k = 0; k < npts_; k++)
    for (int j = 0; j < SPHDEM_NPROBE; j++) array[k][j] = out_[(size_t)SPHDEM_NPROBE * k + j];
}
