// Re-importing a box of a volume into a sparse store of format 2, in one
// LMDB write transaction: readers keep the snapshot they began with and see
// the whole update, or none of it, when they next begin one (MVCC).
//
// What changes. The store becomes what importing the new volume with the
// store's tolerance, quantization, block size, spacing and origin gives
// (the new volume's own spacing and origin are not used): every block whose
// value differs is written, blocks that no longer hold a kept vertex are
// deleted, the header is replaced; blocks that come out the same are not
// touched. Outside the box the new volume must be what the store holds
// (within its tolerance: the store's value at any grid point is within t
// of what it was built from), so a volume that differs elsewhere is refused
// naming the first such point: the box says what changed.
//
// Cost. A kept diamond's error and the keep closure reach across the
// hierarchy, so the new store is built whole (as import, into a temporary
// file beside the store), then compared block by block: O(volume) time and
// the builder's memory, while the write transaction holds only the blocks
// that changed. LMDB caps one transaction's dirty pages (about 512 MiB);
// a map too small is grown first; a full disk fails with nothing written.
//
// Thread safety: one update of a store at a time (LMDB serializes writers);
// readers in any thread or process go on meanwhile.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "storage/error/progress.h"
#include "storage/sparse/sparse_format.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

// Grid points [lo, hi] of the volume, inclusive, in its own coordinates
// (x, y, z[, t]).
struct GridBox {
  std::array<int64_t, 4> lo = {0, 0, 0, 0};
  std::array<int64_t, 4> hi = {0, 0, 0, 0};
};

struct SparseUpdateOptions {
  // Phases "compare" (the volume outside the box against the store), then
  // the builder's, then "write".
  std::function<void(const BuildProgress&)> progress;
  int threads = 0;  // the builder's; 0: one per core
  uint64_t memory_bytes = uint64_t{8} << 30;
};

struct SparseUpdateReport {
  SparseHeader header;  // after the update
  uint64_t blocks_written = 0;    // added or changed
  uint64_t blocks_deleted = 0;
  uint64_t blocks_unchanged = 0;
  double seconds = 0;
};

// Updates the store at `path` with grid points `box` of `volume`, which must
// have the store's dimension, grid and voxel type (InvalidArgument naming
// both otherwise) and agree with the store outside the box. Errors also:
// SparseStore::Open's (a damaged store is not updated), the builder's,
// the write's (nothing written).
Result<SparseUpdateReport> UpdateSparseStore(const std::string& path, const VolumeInfo& volume,
                                             const GridBox& box,
                                             const SparseUpdateOptions& options = {});

}  // namespace simplexdb
