// Writes a format-2 store (storage/dense/hz_format.h) from its records: for
// each HZ position, the diamond error and the field value, given by the
// caller a block at a time.
//
// The writer decides which virtual blocks can hold data from geometry alone
// (a block inside the real grid, or near enough that a diamond of its level
// reaches it), asks the caller to fill those, drops the ones that turn out
// to hold no real vertex and no error, quantizes errors (always rounded up:
// storage/error/quantize.h), compresses blocks on `threads` workers and
// appends them as they finish. The store is written under a temporary name,
// synced and renamed (AtomicFileWriter): a failure leaves nothing.
//
// Thread safety: `fill` is called concurrently from the workers, with the
// worker's index (0 .. threads - 1) so it can keep per-worker state;
// `progress` from the calling thread.
// Lifetimes: nothing is kept after the call; the workers are joined.
// Errors: those of `fill` (the first failure stops the work), of the output
// (storage/io/file.h: the path refused, a full disk), ResourceExhausted
// "not enough memory for ..."; InvalidArgument for parameters out of range.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "storage/dense/format.h"
#include "storage/dense/hz_format.h"
#include "storage/error/progress.h"
#include "util/status.h"

namespace simplexdb {

struct HzWriteOptions {
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
  int threads = 1;  // REQUIRES: >= 1
  // The errors given are upper bounds already rounded (read from another
  // store): stored as the nearest code not below them, with no margin for
  // the rounding of a computation.
  bool errors_are_bounds = false;
  std::function<void(const BuildProgress&)> progress;  // phase "blocks"
};

// Fills the records at HZ positions [first, first + count): errors[i] the
// diamond error of the vertex at first + i (0 when it has none: a corner, a
// hole past the domain's faces, a diamond with no real point), fields[i]
// its field value (read only where the vertex is on the real grid).
using HzFill = std::function<Status(int worker, uint64_t first, size_t count, double* errors,
                                    double* fields)>;

// Writes `path`. From `params` the writer takes dimension, domain_bits,
// dims, voxel_type (the stored field's type: every value given must be
// representable in it), quantization, block_bits, field_min/max (the range
// over the real grid: it sets the quantum), spacing, origin, scaling and
// source; it sets the rest. Returns the header written.
Result<HzHeader> WriteHzStore(const std::string& path, const HzHeader& params,
                              const HzWriteOptions& options, const HzFill& fill);

}  // namespace simplexdb
