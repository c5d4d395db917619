// Building sparse stores (storage/sparse/sparse_store.h), and converting between
// the dense and the sparse store.
//
// Dense -> sparse walks the dense hierarchy depth-first and keeps a node
// when the largest error bound in its subtree exceeds the tolerance (so the
// kept nodes form a tree and every dropped subtree is within the tolerance
// everywhere). The walk keeps the nodes whose fate is still open on a stack
// (the path from the last kept node down): a node is written as soon as
// anything in its subtree is kept, so errors reach LMDB in key order
// (MDB_APPEND), and memory stays at the path, one bit per domain vertex
// (which vertices the kept nodes need; see VertexSet), a write batch of
// about 16 MiB and the dense store's block cache.
//
// Sparse -> dense rebuilds the field on the real grid: stored vertices keep
// their values, every other grid point takes the linear interpolation over
// the leaf (the absent node) that holds it, exact when the store is lossless
// (rounded to the voxel type otherwise); then the dense builder runs on it.
//
// Both write under a temporary name and rename when complete (the LMDB file
// is synced first); a failed or killed conversion leaves nothing under the
// final name.
//
// Thread safety: each function may run in several threads at once for
// different outputs; the dense store read may be shared with readers.
// Errors: the input's own (NotFound, Corruption naming the block or entry),
// InvalidArgument for options out of range, ResourceExhausted for a full
// disk, all naming the file; nothing is left under the final name.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/error/progress.h"
#include "storage/sparse/sparse_store.h"
#include "util/status.h"

namespace simplexdb {

struct SparseBuildOptions {
  // Drop every subtree whose error bounds are all <= tolerance (absolute,
  // in field units). 0: lossless.
  double tolerance = 0;
  // The LMDB map to start with; it doubles whenever it fills (0: 64 MiB).
  uint64_t initial_map_bytes = 0;
  // Dense -> sparse: a bound on the conversion's own memory (the vertex
  // set, the subtree maxima, the write batch; not the dense store's cache),
  // checked before anything is allocated: ResourceExhausted naming each
  // when the bound is smaller. 0: no bound.
  uint64_t memory_bytes = 0;
  std::function<void(const BuildProgress&)> progress;
};

struct SparseBuildReport {
  SparseHeader header;
  double seconds = 0;
  uint64_t nodes_visited = 0;  // dense nodes read
  uint64_t map_growths = 0;    // times the LMDB map was doubled
  uint64_t file_bytes = 0;
};

// Checks, before the dense build of an import --sparse, that converting a
// store of `input`'s grid fits `memory_bytes` (SparseBuildOptions), so a
// conversion that cannot fit fails before the build rather than after it.
// ResourceExhausted with the figures; OK for a bound of 0 and for grids the
// dense builder refuses itself.
Status CheckSparseImportMemory(const VolumeInfo& input, int levels_per_block,
                               uint64_t memory_bytes);

// Converts a dense store to a sparse one at `out_path`.
Result<SparseBuildReport> ConvertDenseToSparse(const DenseStore& dense,
                                               const std::string& out_path,
                                               const SparseBuildOptions& options);

// Converts a sparse store back to a dense one at `out_path`, with the
// sparse store's quantization; `options` sets the rest (compression,
// memory, threads). `options.quantization` is ignored.
Result<DenseBuildReport> ConvertSparseToDense(const SparseStore& sparse,
                                              const std::string& out_path,
                                              DenseBuildOptions options);

}  // namespace simplexdb
