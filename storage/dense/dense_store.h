// DenseStore: a read-only, memory-mapped store of format 2 (storage/dense/
// dense_format.h, docs/format/dense-store.md): per grid vertex its diamond's
// error, in hierarchical Z-order, in blocks; the field as bricks of every
// octave's lattice. Blocks and bricks are raw (blocks are read in place) or
// zstd frames, decoded into a bounded cache. A node's error is the error of
// the diamond whose split vertex it creates; where the store keeps no
// errors for the finest octave, a brick's worth of them is computed from
// the field around it (storage/error/finest_box_errors.h, as the builder
// computed them) and cached like a decoded block.
//
// Opening checks the header, the file's size, the bitmap's and the indexes'
// checksums and every index entry; a block's or brick's own checksum is
// checked the first time it is read (and all of them by Verify()). A
// damaged store gives Corruption naming the file and the block or brick;
// nothing reads past the mapping.
//
// Thread safety: an DenseStore may be shared by any number of threads. Lookups
// go through a Reader, one per thread, which keeps the last block it read
// in each segment (a walk moves between levels at every step, and each
// level's records of each odd-axis pattern are their own blocks; no lock
// while a walk stays in them), the last brick of each lattice and a few
// boxes of finest errors, and the octave steps of the last code
// (hierarchy/hz_order.h SplitVertexCursor).
//
// Memory: decoded blocks, bricks and finest boxes live in the BlockCache (a
// budget set by the caller) plus those a Reader holds, and each Reader
// keeps the field around a few finest boxes (at most 16, within about 1 MiB
// unless one alone is larger; FinestWindowBytes()); raw blocks, the
// bitmap and the indexes are read from the mapping. Beyond that the store
// keeps 8 bytes per 64 virtual blocks (the bitmap's rank directory), two
// bytes per stored block and one per brick. With Options::in_memory every
// block and brick is decoded at open and every grid brick's finest errors
// computed (the in-core case), on every core.
//
// Lifetimes: the store outlives its Readers and BlockHandles; header(),
// path(), quantizer() and grid() live as long as the store.
//
// Errors: Open returns NotFound, InvalidArgument (not a store),
// NotSupported (format 1 or an earlier format 2: import again; another
// version), Corruption (damaged), ResourceExhausted (in_memory and the
// blocks do not fit); lookups return Corruption naming the block or brick
// when it fails its checksum or does not decode, ResourceExhausted "not
// enough memory for ..." when a decoded one does not fit.
//
// A file changed under an open store: the mapping is guarded
// (storage/io/mapping_guard.h), so a read past the end of a file truncated
// since the open reads zeros instead of raising SIGBUS; CheckUnchanged
// reports that, and any truncation or write in place, as IOError, and every
// operation asks it before and after reading (AnyStore::Visit, ops/). A
// file replaced by renaming another over it is not a change: the store
// reads the file it opened.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hierarchy/hz_order.h"
#include "hierarchy/simplex_code.h"
#include "storage/common/block_cache.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/dense_format.h"
#include "storage/error/finest_box_errors.h"
#include "storage/error/quantize.h"
#include "storage/io/file.h"
#include "util/status.h"

namespace simplexdb {

class DenseStore {
 public:
  struct Options {
    size_t cache_bytes = size_t{256} << 20;  // decoded blocks, bricks and boxes kept
    // Decode every block and brick at open and compute every grid brick's
    // finest errors (an error code a finest vertex), on `threads` threads (0: one
    // per core).
    bool in_memory = false;
    int threads = 0;
    std::shared_ptr<BlockCache> cache;       // share one cache between stores
  };

  static Result<std::unique_ptr<DenseStore>> Open(const std::string& path, const Options& options);
  static Result<std::unique_ptr<DenseStore>> Open(const std::string& path) {
    return Open(path, Options{});
  }
  ~DenseStore();

  const DenseHeader& header() const { return header_; }
  int dimension() const { return header_.dimension; }
  const std::string& path() const { return path_; }
  const ErrorQuantizer& quantizer() const { return quantizer_; }
  const BrickGrid& grid() const { return *grid_; }
  uint64_t file_size() const { return header_.file_size; }
  uint64_t stored_blocks() const { return header_.stored_blocks; }
  uint64_t bricks() const { return header_.bricks; }
  // Bytes of a decoded block: its error entries.
  size_t block_bytes() const { return error_size_ << header_.block_bits; }
  // Bytes of a decoded full brick: its voxels.
  size_t brick_bytes() const { return voxel_size_ * grid_->brick_voxels(); }

  // The stored block holding virtual block `vblock`, by its rank among the
  // stored blocks; nullopt when the block is not stored (all its errors are
  // 0). O(1).
  std::optional<uint64_t> StoredIndex(uint64_t vblock) const;
  // The virtual block of stored block `i` (O(log) over the bitmap's words).
  uint64_t VirtualBlock(uint64_t stored) const;
  DenseIndexEntry entry(uint64_t stored) const {
    return ParseDenseIndexEntry(index_ + stored * kDenseIndexEntrySize);
  }
  DenseIndexEntry brick_entry(uint64_t brick) const {
    return ParseDenseIndexEntry(brick_index_ + brick * kDenseIndexEntrySize);
  }

  struct BlockHandle {
    const uint8_t* data = nullptr;  // block_bytes() bytes, or a brick's voxels
    std::shared_ptr<const void> keep;
    // FinestCodes out of core: a box whose codes are computed a vertex at a
    // time as readers ask for them (LazyCode, ComputeLazyCode).
    bool lazy = false;
  };
  // Stored block `i`, decoded.
  Result<BlockHandle> Block(uint64_t stored) const;
  // Brick `b`, decoded: its voxels, little-endian, x fastest over its extent.
  Result<BlockHandle> Brick(uint64_t b) const;
  // The finest-octave error codes of the vertices grid brick `b` owns
  // (BrickGrid::FinestBox), computed from the field, each as a block's
  // (StoredErrorAt), at FinestTiles' slots. In memory every box is
  // computed at open. Out of core the handle is `lazy`: a shared box of
  // codes that readers fill a vertex at a time the first time one asks for
  // it (LazyCode, then ComputeLazyCode from the field around the box,
  // GatherFinestWindow), so a query that refines part of a brick pays for
  // that part, and a vertex asked for again costs a load.
  // REQUIRES: !finest_stored(), b a brick of lattice 0.
  Result<BlockHandle> FinestCodes(uint64_t b) const;
  // The field around grid brick b's finest box (FinestBoxErrors' window:
  // the box grown by 2 points per side, x fastest; points past the real
  // grid 0) as the store's voxels, into `window`. Asks for each brick it
  // meets once.
  Status GatherFinestWindow(uint64_t b, std::vector<uint8_t>& window) const;
  // The bytes of such a window (0 when the store keeps its finest errors).
  size_t FinestWindowBytes() const;

  // Where a finest box's codes are: in tiles of 4^D points (4 per axis, x
  // fastest within), the tiles x fastest over the box. A walk's lookups
  // are near each other in every axis; a tile of 2-byte codes is two cache
  // lines in the HT (an x-fastest box row is one).
  struct FinestTiles {
    static constexpr int kBits = 2;  // log2 of a tile's side
    std::array<int64_t, 4> first{}, extent{}, tile_stride{};
    int dimension = 0;
    uint64_t slots = 0;  // tiles times 4^D: the codes, padding included

    FinestTiles() = default;
    FinestTiles(int d, const BrickGrid::Box& box) : dimension(d) {
      uint64_t tiles = 1;
      for (int a = 0; a < d; ++a) {
        first[a] = box.first[a];
        extent[a] = box.extent[a];
        tile_stride[a] = static_cast<int64_t>(tiles) << (kBits * d);
        tiles *= static_cast<uint64_t>((extent[a] + 3) >> kBits);
      }
      slots = tiles << (kBits * d);
    }
    // g's slot, or -1 when g is outside the box. REQUIRES: N == dimension.
    template <size_t N>
    int64_t Slot(const std::array<int64_t, N>& g) const {
      int64_t slot = 0;
      for (size_t a = 0; a < N; ++a) {
        const int64_t local = g[a] - first[a];
        if (static_cast<uint64_t>(local) >= static_cast<uint64_t>(extent[a])) return -1;
        slot += (local >> kBits) * tile_stride[a] + ((local & 3) << (kBits * static_cast<int>(a)));
      }
      return slot;
    }
  };


  // The error code at `slot` of a decoded block (or of a FinestCodes box
  // computed whole).
  uint32_t StoredErrorAt(const uint8_t* block, uint32_t slot) const {
    return LoadErrorCode(header_.quantization, block, slot);
  }
  // A lazy box's code at `slot` (>= 0; tiles: the box's), when some
  // reader has computed it: true, and *code set.
  bool LazyCode(const BlockHandle& box, const FinestTiles& tiles, int64_t slot, uint32_t* code) const {
    const uint8_t bit = static_cast<uint8_t>(1u << (slot & 7));
    if ((LazyBits(box, tiles)[slot >> 3].load(std::memory_order_acquire) & bit) == 0) return false;
    *code = LazyCodeRef(box, slot);
    return true;
  }
  // Computes finest vertex g's code (at `slot` of the lazy `box`) from
  // `window`, GatherFinestWindow's for the box, stores it in the box and
  // returns it. Thread-safe: readers racing on a vertex store the same code.
  template <size_t N>
  uint32_t ComputeLazyCode(const BlockHandle& box, const FinestTiles& tiles,
                           const std::array<int64_t, N>& g, int64_t slot, const uint8_t* window) const;
  double VoxelAt(const uint8_t* brick, size_t slot) const;

  // OK while the file is as it was opened (MappedFile::CheckUnchanged:
  // IOError naming it once it was truncated or written, or a read of it
  // faulted). Every operation over the store asks before and after it
  // reads (query/open_store.h, ops/).
  Status CheckUnchanged() const { return file_->CheckUnchanged(); }

  // Reads every stored block and brick: checksums, decoding, errors finite
  // and within the recorded maxima, field values within the brick's and the
  // header's range, and (finest errors not stored) each grid brick's finest
  // errors, computed, equal to its recorded maximum. `progress(done,
  // total)` now and then.
  Status Verify(const std::function<void(uint64_t, uint64_t)>& progress = {}) const;

  // "block 12 (level 7, odd axes 011, positions 49152..53247)".
  std::string DescribeBlock(uint64_t vblock) const;
  // "brick 40 (the points at multiples of 2, from (0, 32, 16))".
  std::string DescribeBrick(uint64_t b) const;

  struct Stats {
    uint64_t blocks_decoded = 0;  // zstd frames decoded (cache misses), blocks and bricks
    uint64_t raw_checked = 0;     // raw blocks and bricks checksummed on first use
    uint64_t distinct = 0;        // different blocks and bricks asked for since the open
    uint64_t boxes_computed = 0;  // bricks' finest boxes made (cache misses)
    uint64_t finest_computed = 0;  // finest vertices' errors computed (lazy boxes)
    uint64_t bricks_read = 0;      // of blocks_decoded and raw_checked, the bricks
  };
  Stats stats() const {
    return Stats{decoded_.load(std::memory_order_relaxed),
                 raw_checked_.load(std::memory_order_relaxed),
                 distinct_.load(std::memory_order_relaxed),
                 boxes_.load(std::memory_order_relaxed),
                 finest_computed_.load(std::memory_order_relaxed),
                 bricks_read_.load(std::memory_order_relaxed)};
  }
  const BlockCache* cache() const { return cache_.get(); }
  // Opened with Options::in_memory (every block and brick decoded).
  bool in_memory() const { return in_memory_; }
  // Whether a walk a region at a time (Reader::Region, query/refine.h)
  // pays for its cost per node (15-30 ns against about 80 of a node's
  // lookup and split, for its bookkeeping) with the decodes it saves: out
  // of core, with a cache of at most a sixteenth of the decoded store in
  // the HT (bench/README.md: it gained at 2% and 4% and lost at 8% and
  // more) and smaller than the decoded store in the HP (81 bricks around a
  // finest box instead of 27: it gained at 4% and 31%).
  bool RegionWalkPays(int dimension) const {
    if (in_memory_ || cache_ == nullptr) return false;
    const uint64_t decoded =
        header_.stored_blocks * block_bytes() + header_.bricks * grid_->brick_voxels() * voxel_size_;
    return cache_->capacity() < (dimension == 3 ? decoded / 16 : decoded);
  }

  // Lookups for one thread.
  template <int D>
  class Reader {
   public:
    // REQUIRES: store.dimension() == D; the store outlives the reader.
    explicit Reader(const DenseStore& store);

    // The stored error bound of a node: its diamond's error, rounded up by
    // the quantization; 0 at or below the leaf level. REQUIRES: code.is_valid().
    Result<double> ErrorBound(SimplexCode<D> code);
    Result<uint32_t> StoredError(SimplexCode<D> code);
    // For a query that only asks whether the bound exceeds `threshold`: the
    // bound, or, when the node's block (or brick, for the finest octave) is
    // not the one held and the index records a maximum at most `threshold`,
    // that maximum (nothing decoded or computed).
    Result<double> ErrorBoundForThreshold(SimplexCode<D> code, double threshold) {
      if (code.level() >= order_.levels()) return 0.0;
      if (code.level() >= finest_level_) {  // the finest octave, not stored: by vertex
        bool skipped = false;
        SDB_ASSIGN_OR_RETURN(const uint32_t c, FinestCodeAt(code.key() == vertex_key_ ? vertex_ : VertexOf(code),
                                                            &threshold, &skipped));
        return store_.quantizer().Decode(c);
      }
      return ErrorBoundForThresholdAt(code, Position(code), threshold);
    }
    // The same with the node's HZ position given (Position(code)), for a
    // caller that computed it already.
    Result<double> ErrorBoundForThresholdAt(SimplexCode<D> code, uint64_t position,
                                            double threshold);
    // The HZ position of the node's split vertex. REQUIRES: code above the
    // leaf level.
    uint64_t Position(SimplexCode<D> code) { return PositionOf(code); }
    // The field at grid point p of the domain; points outside the real grid
    // take the value of the nearest real point.
    Result<double> Field(const std::array<int64_t, D>& p);

    // For a walk that keeps its reads local (query/refine.h): the region of
    // the store a node's error reads, for the nodes of the last octave,
    // whose finest boxes and the field around them are too many to keep in
    // a small cache: the Morton index of the grid brick holding the node's
    // split vertex (the nodes of a region read one finest box and one window
    // of the field). Only the last octave: grouping the octave above too
    // decoded more (31,720 frames against 20,431 on a 257^3 uint8 1% query
    // at 1 MiB). kAnyRegion for the coarser nodes (their few blocks stay
    // cached), the leaf level, and every node when RegionWalkPays() is
    // false (a store in memory or a cache that holds much of it). A cursor
    // step after the node's parent; the vertex is kept, so the node's own
    // lookup right after costs nothing more.
    static constexpr uint64_t kAnyRegion = ~uint64_t{0};  // as query/source.h's
    bool has_regions() const { return region_level_ < order_.levels(); }
    uint64_t Region(SimplexCode<D> code) {
      if (code.level() < region_level_ || code.level() >= order_.levels()) return kAnyRegion;
      if (code.key() != vertex_key_) VertexOf(code);
      return BrickRegion(vertex_);
    }
    // The region of both children of `parent`, right after the parent's own
    // lookup, when it is one: a child's split vertex lies within two grid
    // steps of its parent's on every axis (the simplices of the last octave
    // span two), so both are in the parent's brick when that one is two
    // steps or more inside it. kPerChild when the children must be asked
    // one by one (Region).
    static constexpr uint64_t kPerChild = kAnyRegion - 1;
    uint64_t ChildrenRegion(SimplexCode<D> parent) {
      const int level = parent.level() + 1;
      if (level < region_level_ || level >= order_.levels()) return kAnyRegion;
      if (parent.key() != vertex_key_) return kPerChild;
      const int bits = store_.header().brick_bits;
      const int64_t low = 2, high = (int64_t{1} << bits) - 3;
      for (int a = 0; a < D; ++a) {
        const int64_t offset = vertex_[a] & ((int64_t{1} << bits) - 1);
        if (offset < low || offset > high || vertex_[a] + 2 > int64_t{store_.header().dims[a]} - 1) {
          return kPerChild;
        }
      }
      return BrickRegion(vertex_);
    }

    const DenseStore& store() const { return store_; }
    uint64_t block_fetches() const { return block_fetches_; }
    uint64_t blocks_skipped() const { return blocks_skipped_; }

   private:
    struct Held {
      uint64_t vblock = ~uint64_t{0};
      bool stored = false;
      BlockHandle handle;  // null when skipped
      // ErrorBoundForThreshold answered the block from its index maximum
      // (`skipped_max`) without decoding it.
      bool skipped = false;
      double skipped_max = 0;
    };
    // Makes `held` hold virtual block `vblock`.
    Status Hold(Held& held, uint64_t vblock);
    // The block held for the segment (level and odd-axis pattern) of
    // position p: a walk visits each segment a region at a time. Block 0
    // and the coarse octaves inside it share slot 0.
    Held& HeldFor(uint64_t p) {
      const int top = p == 0 ? 0 : 63 - std::countl_zero(p);
      const int octave = top / D - 1;
      if (octave < 0 || (p >> store_.header().block_bits) == 0) return held_[0];
      return held_[static_cast<size_t>(octave) * (1 << D) + static_cast<size_t>(p >> (D * (octave + 1)))];
    }
    // Remembers the vertex of the last position computed: a finest lookup
    // for it needs the vertex, not the position.
    uint64_t PositionOf(SimplexCode<D> code) {
      last_vertex_ = VertexOf(code);
      last_position_ = order_.PositionAtLevel(last_vertex_, code.level());
      return last_position_;
    }
    // The Morton index of the grid brick holding grid point g (clamped to
    // the real grid).
    uint64_t BrickRegion(const std::array<int64_t, D>& g) const {
      std::array<int64_t, D> brick{};
      for (int a = 0; a < D; ++a) {
        brick[a] = std::min<int64_t>(g[a], int64_t{store_.header().dims[a]} - 1) >> store_.header().brick_bits;
      }
      return internal::Morton<D>(brick);
    }
    // The grid point of the node's split vertex, kept as vertex_ (Region's,
    // then the node's lookup).
    const std::array<int64_t, D>& VertexOf(SimplexCode<D> code) {
      vertex_ = LatticeToGrid<D>(cursor_.Of(code), order_.domain_bits());
      vertex_key_ = code.key();
      return vertex_;
    }
    // The error code of finest vertex at position p (not stored), from its
    // brick's box; with `threshold`, the brick's recorded maximum when it
    // is at most that (*skipped set).
    Result<uint32_t> FinestCode(uint64_t p, const double* threshold, bool* skipped);
    // The same for the finest vertex g.
    Result<uint32_t> FinestCodeAt(const std::array<int64_t, D>& g, const double* threshold,
                                  bool* skipped);

    const DenseStore& store_;
    HzOrder<D> order_;
    SplitVertexCursor<D> cursor_;
    // The first level of the finest octave when the store does not keep its
    // errors (their positions are those from error_positions() on), else
    // past the last level.
    int finest_level_;
    // The first level Region() names a region for (past the last level when
    // RegionWalkPays() is false).
    int region_level_;
    std::array<Held, (kCoordBits<D> + 1) << D> held_;
    // The last brick read per lattice (Field) and a few finest boxes, by
    // brick number.
    struct HeldBrick {
      uint64_t brick = ~uint64_t{0};
      BlockHandle handle;
      FinestTiles tiles;  // held_boxes_: the brick's finest box
    };
    std::vector<HeldBrick> held_bricks_;
    std::array<HeldBrick, 8> held_boxes_;
    // The code at `slot` of a held finest box (for vertex g): a computed
    // one, or one computed now from the field around the box.
    Result<uint32_t> BoxCode(const HeldBrick& box, const std::array<int64_t, D>& g, int64_t slot);
    // The field around the last few finest boxes this reader computed
    // vertices of (GatherFinestWindow), by brick; the least recently used
    // is replaced (a walk along a brick's face alternates between two).
    // Up to 16 (an HT uint8 window is 10 KiB), within about 1 MiB (an HP
    // float64 one is 300 KiB), at least 2.
    struct Window {
      uint64_t brick = ~uint64_t{0};
      uint64_t used = 0;  // windows_tick_ when last used
      std::vector<uint8_t> bytes;
    };
    std::vector<Window> windows_;
    uint64_t windows_tick_ = 0;
    int last_box_ = -1;  // index of the held box used last (-1: none)
    std::array<int64_t, D> last_vertex_{};
    std::array<int64_t, D> vertex_{};  // VertexOf's last, of the node with key vertex_key_
    uint64_t vertex_key_ = ~uint64_t{0};
    uint64_t last_position_ = ~uint64_t{0};
    uint64_t block_fetches_ = 0;
    uint64_t blocks_skipped_ = 0;
  };

 private:
  DenseStore() = default;
  Status ValidateBitmapAndIndexes();
  Status LoadAll(int threads);
  // An entry's stored bytes in the mapping; Corruption (or the file's
  // change) when they lie past its end.
  Result<std::span<const uint8_t>> StoredBytes(const DenseIndexEntry& e, const std::string& what) const;
  Result<std::shared_ptr<const BlockCache::Block>> DecodeBlock(uint64_t stored) const;
  Result<std::shared_ptr<const BlockCache::Block>> DecodeBrickAt(uint64_t b) const;
  Result<std::shared_ptr<const BlockCache::Block>> ComputeFinest(uint64_t b) const;
  template <int D>
  Result<std::shared_ptr<const BlockCache::Block>> ComputeFinestOf(uint64_t b) const;
  // A lazy finest box (FinestCodes out of core): one buffer of the codes
  // at their tiles' slots, then a bit per slot, set once its code is
  // (release; read with acquire). Codes and bits are read and written as
  // atomics: readers share the box.
  Result<std::shared_ptr<const BlockCache::Block>> MakeLazyFinest(uint64_t b) const;
  struct AtomicBytes {
    uint8_t* bytes;
    std::atomic_ref<uint8_t> operator[](int64_t i) const { return std::atomic_ref<uint8_t>(bytes[i]); }
  };
  AtomicBytes LazyBits(const BlockHandle& box, const FinestTiles& tiles) const {
    return {const_cast<uint8_t*>(box.data) + error_size_ * tiles.slots};
  }
  uint32_t LazyCodeRef(const BlockHandle& box, int64_t slot) const;
  // FinestBoxErrors' window side, per axis. REQUIRES: !finest_stored().
  int64_t FinestWindowSide() const {
    return header_.dimension == 3 ? finest3_->window_side() : finest4_->window_side();
  }
  void SetLazyCode(const BlockHandle& box, int64_t slot, uint32_t code) const;
  std::string Describe(uint64_t stored) const { return DescribeBlock(VirtualBlock(stored)); }
  // Counts a first request of block or brick `i` (blocks first, then bricks).
  void Touch(uint64_t i) const;

  std::string path_;
  DenseHeader header_;
  ErrorQuantizer quantizer_{Quantization::kU16, 1, 0};
  std::unique_ptr<BrickGrid> grid_;
  std::unique_ptr<MappedFile> file_;
  const uint8_t* bitmap_ = nullptr;  // in the mapping; validated at open
  const uint8_t* index_ = nullptr;
  const uint8_t* brick_index_ = nullptr;
  std::vector<uint64_t> rank_;       // stored blocks before each bitmap word
  size_t error_size_ = 2, voxel_size_ = 1;
  std::shared_ptr<BlockCache> cache_;
  uint64_t cache_store_id_ = 0;
  bool in_memory_ = false;
  // in_memory: every block and brick decoded.
  std::vector<std::shared_ptr<const BlockCache::Block>> resident_, resident_bricks_;
  // in_memory and finest errors not stored: each grid brick's finest error
  // codes (FinestCodes), by brick - grid().FirstBrick(0); null where the
  // brick's recorded maximum is 0.
  std::vector<std::shared_ptr<const BlockCache::Block>> resident_finest_;
  // Finest errors from the field (the stencils for a box's window), the
  // store's dimension's one; null when the store keeps them.
  std::unique_ptr<FinestBoxErrors<3>> finest3_;
  std::unique_ptr<FinestBoxErrors<4>> finest4_;
  std::unique_ptr<std::atomic<uint8_t>[]> raw_state_;  // raw blocks: 1 checked, 2 bad
  std::unique_ptr<std::atomic<uint8_t>[]> touched_;    // blocks then bricks: 1 asked for
  mutable std::atomic<uint64_t> decoded_{0};
  mutable std::atomic<uint64_t> raw_checked_{0};
  mutable std::atomic<uint64_t> distinct_{0};
  mutable std::atomic<uint64_t> boxes_{0};
  mutable std::atomic<uint64_t> finest_computed_{0};
  mutable std::atomic<uint64_t> bricks_read_{0};
};

// Coarse reads (storage/dense/dense_lattice.cc): the field at the points lo +
// i * 2^s (per axis, up to hi inclusive) into out, x fastest: ((hi[a] -
// lo[a]) >> s) + 1 points per axis, read from lattice s's bricks alone
// (storage/dense/field_bricks.h), so a read at a quarter of the resolution
// decodes 1/64 of the field's voxels (1/256 in the HP) instead of asking
// for each point in turn.
// REQUIRES: `out` holds that many doubles; lo[a] a multiple of 2^s,
// 0 <= lo[a] <= hi[a] < dims[a] on the used axes (checked: InvalidArgument).
// Thread safety: as DenseStore's; nothing is kept after the call.
// Errors: those of DenseStore::Brick (Corruption naming the brick,
// ResourceExhausted); InvalidArgument for a box or lattice out of range.
// O(points + the voxels of the bricks the box meets).
Status ReadLattice(const DenseStore& store, int s, const std::array<int64_t, 4>& lo,
                   const std::array<int64_t, 4>& hi, double* out);

}  // namespace simplexdb
