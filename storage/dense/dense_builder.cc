#include "storage/dense/dense_builder.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "storage/dense/block_cache.h"
#include "storage/io/checksum.h"
#include "storage/io/codec.h"
#include "storage/io/file.h"
#include "storage/dense/layout.h"
#include "storage/dense/parallel_run.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"
#include "storage/error/quantize.h"
#include "storage/error/unit_errors.h"
#include "storage/volume/voxel_type.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

// A block's bytes as stored: zero blocks take no bytes; zstd frames only
// when they are smaller than the raw bytes (raw blocks are read in place).
struct StoredBlock {
  BlockEncoding encoding;
  std::vector<uint8_t> bytes;
};

Result<StoredBlock> EncodeBlock(std::vector<uint8_t> raw, Compression compression,
                                ZstdCompressor& zstd) {
  if (std::all_of(raw.begin(), raw.end(), [](uint8_t b) { return b == 0; })) {
    return StoredBlock{BlockEncoding::kZero, {}};
  }
  if (compression == Compression::kZstd) {
    SDB_ASSIGN_OR_RETURN(std::vector<uint8_t> packed, zstd.Compress(raw));
    if (packed.size() < raw.size()) return StoredBlock{BlockEncoding::kZstd, std::move(packed)};
  }
  return StoredBlock{BlockEncoding::kRaw, std::move(raw)};
}

// a * b, or UINT64_MAX when that overflows: estimates of absurd grids must
// still compare as too large.
uint64_t SaturatingMul(uint64_t a, uint64_t b) {
  return b != 0 && a > std::numeric_limits<uint64_t>::max() / b
             ? std::numeric_limits<uint64_t>::max()
             : a * b;
}
uint64_t SaturatingAdd(uint64_t a, uint64_t b) {
  return a > std::numeric_limits<uint64_t>::max() - b ? std::numeric_limits<uint64_t>::max()
                                                      : a + b;
}

std::string MiB(uint64_t bytes) {
  return std::to_string((bytes + (uint64_t{1} << 20) - 1) >> 20) + " MiB";
}

template <int D>
class Builder {
 public:
  Builder(const VolumeInfo& input, const std::string& out, const DenseBuildOptions& options)
      : input_(input),
        out_(out),
        options_(options),
        threads_(options.threads > 0 ? options.threads
                                     : std::max(1, static_cast<int>(
                                                       std::thread::hardware_concurrency()))),
        // At least k = 1: a grid of 2 points per axis still has internal
        // nodes (in a domain of side 2, padded).
        k_(std::max(1, DomainBitsFor(D, input.dims))),
        layout_(D * k_, options.levels_per_block),
        bricks_(D, input.dims, options.brick_bits > 0 ? options.brick_bits : (D == 3 ? 5 : 4)),
        store_type_(StoredVoxelType(input, options.mask.has_value())),
        exact_(!IsFloatType(store_type_)),
        start_(Clock::now()) {}

  Result<DenseBuildReport> Run();

 private:
  // The builder's own allocations, estimated from the grid before any is
  // made; ResourceExhausted naming each when they and the brick cache
  // exceed options_.memory_bytes. With threads 0 (one per core), lowers
  // threads_ to what the bound holds.
  Status CheckMemory();

  // Pass 1: the field, one row of bricks (all x) per work item.
  Status WriteBricks();
  Status WriteBrickRow(uint64_t row, VolumeReader& reader, VolumeReader* mask,
                       ZstdCompressor& zstd);

  // Pass 2: errors.
  Status ComputeErrors();
  Status ProcessUnit(int worker, uint64_t unit);
  Status WriteTopBlocks();
  Status WriteErrorBlock(uint64_t block, const std::vector<uint32_t>& codes, float field_min,
                         float field_max, double error_max, ZstdCompressor& zstd);

  Status Finish(DenseBuildReport& report);

  // Fills a unit's region (its box set) from the bricks.
  Status FillRegion(GridRegion<D>& r);
  Result<double> FieldValue(const IPoint<D>& p);
  Result<std::shared_ptr<const BlockCache::Block>> DecodedBrick(uint64_t brick);

  // Index of a top node (level < units' level) among its root's top nodes.
  uint64_t TopIndex(SimplexCode<D> code) const {
    return static_cast<uint64_t>(code.top()) * top_per_root_ + code.heap_index();
  }

  const VolumeInfo& input_;
  std::string out_;
  DenseBuildOptions options_;
  int threads_;
  int k_;
  ErrorLayout<D> layout_;
  BrickLayout bricks_;
  VoxelType store_type_;  // the field's type in the store
  bool exact_;  // integer voxels: errors computed exactly
  Clock::time_point start_;

  std::unique_ptr<AtomicFileWriter> writer_;
  std::vector<IndexEntry> index_;
  std::unique_ptr<MappedFile> brick_file_;  // the temporary file, after pass 1
  std::unique_ptr<BlockCache> brick_cache_;
  double field_min_ = std::numeric_limits<double>::infinity();
  double field_max_ = -std::numeric_limits<double>::infinity();
  std::mutex stats_mu_;
  // The input has NaN voxels: missing values (see ErrorGivenAvailability).
  bool has_missing_ = false;
  std::unique_ptr<ErrorQuantizer> quantizer_;
  ErrorRules<D> rules_;  // set when pass 1 has the field's range
  std::atomic<uint64_t> nodes_{0};

  // Units: the blocks of the deepest band.
  int unit_level_ = 0;
  uint64_t top_per_root_ = 0;  // nodes above the units, per root
  std::vector<std::vector<double>> top_partials_;  // per worker
  // With missing values: per worker and top node, bit 0 "some point has a
  // value", bit 1 "some point or vertex has none".
  std::vector<std::vector<uint8_t>> top_availability_;
  std::vector<double> worker_error_max_;
};

template <int D>
Result<DenseBuildReport> Builder<D>::Run() {
  if (input_.dimension != D) {
    return Status::InvalidArgument(input_.description + ": a " + std::to_string(input_.dimension) +
                                   "D volume cannot build a " + std::to_string(D) + "D hierarchy");
  }
  if (options_.mask) {
    SDB_RETURN_IF_ERROR(CheckMaskGrid(*options_.mask, input_.dimension, input_.dims,
                                      "the volume " + input_.description + " is"));
  }
  const int max_bits = D == 3 ? 18 : 13;
  if (k_ > max_bits) {
    return Status::InvalidArgument(
        input_.description + ": a grid of this size needs a domain of side 2^" +
        std::to_string(k_) + ", beyond the deepest level a 64-bit location code holds (2^" +
        std::to_string(max_bits) + " per axis)");
  }
  SDB_RETURN_IF_ERROR(CheckMemory());
  SDB_ASSIGN_OR_RETURN(writer_, AtomicFileWriter::Create(out_));
  writer_->Reserve(kHeaderSize);
  index_.resize(layout_.block_count() + bricks_.brick_count());
  SDB_RETURN_IF_ERROR(WriteBricks());
  SDB_RETURN_IF_ERROR(ComputeErrors());
  DenseBuildReport report;
  SDB_RETURN_IF_ERROR(Finish(report));
  return report;
}

// --- memory ---------------------------------------------------------------

template <int D>
Status Builder<D>::CheckMemory() {
  // The block index: one entry per error block and brick, held through the
  // build, and its serialized copy at the end.
  const uint64_t index_entries = SaturatingAdd(layout_.block_count(), bricks_.brick_count());
  const uint64_t index = SaturatingMul(index_entries, sizeof(IndexEntry) + kIndexEntrySize);
  // Pass 1: per thread, a row of bricks as doubles (all of x, a brick's
  // side along the other axes) and one brick's bytes.
  uint64_t row_points = input_.dims[0];
  for (int a = 1; a < D; ++a) {
    row_points = SaturatingMul(row_points, std::min(bricks_.side(), input_.dims[a]));
  }
  const uint64_t brick_points = uint64_t{1} << (bricks_.brick_bits() * D);
  const uint64_t row = SaturatingAdd(SaturatingMul(row_points, sizeof(double)),
                                     SaturatingMul(brick_points, sizeof(double) + 8));
  // Pass 2: per thread, a unit's region (the bounding box of a deepest-band
  // block's root, as doubles) and its codes; per thread and once more, the
  // partial maxima of the nodes above the units (and their availability).
  const int unit_level = layout_.band_start(layout_.bands() - 1);
  const GridSimplex<D> unit_grid =
      GridOf<D>(Vertices(SimplexCode<D>::FromPath(0, 0, unit_level)), k_);
  uint64_t region_points = 1;
  for (int c = 0; c < D; ++c) {
    int64_t lo = unit_grid[0][c], hi = unit_grid[0][c];
    for (int i = 1; i <= D; ++i) {
      lo = std::min(lo, unit_grid[i][c]);
      hi = std::max(hi, unit_grid[i][c]);
    }
    region_points = SaturatingMul(region_points, static_cast<uint64_t>(hi - lo + 1));
  }
  const uint64_t unit_entries = layout_.entries_in_band(layout_.bands() - 1);
  const uint64_t unit = SaturatingAdd(SaturatingMul(region_points, sizeof(double)),
                                      SaturatingMul(unit_entries, sizeof(uint32_t) + 4));
  const uint64_t top_nodes = ((uint64_t{1} << unit_level) - 1) * SimplexCode<D>::kRoots;
  const uint64_t top = SaturatingMul(top_nodes, sizeof(double) + 1);
  // Half the bound is the brick cache's (ComputeErrors); the rest must
  // hold the index, the final maxima, and each thread's share.
  const uint64_t avail = options_.memory_bytes - options_.memory_bytes / 2;
  const uint64_t shared = SaturatingAdd(index, top);
  const uint64_t per_thread = SaturatingAdd(SaturatingAdd(row, unit), top);
  const auto need = [&](uint64_t t) { return SaturatingAdd(shared, SaturatingMul(t, per_thread)); };
  uint64_t threads = static_cast<uint64_t>(threads_);
  if (options_.threads <= 0 && need(threads) > avail && need(1) <= avail) {
    // One per core was not asked for: use as many as the bound holds.
    threads = (avail - shared) / per_thread;
    threads_ = static_cast<int>(threads);
  }
  const uint64_t fixed = need(threads);
  if (fixed <= avail) return Status::OK();
  const uint64_t needed = SaturatingAdd(fixed, fixed);  // with a cache as large
  return Status::ResourceExhausted(
      input_.description + ": building a store of " + FormatDims(D, input_.dims) +
      " (a domain of side 2^" + std::to_string(k_) + ") needs about " + MiB(fixed) +
      " besides the brick cache: the block index of " + std::to_string(index_entries) +
      " blocks, " + MiB(index) + "; the error maxima of " + std::to_string(top_nodes) +
      " top nodes, " + MiB(top) + " once and per thread; " + std::to_string(threads) +
      " threads' rows of bricks and units, " + MiB(SaturatingMul(threads, row)) + " and " +
      MiB(SaturatingMul(threads, unit)) + ". The memory bound (--memory-mb) is " +
      MiB(options_.memory_bytes) + ", half of it for the brick cache" +
      (needed == std::numeric_limits<uint64_t>::max()
           ? std::string(": no memory bound can hold it")
           : ": give at least " + MiB(needed) +
                 (need(1) <= avail
                      ? " (or --threads " + std::to_string((avail - shared) / per_thread) + ")"
                      : std::string())));
}

// --- pass 1 ---------------------------------------------------------------

template <int D>
Status Builder<D>::WriteBricks() {
  // Work items: rows of bricks along x, one per combination of brick
  // coordinates along the other axes.
  uint64_t rows = 1;
  for (int a = 1; a < D; ++a) rows *= bricks_.bricks_along(a);
  std::vector<std::unique_ptr<VolumeReader>> readers(threads_), masks(threads_);
  std::vector<std::unique_ptr<ZstdCompressor>> zstd(threads_);
  for (int w = 0; w < threads_; ++w) {
    SDB_ASSIGN_OR_RETURN(readers[w], VolumeReader::Open(input_));
    if (options_.mask) {
      SDB_ASSIGN_OR_RETURN(masks[w], VolumeReader::Open(*options_.mask));
    }
    zstd[w] = std::make_unique<ZstdCompressor>(options_.zstd_level);
  }
  SDB_RETURN_IF_ERROR(RunParallel(rows, threads_, "field", start_, options_.progress,
                                  [&](int w, uint64_t row) {
                                    return WriteBrickRow(row, *readers[w], masks[w].get(),
                                                         *zstd[w]);
                                  }));
  if (!(field_min_ <= field_max_)) field_min_ = field_max_ = 0;
  return Status::OK();
}

template <int D>
Status Builder<D>::WriteBrickRow(uint64_t row, VolumeReader& reader, VolumeReader* mask,
                                 ZstdCompressor& zstd) {
  const uint32_t side = bricks_.side();
  const auto& dims = input_.dims;
  // Brick coordinates along axes 1..D-1.
  std::array<uint32_t, 4> b = {0, 0, 0, 0};
  uint64_t r = row;
  for (int a = 1; a < D; ++a) {
    b[a] = static_cast<uint32_t>(r % bricks_.bricks_along(a));
    r /= bricks_.bricks_along(a);
  }
  // Read the real rows of this brick row: (y, z, t) within the bricks.
  const uint32_t x_size = dims[0];
  std::array<uint32_t, 4> lo = {0, 0, 0, 0}, count = {x_size, 1, 1, 1};
  for (int a = 1; a < D; ++a) {
    lo[a] = b[a] * side;
    count[a] = std::min(side, dims[a] - lo[a]);
  }
  const uint64_t nrows = uint64_t{count[1]} * count[2] * count[3];
  std::vector<double> values(nrows * x_size), mask_row(mask ? x_size : 0);
  double lmin = std::numeric_limits<double>::infinity(), lmax = -lmin;
  bool missing = false;
  for (uint64_t i = 0; i < nrows; ++i) {
    const uint32_t y = lo[1] + static_cast<uint32_t>(i % count[1]);
    const uint32_t z = lo[2] + static_cast<uint32_t>((i / count[1]) % count[2]);
    const uint32_t t = lo[3] + static_cast<uint32_t>(i / (uint64_t{count[1]} * count[2]));
    const uint64_t first = ((uint64_t{t} * dims[2] + z) * dims[1] + y) * dims[0];
    double* out = values.data() + i * x_size;
    SDB_RETURN_IF_ERROR(reader.Read(first, x_size, out));
    if (mask) {
      SDB_RETURN_IF_ERROR(mask->Read(first, x_size, mask_row.data()));
      ApplyMask(mask_row.data(), x_size, out);
    }
    SDB_RETURN_IF_ERROR(CheckStorableValues(input_, first, out, x_size));
    for (uint32_t x = 0; x < x_size; ++x) {
      // NaN: a missing value. The range and the minima below skip it (a
      // comparison with NaN is false).
      missing = missing || std::isnan(out[x]);
      lmin = std::min(lmin, out[x]);
      lmax = std::max(lmax, out[x]);
    }
  }
  {
    std::lock_guard<std::mutex> lock(stats_mu_);
    field_min_ = std::min(field_min_, lmin);
    field_max_ = std::max(field_max_, lmax);
    has_missing_ = has_missing_ || missing;
  }
  // Cut into bricks: each holds its real points only, x fastest.
  const size_t vsize = VoxelSize(store_type_);
  std::vector<double> brick;
  for (uint32_t bx = 0; bx < bricks_.bricks_along(0); ++bx) {
    const std::array<uint32_t, 4> origin = {bx * side, lo[1], lo[2], lo[3]};
    const uint64_t id = bricks_.Locate(origin).block;
    const std::array<uint32_t, 4> extent = bricks_.BrickExtent(id);
    const uint32_t points = bricks_.PointsInBrick(id);
    brick.resize(points);
    double bmin = std::numeric_limits<double>::infinity(), bmax = -bmin;
    uint32_t e = 0;
    for (uint32_t l3 = 0; l3 < extent[3]; ++l3) {
      for (uint32_t l2 = 0; l2 < extent[2]; ++l2) {
        for (uint32_t l1 = 0; l1 < extent[1]; ++l1) {
          const uint64_t ri = (uint64_t{l3} * count[2] + l2) * count[1] + l1;
          const double* src = values.data() + ri * x_size + origin[0];
          for (uint32_t l0 = 0; l0 < extent[0]; ++l0, ++e) {
            brick[e] = src[l0];
            bmin = std::min(bmin, src[l0]);
            bmax = std::max(bmax, src[l0]);
          }
        }
      }
    }
    std::vector<uint8_t> raw(points * vsize);
    EncodeVoxels(store_type_, ByteOrder::kLittle, brick.data(), points,
                 reinterpret_cast<std::byte*>(raw.data()));
    SDB_ASSIGN_OR_RETURN(StoredBlock stored, EncodeBlock(std::move(raw), options_.compression, zstd));
    IndexEntry& entry = index_[layout_.block_count() + id];
    entry.encoding = stored.encoding;
    entry.raw_size = static_cast<uint32_t>(points * vsize);
    entry.stored_size = static_cast<uint32_t>(stored.bytes.size());
    entry.checksum = Checksum(stored.bytes);
    if (!(bmin <= bmax)) bmin = bmax = 0;  // every value missing
    entry.field_min = RoundDownToFloat(bmin);
    entry.field_max = RoundUpToFloat(bmax);
    if (!stored.bytes.empty()) {
      SDB_ASSIGN_OR_RETURN(entry.offset, writer_->Append(stored.bytes));
    }
  }
  return Status::OK();
}

// --- pass 2 ---------------------------------------------------------------

template <int D>
Result<std::shared_ptr<const BlockCache::Block>> Builder<D>::DecodedBrick(uint64_t brick) {
  // The cache is the builder's own: one store, id 0 (NewStoreId never gives 0).
  const BlockCache::Key key{0, brick};
  if (auto hit = brick_cache_->Lookup(key)) return hit;
  const IndexEntry& e = index_[layout_.block_count() + brick];
  auto block = std::make_shared<BlockCache::Block>(e.raw_size, 0);
  if (e.encoding != BlockEncoding::kZero) {
    const auto stored = brick_file_->bytes().subspan(e.offset, e.stored_size);
    if (e.encoding == BlockEncoding::kRaw) {
      std::memcpy(block->data(), stored.data(), stored.size());
    } else {
      thread_local ZstdDecompressor zstd;
      SDB_RETURN_IF_ERROR(zstd.Decompress(stored, *block, out_ + ": brick " + std::to_string(brick)));
    }
  }
  return brick_cache_->Insert(key, std::move(block));
}

template <int D>
Result<double> Builder<D>::FieldValue(const IPoint<D>& p) {
  std::array<uint32_t, 4> q = {0, 0, 0, 0};
  for (int c = 0; c < D; ++c) {
    q[c] = static_cast<uint32_t>(std::clamp<int64_t>(p[c], 0, input_.dims[c] - 1));
  }
  const BlockSlot slot = bricks_.Locate(q);
  SDB_ASSIGN_OR_RETURN(auto brick, DecodedBrick(slot.block));
  double v;
  DecodeVoxels(store_type_, ByteOrder::kLittle,
               reinterpret_cast<const std::byte*>(brick->data()) + slot.entry * VoxelSize(store_type_),
               1, &v);
  return v;
}

template <int D>
Status Builder<D>::FillRegion(GridRegion<D>& r) {
  const size_t vsize = VoxelSize(store_type_);
  const uint32_t side = bricks_.side();
  // Row by row (all coordinates but x), clamped to the real grid; along x,
  // runs within one brick decoded at once.
  IPoint<D> p = r.lo;
  size_t at = 0;
  const int64_t x_last_real = input_.dims[0] - 1;
  while (true) {
    std::array<uint32_t, 4> q = {0, 0, 0, 0};
    for (int c = 1; c < D; ++c) {
      q[c] = static_cast<uint32_t>(std::min<int64_t>(p[c], input_.dims[c] - 1));
    }
    int64_t x = r.lo[0];
    const int64_t x_real_end = std::min(r.hi[0], x_last_real);
    while (x <= x_real_end) {
      q[0] = static_cast<uint32_t>(x);
      const BlockSlot slot = bricks_.Locate(q);
      const int64_t run = std::min<int64_t>(x_real_end - x + 1, side - (x & (side - 1)));
      SDB_ASSIGN_OR_RETURN(auto brick, DecodedBrick(slot.block));
      DecodeVoxels(store_type_, ByteOrder::kLittle,
                   reinterpret_cast<const std::byte*>(brick->data()) + slot.entry * vsize,
                   static_cast<size_t>(run), r.values.data() + at);
      at += static_cast<size_t>(run);
      x += run;
    }
    // Past the real grid along x: the last real value.
    for (; x <= r.hi[0]; ++x, ++at) r.values[at] = r.values[at - 1];
    if (!NextRow<D>(p, r.lo, r.hi)) break;
  }
  return Status::OK();
}

template <int D>
Status Builder<D>::ComputeErrors() {
  // The bricks are complete: map them for reading back.
  SDB_ASSIGN_OR_RETURN(brick_file_, MappedFile::Open(writer_->temp_path()));
  const double range = field_max_ - field_min_;
  quantizer_ = std::make_unique<ErrorQuantizer>(
      options_.quantization, ErrorQuantizer::QuantumFor(options_.quantization, range), range);
  for (int c = 0; c < D; ++c) rules_.real_hi[c] = static_cast<int64_t>(input_.dims[c]) - 1;
  rules_.range = range;
  rules_.exact = exact_;
  rules_.may_miss = has_missing_;
  const int last_band = layout_.bands() - 1;
  unit_level_ = layout_.band_start(last_band);
  top_per_root_ = (uint64_t{1} << unit_level_) - 1;
  // Memory: half for decoded bricks, half for the workers' units.
  brick_cache_ = std::make_unique<BlockCache>(options_.memory_bytes / 2);
  top_partials_.assign(threads_, std::vector<double>(top_per_root_ * SimplexCode<D>::kRoots, 0));
  if (has_missing_) {
    top_availability_.assign(threads_,
                             std::vector<uint8_t>(top_per_root_ * SimplexCode<D>::kRoots, 0));
  }
  worker_error_max_.assign(threads_, 0);
  const uint64_t units = (uint64_t{1} << unit_level_) * SimplexCode<D>::kRoots;
  // Unit u is the block of the deepest band whose subtree is u-th in order.
  SDB_RETURN_IF_ERROR(RunParallel(units, threads_, "errors", start_, options_.progress,
                                  [&](int w, uint64_t u) { return ProcessUnit(w, u); }));
  return WriteTopBlocks();
}

template <int D>
Status Builder<D>::ProcessUnit(int worker, uint64_t unit) {
  const int top = static_cast<int>(unit >> unit_level_);
  const uint64_t subtree = unit & ((uint64_t{1} << unit_level_) - 1);
  const SimplexCode<D> root = SimplexCode<D>::FromPath(top, subtree, unit_level_);
  const uint64_t block = layout_.Locate(root).block;
  const uint32_t entries = layout_.EntriesInBlock(block);
  thread_local std::unique_ptr<ZstdCompressor> zstd;
  if (!zstd) zstd = std::make_unique<ZstdCompressor>(options_.zstd_level);

  UnitScan<D> scan(rules_, root, GridOf<D>(Vertices(root), k_));
  if (!scan.has_real_points()) {
    // Wholly in the padding: every error is 0, a zero block (no bytes). The
    // common case for padded domains, so no block is materialized.
    IndexEntry& entry = index_[block];
    entry.encoding = BlockEncoding::kZero;
    entry.raw_size = entries * static_cast<uint32_t>(QuantizedSize(options_.quantization));
    entry.checksum = Checksum({});
    entry.field_min = RoundDownToFloat(field_min_);
    entry.field_max = RoundUpToFloat(field_max_);
    return Status::OK();
  }
  SDB_RETURN_IF_ERROR(FillRegion(scan.region()));
  double region_min = std::numeric_limits<double>::infinity(), region_max = -region_min;
  for (const double v : scan.region().values) {  // NaN (missing) compares false: skipped
    region_min = std::min(region_min, v);
    region_max = std::max(region_max, v);
  }
  if (!(region_min <= region_max)) region_min = region_max = 0;

  // The error of every node of the subtree; a node's entry in the block is
  // its heap index within the subtree.
  std::vector<uint32_t> codes(entries, 0);
  double block_max = 0;
  scan.ForEachNode(layout_.leaf_level(), {}, [&](const UnitNode<D>& node) {
    codes[node.entry] = quantizer_->Encode(node.error);
    block_max = std::max(block_max, node.error);
  });
  nodes_.fetch_add(entries, std::memory_order_relaxed);

  // The unit's points, seen from every ancestor above the units: partial
  // maxima of their errors.
  if (unit_level_ > 0) {
    std::array<AncestorInterpolant<D>, UnitScan<D>::kMaxAncestors> ancestors;
    for (int l = 0; l < unit_level_; ++l) {
      const GridSimplex<D> grid = GridOf<D>(Vertices(root.ancestor(l)), k_);
      std::array<double, D + 1> f{};
      for (int i = 0; i <= D; ++i) {
        SDB_ASSIGN_OR_RETURN(f[i], FieldValue(grid[i]));
      }
      ancestors[l] = AncestorInterpolant<D>(rules_, grid, f);
    }
    std::array<double, UnitScan<D>::kMaxAncestors> partial{};
    const Availability a = scan.AncestorPartials({ancestors.data(), size_t(unit_level_)},
                                                 partial.data());
    std::vector<double>& tops = top_partials_[worker];
    for (int l = 0; l < unit_level_; ++l) {
      double& slot = tops[TopIndex(root.ancestor(l))];
      slot = std::max(slot, partial[l]);
    }
    if (has_missing_) {
      // The unit's points count for every ancestor; vertices for their own.
      std::vector<uint8_t>& avail = top_availability_[worker];
      for (int l = 0; l < unit_level_; ++l) {
        avail[TopIndex(root.ancestor(l))] |= static_cast<uint8_t>(
            (a.any_value ? 1 : 0) | (a.any_missing || ancestors[l].vertex_missing() ? 2 : 0));
      }
    }
  }
  worker_error_max_[worker] = std::max(worker_error_max_[worker], block_max);
  return WriteErrorBlock(block, codes, RoundDownToFloat(region_min), RoundUpToFloat(region_max),
                         block_max, *zstd);
}

template <int D>
Status Builder<D>::WriteTopBlocks() {
  if (unit_level_ == 0) return Status::OK();
  std::vector<double> tops(top_per_root_ * SimplexCode<D>::kRoots, 0);
  for (const auto& partial : top_partials_) {
    for (size_t i = 0; i < tops.size(); ++i) tops[i] = std::max(tops[i], partial[i]);
  }
  ZstdCompressor zstd(options_.zstd_level);
  for (uint64_t block = 0; block < layout_.block_count(); ++block) {
    const int band = layout_.BandOfBlock(block);
    if (band == layout_.bands() - 1) continue;
    const SimplexCode<D> root = layout_.BlockRoot(block);
    const uint32_t entries = layout_.EntriesInBlock(block);
    std::vector<uint32_t> codes(entries, 0);
    double block_max = 0;
    // Entry i is the node at local level l = floor(log2(i + 1)).
    for (uint32_t i = 0; i < entries; ++i) {
      int local = 0;
      while ((uint32_t{2} << local) - 1 <= i) ++local;
      const uint64_t local_path = i - ((uint64_t{1} << local) - 1);
      const SimplexCode<D> node = SimplexCode<D>::FromPath(
          root.top(), root.path() << local | local_path, root.level() + local);
      double error = tops[TopIndex(node)];
      if (has_missing_) {
        uint8_t bits = 0;
        for (const auto& avail : top_availability_) bits |= avail[TopIndex(node)];
        error = ErrorGivenAvailability(Availability{(bits & 1) != 0, (bits & 2) != 0}, error,
                                       rules_.range);
      }
      codes[i] = quantizer_->Encode(error);
      block_max = std::max(block_max, error);
    }
    nodes_.fetch_add(entries, std::memory_order_relaxed);
    worker_error_max_[0] = std::max(worker_error_max_[0], block_max);
    // Top blocks span large regions: no useful field range; the global one.
    SDB_RETURN_IF_ERROR(WriteErrorBlock(block, codes, RoundDownToFloat(field_min_),
                                        RoundUpToFloat(field_max_), block_max, zstd));
  }
  return Status::OK();
}

template <int D>
Status Builder<D>::WriteErrorBlock(uint64_t block, const std::vector<uint32_t>& codes,
                                   float field_min, float field_max, double error_max,
                                   ZstdCompressor& zstd) {
  const size_t size = QuantizedSize(options_.quantization);
  std::vector<uint8_t> raw(codes.size() * size);
  for (size_t i = 0; i < codes.size(); ++i) {
    for (size_t b = 0; b < size; ++b) raw[i * size + b] = static_cast<uint8_t>(codes[i] >> (8 * b));
  }
  const uint32_t raw_size = static_cast<uint32_t>(raw.size());
  SDB_ASSIGN_OR_RETURN(StoredBlock stored, EncodeBlock(std::move(raw), options_.compression, zstd));
  IndexEntry& entry = index_[block];
  entry.encoding = stored.encoding;
  entry.raw_size = raw_size;
  entry.stored_size = static_cast<uint32_t>(stored.bytes.size());
  entry.checksum = Checksum(stored.bytes);
  entry.field_min = field_min;
  entry.field_max = field_max;
  // The largest stored (decoded) error, so a reader can trust it as a
  // bound. Decoding is monotone in the stored bits (codes; non-negative
  // floats), so it is the largest entry's.
  const uint32_t largest = codes.empty() ? 0 : *std::max_element(codes.begin(), codes.end());
  entry.error_max = RoundUpToFloat(std::max(quantizer_->Decode(largest), error_max));
  if (!stored.bytes.empty()) {
    SDB_ASSIGN_OR_RETURN(entry.offset, writer_->Append(stored.bytes));
  }
  return Status::OK();
}

// --- pass 3 ---------------------------------------------------------------

template <int D>
Status Builder<D>::Finish(DenseBuildReport& report) {
  brick_file_.reset();
  DenseHeader h;
  h.dimension = static_cast<uint8_t>(D);
  h.quantization = options_.quantization;
  h.voxel_type = store_type_;
  h.domain_bits = static_cast<uint8_t>(k_);
  h.levels_per_block = static_cast<uint8_t>(options_.levels_per_block);
  h.brick_bits = static_cast<uint8_t>(bricks_.brick_bits());
  h.dims = input_.dims;
  h.spacing = input_.spacing;
  h.field_min = field_min_;
  h.field_max = field_max_;
  h.error_max = *std::max_element(worker_error_max_.begin(), worker_error_max_.end());
  h.quantum = quantizer_->quantum();
  h.error_block_count = layout_.block_count();
  h.brick_count = bricks_.brick_count();
  // The header keeps no scaling field: the source says it (info prints it).
  h.source = DescribeSource(input_);
  // The index after the blocks.
  std::vector<uint8_t> index(index_.size() * kIndexEntrySize);
  for (size_t b = 0; b < index_.size(); ++b) {
    SerializeIndexEntry(index_[b], index.data() + b * kIndexEntrySize);
  }
  SDB_ASSIGN_OR_RETURN(h.index_offset, writer_->Append(index));
  h.index_checksum = Checksum(index);
  h.file_size = h.index_offset + index.size();
  SDB_RETURN_IF_ERROR(writer_->WriteAt(0, SerializeHeader(h)));
  SDB_RETURN_IF_ERROR(writer_->Commit());
  report.header = h;
  report.seconds = std::chrono::duration<double>(Clock::now() - start_).count();
  report.grid_points = input_.voxel_count();
  report.nodes = nodes_.load();
  return Status::OK();
}

}  // namespace

Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options) {
  if (options.levels_per_block < 1 || options.levels_per_block > 24) {
    return Status::InvalidArgument("levels per block must be 1..24, not " +
                                   std::to_string(options.levels_per_block));
  }
  if (input.dimension != 3 && input.dimension != 4) {
    return Status::InvalidArgument(input.description + ": volumes must be 3D or 4D");
  }
  // The builder's buffers are bounded by options.memory_bytes, but a budget
  // can exceed what the machine (or ulimit -v) gives; the partial output is
  // removed as the builder unwinds.
  try {
    if (input.dimension == 3) return Builder<3>(input, out_path, options).Run();
    return Builder<4>(input, out_path, options).Run();
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory("building " + out_path + " from " + input.description,
                           "the volume rows, bricks, error blocks and block index; the memory "
                           "budget is " + DescribeByteCount(options.memory_bytes));
  }
}

}  // namespace simplexdb
