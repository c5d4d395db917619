// Re-importing a sub-box of a volume into an existing sparse store, in one
// LMDB write transaction: readers keep the snapshot they began with and see
// the whole update, or none of it, when they next begin one (MVCC).
//
// What changes. Every node whose simplex meets the box (grown to the
// domain's far faces where the box reaches the real grid's, because the
// padding repeats the last real values) gets its error recomputed from the
// new volume: the seed's maximum over the grid points inside the simplex,
// by the error engine the dense builder uses (storage/error/unit_errors.h),
// so the store ends up entry for entry what importing the new volume would
// give (integer voxel types: exactly; floats: within the rounding of a
// differently ordered scan). A node is then
// present when some error in its subtree exceeds the store's tolerance, as
// when it was built; nodes away from the box keep their entries, and they
// tell their ancestors whether their subtrees matter (present = yes).
// Vertices follow: the split midpoints of nodes that appear are added, those
// no present node needs any more are removed, and stored values inside the
// box are rewritten. The header's counts, content sum and error bound are
// adjusted entry by entry.
//
// Cost. An ancestor's error is a maximum over its whole simplex, so every
// node above the box's size is rescanned whole: the roots that meet the box
// read all their grid points once (scanned for all their top levels at
// once), the nodes below read only what is near the box. Memory holds one
// scan unit (a simplex of side 2^6 in 3D, 2^4 in 4D) and the recomputed
// errors of the nodes meeting the box.
//
// Limits. The store's field range fixes its error quantum, so the new values
// in the box must stay within it (InvalidArgument otherwise: import the
// volume again). The update holds its changes in one transaction; LMDB caps
// one transaction's dirty pages (about 512 MiB here), which a box of tens of
// millions of nodes can exceed (ResourceExhausted, nothing written). A
// full map is grown and the transaction redone; a full disk fails with
// nothing written.
//
// Thread safety: one update of a store at a time (LMDB serializes writers:
// a second one waits); readers in any thread or process go on meanwhile.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "storage/error/progress.h"
#include "storage/sparse/hz_sparse_update.h"  // GridBox
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct SparseUpdateOptions {
  std::function<void(const BuildProgress&)> progress;  // phase "units"
  // As DenseBuildOptions::mask: 0 or NaN where the field is missing (the
  // store was imported with a mask; integers are then float32 in it).
  std::optional<VolumeInfo> mask;
};

struct SparseUpdateReport {
  SparseHeader header;              // after the update
  uint64_t nodes_recomputed = 0;    // nodes whose simplex meets the box
  uint64_t nodes_written = 0;       // added, or stored with a new error
  uint64_t nodes_deleted = 0;
  uint64_t vertices_written = 0;    // added, or stored with a new value
  uint64_t vertices_deleted = 0;
  uint64_t map_growths = 0;
  double seconds = 0;
};

// Updates the sparse store at `path` with grid points `box` of `volume`,
// which must have the store's dimension, grid and voxel type
// (InvalidArgument naming both otherwise). Points outside the box are read
// where a recomputed simplex covers them and are taken to be what the
// store was built from.
Result<SparseUpdateReport> UpdateSparseStore(const std::string& path, const VolumeInfo& volume,
                                             const GridBox& box,
                                             const SparseUpdateOptions& options = {});

}  // namespace simplexdb
