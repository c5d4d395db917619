// SparseStore: the sparse store of format 2 (storage/sparse/
// sparse_format.h), read-only: one LMDB value (in parts) per block of the
// hierarchical Z-order holding the diamonds kept at the store's tolerance t.
//
// What a reader answers, for a store built at tolerance t:
//   - ErrorBound(node): 0 for a node whose diamond was dropped (its error and
//     every descendant's is within t: a query never refines it); for a kept
//     diamond below the finest octave, its stored error (the dense store's
//     quantization, rounded up); for a kept finest diamond, its error over
//     the rebuilt field plus t + s / 2 (the rebuilt values at the points
//     inside are within t of the input, those at its vertices within s / 2,
//     s the header's value step, 2t or 0), rounded up. At t = 0 every answer
//     is the dense store's.
//   - Field(p): the rebuilt value at p clamped to the real grid: within t of
//     the input's (equal at t = 0); at a kept vertex within s / 2.
//
// Thread safety: a store may be shared by threads; a Reader is one thread's.
// Decoded blocks go to the store's cache (storage/common/block_cache.h),
// shared by its readers.
// Lifetimes: the store must outlive its readers; a reader holds an LMDB
// read transaction (a snapshot) for its life.
// Errors: Open's are NotFound, InvalidArgument (not a SimplexDB sparse
// store), NotSupported (another format version: the message says to import
// again), Corruption (a damaged file, header or block, named); a reader's
// lookups return Corruption for a damaged block.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "hierarchy/hz_order.h"
#include "hierarchy/simplex_code.h"
#include "storage/common/block_cache.h"
#include "storage/error/finest_diamonds.h"
#include "storage/error/quantize.h"
#include "storage/sparse/sparse_format.h"
#include "util/status.h"

namespace simplexdb {

namespace lmdb {
class Env;
class Txn;
}  // namespace lmdb

class SparseStore {
 public:
  struct Options {
    size_t cache_bytes = size_t{256} << 20;  // decoded blocks, for all readers
    std::shared_ptr<BlockCache> cache;       // or this cache, shared with other stores
  };

  static Result<std::unique_ptr<SparseStore>> Open(const std::string& path, const Options& options);
  ~SparseStore();

  const SparseHeader& header() const { return header_; }
  int dimension() const { return header_.dimension; }
  const std::string& path() const { return path_; }
  // Its error codes (stored and computed) and their values.
  const SparseErrorCoder& errors() const { return *errors_; }
  uint64_t file_bytes() const;

  // Reads every block once (checksum, sizes, counts, the kept values rebuilt),
  // checks the count of blocks and kept vertices against the header and
  // that every key names a block that can hold vertices. The B-tree's pages
  // were walked by Open. The first failure, naming the block.
  Status Verify(const std::function<void(uint64_t, uint64_t)>& progress = {}) const;

  // OK while the file is as LMDB left it (lmdb::Env::CheckUnchanged:
  // IOError naming it once it was cut short or a read of it faulted,
  // Corruption when something other than LMDB wrote it). Every operation
  // over the store asks before and after it reads (query/open_store.h).
  Status CheckUnchanged() const;

  struct Stats {
    uint64_t blocks_decoded = 0;  // entries decoded (cache misses)
    uint64_t blocks_rebuilt = 0;  // blocks without an entry met
  };
  Stats stats() const;

  template <int D>
  class Reader {
   public:
    // REQUIRES: store.dimension() == D. Errors of the first lookup include
    // those of beginning the read transaction.
    explicit Reader(const SparseStore& store);
    ~Reader();

    Result<double> ErrorBound(SimplexCode<D> code);
    Result<double> Field(const std::array<int64_t, D>& p);
    // Whether grid vertex g's diamond is kept (corners: true).
    Result<bool> Kept(const std::array<int64_t, D>& g);
    // Decodes block b from the file (a cached copy is not used) and
    // rebuilds its values: its kept vertices (Verify's walk).
    Result<uint64_t> Rebuild(uint64_t b);

   private:
    // A decoded block, compact: its kept vertices only, by offset in the
    // block (ascending), with their values and states. A block without an
    // entry has none. Dropped vertices' values are rebuilt as asked.
    struct View {
      uint64_t b = ~uint64_t{0};
      std::shared_ptr<const BlockCache::Block> block;
      size_t kept = 0;
      const double* values = nullptr;
      const uint32_t* offsets = nullptr;
      const uint32_t* states = nullptr;
      const uint64_t* bits = nullptr;  // bit `offset` set when kept (null: none kept)
      bool Has(uint32_t offset) const { return bits != nullptr && (bits[offset >> 6] >> (offset & 63) & 1) != 0; }
      // The index of the kept vertex at `offset`, or kept when it is dropped.
      size_t Find(uint32_t offset) const {
        if (!Has(offset)) return kept;
        const uint32_t* it = std::lower_bound(offsets, offsets + kept, offset);
        return it != offsets + kept && *it == offset ? static_cast<size_t>(it - offsets) : kept;
      }
    };
    Result<const View*> Get(uint64_t p);
    Result<View> Fetch(uint64_t b);
    Result<View> Materialize(uint64_t b);
    // The value of dropped vertex g (at position p): the mean of its split
    // edge's ends (through `value`), remembered.
    template <class Value>
    Result<double> RebuiltValue(const std::array<int64_t, D>& g, uint64_t p, Value&& value);
    // The rebuilt value of domain vertex g (at position p).
    Result<double> Value(const std::array<int64_t, D>& g);
    // A kept vertex's value from its residual and prediction p.
    double KeptValue(uint64_t residual, double p) const {
      const SparseHeader& h = store_.header();
      return h.value_step > 0 ? HzFromStepResidual(residual, p, h.value_step)
                              : HzFromResidual(h.voxel_type, residual, p);
    }
    Result<uint32_t> FinestCode(const std::array<int64_t, D>& g);

    const SparseStore& store_;
    HzOrder<D> order_;
    SplitVertexCursor<D> cursor_;
    std::array<int64_t, D> dims_{};
    std::unique_ptr<lmdb::Txn> txn_;
    ZstdDecompressor zstd_;
    std::array<View, (kCoordBits<D> + 1) << D> held_;
    DiamondStencils<D> stencils_;
    std::array<double, D == 3 ? 125 : 625> window_{};
    // Rebuilt values of recent windows' points, direct-mapped by grid point.
    struct WindowMemo {
      uint64_t key = ~uint64_t{0};
      double value = 0;
    };
    static constexpr int kWindowMemoBits = 16;
    std::vector<WindowMemo> window_memo_;
    // Dropped vertices' values rebuilt, by position; cleared when it
    // reaches kRebuiltValuesHeld (about 64 MiB).
    static constexpr size_t kRebuiltValuesHeld = size_t{1} << 21;
    std::unordered_map<uint64_t, double> rebuilt_values_;
    // Blocks that failed to decode, with why: damage does not change
    // within the reader's snapshot, so it is not decoded again.
    std::unordered_map<uint64_t, Status> failed_;
  };

  // A kept vertex's state in a decoded block: kept in the finest octave
  // with its error not computed yet, or the code. A
  // reader computing a finest code writes it into the cached block (an
  // atomic store of the one value any reader would compute), so the
  // readers of a store compute each once while the block stays cached.
  static constexpr uint32_t kFinestKept = 0xFFFFFFFEu;

 private:
  SparseStore() = default;

  std::string path_;
  SparseHeader header_;
  std::unique_ptr<SparseErrorCoder> errors_;
  std::unique_ptr<lmdb::Env> env_;
  unsigned int db_ = 0;  // blocks and header
  std::shared_ptr<BlockCache> cache_;
  uint64_t cache_id_ = 0;
  mutable std::atomic<uint64_t> decoded_{0}, rebuilt_{0};
};

// Block b's value in the store's database `dbi`: its parts (keys (b, 0),
// (b, 1), ...) joined into `out`. False when the block has no entry.
// Errors: Corruption naming `path` for parts out of sequence or a key that
// is neither a block's nor the header's; LMDB's.
Result<bool> ReadSparseBlockValue(lmdb::Txn& txn, unsigned int dbi, uint64_t b, const std::string& path,
                                  std::vector<uint8_t>* out);

}  // namespace simplexdb
