#include "storage/dense/dense_writer.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <type_traits>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/dense/field_bricks.h"
#include "storage/common/parallel_run.h"
#include "storage/error/quantize.h"
#include "storage/io/checksum.h"
#include "storage/io/codec.h"
#include "storage/io/file.h"
#include "util/little_endian.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

// Appends the stored blocks or bricks of one parallel run in the run's
// item order, whichever worker finishes first, so that a store's bytes do
// not depend on the thread count or on timing. A worker hands over its
// item's bytes (none: nothing stored) and whoever completes the items
// from the next one to append writes them; items finished early wait in
// memory (a few, as items are taken in order). An item that fails is
// never handed over: what follows it stays unwritten, and the run fails.
class AppendInOrder {
 public:
  using Append = std::function<Result<uint64_t>(std::span<const uint8_t>)>;
  explicit AppendInOrder(Append append) : append_(std::move(append)) {}

  // Item `item`'s stored bytes, whose offset, size and checksum go to
  // `entry` once written (`entry` null: the item stores nothing).
  Status Put(uint64_t item, std::vector<uint8_t> bytes, DenseIndexEntry* entry) {
    std::lock_guard<std::mutex> lock(mu_);
    if (item != next_) {
      waiting_.emplace(item, Pending{std::move(bytes), entry});
      return Status::OK();
    }
    SDB_RETURN_IF_ERROR(Write(bytes, entry));
    for (auto it = waiting_.begin(); it != waiting_.end() && it->first == next_;
         it = waiting_.erase(it)) {
      SDB_RETURN_IF_ERROR(Write(it->second.bytes, it->second.entry));
    }
    return Status::OK();
  }

 private:
  struct Pending {
    std::vector<uint8_t> bytes;
    DenseIndexEntry* entry;
  };
  Status Write(std::span<const uint8_t> stored, DenseIndexEntry* e) {
    ++next_;
    if (e == nullptr) return Status::OK();
    SDB_ASSIGN_OR_RETURN(e->offset, append_(stored));
    e->stored_size = static_cast<uint32_t>(stored.size());
    e->checksum = Checksum(stored);
    return Status::OK();
  }

  Append append_;
  std::mutex mu_;
  uint64_t next_ = 0;
  std::map<uint64_t, Pending> waiting_;
};

// OK when every value of the field fits the stored type. A field held in
// the stored type's own C++ type (as the builder holds it) fits by
// construction: no pass over it.
template <int D, class V>
Status CheckField(const std::string& path, const DenseHeader& h, const V* field) {
  const bool own_type =
      WithVoxelCppType(h.voxel_type, [](auto voxel) { return std::is_same_v<decltype(voxel), V>; });
  if (own_type) return Status::OK();
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) n *= h.dims[a];
  for (uint64_t i = 0; i < n; ++i) {
    if (IsRepresentable(h.voxel_type, field[i])) continue;
    std::string at;
    uint64_t rest = i;
    for (int a = 0; a < D; ++a) {
      at += (a == 0 ? "(" : ", ") + std::to_string(rest % h.dims[a]);
      rest /= h.dims[a];
    }
    return Status::InvalidArgument(path + ": the field value " + std::to_string(field[i]) +
                                   " at grid point " + at + ") is not a " +
                                   std::string(VoxelTypeName(h.voxel_type)));
  }
  return Status::OK();
}

// Whether the parameters describe a store this writer can make.
Status CheckParams(const std::string& path, const DenseHeader& params, const DenseWriteOptions& options) {
  const int max_bits = params.dimension == 3 ? 18 : 13;
  if ((params.dimension != 3 && params.dimension != 4) || params.domain_bits < 1 ||
      params.domain_bits > max_bits || params.block_bits < 6 || params.block_bits > 20 ||
      params.brick_bits < 1 || params.brick_bits > (params.dimension == 3 ? 6 : 4) ||
      (params.flags & ~kDenseFinestStored) != 0 || options.threads < 1 ||
      !(params.field_min <= params.field_max)) {
    return Status::InvalidArgument(path + ": store parameters out of range");
  }
  return Status::OK();
}

}  // namespace

struct DenseStoreWriter::Worker {
  std::vector<double> errors;
  std::vector<uint8_t> raw;
  std::unique_ptr<ZstdCompressor> zstd;
};

DenseStoreWriter::DenseStoreWriter() = default;
DenseStoreWriter::~DenseStoreWriter() = default;

Result<std::unique_ptr<DenseStoreWriter>> DenseStoreWriter::Create(const std::string& path,
                                                                   const DenseHeader& params,
                                                                   const DenseWriteOptions& options) {
  SDB_RETURN_IF_ERROR(CheckParams(path, params, options));
  std::unique_ptr<DenseStoreWriter> w(new DenseStoreWriter());
  w->path_ = path;
  w->options_ = options;
  w->start_ = std::chrono::steady_clock::now();
  DenseHeader& h = w->h_;
  h = params;
  h.version = kDenseFormatVersion;
  const uint64_t stored_positions = h.error_positions();
  const int stored_bits = std::countr_zero(stored_positions);
  h.virtual_blocks = stored_bits <= h.block_bits ? 1 : uint64_t{1} << (stored_bits - h.block_bits);
  const double range = h.field_max - h.field_min;
  h.quantum = ErrorQuantizer::QuantumFor(h.quantization, range);
  w->quantizer_ = ErrorQuantizer(h.quantization, h.quantum, range);
  w->grid_ = std::make_unique<BrickGrid>(h.dimension, h.dims, h.domain_bits, h.brick_bits);
  h.bricks = w->grid_->bricks();
  w->positions_ = h.dimension == 3 ? HzOrder<3>(h.domain_bits).size() : HzOrder<4>(h.domain_bits).size();
  try {
    for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
      if (w->MayHoldData(b)) w->candidates_.push_back(b);
    }
    w->entries_.resize(w->candidates_.size());
    w->kept_.assign(w->candidates_.size(), 0);
    w->block_written_.assign(w->candidates_.size(), 0);
    w->brick_entries_.resize(h.bricks);
    w->brick_written_.assign(h.bricks, 0);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path + ": the block list", h.virtual_blocks * 8 + h.bricks * 48);
  }
  if (options.group != nullptr && !options.spool) {
    return Status::InvalidArgument(path + ": a store written by several processes is spooled");
  }
  if (options.group == nullptr || options.group->rank() == 0) {
    SDB_ASSIGN_OR_RETURN(w->writer_, AtomicFileWriter::Create(path));
    w->writer_->Reserve(kDenseHeaderSize);
  }
  if (options.spool) {
    SDB_ASSIGN_OR_RETURN(w->spool_, ScratchFile::Create(path, "spool"));
  }
  w->workers_.resize(static_cast<size_t>(options.threads));
  return w;
}

DenseStoreWriter::Worker& DenseStoreWriter::Prepare(int w) {
  Worker& wk = workers_[static_cast<size_t>(w)];
  if (wk.errors.empty()) {
    wk.errors.resize(h_.block_records());
    wk.raw.resize(h_.block_records() * QuantizedSize(h_.quantization));
    if (options_.compression == Compression::kZstd) {
      wk.zstd = std::make_unique<ZstdCompressor>(options_.zstd_level);
    }
  }
  return wk;
}

DenseStoreWriter::BlockSpan DenseStoreWriter::SpanOf(uint64_t vblock) const {
  BlockSpan span;
  const int d = h_.dimension;
  const int64_t side = int64_t{1} << h_.domain_bits;
  for (int a = 0; a < d; ++a) span.hi[a] = side;
  const uint64_t first = vblock << h_.block_bits;
  if (vblock == 0) return span;
  const int octave = (63 - std::countl_zero(first)) / d - 1;
  const uint64_t segment_size = uint64_t{1} << (d * (octave + 1));
  if (segment_size < h_.block_records()) return span;
  const uint32_t odd = d == 3 ? internal::kOddPatterns<3>.mask_of[(first >> (3 * (octave + 1))) - 1]
                              : internal::kOddPatterns<4>.mask_of[(first >> (4 * (octave + 1))) - 1];
  std::array<int64_t, 4> cell{};
  if (d == 3) {
    const auto u = internal::FromMorton<3>(first & (segment_size - 1));
    std::copy(u.begin(), u.end(), cell.begin());
  } else {
    const auto u = internal::FromMorton<4>(first & (segment_size - 1));
    std::copy(u.begin(), u.end(), cell.begin());
  }
  span.scale = h_.domain_bits - 1 - octave;
  const int s = span.scale;
  // The block's Morton codes are one aligned run: per axis, the low bits of
  // the block's share (the lower axes take the remainder of block_bits / D).
  for (int a = 0; a < d; ++a) {
    const int bits = h_.block_bits / d + (a < h_.block_bits % d ? 1 : 0);
    const int64_t offset = static_cast<int64_t>(odd >> a & 1) << s;
    span.lo[a] = (cell[a] << (s + 1)) | offset;
    span.hi[a] = ((cell[a] + (int64_t{1} << bits) - 1) << (s + 1)) | offset;
  }
  return span;
}

// A block of one octave holds a real vertex or a non-zero error only when
// its first vertex is inside the domain (the rest are holes) and a diamond
// of its level, which reaches 2^(s+1) from its vertex, reaches the real
// grid from there.
bool DenseStoreWriter::MayHoldData(uint64_t vblock) const {
  const BlockSpan span = SpanOf(vblock);
  if (span.scale < 0) return true;
  const int64_t side = int64_t{1} << h_.domain_bits;
  for (int a = 0; a < h_.dimension; ++a) {
    if (span.lo[a] > side) return false;  // holes only
    if (span.lo[a] > int64_t{h_.dims[a]} - 1 + (int64_t{2} << span.scale)) return false;
  }
  return true;
}

Status DenseStoreWriter::WriteBlocks(std::span<const uint64_t> which, const DenseFill& fill) {
  for (const uint64_t i : which) {
    if (i >= candidates_.size() || block_written_[i]) {
      return Status::InvalidArgument(path_ + ": candidate block " + std::to_string(i) +
                                     (i >= candidates_.size()
                                          ? " is past the " + std::to_string(candidates_.size()) + " there are"
                                          : " was written before"));
    }
    block_written_[i] = 1;
  }
  const size_t n = h_.block_records();
  const uint64_t stored_positions = h_.error_positions();
  AppendInOrder in_order([this](std::span<const uint8_t> bytes) { return AppendItem(bytes); });
  const auto block = [&](int w, uint64_t run_item) -> Status {
    const uint64_t item = which[run_item];
    Worker& wk = Prepare(w);
    const uint64_t first = candidates_[item] << h_.block_bits;
    const size_t filled =
        static_cast<size_t>(std::min<uint64_t>(n, positions_ > first ? positions_ - first : 0));
    std::fill(wk.errors.begin(), wk.errors.end(), 0.0);
    std::fill(wk.raw.begin(), wk.raw.end(), uint8_t{0});
    if (filled > 0) SDB_RETURN_IF_ERROR(fill(w, first, filled, wk.errors.data()));
    bool any_error = false;
    double emax = 0;
    uint32_t code_max = 0;
    for (size_t i = 0; i < n; ++i) {
      const double e = wk.errors[i];
      if (!(e >= 0) || !std::isfinite(e)) {
        return Status::InvalidArgument(path_ + ": the error at position " + std::to_string(first + i) +
                                       " is " + std::to_string(e));
      }
      const uint32_t code =
          options_.errors_are_bounds ? quantizer_.EncodeBound(e) : quantizer_.Encode(e);
      // Block 0 may reach into the finest octave (a small domain): those
      // entries stay 0; the grid bricks record their maxima.
      if (first + i >= stored_positions) continue;
      emax = std::max(emax, e);
      any_error = any_error || code != 0;
      code_max = std::max(code_max, code);  // f32 bits of non-negative floats order as the floats
      StoreErrorCode(h_.quantization, wk.raw.data(), i, code);
    }
    RaiseErrorMax(emax);
    if (!any_error && candidates_[item] != 0) return in_order.Put(run_item, {}, nullptr);  // not stored
    DenseIndexEntry& e = entries_[item];
    std::vector<uint8_t> bytes;
    e.encoding = static_cast<uint8_t>(BlockEncoding::kRaw);
    if (wk.zstd) {
      SDB_ASSIGN_OR_RETURN(bytes, wk.zstd->Compress(wk.raw));
      if (bytes.size() < wk.raw.size()) e.encoding = static_cast<uint8_t>(BlockEncoding::kZstd);
    }
    if (e.encoding == static_cast<uint8_t>(BlockEncoding::kRaw)) bytes.assign(wk.raw.begin(), wk.raw.end());
    e.error_max = code_max;
    SDB_RETURN_IF_ERROR(in_order.Put(run_item, std::move(bytes), &e));
    kept_[item] = 1;
    return Status::OK();
  };
  return RunParallel(which.size(), options_.threads, "blocks", start_, options_.progress, block);
}

template <class V>
Status DenseStoreWriter::WriteBricks(std::span<const uint64_t> which, const HeldField<V>& field,
                                     const double* finest_max) {
  if ((finest_max == nullptr) != h_.finest_stored()) {
    return Status::InvalidArgument(path_ + ": the finest errors' maxima go with a store that "
                                           "does not keep them");
  }
  for (const uint64_t b : which) {
    if (b >= h_.bricks || brick_written_[b]) {
      return Status::InvalidArgument(path_ + ": brick " + std::to_string(b) +
                                     (b >= h_.bricks ? " is past the " + std::to_string(h_.bricks) + " there are"
                                                     : " was written before"));
    }
    brick_written_[b] = 1;
  }
  AppendInOrder in_order([this](std::span<const uint8_t> bytes) { return AppendItem(bytes); });
  const auto brick = [&](int w, uint64_t i) -> Status {
    const uint64_t b = which[i];
    Worker& wk = Prepare(w);
    SDB_ASSIGN_OR_RETURN(EncodedBrick coded,
                         EncodeBrick(*grid_, b, field, h_.voxel_type, wk.zstd.get()));
    DenseIndexEntry& e = brick_entries_[b];
    e.encoding = static_cast<uint8_t>(coded.coding);
    SDB_RETURN_IF_ERROR(in_order.Put(i, std::move(coded.bytes), &e));
    e.field_min = RoundDownToFloat(coded.min);
    e.field_max = RoundUpToFloat(coded.max);
    if (b >= grid_->FirstBrick(0) && finest_max != nullptr) {
      const double m = finest_max[b - grid_->FirstBrick(0)];
      e.error_max = options_.errors_are_bounds ? quantizer_.EncodeBound(m) : quantizer_.Encode(m);
      RaiseErrorMax(m);
    }
    return Status::OK();
  };
  return RunParallel(which.size(), options_.threads, "bricks", start_, options_.progress, brick);
}

void DenseStoreWriter::RaiseErrorMax(double e) {
  std::lock_guard<std::mutex> lock(max_mu_);
  error_max_ = std::max(error_max_, e);
}

Result<uint64_t> DenseStoreWriter::AppendItem(std::span<const uint8_t> bytes) {
  return spool_ != nullptr ? spool_->Append(bytes) : writer_->Append(bytes);
}

namespace {

// A spooled item as the ranks exchange it: blocks by candidate index,
// bricks after them; the entry's offset is the item's in the spool.
// The most bytes CopySpooled copies at once (a block or a brick is far
// smaller).
constexpr uint64_t kSpoolRun = uint64_t{1} << 20;

struct SpoolRecord {
  uint64_t item;
  DenseIndexEntry entry;
};
SpoolRecord RecordAt(const std::string& records, size_t k) {
  SpoolRecord r;
  std::memcpy(&r, records.data() + sizeof(double) + k * sizeof(SpoolRecord), sizeof r);
  return r;
}
size_t RecordCount(const std::string& records) {
  return (records.size() - sizeof(double)) / sizeof(SpoolRecord);
}
uint64_t U64At(const std::string& text, size_t k) {
  uint64_t v;
  std::memcpy(&v, text.data() + k * sizeof v, sizeof v);
  return v;
}

}  // namespace

DenseStoreWriter::Memory DenseStoreWriter::MemoryFor(const DenseHeader& params, bool spool) {
  DenseHeader h = params;
  const int stored_bits = std::countr_zero(h.error_positions());
  h.virtual_blocks = stored_bits <= h.block_bits ? 1 : uint64_t{1} << (stored_bits - h.block_bits);
  DenseStoreWriter geometry;  // MayHoldData reads the header alone
  geometry.h_ = h;
  uint64_t blocks = 0;
  for (uint64_t b = 0; b < h.virtual_blocks; ++b) blocks += geometry.MayHoldData(b) ? 1 : 0;
  const uint64_t bricks = BrickGrid(h.dimension, h.dims, h.domain_bits, h.brick_bits).bricks();
  Memory m;
  // candidates_, entries_, kept_, block_written_; brick_entries_, brick_written_.
  m.tables = blocks * (sizeof(uint64_t) + sizeof(DenseIndexEntry) + 2) + bricks * (sizeof(DenseIndexEntry) + 1);
  m.finish = (blocks + bricks) * kDenseIndexEntrySize + 8 * ((h.virtual_blocks + 63) / 64);
  if (spool) m.finish += (blocks + bricks) * (sizeof(SpoolRecord) + sizeof(uint64_t)) + kSpoolRun;
  return m;
}

Result<DenseHeader> DenseStoreWriter::Finish() {
  if (!options_.spool) return WriteTail();
  ProcessGroup* group = options_.group;
  const bool root = group == nullptr || group->rank() == 0;
  // This process's items (its largest error first), to rank 0.
  std::string mine(sizeof(double), '\0');
  std::memcpy(mine.data(), &error_max_, sizeof(double));
  const auto add = [&](uint64_t item, const DenseIndexEntry& e) {
    const SpoolRecord r{item, e};
    mine.append(reinterpret_cast<const char*>(&r), sizeof r);
  };
  for (uint64_t i = 0; i < candidates_.size(); ++i) {
    if (kept_[i]) add(i, entries_[i]);
  }
  for (uint64_t b = 0; b < h_.bricks; ++b) {
    if (brick_written_[b]) add(candidates_.size() + b, brick_entries_[b]);
  }
  std::vector<std::string> records{mine}, places;
  if (group != nullptr) {
    SDB_ASSIGN_OR_RETURN(records, group->Gather(mine));
  }
  // Rank 0 places every item; each rank learns where its own go.
  Status placed = root ? MergeSpooled(records, places) : Status::OK();
  std::string my_places = root && placed.ok() ? places[0] : std::string();
  if (group != nullptr) {
    if (places.size() != static_cast<size_t>(group->size())) places.assign(static_cast<size_t>(group->size()), {});
    SDB_ASSIGN_OR_RETURN(my_places, group->Scatter(places));
    placed = group->Agree(placed);
  }
  SDB_RETURN_IF_ERROR(placed);
  Status copied = CopySpooled(mine, my_places);
  if (group != nullptr) copied = group->Agree(copied);
  SDB_RETURN_IF_ERROR(copied);
  if (group == nullptr) return WriteTail();
  Result<DenseHeader> done = root ? WriteTail() : Result<DenseHeader>(DenseHeader{});
  SDB_RETURN_IF_ERROR(group->Agree(done.status()));
  std::array<uint8_t, kDenseHeaderSize> header{};
  if (root) header = SerializeDenseHeader(*done);
  SDB_RETURN_IF_ERROR(group->Broadcast(header, 0));
  return ParseDenseHeader(header, path_);
}

// Rank 0: every rank's items into this writer's tables (its own are there
// already), each placed in the canonical order from just past the header;
// places[r] the offsets of rank r's items in its order, then the path of
// the temporary they go to.
Status DenseStoreWriter::MergeSpooled(const std::vector<std::string>& records, std::vector<std::string>& places) {
  const uint64_t blocks = candidates_.size();
  for (size_t r = 0; r < records.size(); ++r) {
    double emax = 0;
    std::memcpy(&emax, records[r].data(), sizeof emax);
    error_max_ = std::max(error_max_, emax);
    for (size_t k = 0; r > 0 && k < RecordCount(records[r]); ++k) {
      const SpoolRecord rec = RecordAt(records[r], k);
      const bool block = rec.item < blocks;
      const uint64_t i = block ? rec.item : rec.item - blocks;
      if (block ? kept_[i] != 0 : brick_written_[i] != 0) {
        return Status::InvalidArgument(path_ + ": " + (block ? "candidate block " : "brick ") + std::to_string(i) +
                                       " was written by two ranks");
      }
      (block ? kept_[i] : brick_written_[i]) = 1;
      (block ? entries_[i] : brick_entries_[i]) = rec.entry;
    }
  }
  uint64_t at = kDenseHeaderSize;
  for (uint64_t i = 0; i < blocks; ++i) {
    if (!kept_[i]) continue;
    entries_[i].offset = at;
    at += entries_[i].stored_size;
  }
  for (uint64_t b = 0; b < h_.bricks; ++b) {
    if (!brick_written_[b]) continue;
    brick_entries_[b].offset = at;
    at += brick_entries_[b].stored_size;
  }
  data_end_ = at;
  places.assign(records.size(), {});
  for (size_t r = 0; r < records.size(); ++r) {
    for (size_t k = 0; k < RecordCount(records[r]); ++k) {
      const uint64_t item = RecordAt(records[r], k).item;
      const uint64_t offset = item < blocks ? entries_[item].offset : brick_entries_[item - blocks].offset;
      places[r].append(reinterpret_cast<const char*>(&offset), sizeof offset);
    }
    places[r] += writer_->temp_path();
  }
  return Status::OK();
}

// This process's spooled items to their places in the store's temporary,
// runs that follow each other in both files at once.
Status DenseStoreWriter::CopySpooled(const std::string& records, const std::string& places) {
  const size_t n = RecordCount(records);
  std::unique_ptr<FilePartWriter> part;
  if (writer_ == nullptr) {
    SDB_ASSIGN_OR_RETURN(part, FilePartWriter::Open(places.substr(n * sizeof(uint64_t))));
  }
  std::vector<uint8_t> buffer;
  uint64_t from = 0, to = 0, size = 0;
  const auto flush = [&]() -> Status {
    if (size == 0) return Status::OK();
    buffer.resize(size);
    SDB_RETURN_IF_ERROR(spool_->ReadAt(from, buffer));
    return writer_ != nullptr ? writer_->WriteAt(to, buffer) : part->WriteAt(to, buffer);
  };
  for (size_t k = 0; k < n; ++k) {
    const DenseIndexEntry e = RecordAt(records, k).entry;
    const uint64_t place = U64At(places, k);
    if (size > 0 && e.offset == from + size && place == to + size && size + e.stored_size <= kSpoolRun) {
      size += e.stored_size;
      continue;
    }
    SDB_RETURN_IF_ERROR(flush());
    from = e.offset;
    to = place;
    size = e.stored_size;
  }
  SDB_RETURN_IF_ERROR(flush());
  return part != nullptr ? part->Sync() : Status::OK();
}

// The indexes after the items, the header, and the file into place.
Result<DenseHeader> DenseStoreWriter::WriteTail() {
  if (options_.spool) writer_->Reserve(data_end_ - writer_->size());
  for (uint64_t b = 0; b < h_.bricks; ++b) {
    if (!brick_written_[b]) {
      return Status::InvalidArgument(path_ + ": brick " + std::to_string(b) + " was not written");
    }
  }
  DenseHeader& h = h_;
  // Bitmap and indexes, in block and brick order.
  std::vector<uint8_t> bitmap(8 * h.bitmap_words(), 0), index, brick_index;
  uint64_t stored = 0;
  for (size_t i = 0; i < candidates_.size(); ++i) stored += kept_[i];
  index.resize(stored * kDenseIndexEntrySize);
  uint64_t j = 0;
  for (size_t i = 0; i < candidates_.size(); ++i) {
    if (!kept_[i]) continue;
    const uint64_t b = candidates_[i];
    bitmap[b / 8] |= static_cast<uint8_t>(1u << (b % 8));  // little-endian words: bit b of the map
    SerializeDenseIndexEntry(entries_[i], index.data() + j++ * kDenseIndexEntrySize);
  }
  brick_index.resize(h.bricks * kDenseIndexEntrySize);
  for (uint64_t b = 0; b < h.bricks; ++b) {
    SerializeDenseIndexEntry(brick_entries_[b], brick_index.data() + b * kDenseIndexEntrySize);
  }
  h.stored_blocks = stored;
  h.error_max = error_max_;
  SDB_ASSIGN_OR_RETURN(h.bitmap_offset, writer_->Append(bitmap));
  SDB_ASSIGN_OR_RETURN(h.index_offset, writer_->Append(index));
  SDB_ASSIGN_OR_RETURN(h.brick_index_offset, writer_->Append(brick_index));
  h.file_size = writer_->size();
  h.bitmap_checksum = Checksum(bitmap);
  h.index_checksum = Checksum(index);
  h.brick_index_checksum = Checksum(brick_index);
  const auto header = SerializeDenseHeader(h);
  SDB_RETURN_IF_ERROR(writer_->WriteAt(0, header));
  SDB_RETURN_IF_ERROR(writer_->Commit());
  return h;
}

#define SDB_WRITE_BRICKS_(V) \
  template Status DenseStoreWriter::WriteBricks(std::span<const uint64_t>, const HeldField<V>&, \
                                                const double*);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WRITE_BRICKS_)
#undef SDB_WRITE_BRICKS_


template <class V>
Result<DenseHeader> WriteDenseStore(const std::string& path, const DenseHeader& params,
                                    const DenseWriteOptions& options, const DenseFill& fill, const V* field,
                                    const double* finest_max) {
  SDB_RETURN_IF_ERROR(CheckParams(path, params, options));
  if ((finest_max == nullptr) != ((params.flags & kDenseFinestStored) != 0)) {
    return Status::InvalidArgument(path + ": the finest errors' maxima go with a store that "
                                          "does not keep them");
  }
  SDB_RETURN_IF_ERROR(params.dimension == 3 ? CheckField<3>(path, params, field)
                                            : CheckField<4>(path, params, field));
  SDB_ASSIGN_OR_RETURN(auto writer, DenseStoreWriter::Create(path, params, options));
  std::vector<uint64_t> all(writer->candidate_blocks().size());
  for (uint64_t i = 0; i < all.size(); ++i) all[i] = i;
  SDB_RETURN_IF_ERROR(writer->WriteBlocks(all, fill));
  std::vector<uint64_t> bricks(writer->header().bricks);
  for (uint64_t b = 0; b < bricks.size(); ++b) bricks[b] = b;
  HeldField<V> whole{field, {1, 1, 1, 1}, 0, 0};  // x fastest
  for (int a = 1; a < 4; ++a) whole.stride[a] = whole.stride[a - 1] * params.dims[a - 1];
  SDB_RETURN_IF_ERROR(writer->WriteBricks(bricks, whole, finest_max));
  return writer->Finish();
}

#define SDB_WRITE_HZ_STORE_(V)                                                           \
  template Result<DenseHeader> WriteDenseStore(const std::string&, const DenseHeader&,            \
                                               const DenseWriteOptions&, const DenseFill&, const V*, \
                                               const double*);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_WRITE_HZ_STORE_)
#undef SDB_WRITE_HZ_STORE_

}  // namespace simplexdb
