#include "storage/dense/hz_store.h"

#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

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

HzStore::BlockHandle HandleOf(std::shared_ptr<const BlockCache::Block> block) {
  const uint8_t* data = block->data();
  return HzStore::BlockHandle{data, std::move(block)};
}

}  // namespace

HzStore::~HzStore() {
  if (cache_ && cache_.use_count() > 1) cache_->EraseStore(cache_store_id_);
}

Result<std::unique_ptr<HzStore>> HzStore::Open(const std::string& path, const Options& options) {
  std::unique_ptr<HzStore> s(new HzStore());
  s->path_ = path;
  SDB_ASSIGN_OR_RETURN(s->file_, MappedFile::Open(path));
  const std::span<const uint8_t> bytes = s->file_->bytes();
  SDB_ASSIGN_OR_RETURN(s->header_, ParseHzHeader(bytes, path));
  const HzHeader& h = s->header_;
  if (bytes.size() != h.file_size) {
    return Status::Corruption(path + ": the file is " + std::to_string(bytes.size()) +
                              " bytes; its header says " + std::to_string(h.file_size) +
                              (bytes.size() < h.file_size ? " (truncated)" : ""));
  }
  s->quantizer_ = ErrorQuantizer(h.quantization, h.quantum, h.field_max - h.field_min);
  s->error_size_ = QuantizedSize(h.quantization);
  s->voxel_size_ = VoxelSize(h.voxel_type);
  SDB_RETURN_IF_ERROR(s->ValidateBitmapAndIndex());
  s->raw_state_ = std::make_unique<std::atomic<uint8_t>[]>(h.stored_blocks);
  s->touched_ = std::make_unique<std::atomic<uint8_t>[]>(h.stored_blocks);
  if (options.in_memory) {
    SDB_RETURN_IF_ERROR(s->LoadAll());
  } else {
    if (options.cache) {
      s->cache_ = options.cache;
    } else {
      // Few shards for a small budget, so that one shard holds a block.
      const int shards = static_cast<int>(
          std::clamp<size_t>(options.cache_bytes / (4 * s->block_bytes() + 1), 1, 16));
      s->cache_ = std::make_shared<BlockCache>(options.cache_bytes, shards);
    }
    s->cache_store_id_ = BlockCache::NewStoreId();
  }
  return s;
}

Status HzStore::ValidateBitmapAndIndex() {
  const HzHeader& h = header_;
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
  const std::span<const uint8_t> index =
      bytes.subspan(h.index_offset, h.stored_blocks * kHzIndexEntrySize);
  if (Checksum(index) != h.index_checksum) return corrupt("block index: checksum mismatch");
  index_ = index.data();
  const size_t raw = block_bytes();
  const uint32_t max_code = ErrorQuantizer::MaxCode(h.quantization);
  for (uint64_t i = 0; i < h.stored_blocks; ++i) {
    const uint8_t* e = index_ + i * kHzIndexEntrySize;
    const auto bad = [&](const std::string& why) {
      return corrupt("block index: " + Describe(i) + ": " + why);
    };
    bool reserved = false;
    for (int j : {13, 14, 15, 36, 37, 38, 39}) reserved = reserved || e[j] != 0;
    if (reserved) return bad("reserved bytes are set");
    const HzIndexEntry entry = ParseHzIndexEntry(e);
    switch (entry.encoding) {
      case BlockEncoding::kRaw:
        if (entry.stored_size != raw) return bad("raw block of " + std::to_string(entry.stored_size) + " bytes");
        break;
      case BlockEncoding::kZstd:
        if (entry.stored_size == 0 || entry.stored_size > ZSTD_compressBound(raw)) {
          return bad("compressed size " + std::to_string(entry.stored_size));
        }
        break;
      default:
        return bad("unknown encoding " + std::to_string(static_cast<int>(entry.encoding)));
    }
    if (entry.offset < kHzHeaderSize || entry.offset > h.bitmap_offset ||
        entry.stored_size > h.bitmap_offset - entry.offset) {
      return bad("data outside the block area");
    }
    if (!std::isfinite(entry.field_min) || !std::isfinite(entry.field_max) ||
        !(entry.field_min <= entry.field_max)) {
      return bad("field range is not a finite interval");
    }
    if (h.quantization == Quantization::kF32) {
      float f;
      std::memcpy(&f, &entry.error_max, 4);
      if (!std::isfinite(f) || f < 0) return bad("largest error is not finite and non-negative");
    } else if (entry.error_max > max_code) {
      return bad("largest error code " + std::to_string(entry.error_max) + " past " +
                 std::to_string(max_code));
    }
  }
  return Status::OK();
}

std::optional<uint64_t> HzStore::StoredIndex(uint64_t vblock) const {
  if (vblock >= header_.virtual_blocks) return std::nullopt;
  const uint64_t word = LoadLittle<uint64_t>(bitmap_ + 8 * (vblock >> 6));
  const uint64_t bit = uint64_t{1} << (vblock & 63);
  if ((word & bit) == 0) return std::nullopt;
  return rank_[vblock >> 6] + static_cast<uint64_t>(std::popcount(word & (bit - 1)));
}

uint64_t HzStore::VirtualBlock(uint64_t stored) const {
  // The last word whose rank is at most `stored`, then the bit within it.
  const uint64_t w = static_cast<uint64_t>(
      std::upper_bound(rank_.begin(), rank_.end(), stored) - rank_.begin() - 1);
  uint64_t word = LoadLittle<uint64_t>(bitmap_ + 8 * w);
  for (uint64_t skip = stored - rank_[w]; skip > 0; --skip) word &= word - 1;
  return 64 * w + static_cast<uint64_t>(std::countr_zero(word));
}

std::string HzStore::DescribeBlock(uint64_t vblock) const {
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

Result<std::shared_ptr<const BlockCache::Block>> HzStore::DecodeBlock(uint64_t i) const {
  const HzIndexEntry e = entry(i);
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
  if (e.encoding == BlockEncoding::kRaw) {
    std::memcpy(block->data(), stored.data(), stored.size());
  } else {
    SDB_RETURN_IF_ERROR(
        ThreadDecompressor().Decompress(stored, *block, path_ + ": " + Describe(i)));
    decoded_.fetch_add(1, std::memory_order_relaxed);
  }
  return std::shared_ptr<const BlockCache::Block>(std::move(block));
}

Result<HzStore::BlockHandle> HzStore::Block(uint64_t i) const {
  if (i >= header_.stored_blocks) {
    return Status::InvalidArgument(path_ + ": stored block " + std::to_string(i) + " out of range");
  }
  if (touched_[i].load(std::memory_order_relaxed) == 0 &&
      touched_[i].exchange(1, std::memory_order_relaxed) == 0) {
    distinct_.fetch_add(1, std::memory_order_relaxed);
  }
  if (!resident_.empty()) return BlockHandle{resident_[i]->data(), nullptr};
  const HzIndexEntry e = entry(i);
  if (e.encoding == BlockEncoding::kRaw) {
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

Status HzStore::LoadAll() {
  const uint64_t total = header_.stored_blocks * block_bytes();
  const std::string all = "all " + std::to_string(header_.stored_blocks) + " blocks of " + path_ +
                          " decoded in memory";
  try {
    resident_.resize(header_.stored_blocks);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(all, total);
  }
  for (uint64_t i = 0; i < header_.stored_blocks; ++i) {
    Result<std::shared_ptr<const BlockCache::Block>> block = DecodeBlock(i);
    if (!block.ok()) {
      if (block.status().code() == Status::Code::kResourceExhausted) return NotEnoughMemory(all, total);
      return block.status();
    }
    resident_[i] = *std::move(block);
  }
  return Status::OK();
}

uint32_t HzStore::StoredErrorAt(const uint8_t* block, uint32_t slot) const {
  switch (header_.quantization) {
    case Quantization::kU16: return LoadLittle<uint16_t>(block + 2 * size_t{slot});
    case Quantization::kU8: return block[slot];
    case Quantization::kF32: return LoadLittle<uint32_t>(block + 4 * size_t{slot});
  }
  return 0;
}

double HzStore::FieldAt(const uint8_t* block, uint32_t slot) const {
  return ReadVoxel(header_.voxel_type, block + error_bytes() + size_t{slot} * voxel_size_);
}

Status HzStore::Verify(const std::function<void(uint64_t, uint64_t)>& progress) const {
  const uint64_t total = header_.stored_blocks;
  const uint32_t n = static_cast<uint32_t>(header_.block_records());
  const int d = header_.dimension;
  const auto check = [&](const auto& order) -> Status {
    for (uint64_t i = 0; i < total; ++i) {
      if (progress && i % 256 == 0) progress(i, total);
      const HzIndexEntry e = entry(i);
      // The stored bytes, even when the block is cached or resident.
      if (Checksum(file_->bytes().subspan(e.offset, e.stored_size)) != e.checksum) {
        return Status::Corruption(path_ + ": " + Describe(i) + ": checksum mismatch");
      }
      SDB_ASSIGN_OR_RETURN(const BlockHandle h, Block(i));
      const auto bad = [&](const std::string& why) {
        return Status::Corruption(path_ + ": " + Describe(i) + ": " + why);
      };
      const uint64_t first = VirtualBlock(i) << header_.block_bits;
      uint32_t largest = 0;
      for (uint32_t slot = 0; slot < n; ++slot) {
        const uint32_t code = StoredErrorAt(h.data, slot);
        const double v = quantizer_.Decode(code);
        if (!std::isfinite(v) || v < 0) {
          return bad("error entry " + std::to_string(slot) + " is " + std::to_string(v));
        }
        largest = std::max(largest, code);  // f32 bits of non-negative floats order as the floats
        typename std::decay_t<decltype(order)>::GridPoint g{};
        const uint64_t p = first + slot;
        const bool real = p < order.size() && order.Decode(p, g) && [&] {
          for (int a = 0; a < d; ++a) {
            if (g[a] >= header_.dims[a]) return false;
          }
          return true;
        }();
        const double f = FieldAt(h.data, slot);
        if (!real) {
          if (f != 0) return bad("field entry " + std::to_string(slot) + " off the grid is " + std::to_string(f));
          continue;
        }
        if (std::isnan(f)) continue;  // a missing value
        if (!(f >= e.field_min && f <= e.field_max && f >= header_.field_min &&
              f <= header_.field_max)) {
          return bad("field entry " + std::to_string(slot) + " is " + std::to_string(f) +
                     ", outside the recorded range");
        }
      }
      if (largest > e.error_max) {
        return bad("holds an error of " + std::to_string(quantizer_.Decode(largest)) +
                   " above its recorded maximum " + std::to_string(quantizer_.Decode(e.error_max)));
      }
    }
    return Status::OK();
  };
  SDB_RETURN_IF_ERROR(d == 3 ? check(HzOrder<3>(header_.domain_bits))
                             : check(HzOrder<4>(header_.domain_bits)));
  if (progress) progress(total, total);
  return Status::OK();
}

template <int D>
HzStore::Reader<D>::Reader(const HzStore& store)
    : store_(store), order_(store.header().domain_bits) {}

template <int D>
Status HzStore::Reader<D>::Hold(Held& held, uint64_t vblock) {
  const std::optional<uint64_t> stored = store_.StoredIndex(vblock);
  held.vblock = vblock;
  held.stored = stored.has_value();
  held.handle = BlockHandle{};
  held.skipped = false;
  if (!stored) return Status::OK();
  ++block_fetches_;
  Result<BlockHandle> h = store_.Block(*stored);
  if (!h.ok()) {
    held.vblock = ~uint64_t{0};
    return h.status();
  }
  held.handle = *std::move(h);
  return Status::OK();
}

template <int D>
Result<uint32_t> HzStore::Reader<D>::StoredError(SimplexCode<D> code) {
  if (code.level() >= order_.levels()) return 0u;
  const uint64_t p = PositionOf(code);
  const uint64_t vblock = p >> store_.header().block_bits;
  Held& held = HeldFor(p);
  if (vblock != held.vblock || held.skipped) SDB_RETURN_IF_ERROR(Hold(held, vblock));
  if (!held.stored) return 0u;
  return store_.StoredErrorAt(held.handle.data,
                              static_cast<uint32_t>(p & (store_.header().block_records() - 1)));
}

template <int D>
Result<double> HzStore::Reader<D>::ErrorBound(SimplexCode<D> code) {
  SDB_ASSIGN_OR_RETURN(const uint32_t stored, StoredError(code));
  return store_.quantizer().Decode(stored);
}

template <int D>
Result<double> HzStore::Reader<D>::ErrorBoundForThresholdAt(SimplexCode<D> code, uint64_t p,
                                                            double threshold) {
  if (code.level() >= order_.levels()) return 0.0;
  const uint64_t vblock = p >> store_.header().block_bits;
  Held& held = HeldFor(p);
  if (vblock == held.vblock && held.skipped) {
    if (held.skipped_max <= threshold) return held.skipped_max;
    SDB_RETURN_IF_ERROR(Hold(held, vblock));
  } else if (vblock != held.vblock) {
    const std::optional<uint64_t> stored = store_.StoredIndex(vblock);
    if (!stored) {
      SDB_RETURN_IF_ERROR(Hold(held, vblock));  // nothing to read: remember that
      return 0.0;
    }
    const double block_max = store_.quantizer().Decode(store_.entry(*stored).error_max);
    if (block_max <= threshold) {
      ++blocks_skipped_;
      held.vblock = vblock;
      held.stored = true;
      held.handle = BlockHandle{};
      held.skipped = true;
      held.skipped_max = block_max;
      return block_max;
    }
    SDB_RETURN_IF_ERROR(Hold(held, vblock));
  }
  if (!held.stored) return 0.0;
  return store_.quantizer().Decode(store_.StoredErrorAt(
      held.handle.data, static_cast<uint32_t>(p & (store_.header().block_records() - 1))));
}

template <int D>
Result<double> HzStore::Reader<D>::Field(const std::array<int64_t, D>& p) {
  std::array<int64_t, D> q{};
  const auto& dims = store_.header().dims;
  for (int a = 0; a < D; ++a) q[a] = std::clamp<int64_t>(p[a], 0, int64_t{dims[a]} - 1);
  const int level = order_.Level(q);
  const uint64_t pos = order_.PositionAtLevel(q, level);
  const uint64_t vblock = pos >> store_.header().block_bits;
  Held& held = HeldFor(pos);
  if (vblock != held.vblock || held.skipped) SDB_RETURN_IF_ERROR(Hold(held, vblock));
  if (!held.stored) {
    return Status::Corruption(store_.path() + ": " + store_.DescribeBlock(vblock) +
                              " holds a grid point but is not stored");
  }
  return store_.FieldAt(held.handle.data,
                        static_cast<uint32_t>(pos & (store_.header().block_records() - 1)));
}

template class HzStore::Reader<3>;
template class HzStore::Reader<4>;

}  // namespace simplexdb
