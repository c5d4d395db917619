// DenseStore: a read-only, memory-mapped dense store (docs/format/
// dense-store.md): the errors of every internal node of an HT or HP, indexed
// by location code, and the field on the real grid, in blocks that are raw
// (read in place from the mapping) or zstd frames (decoded into a bounded
// cache).
//
// Opening checks the header, the file's size, the index's checksum and every
// index entry against the layout the header implies; a block's own checksum
// is checked the first time it is read (and all of them by Verify()). A
// damaged store gives Corruption naming the file and the block; nothing
// reads past the mapping.
//
// Thread safety: a DenseStore may be shared by any number of threads, and
// many processes may open the same file. Lookups go through a Reader, one
// per thread, which keeps the blocks it last used (no locking while a walk
// stays in them).
//
// Memory: decoded blocks live in the BlockCache (a budget set by the
// caller) plus the few a Reader holds; raw blocks and the block index are
// read from the mapping (file pages, not anonymous memory). Beyond that a
// store keeps one byte per block (raw blocks' checksum state). With Options::in_memory every block
// is decoded into memory at open: the in-core case. Stores sharing a cache
// (Options::cache) each have their own never-reused id in it; closing a
// store erases its blocks from a shared cache (O(blocks cached)).
//
// Lifetimes: the store must outlive its Readers and every BlockHandle it
// hands out keeps its block alive by itself (a handle outlives eviction, not
// the store's mapping: drop handles before the store). header(), path() and
// quantizer() live as long as the store.
//
// Errors: Open returns NotFound, InvalidArgument (not a store), NotSupported
// (another format version) or Corruption; lookups return Corruption naming
// the block when a block fails its checksum or does not decode, and
// InvalidArgument for a block number out of range. Both return
// ResourceExhausted "not enough memory for ..." when decoded blocks do not
// fit in memory (Open with in_memory: all of them; lookups: the one block).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "storage/dense/block_cache.h"
#include "storage/io/file.h"
#include "storage/dense/format.h"
#include "storage/dense/layout.h"
#include "storage/error/quantize.h"
#include "util/status.h"

namespace simplexdb {

class DenseStore {
 public:
  struct Options {
    size_t cache_bytes = size_t{256} << 20;  // decoded blocks kept
    bool in_memory = false;                  // decode everything at open
    std::shared_ptr<BlockCache> cache;       // share one cache between stores
  };

  // Opens and validates a store. Errors: NotFound, InvalidArgument (not a
  // store), NotSupported (another format version), Corruption (damaged),
  // ResourceExhausted (in_memory, and the decoded blocks do not fit).
  static Result<std::unique_ptr<DenseStore>> Open(const std::string& path,
                                                  const Options& options);
  static Result<std::unique_ptr<DenseStore>> Open(const std::string& path) {
    return Open(path, Options{});
  }
  ~DenseStore();

  const DenseHeader& header() const { return header_; }
  int dimension() const { return header_.dimension; }
  const std::string& path() const { return path_; }
  const ErrorQuantizer& quantizer() const { return quantizer_; }
  uint64_t file_size() const { return header_.file_size; }

  // Blocks are numbered error blocks first, then field bricks.
  uint64_t block_count() const { return header_.block_count(); }
  uint64_t error_block_count() const { return header_.error_block_count; }
  // Parsed from the mapping on every call: the index is never copied, so a
  // store's anonymous memory does not grow with its size.
  IndexEntry entry(uint64_t block) const {
    return ParseIndexEntry(index_ + block * kIndexEntrySize);
  }
  uint64_t BrickBlock(uint64_t brick) const { return header_.error_block_count + brick; }

  // A decoded block; its bytes stay valid while the handle lives.
  struct BlockHandle {
    const uint8_t* data = nullptr;
    size_t size = 0;
    std::shared_ptr<const void> keep;
  };
  Result<BlockHandle> Block(uint64_t block) const;

  // The value of entry `i` of a decoded error block / brick.
  double ErrorAt(const uint8_t* block, uint32_t i) const {
    return quantizer_.Decode(StoredAt(block, i));
  }
  uint32_t StoredAt(const uint8_t* block, uint32_t i) const;
  double FieldAt(const uint8_t* brick, uint32_t i) const;

  // Reads every block: checksum, decoding, and that stored values are in
  // range (errors finite and non-negative, at most the block's error_max;
  // field values within the block's and the header's range). Returns the
  // first failure, naming the block. `progress(done, total)` is called now
  // and then.
  Status Verify(const std::function<void(uint64_t, uint64_t)>& progress = {}) const;

  struct Stats {
    uint64_t blocks_decoded = 0;   // zstd frames decoded (cache misses)
    uint64_t raw_checked = 0;      // raw blocks checksummed on first use
  };
  Stats stats() const {
    return Stats{decoded_.load(std::memory_order_relaxed),
                 raw_checked_.load(std::memory_order_relaxed)};
  }
  const BlockCache* cache() const { return cache_.get(); }

  // Describes block `b` for messages: "error block 12 (root 0, levels
  // 14..27, subtree 11)" or "field brick 3".
  std::string DescribeBlock(uint64_t b) const;

  // Lookups for one thread.
  template <int D>
  class Reader {
   public:
    // REQUIRES: store.dimension() == D; the store outlives the reader.
    explicit Reader(const DenseStore& store);

    // The stored error bound of a node: an upper bound of its true error
    // (exact in the float32 mode up to rounding up). Nodes at or below the
    // leaf level have error 0.
    // REQUIRES: code.is_valid().
    Result<double> ErrorBound(SimplexCode<D> code);
    // The entry as stored (u16 / u8 codes, f32 bits): what ErrorBound decodes.
    Result<uint32_t> StoredError(SimplexCode<D> code);
    // For a query that only asks whether the bound exceeds `threshold`: the
    // bound, or, when the node's block is not the one this reader holds and
    // the block index records a maximum at most `threshold`, that maximum
    // (no block is read or decoded: every node in the block passes).
    Result<double> ErrorBoundForThreshold(SimplexCode<D> code, double threshold);

    // The field at grid point p of the domain [0, 2^k]^D; points outside the
    // real grid take the value of the nearest real point (the padding).
    Result<double> Field(const std::array<int64_t, D>& p);

    const DenseStore& store() const { return store_; }
    // Blocks this reader switched to (error blocks and field bricks): the
    // blocks a walk read, counting a block again when it comes back to it.
    uint64_t block_fetches() const { return block_fetches_; }
    // Blocks ErrorBoundForThreshold answered from the index alone.
    uint64_t blocks_skipped() const { return blocks_skipped_; }

   private:
    const DenseStore& store_;
    ErrorLayout<D> layout_;
    BrickLayout bricks_;
    uint64_t error_block_ = ~uint64_t{0};
    BlockHandle error_handle_;
    uint64_t brick_ = ~uint64_t{0};
    BlockHandle brick_handle_;
    uint64_t block_fetches_ = 0;
    uint64_t blocks_skipped_ = 0;
  };

 private:
  DenseStore() = default;
  Status ValidateIndex();
  Status LoadAll();
  Result<std::shared_ptr<const BlockCache::Block>> DecodeBlock(uint64_t block) const;
  uint32_t ExpectedRawSize(uint64_t block) const;

  std::string path_;
  DenseHeader header_;
  ErrorQuantizer quantizer_{Quantization::kU16, 1, 0};
  std::unique_ptr<MappedFile> file_;
  const uint8_t* index_ = nullptr;  // in the mapping; validated at open
  std::shared_ptr<BlockCache> cache_;
  uint64_t cache_store_id_ = 0;  // this store's keys in the cache: {id, block}
  std::vector<uint8_t> zeros_;
  // in_memory: every block decoded.
  std::vector<std::shared_ptr<const BlockCache::Block>> resident_;
  // Raw blocks whose checksum was checked (1) or found bad (2).
  std::unique_ptr<std::atomic<uint8_t>[]> raw_state_;
  mutable std::atomic<uint64_t> decoded_{0};
  mutable std::atomic<uint64_t> raw_checked_{0};
  uint32_t error_block_bytes_ = 0;  // largest raw error block
  uint32_t brick_bytes_ = 0;
  size_t voxel_size_ = 1;
};

}  // namespace simplexdb
