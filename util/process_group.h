// The processes that do one job together (issue 42: the ranks of an MPI
// run building one store). The library knows only this interface, so
// nothing below tools/ links MPI; parallel/mpi_session.h implements it
// over MPI_COMM_WORLD.
//
// Every member but rank() and size() is collective: every process of the
// group calls it, in the same order, with arguments of the same shape.
// A process that failed goes on calling them until the next Agree, which
// tells every process; so a failure anywhere stops all at the same place.
//
// Thread safety: one thread per process calls the members.
// Errors: Agree's as documented; the others return IOError naming the
// call when the transport fails (after which the group cannot be used).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "util/status.h"

namespace simplexdb {

class ProcessGroup {
 public:
  virtual ~ProcessGroup() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;

  // Every process's outcome: OK when every one's is; else, on every
  // process, the status (its code) of the lowest rank that failed by
  // itself, its message prefixed "rank R of N: ".
  virtual Status Agree(const Status& mine) = 0;
  // `bytes` on every process made equal to those of rank `root`.
  virtual Status Broadcast(std::span<uint8_t> bytes, int root) = 0;
  // values[i] made, on every process, the largest of every process's
  // values[i] (NaN must not occur).
  virtual Status Max(std::span<double> values) = 0;
  virtual Status Max(std::span<float> values) = 0;
  // words[i] made, on every process, the bitwise or of every process's.
  virtual Status Or(std::span<uint64_t> words) = 0;
  // Each process's bytes at rank 0, in rank order (empty elsewhere).
  virtual Result<std::vector<std::string>> Gather(const std::string& mine) = 0;
  // parts[r] (given at rank 0, ignored elsewhere) to process r.
  virtual Result<std::string> Scatter(const std::vector<std::string>& parts) = 0;
};

}  // namespace simplexdb
