// Writes a format-2 store (storage/dense/dense_format.h): the diamond errors
// the caller gives a block at a time, and the field, in memory, as bricks.
//
// The writer decides which virtual blocks can hold a non-zero error from
// geometry alone (a block inside the real grid, or near enough that a
// diamond of its level reaches it), asks the caller to fill those, drops
// the ones that turn out to hold only zeros, quantizes errors (always
// rounded up: storage/error/quantize.h), compresses blocks and bricks on
// `threads` workers and appends them in the order they were asked for,
// whichever worker finishes first: the same runs give the same bytes at
// any thread count. Unless the header's
// flags say kDenseFinestStored, the finest octave's errors are not asked for:
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

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "storage/dense/field_bricks.h"
#include "storage/dense/dense_format.h"
#include "storage/error/progress.h"
#include "storage/error/quantize.h"
#include "storage/io/file.h"
#include "storage/volume/voxel_type.h"
#include "util/process_group.h"
#include "util/status.h"

namespace simplexdb {

struct DenseWriteOptions {
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
  int threads = 1;  // REQUIRES: >= 1
  // The errors given are upper bounds already rounded (read from another
  // store): stored as the nearest code not below them, with no margin for
  // the rounding of a computation.
  bool errors_are_bounds = false;
  std::function<void(const BuildProgress&)> progress;  // phases "blocks", "bricks"
  // The store's canonical order whatever order the items are made in:
  // they go to a scratch file (storage/io/file.h ScratchFile) as made, and
  // Finish writes every stored block in index order, then every brick, as
  // a writer asked for them in that order writes them directly. For a
  // build that makes them a window of planes at a time, or a rank's part.
  bool spool = false;
  // The processes writing this store together, each its own items
  // (REQUIRES: spool); Finish is then collective: every rank copies its
  // items to their place in rank 0's temporary (a file system all see),
  // rank 0 writes the indexes and the header and renames the file into
  // place once every rank has succeeded. Null: this process alone.
  ProcessGroup* group = nullptr;
};

// Fills the errors at HZ positions [first, first + count): errors[i] the
// diamond error of the vertex at first + i (0 when it has none: a corner, a
// hole past the domain's faces, a diamond with no real point).
using DenseFill = std::function<Status(int worker, uint64_t first, size_t count, double* errors)>;

// Writes a store in parts: the candidate blocks (those that may hold data,
// by geometry) in runs, the bricks in runs, each run on every worker, then
// Finish() writes the bitmap, the indexes and the header and renames the
// file into place. Runs may come in any order and grouping (a builder that
// streams the volume gives a band at a time); a candidate block never
// written is not stored, and every brick must be written once. Dropped
// without Finish(), it leaves nothing under `path`. Not thread-safe itself:
// one run at a time (each runs on options.threads workers).
class DenseStoreWriter {
 public:
  // The memory a writer of a store of `params` (its dimension, dims,
  // domain, block and brick bits, finest flag) holds: its tables for the
  // whole build, and what Finish adds to them (the indexes' buffers; with
  // `spool` also every item's record and place and the copy's buffer).
  // An upper bound. O(virtual blocks).
  struct Memory {
    uint64_t tables = 0, finish = 0;
  };
  static Memory MemoryFor(const DenseHeader& params, bool spool);

  // Checks `params` (as WriteDenseStore) and opens the temporary file.
  static Result<std::unique_ptr<DenseStoreWriter>> Create(const std::string& path,
                                                          const DenseHeader& params,
                                                          const DenseWriteOptions& options);
  ~DenseStoreWriter();

  // The header as planned: version, virtual_blocks, quantum and bricks set.
  const DenseHeader& header() const { return h_; }
  // The virtual blocks that may hold data, ascending.
  const std::vector<uint64_t>& candidate_blocks() const { return candidates_; }
  const BrickGrid& grid() const { return *grid_; }

  // Where a virtual block's vertices are: one octave's (its scale s: the
  // vertices are odd multiples of 2^s on some axis) in the grid box [lo,
  // hi] per axis, or, for a block spanning several octaves or patterns
  // (block 0, and a few more when block_bits is not a multiple of D),
  // scale -1 and the whole domain.
  struct BlockSpan {
    int scale = -1;
    std::array<int64_t, 4> lo{}, hi{};
  };
  BlockSpan SpanOf(uint64_t vblock) const;

  // Fills, codes and appends the candidate blocks whose indices (into
  // candidate_blocks()) `which` lists; those whose errors all code to 0
  // are dropped. Each candidate is written at most once over all runs.
  Status WriteBlocks(std::span<const uint64_t> which, const DenseFill& fill);
  // Encodes and appends the bricks `which` lists from `field` (holding
  // their points: field_bricks.h); `finest_max` as WriteDenseStore's, indexed
  // by lattice-0 brick from the grid's first (read for the lattice-0
  // bricks listed only). Each brick is written exactly once over all runs.
  template <class V>
  Status WriteBricks(std::span<const uint64_t> which, const HeldField<V>& field,
                     const double* finest_max);
  // Completes the file. Returns the header written (on every rank of a
  // group). With a group, collective: any rank's failure fails all
  // (ProcessGroup::Agree) and leaves nothing.
  Result<DenseHeader> Finish();

 private:
  struct Worker;
  DenseStoreWriter();
  Worker& Prepare(int worker);
  bool MayHoldData(uint64_t vblock) const;
  void RaiseErrorMax(double e);
  Result<uint64_t> AppendItem(std::span<const uint8_t> bytes);
  Status MergeSpooled(const std::vector<std::string>& records, std::vector<std::string>& places);
  Status CopySpooled(const std::string& records, const std::string& places);
  Result<DenseHeader> WriteTail();

  std::string path_;
  DenseWriteOptions options_;
  std::chrono::steady_clock::time_point start_;
  DenseHeader h_;
  ErrorQuantizer quantizer_{Quantization::kU16, 1, 0};
  std::unique_ptr<BrickGrid> grid_;
  uint64_t positions_ = 0;  // the HZ order's size
  std::vector<uint64_t> candidates_;
  std::vector<DenseIndexEntry> entries_, brick_entries_;
  std::vector<uint8_t> kept_, block_written_, brick_written_;
  std::unique_ptr<AtomicFileWriter> writer_;  // null on a group's ranks but 0
  std::unique_ptr<ScratchFile> spool_;        // with options_.spool
  uint64_t data_end_ = 0;                     // spooled: the items' end in the store
  std::vector<Worker> workers_;
  std::mutex max_mu_;
  double error_max_ = 0;
};
#define SDB_WRITE_BRICKS_(V) \
  extern template Status DenseStoreWriter::WriteBricks(std::span<const uint64_t>, \
                                                       const HeldField<V>&, const double*);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WRITE_BRICKS_)
#undef SDB_WRITE_BRICKS_

// Writes `path` at once (DenseStoreWriter: every block, every brick). From `params` the writer takes dimension, domain_bits,
// dims, voxel_type (the stored field's type), quantization, block_bits,
// brick_bits, flags, field_min/max (the range over the real grid: it sets
// the quantum), spacing, origin, scaling and source; it sets the rest.
// `field` holds the real grid's values, x fastest (NaN: missing), each
// representable in voxel_type. `finest_max`: unless flags has
// kDenseFinestStored (then null), per grid brick (lattice 0, in brick order)
// the largest finest-octave error of the vertices it owns
// (BrickGrid::FinestBox). Returns the header written.
template <class V>  // a voxel C++ type (uint8_t ... double) holding every value
Result<DenseHeader> WriteDenseStore(const std::string& path, const DenseHeader& params,
                                    const DenseWriteOptions& options, const DenseFill& fill, const V* field,
                                    const double* finest_max);
#define SDB_WRITE_HZ_STORE_(V)                                                         \
  extern template Result<DenseHeader> WriteDenseStore(const std::string&, const DenseHeader&,  \
                                                      const DenseWriteOptions&, const DenseFill&, \
                                                      const V*, const double*);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WRITE_HZ_STORE_)
#undef SDB_WRITE_HZ_STORE_

}  // namespace simplexdb
