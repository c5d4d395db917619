// MPI for the `simplexdb` command (issue 42, ../shared/DESIGN.md "Beyond
// one machine"): OpenMPI from Debian, initialised only when an MPI launcher
// (mpirun, mpiexec, srun) started the process, so a plain run behaves as
// it always did and never touches MPI.
//
// Under a launcher each rank runs the same command; what ranks share goes
// through the collectives below, called by every rank in the same order.
//
// Thread safety: MPI is initialised for one calling thread
// (MPI_THREAD_FUNNELED): only the thread that made the session calls it.
// Lifetimes: the session finalises MPI when destroyed; at most one exists.
// Errors: Start returns IOError with MPI's message when MPI_Init fails.
// The collectives run with MPI_ERRORS_RETURN and return IOError naming the
// call and MPI's message; MPI cannot be used after one fails.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "util/status.h"

namespace simplexdb {

class MpiSession {
 public:
  // Whether a launcher started this process (it put its rank in the
  // environment: OMPI_COMM_WORLD_RANK, PMI_RANK, PMIX_RANK or SLURM_PROCID
  // with SLURM_NTASKS). O(1).
  static bool Launched();
  // Initialises MPI. REQUIRES: Launched(), no session exists.
  static Result<std::unique_ptr<MpiSession>> Start(int* argc, char*** argv);
  // The session Start made, or null (none, or a run without a launcher).
  static MpiSession* Current();
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }

  // Every rank hands over one list per rank (outbox[r] for rank r) and gets
  // what every rank sent it, in rank order; *quiet is set when no rank sent
  // anything. A rank that failed says so (`failed`); then every rank gets
  // PeerFailed() instead. REQUIRES: outbox.size() == size(). Cost: two
  // all-to-alls and an all-reduce.
  Result<std::vector<uint64_t>> Exchange(const std::vector<std::vector<uint64_t>>& outbox, bool failed,
                                         bool* quiet);
  // What Exchange returns when some rank failed.
  static Status PeerFailed();
  // Every rank's outcome: OK when every rank's is, else on every rank the
  // status (its code) of the lowest rank that failed by itself (not with
  // PeerFailed), its message prefixed "rank R of N: ": one rank's error
  // stops them all with one message.
  Status Agree(const Status& mine);
  // Each rank's text at rank 0, in rank order (empty elsewhere).
  Result<std::vector<std::string>> Gather(const std::string& mine);

 private:
  MpiSession(int rank, int size) : rank_(rank), size_(size) {}
  int rank_, size_;
};

}  // namespace simplexdb
