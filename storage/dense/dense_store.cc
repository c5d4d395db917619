#include "storage/dense/dense_store.h"

#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <chrono>
#include <limits>
#include <thread>

#include "storage/dense/brick_codec.h"
#include "storage/error/quantize.h"
#include "storage/common/parallel_run.h"
#include "storage/io/checksum.h"
#include "storage/io/codec.h"
#include "util/little_endian.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

ZstdDecompressor& ThreadDecompressor() {
  thread_local ZstdDecompressor d;
  return d;
}

double ReadVoxel(VoxelType type, const uint8_t* p) {
  switch (type) {
    case VoxelType::kU8: return p[0];
    case VoxelType::kI8: return static_cast<int8_t>(p[0]);
    case VoxelType::kU16: return LoadLittle<uint16_t>(p);
    case VoxelType::kI16: return static_cast<int16_t>(LoadLittle<uint16_t>(p));
    case VoxelType::kF32: return LoadLittle<float>(p);
    case VoxelType::kF64: return LoadLittle<double>(p);
  }
  return 0;
}

// Copies a short row of voxels (a brick's part of a window row: a few to
// a few dozen bytes) with fixed-size moves: no call per row.
inline void CopyRow(uint8_t* to, const uint8_t* from, size_t n) {
  if (n >= 8) {
    for (size_t i = 0; i + 8 < n; i += 8) std::memcpy(to + i, from + i, 8);
    std::memcpy(to + n - 8, from + n - 8, 8);  // the last 8, overlapping
    return;
  }
  if (n & 4) std::memcpy(to, from, 4);
  if (n & 2) std::memcpy(to + (n & 4), from + (n & 4), 2);
  if (n & 1) to[n - 1] = from[n - 1];
}

DenseStore::BlockHandle HandleOf(std::shared_ptr<const BlockCache::Block> block) {
  const uint8_t* data = block->data();
  return DenseStore::BlockHandle{data, std::move(block)};
}

}  // namespace

DenseStore::~DenseStore() {
  if (cache_ && cache_.use_count() > 1) cache_->EraseStore(cache_store_id_);
}

Result<std::unique_ptr<DenseStore>> DenseStore::Open(const std::string& path, const Options& options) {
  std::unique_ptr<DenseStore> s(new DenseStore());
  s->path_ = path;
  SDB_ASSIGN_OR_RETURN(s->file_, MappedFile::Open(path));
  const std::span<const uint8_t> bytes = s->file_->bytes();
  SDB_ASSIGN_OR_RETURN(s->header_, ParseDenseHeader(bytes, path));
  const DenseHeader& h = s->header_;
  if (bytes.size() != h.file_size) {
    return Status::Corruption(path + ": the file is " + std::to_string(bytes.size()) +
                              " bytes; its header says " + std::to_string(h.file_size) +
                              (bytes.size() < h.file_size ? " (truncated)" : ""));
  }
  s->grid_ = std::make_unique<BrickGrid>(h.dimension, h.dims, h.domain_bits, h.brick_bits);
  if (s->grid_->bricks() != h.bricks) {
    return Status::Corruption(path + ": header: " + std::to_string(h.bricks) +
                              " bricks, expected " + std::to_string(s->grid_->bricks()));
  }
  s->quantizer_ = ErrorQuantizer(h.quantization, h.quantum, h.field_max - h.field_min);
  s->error_size_ = QuantizedSize(h.quantization);
  s->voxel_size_ = VoxelSize(h.voxel_type);
  SDB_RETURN_IF_ERROR(s->ValidateBitmapAndIndexes());
  s->raw_state_ = std::make_unique<std::atomic<uint8_t>[]>(h.stored_blocks);
  s->touched_ = std::make_unique<std::atomic<uint8_t>[]>(h.stored_blocks + h.bricks);
  if (!h.finest_stored()) {
    const int64_t box = (int64_t{1} << h.brick_bits) + 2;
    if (h.dimension == 3) {
      s->finest3_ = std::make_unique<FinestBoxErrors<3>>(box);
    } else {
      s->finest4_ = std::make_unique<FinestBoxErrors<4>>(box);
    }
  }
  if (options.in_memory) {
    SDB_RETURN_IF_ERROR(s->LoadAll(options.threads));
    // Whatever else is computed (Verify's boxes) is kept.
    s->cache_ = std::make_shared<BlockCache>(std::numeric_limits<size_t>::max() / 4, 1);
  } else if (options.cache) {
    s->cache_ = options.cache;
  } else {
    // Few shards for a small budget, so that one shard holds a block.
    const size_t largest = std::max(s->block_bytes(), 4 * s->grid_->brick_voxels());
    const int shards =
        static_cast<int>(std::clamp<size_t>(options.cache_bytes / (4 * largest + 1), 1, 16));
    s->cache_ = std::make_shared<BlockCache>(options.cache_bytes, shards);
  }
  s->cache_store_id_ = BlockCache::NewStoreId();
  return s;
}

Status DenseStore::ValidateBitmapAndIndexes() {
  const DenseHeader& h = header_;
  const auto corrupt = [&](const std::string& why) {
    return Status::Corruption(path_ + ": " + why);
  };
  const std::span<const uint8_t> bytes = file_->bytes();
  const std::span<const uint8_t> bitmap = bytes.subspan(h.bitmap_offset, 8 * h.bitmap_words());
  if (Checksum(bitmap) != h.bitmap_checksum) return corrupt("block bitmap: checksum mismatch");
  bitmap_ = bitmap.data();
  try {
    rank_.resize(h.bitmap_words());
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the block bitmap's rank directory", 8 * h.bitmap_words());
  }
  uint64_t count = 0;
  for (uint64_t w = 0; w < h.bitmap_words(); ++w) {
    rank_[w] = count;
    uint64_t word = LoadLittle<uint64_t>(bitmap_ + 8 * w);
    if (w + 1 == h.bitmap_words() && h.virtual_blocks % 64 != 0 &&
        (word >> (h.virtual_blocks % 64)) != 0) {
      return corrupt("block bitmap: bits set past the last block");
    }
    count += static_cast<uint64_t>(std::popcount(word));
  }
  if (count != h.stored_blocks) {
    return corrupt("block bitmap: " + std::to_string(count) + " blocks marked, the header says " +
                   std::to_string(h.stored_blocks));
  }
  if ((LoadLittle<uint64_t>(bitmap_) & 1) == 0) return corrupt("block bitmap: block 0 is not stored");
  const std::span<const uint8_t> index =
      bytes.subspan(h.index_offset, h.stored_blocks * kDenseIndexEntrySize);
  if (Checksum(index) != h.index_checksum) return corrupt("block index: checksum mismatch");
  index_ = index.data();
  const std::span<const uint8_t> brick_index =
      bytes.subspan(h.brick_index_offset, h.bricks * kDenseIndexEntrySize);
  if (Checksum(brick_index) != h.brick_index_checksum) {
    return corrupt("brick index: checksum mismatch");
  }
  brick_index_ = brick_index.data();
  const uint32_t max_code = ErrorQuantizer::MaxCode(h.quantization);
  // What every entry shares: reserved bytes, where its bytes lie, its
  // error maximum.
  const auto check = [&](const uint8_t* e, const auto& bad, size_t decoded, bool raw,
                         bool may_have_error) -> Status {
    bool reserved = false;
    for (int j : {13, 14, 15, 36, 37, 38, 39}) reserved = reserved || e[j] != 0;
    if (reserved) return bad("reserved bytes are set");
    const DenseIndexEntry entry = ParseDenseIndexEntry(e);
    if (raw ? entry.stored_size != decoded
            : (entry.stored_size == 0 || entry.stored_size > ZSTD_compressBound(decoded))) {
      return bad("stored size " + std::to_string(entry.stored_size) + " for " +
                 std::to_string(decoded) + " bytes decoded");
    }
    if (entry.offset < kDenseHeaderSize || entry.offset > h.bitmap_offset ||
        entry.stored_size > h.bitmap_offset - entry.offset) {
      return bad("data outside the block area");
    }
    if (!std::isfinite(entry.field_min) || !std::isfinite(entry.field_max) ||
        !(entry.field_min <= entry.field_max)) {
      return bad("field range is not a finite interval");
    }
    if (!may_have_error && entry.error_max != 0) return bad("an error maximum where none belongs");
    if (h.quantization == Quantization::kF32) {
      float f;
      std::memcpy(&f, &entry.error_max, 4);
      if (!std::isfinite(f) || f < 0) return bad("largest error is not finite and non-negative");
    } else if (entry.error_max > max_code) {
      return bad("largest error code " + std::to_string(entry.error_max) + " past " +
                 std::to_string(max_code));
    }
    return Status::OK();
  };
  for (uint64_t i = 0; i < h.stored_blocks; ++i) {
    const uint8_t* e = index_ + i * kDenseIndexEntrySize;
    const auto bad = [&](const std::string& why) {
      return corrupt("block index: " + Describe(i) + ": " + why);
    };
    const uint8_t encoding = e[12];
    if (encoding != static_cast<uint8_t>(BlockEncoding::kRaw) &&
        encoding != static_cast<uint8_t>(BlockEncoding::kZstd)) {
      return bad("unknown encoding " + std::to_string(encoding));
    }
    SDB_RETURN_IF_ERROR(check(e, bad, block_bytes(),
                              encoding == static_cast<uint8_t>(BlockEncoding::kRaw), true));
  }
  for (uint64_t b = 0; b < h.bricks; ++b) {
    const uint8_t* e = brick_index_ + b * kDenseIndexEntrySize;
    const auto bad = [&](const std::string& why) {
      return corrupt("brick index: " + DescribeBrick(b) + ": " + why);
    };
    const uint8_t coding = e[12];
    if (coding < static_cast<uint8_t>(BrickCoding::kRaw) ||
        coding > static_cast<uint8_t>(BrickCoding::kZstdPredicted)) {
      return bad("unknown coding " + std::to_string(coding));
    }
    const BrickPlace place = grid_->Place(b);
    SDB_RETURN_IF_ERROR(check(e, bad, BrickVoxels(h.dimension, place.extent) * voxel_size_,
                              coding == static_cast<uint8_t>(BrickCoding::kRaw),
                              place.lattice == 0 && !h.finest_stored()));
  }
  return Status::OK();
}

std::optional<uint64_t> DenseStore::StoredIndex(uint64_t vblock) const {
  if (vblock >= header_.virtual_blocks) return std::nullopt;
  const uint64_t word = LoadLittle<uint64_t>(bitmap_ + 8 * (vblock >> 6));
  const uint64_t bit = uint64_t{1} << (vblock & 63);
  if ((word & bit) == 0) return std::nullopt;
  return rank_[vblock >> 6] + static_cast<uint64_t>(std::popcount(word & (bit - 1)));
}

uint64_t DenseStore::VirtualBlock(uint64_t stored) const {
  // The last word whose rank is at most `stored`, then the bit within it.
  const uint64_t w = static_cast<uint64_t>(
      std::upper_bound(rank_.begin(), rank_.end(), stored) - rank_.begin() - 1);
  uint64_t word = LoadLittle<uint64_t>(bitmap_ + 8 * w);
  for (uint64_t skip = stored - rank_[w]; skip > 0; --skip) word &= word - 1;
  return 64 * w + static_cast<uint64_t>(std::countr_zero(word));
}

std::string DenseStore::DescribeBlock(uint64_t vblock) const {
  const uint64_t first = vblock << header_.block_bits;
  const uint64_t last = first + header_.block_records() - 1;
  const std::string positions =
      "positions " + std::to_string(first) + ".." + std::to_string(last);
  const int d = header_.dimension;
  const int top_bit = first == 0 ? 0 : 63 - std::countl_zero(first);
  const int octave = top_bit / d - 1;
  if (vblock == 0 || octave < 0) {
    return "block 0 (the corners and the coarsest levels, " + positions + ")";
  }
  if ((uint64_t{1} << (d * (octave + 1))) < header_.block_records()) {
    return "block " + std::to_string(vblock) + " (several levels of octave " +
           std::to_string(octave) + ", " + positions + ")";
  }
  const uint64_t segment = (first >> (d * (octave + 1))) - 1;
  const uint32_t mask = d == 3 ? internal::kOddPatterns<3>.mask_of[segment]
                               : internal::kOddPatterns<4>.mask_of[segment];
  std::string odd;
  for (int a = 0; a < d; ++a) odd.push_back((mask >> a & 1) ? '1' : '0');
  const int level = d * octave + (d - std::popcount(mask));
  return "block " + std::to_string(vblock) + " (level " + std::to_string(level) +
         ", odd axes " + odd + ", " + positions + ")";
}

std::string DenseStore::DescribeBrick(uint64_t b) const {
  const BrickPlace place = grid_->Place(b);
  std::string from;
  for (int a = 0; a < header_.dimension; ++a) {
    from += (a == 0 ? "(" : ", ") + std::to_string(place.first[a]);
  }
  const std::string which = place.lattice == 0
                                ? "the grid"
                                : "the points at multiples of " +
                                      std::to_string(int64_t{1} << place.lattice);
  return "brick " + std::to_string(b) + " (" + which + ", from " + from + "))";
}

void DenseStore::Touch(uint64_t i) const {
  if (touched_[i].load(std::memory_order_relaxed) == 0 &&
      touched_[i].exchange(1, std::memory_order_relaxed) == 0) {
    distinct_.fetch_add(1, std::memory_order_relaxed);
  }
}

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::DecodeBlock(uint64_t i) const {
  const DenseIndexEntry e = entry(i);
  const std::span<const uint8_t> stored = file_->bytes().subspan(e.offset, e.stored_size);
  if (Checksum(stored) != e.checksum) {
    return Status::Corruption(path_ + ": " + Describe(i) + ": checksum mismatch");
  }
  std::shared_ptr<BlockCache::Block> block;
  try {
    block = std::make_shared<BlockCache::Block>(block_bytes());
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": " + Describe(i) + " decoded", block_bytes());
  }
  if (e.encoding == static_cast<uint8_t>(BlockEncoding::kRaw)) {
    std::memcpy(block->data(), stored.data(), stored.size());
  } else {
    SDB_RETURN_IF_ERROR(
        ThreadDecompressor().Decompress(stored, *block, path_ + ": " + Describe(i)));
    decoded_.fetch_add(1, std::memory_order_relaxed);
  }
  return std::shared_ptr<const BlockCache::Block>(std::move(block));
}

Result<DenseStore::BlockHandle> DenseStore::Block(uint64_t i) const {
  if (i >= header_.stored_blocks) {
    return Status::InvalidArgument(path_ + ": stored block " + std::to_string(i) + " out of range");
  }
  Touch(i);
  if (!resident_.empty()) return BlockHandle{resident_[i]->data(), nullptr};
  const DenseIndexEntry e = entry(i);
  if (e.encoding == static_cast<uint8_t>(BlockEncoding::kRaw)) {
    const uint8_t* data = file_->bytes().data() + e.offset;
    uint8_t state = raw_state_[i].load(std::memory_order_acquire);
    if (state == 0) {
      state = Checksum(std::span<const uint8_t>(data, e.stored_size)) == e.checksum ? 1 : 2;
      raw_state_[i].store(state, std::memory_order_release);
      raw_checked_.fetch_add(1, std::memory_order_relaxed);
    }
    if (state == 2) return Status::Corruption(path_ + ": " + Describe(i) + ": checksum mismatch");
    return BlockHandle{data, nullptr};
  }
  const BlockCache::Key key{cache_store_id_, i};
  if (auto hit = cache_->Lookup(key)) return HandleOf(std::move(hit));
  SDB_ASSIGN_OR_RETURN(auto fresh, DecodeBlock(i));
  return HandleOf(cache_->Insert(key, std::move(fresh)));
}

Status DenseStore::LoadAll(int threads) {
  const uint64_t finest = header_.finest_stored() ? 0 : grid_->Count(0);
  const uint64_t total = header_.stored_blocks * block_bytes() + header_.bricks * brick_bytes() +
                         error_size_ * finest * grid_->brick_voxels();
  const std::string all = "all " + std::to_string(header_.stored_blocks) + " blocks and " +
                          std::to_string(header_.bricks) + " bricks of " + path_ +
                          " decoded in memory, with the finest errors";
  try {
    resident_.resize(header_.stored_blocks);
    resident_bricks_.resize(header_.bricks);
    resident_finest_.resize(finest);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(all, total);
  }
  // A decoder's or the cache's allocation failing names the whole (the
  // message's own allocation failing is RunParallel's to report).
  const auto keep = [&](const auto& decode, std::shared_ptr<const BlockCache::Block>& to) -> Status {
    try {
      Result<std::shared_ptr<const BlockCache::Block>> decoded = decode();
      if (!decoded.ok()) {
        if (decoded.status().code() == Status::Code::kResourceExhausted) {
          return NotEnoughMemory(all, total);
        }
        return decoded.status();
      }
      to = *std::move(decoded);
      return Status::OK();
    } catch (const std::bad_alloc&) {
      return NotEnoughMemory(all, total);
    }
  };
  if (threads <= 0) threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const auto start = std::chrono::steady_clock::now();
  // The field first: the finest errors are computed from it.
  SDB_RETURN_IF_ERROR(RunParallel(
      header_.stored_blocks + header_.bricks, threads, "decode", start, {},
      [&](int, uint64_t i) -> Status {
        if (i < header_.stored_blocks) return keep([&] { return DecodeBlock(i); }, resident_[i]);
        const uint64_t b = i - header_.stored_blocks;
        return keep([&] { return DecodeBrickAt(b); }, resident_bricks_[b]);
      }));
  // The finest errors of every grid brick whose recorded maximum is not 0
  // (a reader asks for no other: FinestCode answers 0 from the index).
  return RunParallel(finest, threads, "finest", start, {}, [&](int, uint64_t i) -> Status {
    const uint64_t b = grid_->FirstBrick(0) + i;
    if (brick_entry(b).error_max == 0) return Status::OK();
    return keep([&] { return ComputeFinest(b); }, resident_finest_[i]);
  });
}

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::DecodeBrickAt(uint64_t b) const {
  const DenseIndexEntry e = brick_entry(b);
  const std::span<const uint8_t> stored = file_->bytes().subspan(e.offset, e.stored_size);
  if (Checksum(stored) != e.checksum) {
    return Status::Corruption(path_ + ": " + DescribeBrick(b) + ": checksum mismatch");
  }
  const BrickPlace place = grid_->Place(b);
  const size_t bytes = BrickVoxels(header_.dimension, place.extent) * voxel_size_;
  std::shared_ptr<BlockCache::Block> brick;
  try {
    brick = std::make_shared<BlockCache::Block>(bytes);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": " + DescribeBrick(b) + " decoded", bytes);
  }
  const auto coding = static_cast<BrickCoding>(e.encoding);
  SDB_RETURN_IF_ERROR(DecodeBrick(stored, coding, header_.voxel_type, header_.dimension,
                                  place.extent, ThreadDecompressor(), *brick,
                                  path_ + ": " + DescribeBrick(b)));
  (coding == BrickCoding::kRaw ? raw_checked_ : decoded_).fetch_add(1, std::memory_order_relaxed);
  bricks_read_.fetch_add(1, std::memory_order_relaxed);
  return std::shared_ptr<const BlockCache::Block>(std::move(brick));
}

Result<DenseStore::BlockHandle> DenseStore::Brick(uint64_t b) const {
  if (b >= header_.bricks) {
    return Status::InvalidArgument(path_ + ": brick " + std::to_string(b) + " out of range");
  }
  Touch(header_.stored_blocks + b);
  if (!resident_bricks_.empty()) return BlockHandle{resident_bricks_[b]->data(), nullptr};
  const BlockCache::Key key{cache_store_id_, header_.stored_blocks + b};
  if (auto hit = cache_->Lookup(key)) return HandleOf(std::move(hit));
  SDB_ASSIGN_OR_RETURN(auto fresh, DecodeBrickAt(b));
  return HandleOf(cache_->Insert(key, std::move(fresh)));
}

Result<DenseStore::BlockHandle> DenseStore::FinestCodes(uint64_t b) const {
  if (!resident_finest_.empty()) {
    const auto& codes = resident_finest_[b - grid_->FirstBrick(0)];
    if (codes != nullptr) return BlockHandle{codes->data(), nullptr};
  }
  const BlockCache::Key key{cache_store_id_, header_.stored_blocks + header_.bricks + b};
  std::shared_ptr<const BlockCache::Block> box = cache_->Lookup(key);
  if (box == nullptr) {
    SDB_ASSIGN_OR_RETURN(auto fresh, MakeLazyFinest(b));
    box = cache_->Insert(key, std::move(fresh));
  }
  BlockHandle handle = HandleOf(std::move(box));
  handle.lazy = true;
  return handle;
}

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::MakeLazyFinest(uint64_t b) const {
  const FinestTiles tiles(header_.dimension, grid_->FinestBox(b));
  const size_t bytes = error_size_ * tiles.slots + (tiles.slots + 7) / 8;
  try {
    boxes_.fetch_add(1, std::memory_order_relaxed);
    return std::shared_ptr<const BlockCache::Block>(
        std::make_shared<BlockCache::Block>(bytes));  // nothing computed
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the finest errors of " + DescribeBrick(b), bytes);
  }
}

Status DenseStore::GatherFinestWindow(uint64_t b, std::vector<uint8_t>& window) const {
  static_assert(std::endian::native == std::endian::little, "bricks hold little-endian voxels");
  const int d = header_.dimension;
  const BrickGrid::Box box = grid_->FinestBox(b);
  const int64_t w = d == 3 ? finest3_->window_side() : finest4_->window_side();
  uint64_t window_points = 1;
  std::array<int64_t, 4> lo{}, hi{};
  for (int a = 0; a < d; ++a) {
    window_points *= static_cast<uint64_t>(w);
    // The window's real points.
    lo[a] = std::max<int64_t>(0, box.first[a] - 2);
    hi[a] = std::min<int64_t>(header_.dims[a] - 1, box.first[a] - 2 + w - 1);
  }
  try {
    window.assign(window_points * voxel_size_, 0);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the field around " + DescribeBrick(b), window_points * voxel_size_);
  }
  // Brick by brick (lattice 0: every point), a row segment at a time,
  // voxels copied as they are.
  std::array<int64_t, 4> corner = lo;  // the first point of a brick's part
  while (true) {
    size_t first_slot = 0;
    const uint64_t at = grid_->BrickOf(0, corner, &first_slot);
    SDB_ASSIGN_OR_RETURN(const BlockHandle brick, Brick(at));
    const BrickPlace place = grid_->Place(at);
    std::array<int64_t, 4> end{}, stride{};  // the part's last point; the brick's strides
    int64_t n = 1;
    for (int a = 0; a < d; ++a) {
      end[a] = std::min(hi[a], place.first[a] + place.extent[a] - 1);
      stride[a] = n;
      n *= place.extent[a];
    }
    const size_t run = static_cast<size_t>(end[0] - corner[0] + 1) * voxel_size_;
    std::array<int64_t, 4> q = corner;
    while (true) {
      size_t from = 0, to = 0, scale = 1;
      for (int a = 0; a < d; ++a) {
        from += static_cast<size_t>((q[a] - place.first[a]) * stride[a]);
        to += static_cast<size_t>(q[a] - box.first[a] + 2) * scale;
        scale *= static_cast<size_t>(w);
      }
      CopyRow(window.data() + to * voxel_size_, brick.data + from * voxel_size_, run);
      int a = 1;
      for (; a < d; ++a) {
        if (++q[a] <= end[a]) break;
        q[a] = corner[a];
      }
      if (a == d) break;
    }
    // The next brick's part, x first (bricks are aligned: a row of them
    // shares its extent on the other axes).
    int a = 0;
    for (; a < d; ++a) {
      corner[a] = end[a] + 1;
      if (corner[a] <= hi[a]) break;
      corner[a] = lo[a];
    }
    if (a == d) break;
  }
  return Status::OK();
}

uint32_t DenseStore::LazyCodeRef(const BlockHandle& box, int64_t slot) const {
  uint8_t* data = const_cast<uint8_t*>(box.data);
  switch (header_.quantization) {
    case Quantization::kU8:
      return std::atomic_ref<uint8_t>(data[slot]).load(std::memory_order_relaxed);
    case Quantization::kU16:
      return std::atomic_ref<uint16_t>(reinterpret_cast<uint16_t*>(data)[slot]).load(std::memory_order_relaxed);
    case Quantization::kF32:
      break;
  }
  return std::atomic_ref<uint32_t>(reinterpret_cast<uint32_t*>(data)[slot]).load(std::memory_order_relaxed);
}

void DenseStore::SetLazyCode(const BlockHandle& box, int64_t slot, uint32_t code) const {
  uint8_t* data = const_cast<uint8_t*>(box.data);
  switch (header_.quantization) {
    case Quantization::kU8:
      std::atomic_ref<uint8_t>(data[slot]).store(static_cast<uint8_t>(code), std::memory_order_relaxed);
      return;
    case Quantization::kU16:
      std::atomic_ref<uint16_t>(reinterpret_cast<uint16_t*>(data)[slot])
          .store(static_cast<uint16_t>(code), std::memory_order_relaxed);
      return;
    case Quantization::kF32:
      std::atomic_ref<uint32_t>(reinterpret_cast<uint32_t*>(data)[slot]).store(code, std::memory_order_relaxed);
      return;
  }
}

template <size_t N>
uint32_t DenseStore::ComputeLazyCode(const BlockHandle& box, const FinestTiles& tiles,
                                     const std::array<int64_t, N>& g, int64_t slot,
                                     const uint8_t* window) const {
  constexpr int D = static_cast<int>(N);
  std::array<int64_t, D> first{}, dims{};
  for (int a = 0; a < D; ++a) {
    first[a] = tiles.first[a];
    dims[a] = header_.dims[a];
  }
  const double e = WithVoxelCppType(header_.voxel_type, [&](auto voxel) {
    using V = decltype(voxel);
    const V* values = reinterpret_cast<const V*>(window);
    if constexpr (D == 3) {
      return finest3_->ErrorAt(g, first, header_.domain_bits, dims, values);
    } else {
      return finest4_->ErrorAt(g, first, header_.domain_bits, dims, values);
    }
  });
  finest_computed_.fetch_add(1, std::memory_order_relaxed);
  // As the writer coded the builder's errors (rounded up to float first).
  const uint32_t code = quantizer_.Encode(static_cast<double>(RoundUpToFloat(e)));
  SetLazyCode(box, slot, code);
  LazyBits(box, tiles)[slot >> 3].fetch_or(static_cast<uint8_t>(1u << (slot & 7)), std::memory_order_release);
  return code;
}

template uint32_t DenseStore::ComputeLazyCode(const BlockHandle&, const FinestTiles&,
                                              const std::array<int64_t, 3>&, int64_t, const uint8_t*) const;
template uint32_t DenseStore::ComputeLazyCode(const BlockHandle&, const FinestTiles&,
                                              const std::array<int64_t, 4>&, int64_t, const uint8_t*) const;

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::ComputeFinest(uint64_t b) const {
  return header_.dimension == 3 ? ComputeFinestOf<3>(b) : ComputeFinestOf<4>(b);
}

template <int D>
Result<std::shared_ptr<const BlockCache::Block>> DenseStore::ComputeFinestOf(uint64_t b) const {
  const FinestBoxErrors<D>& finest = [&]() -> const FinestBoxErrors<D>& {
    if constexpr (D == 3) {
      return *finest3_;
    } else {
      return *finest4_;
    }
  }();
  const BrickGrid::Box box = grid_->FinestBox(b);
  const FinestTiles tiles(D, box);
  const int64_t w = finest.window_side();
  std::array<int64_t, D> first{}, extent{}, dims{};
  std::array<int64_t, 4> lo{}, hi{};
  uint64_t points = 1, real_points = 1;
  for (int a = 0; a < D; ++a) {
    first[a] = box.first[a];
    extent[a] = box.extent[a];
    dims[a] = header_.dims[a];
    points *= static_cast<uint64_t>(extent[a]);
    // The window's real points.
    lo[a] = std::max<int64_t>(0, first[a] - 2);
    hi[a] = std::min<int64_t>(dims[a] - 1, first[a] - 2 + w - 1);
    real_points *= static_cast<uint64_t>(hi[a] - lo[a] + 1);
  }
  std::vector<double> window, real;
  std::shared_ptr<BlockCache::Block> codes;
  try {
    window.assign(finest.window_points(), 0.0);
    real.resize(real_points);
    codes = std::make_shared<BlockCache::Block>(error_size_ * tiles.slots);  // zeros
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the finest errors of " + DescribeBrick(b), 8 * finest.window_points());
  }
  // Read from the grid's bricks, then placed in the window row by row.
  SDB_RETURN_IF_ERROR(ReadLattice(*this, 0, lo, hi, real.data()));
  const int64_t row = hi[0] - lo[0] + 1;
  std::array<int64_t, 4> q = lo;
  for (const double* from = real.data();; from += row) {
    size_t at = 0, scale = 1;
    for (int a = 0; a < D; ++a) {
      at += static_cast<size_t>(q[a] - first[a] + 2) * scale;
      scale *= static_cast<size_t>(w);
    }
    std::copy(from, from + row, window.begin() + static_cast<std::ptrdiff_t>(at));
    int a = 1;
    for (; a < D; ++a) {
      if (++q[a] <= hi[a]) break;
      q[a] = lo[a];
    }
    if (a == D) break;
  }
  std::vector<double> errors(points);
  finest.Compute(first, extent, header_.domain_bits, dims, window.data(), errors.data());
  // As the writer coded the builder's errors (rounded up to float first),
  // in the width of a block's (StoredErrorAt reads them), at their tiles.
  std::array<int64_t, D> g = first;
  for (uint64_t i = 0; i < points; ++i) {
    StoreErrorCode(header_.quantization, codes->data(), static_cast<size_t>(tiles.Slot(g)),
                   quantizer_.Encode(static_cast<double>(RoundUpToFloat(errors[i]))));
    for (int a = 0; a < D; ++a) {
      if (++g[a] < first[a] + extent[a]) break;
      g[a] = first[a];
    }
  }
  boxes_.fetch_add(1, std::memory_order_relaxed);
  return std::shared_ptr<const BlockCache::Block>(std::move(codes));
}

double DenseStore::VoxelAt(const uint8_t* brick, size_t slot) const {
  return ReadVoxel(header_.voxel_type, brick + slot * voxel_size_);
}

}  // namespace simplexdb
