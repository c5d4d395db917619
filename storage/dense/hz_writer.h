// Writes a format-2 store (storage/dense/hz_format.h): the diamond errors
// the caller gives a block at a time, and the field, in memory, as bricks.
//
// The writer decides which virtual blocks can hold a non-zero error from
// geometry alone (a block inside the real grid, or near enough that a
// diamond of its level reaches it), asks the caller to fill those, drops
// the ones that turn out to hold only zeros, quantizes errors (always
// rounded up: storage/error/quantize.h), compresses blocks and bricks on
// `threads` workers and appends them as they finish. Unless the header's
// flags say kHzFinestStored, the finest octave's errors are not asked for:
// each grid brick records the largest of its vertices', which the caller
// gives (the reader computes them from the field, storage/error/
// finest_box_errors.h, and must find the same). The store is written under
// a temporary name, synced and renamed (AtomicFileWriter): a failure leaves
// nothing.
//
// Thread safety: `fill` is called concurrently from the workers, with the
// worker's index (0 .. threads - 1) so it can keep per-worker state;
// `progress` from the calling thread.
// Lifetimes: nothing is kept after the call; the workers are joined.
// Errors: those of `fill` (the first failure stops the work), of the output
// (storage/io/file.h: the path refused, a full disk), ResourceExhausted
// "not enough memory for ..."; InvalidArgument for parameters out of range
// or a field value the voxel type cannot hold (naming the grid point).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "storage/dense/format.h"
#include "storage/dense/hz_format.h"
#include "storage/error/progress.h"
#include "storage/volume/voxel_type.h"
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
  std::function<void(const BuildProgress&)> progress;  // phases "blocks", "bricks"
};

// Fills the errors at HZ positions [first, first + count): errors[i] the
// diamond error of the vertex at first + i (0 when it has none: a corner, a
// hole past the domain's faces, a diamond with no real point).
using HzFill = std::function<Status(int worker, uint64_t first, size_t count, double* errors)>;

// Writes `path`. From `params` the writer takes dimension, domain_bits,
// dims, voxel_type (the stored field's type), quantization, block_bits,
// brick_bits, flags, field_min/max (the range over the real grid: it sets
// the quantum), spacing, origin, scaling and source; it sets the rest.
// `field` holds the real grid's values, x fastest (NaN: missing), each
// representable in voxel_type. `finest_max`: unless flags has
// kHzFinestStored (then null), per grid brick (lattice 0, in brick order)
// the largest finest-octave error of the vertices it owns
// (BrickGrid::FinestBox). Returns the header written.
template <class V>  // a voxel C++ type (uint8_t ... double) holding every value
Result<HzHeader> WriteHzStore(const std::string& path, const HzHeader& params,
                              const HzWriteOptions& options, const HzFill& fill, const V* field,
                              const double* finest_max);
#define SDB_WRITE_HZ_STORE_(V)                                                         \
  extern template Result<HzHeader> WriteHzStore(const std::string&, const HzHeader&,  \
                                                const HzWriteOptions&, const HzFill&, \
                                                const V*, const double*);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WRITE_HZ_STORE_)
#undef SDB_WRITE_HZ_STORE_

}  // namespace simplexdb
