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
    s->in_memory_ = true;
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

Result<std::span<const uint8_t>> DenseStore::StoredBytes(const DenseIndexEntry& e,
                                                         const std::string& what) const {
  // Checked at open; checked again, as the file may have changed since.
  const std::span<const uint8_t> file = file_->bytes();
  if (e.offset > file.size() || e.stored_size > file.size() - e.offset) {
    SDB_RETURN_IF_ERROR(file_->CheckUnchanged());
    return Status::Corruption(path_ + ": " + what + ": its bytes lie past the end of the file");
  }
  return file.subspan(e.offset, e.stored_size);
}

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::DecodeBlock(uint64_t i) const {
  const DenseIndexEntry e = entry(i);
  SDB_ASSIGN_OR_RETURN(const std::span<const uint8_t> stored, StoredBytes(e, Describe(i)));
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
    SDB_ASSIGN_OR_RETURN(const std::span<const uint8_t> raw, StoredBytes(e, Describe(i)));
    const uint8_t* data = raw.data();
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
  SDB_ASSIGN_OR_RETURN(const std::span<const uint8_t> stored, StoredBytes(e, DescribeBrick(b)));
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

double DenseStore::VoxelAt(const uint8_t* brick, size_t slot) const {
  return ReadVoxel(header_.voxel_type, brick + slot * voxel_size_);
}

}  // namespace simplexdb
