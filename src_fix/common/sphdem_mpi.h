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

/* Collective sums, maxima and minima of a few values. */
inline void sum(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, world); }
inline void max(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX, world); }
inline void min(MPI_Comm world, double *v, int n) { MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MIN, world); }

}  // namespace sphdem_mpi

#endif
