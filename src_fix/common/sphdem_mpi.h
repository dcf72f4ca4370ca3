/* sphdem_mpi.h - the engine's MPI world as the core's reductions (sphdem_comm), and the collective stop: a
 * failure seen on some ranks stops every rank with the message of the lowest such rank. Same in both engines. */
#ifndef SPHDEM_MPI_H
#define SPHDEM_MPI_H

#include <mpi.h>

#include <string>
#include <vector>

#include "sphdem.h"

namespace sphdem_mpi {

inline int allreduce_cb(void *user, double *buf, int n, int op) {
  MPI_Comm world = *(MPI_Comm *)user;
  MPI_Op o = op == SPHDEM_RED_MAX ? MPI_MAX : op == SPHDEM_RED_MIN ? MPI_MIN : MPI_SUM;
  return MPI_Allreduce(MPI_IN_PLACE, buf, n, MPI_DOUBLE, o, world) == MPI_SUCCESS ? 0 : 1;
}

/* The reductions over *world (which must outlive the context: the engine's lmp->world). */
inline sphdem_comm comm(MPI_Comm *world) {
  sphdem_comm c;
  c.user = world;
  c.allreduce = allreduce_cb;
  c.exchange = nullptr;
  MPI_Comm_rank(*world, &c.rank);
  MPI_Comm_size(*world, &c.nranks);
  return c;
}

/* Collective: every rank calls it with its own (bad, msg). Returns "" when no rank is bad, otherwise on every
 * rank the message of the lowest bad rank (prefixed with its rank number when there are several ranks). */
inline std::string first_failure(MPI_Comm world, bool bad, const std::string &msg) {
  int me = 0, n = 1;
  MPI_Comm_rank(world, &me);
  MPI_Comm_size(world, &n);
  int mine = bad ? me : n, first = n;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, world);
  if (first == n) return std::string();
  int len = me == first ? (int)msg.size() : 0;
  MPI_Bcast(&len, 1, MPI_INT, first, world);
  std::vector<char> buf((size_t)len + 1, 0);
  if (me == first && len) msg.copy(buf.data(), (size_t)len);
  if (len) MPI_Bcast(buf.data(), len, MPI_CHAR, first, world);
  std::string out(buf.data(), (size_t)len);
  if (n > 1) out = "(rank " + std::to_string(first) + ") " + out;
  return out;
}

/* Collective, many ranks and a GPU wanted: each rank takes GPU (rank on its node) mod (GPUs on the node); the
 * mapping as one line for rank 0 to print ("" on other ranks, or where no rank has a GPU). */
inline std::string select_gpus(MPI_Comm world) {
  int me = 0, n = 1;
  MPI_Comm_rank(world, &me);
  MPI_Comm_size(world, &n);
  MPI_Comm node;
  MPI_Comm_split_type(world, MPI_COMM_TYPE_SHARED, me, MPI_INFO_NULL, &node);
  int local = 0;
  MPI_Comm_rank(node, &local);
  MPI_Comm_free(&node);
  char msg[256] = "";
  const int ok = sphdem_gpu_select(local, msg, sizeof msg) == SPHDEM_OK ? 1 : 0;
  int any = 0;
  MPI_Allreduce(&ok, &any, 1, MPI_INT, MPI_MAX, world);
  if (!any) return std::string();
  std::string mine = "rank " + std::to_string(me) + " -> " + (ok ? std::string(msg) : "no GPU (" + std::string(msg) + ")");
  int len = (int)mine.size();
  std::vector<int> lens(n), offs(n, 0);
  MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, world);
  std::string all;
  if (me == 0) {
    for (int r = 1; r < n; r++) offs[r] = offs[r - 1] + lens[r - 1];
    all.resize((size_t)offs[n - 1] + (size_t)lens[n - 1]);
  }
  MPI_Gatherv(mine.data(), len, MPI_CHAR, me == 0 ? &all[0] : nullptr, lens.data(), offs.data(), MPI_CHAR, 0, world);
  if (me != 0) return std::string();
  std::string line;
  for (int r = 0; r < n; r++) line += (r ? "; " : "") + all.substr((size_t)offs[r], (size_t)lens[r]);
  return line;
}

/* Collective sums, maxima and minima of a few values. */
inline void sum(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, world); }
inline void max(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX, world); }
inline void min(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MIN, world); }

}  // namespace sphdem_mpi

#endif
