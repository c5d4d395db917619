// Builds a sparse store of format 2 (storage/sparse/sparse_format.h) from
// a volume held in memory.
//
// The diamond errors come from the dense builder's engine (storage/error/
// diamond_errors.h), for every vertex, the finest octave included. Then:
//   1. keep, finest level first: a vertex whose error exceeds t, or that a
//      kept diamond's simplices stand on, is kept along with those vertices;
//   2. rebuild, coarsest level first: a dropped vertex is the mean of its
//      split edge's ends; every dropped real grid point must come within t of
//      its value (equal at t = 0): one that does not is kept, and 1-2 run
//      again until none fails;
//   3. write each block holding a kept vertex, in key order.
// The work arrays cover the real grid grown by a margin at each octave's
// scale (far padding costs nothing): about 23 bytes per grid point besides
// the field's 8, checked against `memory_bytes` before anything is read.
//
// Thread safety: one build per output path at a time. Errors: the volume
// reader's; InvalidArgument for a bad tolerance or block size;
// ResourceExhausted when the work arrays exceed memory_bytes; NotSupported
// for fields with missing values (NaN); the output's errors (the store is
// written to a temporary file and renamed into place once complete).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "storage/error/progress.h"
#include "storage/error/quantization.h"
#include "storage/sparse/sparse_format.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct SparseBuildOptions {
  double tolerance = 0;  // t, in the field's units; 0: lossless
  bool tolerance_percent = false;  // tolerance is a percentage of the field's range
  Quantization quantization = Quantization::kU16;
  int block_bits = 0;  // 0: 18 for the HT, 20 for the HP
  int zstd_level = 19;  // blocks are written once and read often: for size (bench/README.md)
  uint64_t memory_bytes = uint64_t{8} << 30;
  int threads = 0;  // 0: one per core
  std::function<void(const BuildProgress&)> progress;  // "field", "errors", "keep", "blocks"
};

struct SparseBuildReport {
  SparseHeader header;
  double seconds = 0;
  int rounds = 0;              // keep-and-rebuild passes (1 when no check failed)
  uint64_t kept_by_check = 0;  // vertices the rebuild check kept
  uint64_t file_bytes = 0;
};

Result<SparseBuildReport> BuildSparseStore(const VolumeInfo& input, const std::string& out_path,
                                           const SparseBuildOptions& options);

}  // namespace simplexdb
