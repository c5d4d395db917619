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

#include "util/process_group.h"
#include "util/status.h"

namespace simplexdb {

class MpiSession : public ProcessGroup {
 public:
  // Whether a launcher started this process (it put its rank in the
  // environment: OMPI_COMM_WORLD_RANK, PMI_RANK, PMIX_RANK or SLURM_PROCID
  // with SLURM_NTASKS). O(1).
  static bool Launched();
  // Initialises MPI. REQUIRES: Launched(), no session exists.
  static Result<std::unique_ptr<MpiSession>> Start(int* argc, char*** argv);
  // The session Start made, or null (none, or a run without a launcher).
  static MpiSession* Current();
  ~MpiSession() override;
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  // The ranks on this rank's machine (sharing its memory), this one included.
  int local_size() const { return local_size_; }

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
  Status Agree(const Status& mine) override;
  // Each rank's text at rank 0, in rank order (empty elsewhere).
  Result<std::vector<std::string>> Gather(const std::string& mine) override;
  // ProcessGroup's, over MPI_COMM_WORLD (any size: sent in parts of at
  // most 2^30 elements).
  Status Broadcast(std::span<uint8_t> bytes, int root) override;
  Status Max(std::span<double> values) override;
  Status Max(std::span<float> values) override;
  Status Or(std::span<uint64_t> words) override;
  Result<std::string> Scatter(const std::vector<std::string>& parts) override;

  // What this rank has handed to the ProcessGroup collectives so far (the
  // build's exchanges; extraction counts its own): calls, and the bytes of
  // its own payload (a root's broadcast or scatter, its share of a
  // reduction or gather).
  uint64_t collective_calls() const { return calls_; }
  uint64_t payload_bytes() const { return payload_; }

 private:
  MpiSession(int rank, int size, int local_size) : rank_(rank), size_(size), local_size_(local_size) {}
  void Count(uint64_t bytes) {
    ++calls_;
    payload_ += bytes;
  }
  int rank_, size_, local_size_;
  uint64_t calls_ = 0, payload_ = 0;
};

}  // namespace simplexdb
