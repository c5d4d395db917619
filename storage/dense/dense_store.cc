#include "storage/dense/dense_store.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <new>

#include "storage/io/checksum.h"
#include "storage/io/codec.h"
#include "util/little_endian.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

// One decompressor per thread: zstd contexts are reusable, not shareable.
ZstdDecompressor& ThreadDecompressor() {
  thread_local ZstdDecompressor d;
  return d;
}

// Calls fn with an ErrorLayout of the store's dimension.
template <class Fn>
auto WithErrorLayout(const DenseHeader& h, Fn&& fn) {
  if (h.dimension == 3) return fn(ErrorLayout<3>(h.leaf_level(), h.levels_per_block));
  return fn(ErrorLayout<4>(h.leaf_level(), h.levels_per_block));
}

BrickLayout BricksOf(const DenseHeader& h) {
  return BrickLayout(h.dimension, h.dims, h.brick_bits);
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

}  // namespace

DenseStore::~DenseStore() {
  // A shared cache outlives the store: leave nothing in it that no one can
  // look up again. A private cache (only we hold it) goes away with us.
  if (cache_ && cache_.use_count() > 1) cache_->EraseStore(cache_store_id_);
}

Result<std::unique_ptr<DenseStore>> DenseStore::Open(const std::string& path,
                                                     const Options& options) {
  std::unique_ptr<DenseStore> s(new DenseStore());
  s->path_ = path;
  SDB_ASSIGN_OR_RETURN(s->file_, MappedFile::Open(path));
  const std::span<const uint8_t> bytes = s->file_->bytes();
  SDB_ASSIGN_OR_RETURN(s->header_, ParseHeader(bytes, path));
  const DenseHeader& h = s->header_;
  if (bytes.size() != h.file_size) {
    return Status::Corruption(path + ": the file is " + std::to_string(bytes.size()) +
                              " bytes; its header says " + std::to_string(h.file_size) +
                              (bytes.size() < h.file_size ? " (truncated)" : ""));
  }
  if (h.quantization != Quantization::kF32 && !(h.quantum > 0)) {
    return Status::Corruption(path + ": header: quantized errors need a positive quantum");
  }
  s->quantizer_ = ErrorQuantizer(h.quantization, h.quantum, h.field_max - h.field_min);
  s->voxel_size_ = VoxelSize(h.voxel_type);
  SDB_RETURN_IF_ERROR(s->ValidateIndex());
  s->raw_state_ = std::make_unique<std::atomic<uint8_t>[]>(h.block_count());
  if (options.in_memory) {
    SDB_RETURN_IF_ERROR(s->LoadAll());
  } else {
    if (options.cache) {
      s->cache_ = options.cache;
    } else {
      // Few shards for a small budget, so one shard can hold a block.
      const size_t block = std::max<size_t>(s->error_block_bytes_, s->brick_bytes_);
      const int shards =
          static_cast<int>(std::clamp<size_t>(options.cache_bytes / (4 * block + 1), 1, 16));
      s->cache_ = std::make_shared<BlockCache>(options.cache_bytes, shards);
    }
    s->cache_store_id_ = BlockCache::NewStoreId();
  }
  return s;
}

uint32_t DenseStore::ExpectedRawSize(uint64_t block) const {
  if (block < header_.error_block_count) {
    const uint32_t entries =
        WithErrorLayout(header_, [&](const auto& layout) { return layout.EntriesInBlock(block); });
    return entries * static_cast<uint32_t>(QuantizedSize(header_.quantization));
  }
  return static_cast<uint32_t>(
      BricksOf(header_).PointsInBrick(block - header_.error_block_count) * voxel_size_);
}

Status DenseStore::ValidateIndex() {
  const DenseHeader& h = header_;
  const auto corrupt = [&](const std::string& why) {
    return Status::Corruption(path_ + ": index: " + why);
  };
  const uint64_t expected_errors =
      WithErrorLayout(h, [](const auto& layout) { return layout.block_count(); });
  const uint64_t expected_bricks = BricksOf(h).brick_count();
  if (h.error_block_count != expected_errors || h.brick_count != expected_bricks) {
    return corrupt("block counts " + std::to_string(h.error_block_count) + " + " +
                   std::to_string(h.brick_count) + " do not match the layout (" +
                   std::to_string(expected_errors) + " + " + std::to_string(expected_bricks) +
                   ")");
  }
  const std::span<const uint8_t> bytes = file_->bytes();
  const std::span<const uint8_t> index =
      bytes.subspan(h.index_offset, h.block_count() * kIndexEntrySize);
  if (Checksum(index) != h.index_checksum) return corrupt("checksum mismatch");
  for (uint64_t b = 0; b < h.block_count(); ++b) {
    const uint8_t* e = index.data() + b * kIndexEntrySize;
    if (e[25] != 0 || e[26] != 0 || e[27] != 0) {
      return corrupt(DescribeBlock(b) + ": reserved bytes are set");
    }
    IndexEntry entry = ParseIndexEntry(e);
    const uint32_t raw = ExpectedRawSize(b);
    if (b < h.error_block_count) {
      error_block_bytes_ = std::max(error_block_bytes_, raw);
    } else {
      brick_bytes_ = std::max(brick_bytes_, raw);
    }
    if (entry.raw_size != raw) {
      return corrupt(DescribeBlock(b) + ": raw size " + std::to_string(entry.raw_size) +
                     ", expected " + std::to_string(raw));
    }
    switch (entry.encoding) {
      case BlockEncoding::kZero:
        if (entry.stored_size != 0) return corrupt(DescribeBlock(b) + ": zero block with data");
        break;
      case BlockEncoding::kRaw:
        if (entry.stored_size != raw) return corrupt(DescribeBlock(b) + ": raw block size");
        break;
      case BlockEncoding::kZstd:
        if (entry.stored_size == 0 || entry.stored_size > ZSTD_compressBound(raw)) {
          return corrupt(DescribeBlock(b) + ": compressed size " +
                         std::to_string(entry.stored_size));
        }
        break;
      default:
        return corrupt(DescribeBlock(b) + ": unknown encoding " +
                       std::to_string(static_cast<int>(entry.encoding)));
    }
    if (entry.stored_size > 0 &&
        (entry.offset < kHeaderSize || entry.offset > h.index_offset ||
         entry.stored_size > h.index_offset - entry.offset)) {
      return corrupt(DescribeBlock(b) + ": data outside the block area");
    }
    if (!(entry.field_min <= entry.field_max) || !std::isfinite(entry.field_min) ||
        !std::isfinite(entry.field_max) || !(entry.error_max >= 0) ||
        !std::isfinite(entry.error_max)) {
      return corrupt(DescribeBlock(b) + ": block statistics are not finite ranges");
    }
  }
  index_ = index.data();
  zeros_.assign(std::max(error_block_bytes_, brick_bytes_), 0);
  return Status::OK();
}

std::string DenseStore::DescribeBlock(uint64_t b) const {
  if (b >= header_.error_block_count) {
    return "field brick " + std::to_string(b - header_.error_block_count) + " (block " +
           std::to_string(b) + ")";
  }
  return WithErrorLayout(header_, [&](const auto& layout) {
    const auto root = layout.BlockRoot(b);
    const int band = layout.BandOfBlock(b);
    return "error block " + std::to_string(b) + " (subtree of " + root.ToString() +
           ", levels " + std::to_string(layout.band_start(band)) + ".." +
           std::to_string(layout.band_start(band) + layout.band_depth(band) - 1) + ")";
  });
}

namespace {

DenseStore::BlockHandle HandleOf(std::shared_ptr<const BlockCache::Block> block) {
  const uint8_t* data = block->data();
  const size_t size = block->size();
  return DenseStore::BlockHandle{data, size, std::move(block)};
}

}  // namespace

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::DecodeBlock(uint64_t b) const {
  const IndexEntry e = entry(b);
  const std::span<const uint8_t> stored = file_->bytes().subspan(e.offset, e.stored_size);
  if (Checksum(stored) != e.checksum) {
    return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": checksum mismatch");
  }
  std::shared_ptr<BlockCache::Block> block;
  try {
    block = std::make_shared<BlockCache::Block>(e.raw_size);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": " + DescribeBlock(b) + " decoded", e.raw_size);
  }
  SDB_RETURN_IF_ERROR(ThreadDecompressor().Decompress(stored, *block,
                                                      path_ + ": " + DescribeBlock(b)));
  decoded_.fetch_add(1, std::memory_order_relaxed);
  return std::shared_ptr<const BlockCache::Block>(std::move(block));
}

Result<DenseStore::BlockHandle> DenseStore::Block(uint64_t b) const {
  if (b >= block_count()) {
    return Status::InvalidArgument(path_ + ": block " + std::to_string(b) + " out of range");
  }
  if (!resident_.empty()) {
    // Resident blocks live as long as the store: no reference to count.
    return BlockHandle{resident_[b]->data(), resident_[b]->size(), nullptr};
  }
  const IndexEntry e = entry(b);
  switch (e.encoding) {
    case BlockEncoding::kZero:
      return BlockHandle{zeros_.data(), e.raw_size, nullptr};
    case BlockEncoding::kRaw: {
      const uint8_t* data = file_->bytes().data() + e.offset;
      uint8_t state = raw_state_[b].load(std::memory_order_acquire);
      if (state == 0) {
        state = Checksum(std::span<const uint8_t>(data, e.stored_size)) == e.checksum ? 1 : 2;
        raw_state_[b].store(state, std::memory_order_release);
        raw_checked_.fetch_add(1, std::memory_order_relaxed);
      }
      if (state == 2) {
        return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": checksum mismatch");
      }
      return BlockHandle{data, e.raw_size, nullptr};
    }
    case BlockEncoding::kZstd: {
      const BlockCache::Key key{cache_store_id_, b};
      if (auto hit = cache_->Lookup(key)) return HandleOf(std::move(hit));
      SDB_ASSIGN_OR_RETURN(auto fresh, DecodeBlock(b));
      return HandleOf(cache_->Insert(key, std::move(fresh)));
    }
  }
  return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": unknown encoding");
}

Status DenseStore::LoadAll() {
  uint64_t total = 0;  // what this holds: every block decoded
  for (uint64_t b = 0; b < block_count(); ++b) total += entry(b).raw_size;
  const std::string all_blocks =
      "all " + std::to_string(block_count()) + " blocks of " + path_ + " decoded in memory";
  // Partly loaded blocks are freed when the store is (Open fails).
  try {
    resident_.resize(block_count());
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(all_blocks, total);
  }
  for (uint64_t b = 0; b < block_count(); ++b) {
    const IndexEntry e = entry(b);
    std::shared_ptr<BlockCache::Block> block;
    try {
      block = std::make_shared<BlockCache::Block>(e.raw_size, 0);
    } catch (const std::bad_alloc&) {
      return NotEnoughMemory(all_blocks, total);
    }
    if (e.encoding == BlockEncoding::kRaw) {
      const std::span<const uint8_t> stored = file_->bytes().subspan(e.offset, e.stored_size);
      if (Checksum(stored) != e.checksum) {
        return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": checksum mismatch");
      }
      std::memcpy(block->data(), stored.data(), stored.size());
    } else if (e.encoding == BlockEncoding::kZstd) {
      const Result<std::shared_ptr<const BlockCache::Block>> decoded = DecodeBlock(b);
      if (!decoded.ok()) {
        if (decoded.status().code() != Status::Code::kResourceExhausted) return decoded.status();
        return NotEnoughMemory(all_blocks, total);
      }
      resident_[b] = decoded.value();
      continue;
    }
    resident_[b] = std::move(block);
  }
  return Status::OK();
}

uint32_t DenseStore::StoredAt(const uint8_t* block, uint32_t i) const {
  switch (header_.quantization) {
    case Quantization::kU16:
      return LoadLittle<uint16_t>(block + 2 * static_cast<size_t>(i));
    case Quantization::kU8:
      return block[i];
    case Quantization::kF32:
      return LoadLittle<uint32_t>(block + 4 * static_cast<size_t>(i));
  }
  return 0;
}

double DenseStore::FieldAt(const uint8_t* brick, uint32_t i) const {
  return ReadVoxel(header_.voxel_type, brick + static_cast<size_t>(i) * voxel_size_);
}

Status DenseStore::Verify(const std::function<void(uint64_t, uint64_t)>& progress) const {
  const uint64_t total = block_count();
  for (uint64_t b = 0; b < total; ++b) {
    if (progress && (b % 256 == 0)) progress(b, total);
    const IndexEntry e = entry(b);
    // Check the stored bytes even if the block is cached or resident.
    if (e.encoding != BlockEncoding::kZero &&
        Checksum(file_->bytes().subspan(e.offset, e.stored_size)) != e.checksum) {
      return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": checksum mismatch");
    }
    SDB_ASSIGN_OR_RETURN(BlockHandle h, Block(b));
    const auto bad = [&](const std::string& why) {
      return Status::Corruption(path_ + ": " + DescribeBlock(b) + ": " + why);
    };
    if (b < header_.error_block_count) {
      const uint32_t n = e.raw_size / static_cast<uint32_t>(QuantizedSize(header_.quantization));
      double largest = 0;
      for (uint32_t i = 0; i < n; ++i) {
        const double v = ErrorAt(h.data, i);
        if (!std::isfinite(v) || v < 0) return bad("error entry " + std::to_string(i) + " is " +
                                                   std::to_string(v));
        largest = std::max(largest, v);
      }
      if (largest > e.error_max) {
        return bad("holds an error of " + std::to_string(largest) +
                   " above its recorded maximum " + std::to_string(e.error_max));
      }
    } else {
      const uint32_t n = e.raw_size / static_cast<uint32_t>(voxel_size_);
      for (uint32_t i = 0; i < n; ++i) {
        const double v = FieldAt(h.data, i);
        if (std::isnan(v)) continue;  // a missing value (float fields)
        if (!(v >= e.field_min && v <= e.field_max && v >= header_.field_min &&
              v <= header_.field_max)) {
          return bad("field entry " + std::to_string(i) + " is " + std::to_string(v) +
                     ", outside the recorded range");
        }
      }
    }
  }
  if (progress) progress(total, total);
  return Status::OK();
}

template <int D>
DenseStore::Reader<D>::Reader(const DenseStore& store)
    : store_(store),
      layout_(store.header().leaf_level(), store.header().levels_per_block),
      bricks_(BricksOf(store.header())) {}

template <int D>
Result<double> DenseStore::Reader<D>::ErrorBound(SimplexCode<D> code) {
  SDB_ASSIGN_OR_RETURN(const uint32_t stored, StoredError(code));
  return store_.quantizer().Decode(stored);
}

template <int D>
Result<uint32_t> DenseStore::Reader<D>::StoredError(SimplexCode<D> code) {
  if (code.level() >= layout_.leaf_level()) return 0u;
  const BlockSlot slot = layout_.Locate(code);
  if (slot.block != error_block_) {
    SDB_ASSIGN_OR_RETURN(error_handle_, store_.Block(slot.block));
    error_block_ = slot.block;
    ++block_fetches_;
  }
  return store_.StoredAt(error_handle_.data, slot.entry);
}

template <int D>
Result<double> DenseStore::Reader<D>::ErrorBoundForThreshold(SimplexCode<D> code, double threshold) {
  if (code.level() >= layout_.leaf_level()) return 0.0;
  const BlockSlot slot = layout_.Locate(code);
  if (slot.block != error_block_) {
    // The index records the largest decoded error of the block (rounded up
    // to float): a bound of every entry.
    const double block_max = store_.entry(slot.block).error_max;
    if (block_max <= threshold) {
      ++blocks_skipped_;
      return block_max;
    }
  }
  return ErrorBound(code);
}

template <int D>
Result<double> DenseStore::Reader<D>::Field(const std::array<int64_t, D>& p) {
  std::array<uint32_t, 4> q = {0, 0, 0, 0};
  const auto& dims = store_.header().dims;
  for (int a = 0; a < D; ++a) {
    q[a] = static_cast<uint32_t>(std::clamp<int64_t>(p[a], 0, int64_t{dims[a]} - 1));
  }
  const BlockSlot slot = bricks_.Locate(q);
  const uint64_t block = store_.BrickBlock(slot.block);
  if (block != brick_) {
    SDB_ASSIGN_OR_RETURN(brick_handle_, store_.Block(block));
    brick_ = block;
    ++block_fetches_;
  }
  return store_.FieldAt(brick_handle_.data, slot.entry);
}

template class DenseStore::Reader<3>;
template class DenseStore::Reader<4>;

}  // namespace simplexdb
