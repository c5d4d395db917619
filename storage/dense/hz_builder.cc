#include "storage/dense/hz_builder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <thread>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/hz_writer.h"
#include "storage/dense/layout.h"
#include "storage/dense/parallel_run.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"
#include "storage/io/file.h"
#include "util/big_array.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

std::string MiB(uint64_t bytes) {
  return std::to_string((bytes + (uint64_t{1} << 20) - 1) >> 20) + " MiB";
}

// Diamond errors by vertex: a float per point of the real grid grown by two
// points per axis (the finest diamonds of padding vertices reach real
// points from there), a map for the coarser padding vertices beyond.
template <int D>
class DiamondTable {
 public:
  DiamondTable(const std::array<uint32_t, 4>& dims, int k) {
    size_ = 1;
    for (int a = 0; a < D; ++a) {
      extent_[a] = std::min<int64_t>(int64_t{1} << k, int64_t{dims[a]} + 1) + 1;
      stride_[a] = size_;
      size_ *= static_cast<uint64_t>(extent_[a]);
    }
  }
  uint64_t bytes() const { return size_ * sizeof(float); }
  void Allocate() { dense_.assign(size_, 0.0f); }

  void Raise(const std::array<int64_t, D>& g, uint64_t position, float e) {
    float& slot = Slot(g, position);
    slot = std::max(slot, e);
  }
  double At(const std::array<int64_t, D>& g, uint64_t position) const {
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) {
      if (g[a] >= extent_[a]) {
        const auto it = far_.find(position);
        return it == far_.end() ? 0.0 : it->second;
      }
      i += static_cast<uint64_t>(g[a]) * stride_[a];
    }
    return dense_[i];
  }

 private:
  float& Slot(const std::array<int64_t, D>& g, uint64_t position) {
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) {
      if (g[a] >= extent_[a]) return far_[position];
      i += static_cast<uint64_t>(g[a]) * stride_[a];
    }
    return dense_[i];
  }

  std::array<int64_t, D> extent_{};
  std::array<uint64_t, D> stride_{};
  uint64_t size_ = 0;
  std::vector<float> dense_;
  std::unordered_map<uint64_t, float> far_;
};

template <int D>
Result<HzBuildReport> Convert(const DenseStore& f1, const std::string& out,
                              const HzBuildOptions& options, Clock::time_point start) {
  const DenseHeader& f = f1.header();
  const int k = f.domain_bits;
  const int leaf = f.leaf_level();
  const HzOrder<D> order(k);
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));

  DiamondTable<D> table(f.dims, k);
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) n *= f.dims[a];
  const uint64_t writer_bytes = uint64_t(threads) * (uint64_t{1} << options.block_bits) * 40;
  if (table.bytes() + n * sizeof(double) + writer_bytes > options.memory_bytes) {
    return Status::ResourceExhausted(
        out + ": the diamond table needs " + MiB(table.bytes()) + ", the field " +
        MiB(n * sizeof(double)) + " and the writer " + MiB(writer_bytes) +
        ", more than the memory bound of " + MiB(options.memory_bytes) + " (--memory-mb)");
  }
  std::vector<double> field;
  try {
    table.Allocate();
    field.resize(n);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(out + ": the diamond table and the field", table.bytes() + n * 8);
  }

  // Every node holding a real grid point, depth first with its vertices:
  // its stored error raises its diamond's. Nodes past the real grid on some
  // axis have error 0, and so have their descendants.
  HzBuildReport report;
  {
    DenseStore::Reader<D> reader(f1);
    // The field, x fastest, as the format-1 store holds it.
    std::array<int64_t, D> p{};
    for (uint64_t i = 0; i < n; ++i) {
      SDB_ASSIGN_OR_RETURN(field[i], reader.Field(p));
      for (int a = 0; a < D; ++a) {
        if (++p[a] < int64_t{f.dims[a]}) break;
        p[a] = 0;
      }
    }
    struct Frame {
      SimplexCode<D> code;
      SimplexVertices<D> v;
    };
    std::vector<Frame> stack;
    for (int t = SimplexCode<D>::kRoots - 1; t >= 0; --t) {
      stack.push_back({SimplexCode<D>::Root(t), RootVertices<D>(t)});
    }
    uint64_t expected = SimplexCode<D>::kRoots;
    for (int a = 0; a < D; ++a) expected *= f.dims[a];
    auto last = Clock::now();
    while (!stack.empty()) {
      const Frame fr = stack.back();
      stack.pop_back();
      if (fr.code.level() >= leaf) continue;
      bool real = true;
      for (int a = 0; a < D && real; ++a) {
        int64_t lo = std::numeric_limits<int64_t>::max();
        for (int i = 0; i <= D; ++i) lo = std::min(lo, LatticeToGrid<D>(fr.v[i], k)[a]);
        real = lo <= int64_t{f.dims[a]} - 1;
      }
      if (!real) continue;
      ++report.nodes;
      SDB_ASSIGN_OR_RETURN(const double e, reader.ErrorBound(fr.code));
      if (e > 0) {
        const auto g = LatticeToGrid<D>(SplitMidpoint<D>(fr.code, fr.v), k);
        table.Raise(g, order.PositionAtLevel(g, fr.code.level()), RoundUpToFloat(e));
      }
      for (int i = 1; i >= 0; --i) {
        stack.push_back({fr.code.child(i), ChildVertices<D>(fr.code, fr.v, i)});
      }
      if (options.progress && (report.nodes & 0xfffff) == 0 && Clock::now() - last > std::chrono::milliseconds(250)) {
        last = Clock::now();
        options.progress({"diamonds", std::min(report.nodes, expected), expected,
                          std::chrono::duration<double>(last - start).count()});
      }
    }
  }

  HzHeader params;
  params.dimension = static_cast<uint8_t>(D);
  params.quantization = options.quantization;
  params.voxel_type = f.voxel_type;
  params.domain_bits = static_cast<uint8_t>(k);
  params.block_bits = static_cast<uint8_t>(options.block_bits);
  params.brick_bits = static_cast<uint8_t>(HzDefaultBrickBits(D));
  // The errors are the engine's per-node bounds, not what a reader would
  // compute for the finest octave: keep them all.
  params.flags = kHzFinestStored;
  params.dims = f.dims;
  params.spacing = f.spacing;
  params.field_min = f.field_min;
  params.field_max = f.field_max;
  params.source = f.source;

  HzWriteOptions write;
  write.compression = options.compression;
  write.zstd_level = options.zstd_level;
  write.threads = threads;
  write.errors_are_bounds = true;
  write.progress = options.progress;
  const auto fill = [&](int, uint64_t first, size_t count, double* errors) -> Status {
    for (size_t i = 0; i < count; ++i) {
      std::array<int64_t, D> g{};
      if (order.Decode(first + i, g)) errors[i] = table.At(g, first + i);
    }
    return Status::OK();
  };
  SDB_ASSIGN_OR_RETURN(report.header, WriteHzStore(out, params, write, fill, field.data(), nullptr));
  report.grid_points = n;
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

// The direct build: the whole field in memory (as V, the stored voxel
// type's C++ type), diamond errors octave by octave on every core
// (storage/error/diamond_errors.h), then the writer. Returns nullopt,
// having written nothing, when the volume has missing values (NaN): the
// caller then takes the engine's path. ResourceExhausted when the field
// and the table exceed the memory bound.
template <int D, class V>
Result<std::optional<HzBuildReport>> BuildDirect(const VolumeInfo& input, const std::string& out,
                                                 const HzBuildOptions& options,
                                                 Clock::time_point start) {
  std::array<int64_t, D> dims{};
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = input.dims[a];
    n *= input.dims[a];
  }
  const int k = std::max(1, DomainBitsFor(D, input.dims));
  if (k > (D == 3 ? 18 : 13)) return std::optional<HzBuildReport>();  // the engine says why
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  constexpr uint64_t kChunk = uint64_t{1} << 20;  // voxels a worker reads at a time
  const uint64_t field_bytes = n * sizeof(V);
  const uint64_t table_bytes = DiamondErrors<D, V>::TableBytes(dims, k);
  const uint64_t writer_bytes = uint64_t(threads) * (uint64_t{1} << options.block_bits) * 40;
  const uint64_t reader_bytes =
      std::is_same_v<V, double> ? 0 : uint64_t(threads) * std::min(n, kChunk) * sizeof(double);
  if (field_bytes + table_bytes + writer_bytes + reader_bytes > options.memory_bytes) {
    // The engine's path needs the field and the table too.
    return Status::ResourceExhausted(
        out + ": the field needs " + MiB(field_bytes) + ", the diamond table " + MiB(table_bytes) +
        ", the reader and the writer " + MiB(reader_bytes + writer_bytes) +
        ", more than the memory bound of " + MiB(options.memory_bytes) +
        " (--memory-mb); format 2 is built in memory for now");
  }

  // The field, checked as every store's (finite, float32 range) and held
  // as the store keeps it (a scaled volume's values rounded to float32), so
  // the errors are those of the stored values.
  const VoxelType stored = StoredVoxelType(input, false);
  // Its pages are zeroed by the workers that first write them (zeroing it
  // up front, on one thread, took a twentieth of a build).
  BigArray<V> field(n);
  // Read in chunks by every worker, each with its own reader (a gzip file
  // is read by one: each reader would inflate everything before its
  // chunks). What a chunk finds is kept by chunk, and the first chunk's in
  // file order is reported, as a one-thread read would.
  const uint64_t chunks = (n + kChunk - 1) / kChunk;
  struct ChunkResult {
    Status status;
    bool missing = false;  // a NaN: the engine's path
    double min = std::numeric_limits<double>::infinity(), max = -min;
  };
  std::vector<ChunkResult> found(chunks);
  const int readers = input.encoding == VolumeInfo::Encoding::kGzip ? 1 : threads;
  std::vector<std::unique_ptr<VolumeReader>> reader(static_cast<size_t>(readers));
  // Readers give doubles: a field of other voxels is read through a chunk
  // of them.
  std::vector<std::vector<double>> scratch(static_cast<size_t>(readers));
  const auto read_chunk = [&](int worker, uint64_t c) -> Status {
    auto& r = reader[static_cast<size_t>(worker)];
    if (r == nullptr) {
      SDB_ASSIGN_OR_RETURN(r, VolumeReader::Open(input));
    }
    const uint64_t first = c * kChunk;
    const size_t count = static_cast<size_t>(std::min(kChunk, n - first));
    double* values;
    if constexpr (std::is_same_v<V, double>) {
      values = field.data() + first;
    } else {
      auto& buffer = scratch[static_cast<size_t>(worker)];
      buffer.resize(count);
      values = buffer.data();
    }
    SDB_RETURN_IF_ERROR(r->Read(first, count, values));
    ChunkResult& result = found[c];
    result.status = CheckStorableValues(input, first, values, count);
    if (!result.status.ok()) return Status::OK();
    V* to = field.data() + first;
    for (size_t i = 0; i < count; ++i) {
      if (std::isnan(values[i])) {
        result.missing = true;
        return Status::OK();
      }
      if (stored == VoxelType::kF32) values[i] = static_cast<float>(values[i]);
      to[i] = static_cast<V>(values[i]);  // exact: V is the stored type
      result.min = std::min(result.min, values[i]);
      result.max = std::max(result.max, values[i]);
    }
    return Status::OK();
  };
  SDB_RETURN_IF_ERROR(RunParallel(chunks, readers, "field", start, options.progress, read_chunk));
  reader.clear();
  scratch.clear();
  double fmin = std::numeric_limits<double>::infinity(), fmax = -fmin;
  for (const ChunkResult& c : found) {
    if (!c.status.ok()) return c.status;
    if (c.missing) return std::optional<HzBuildReport>();
    fmin = std::min(fmin, c.min);
    fmax = std::max(fmax, c.max);
  }

  DiamondErrors<D, V> diamonds(field.data(), dims, k, !IsFloatType(stored), fmax - fmin, threads);
  diamonds.Allocate();
  // Work items: the coarser octaves' slabs (the table), then each grid
  // brick's largest finest error (the store keeps that, not the errors:
  // its reader computes them as these do).
  const BrickGrid grid(D, input.dims, k, HzDefaultBrickBits(D));
  std::vector<double> finest_max(grid.Count(0), 0.0);
  const uint64_t slabs = diamonds.item_count();
  SDB_RETURN_IF_ERROR(RunParallel(slabs + grid.Count(0), threads, "errors", start,
                                  options.progress, [&](int worker, uint64_t item) {
                                    if (item < slabs) {
                                      diamonds.ComputeItem(worker, item);
                                      return Status::OK();
                                    }
                                    const BrickGrid::Box box =
                                        grid.FinestBox(grid.FirstBrick(0) + item - slabs);
                                    std::array<int64_t, D> first{}, extent{};
                                    for (int a = 0; a < D; ++a) {
                                      first[a] = box.first[a];
                                      extent[a] = box.extent[a];
                                    }
                                    finest_max[item - slabs] = diamonds.FinestBoxMax(first, extent);
                                    return Status::OK();
                                  }));
  diamonds.Finish();

  HzHeader params;
  params.dimension = static_cast<uint8_t>(D);
  params.quantization = options.quantization;
  params.voxel_type = stored;
  params.domain_bits = static_cast<uint8_t>(k);
  params.block_bits = static_cast<uint8_t>(options.block_bits);
  params.brick_bits = static_cast<uint8_t>(HzDefaultBrickBits(D));
  params.dims = input.dims;
  params.spacing = input.spacing;
  params.field_min = fmin;
  params.field_max = fmax;
  params.scale_slope = input.scale;
  params.scale_intercept = input.shift;
  params.source = DescribeSource(input);
  const HzOrder<D> order(k);
  HzWriteOptions write;
  write.compression = options.compression;
  write.zstd_level = options.zstd_level;
  write.threads = threads;
  write.progress = options.progress;
  // HZ order is not the table's: the positions' vertices are found a batch
  // at a time and their entries asked for before any is read.
  const auto fill = [&](int, uint64_t first, size_t count, double* errors) -> Status {
    constexpr size_t kBatch = 64;
    std::array<std::array<int64_t, D>, kBatch> g{};
    std::array<bool, kBatch> vertex{};
    for (size_t base = 0; base < count; base += kBatch) {
      const size_t batch = std::min(kBatch, count - base);
      for (size_t i = 0; i < batch; ++i) {
        vertex[i] = order.Decode(first + base + i, g[i]);
        if (vertex[i]) diamonds.Prefetch(g[i]);
      }
      for (size_t i = 0; i < batch; ++i) {
        if (vertex[i]) errors[base + i] = diamonds.At(g[i], first + base + i);
      }
    }
    return Status::OK();
  };
  HzBuildReport report;
  SDB_ASSIGN_OR_RETURN(report.header,
                       WriteHzStore(out, params, write, fill, field.data(), finest_max.data()));
  report.grid_points = n;
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return std::optional<HzBuildReport>(report);
}

// The store's block bitmap covers the padded domain: a bit per block of
// 2^block_bits positions (2^(D k) of them, 2^(D (k + 1)) when the finest
// octave is stored), which the writer walks and a reader holds. Padding
// costs nothing else, but a grid far longer on one axis than the others
// (a domain of side 2^18 for 200000x2x2) would make the bitmap itself
// terabytes: refused, with the figures, before anything is computed.
Status CheckBlockBitmap(int dimension, const std::array<uint32_t, 4>& dims, int k,
                        const HzBuildOptions& options, bool finest_stored,
                        const std::string& out, const std::string& what) {
  const int position_bits = dimension * (k + (finest_stored ? 1 : 0));
  const int block_bits = std::min(options.block_bits, position_bits);
  const int bitmap_bits = position_bits - block_bits;  // log2 of the virtual blocks
  constexpr int kMaxBits = 30;  // a 128 MiB bitmap, walked in seconds
  const uint64_t bytes = bitmap_bits >= 3 ? uint64_t{1} << std::min(bitmap_bits - 3, 60) : 1;
  if (bitmap_bits <= kMaxBits && bytes <= options.memory_bytes) return Status::OK();
  std::string grid;
  for (int a = 0; a < dimension; ++a) {
    if (a > 0) grid += 'x';
    grid += std::to_string(dims[a]);
  }
  return Status::ResourceExhausted(
      out + ": " + what + " (" + grid + ") has a domain of side 2^" + std::to_string(k) +
      " + 1, whose block index of 2^" + std::to_string(bitmap_bits) +
      " virtual blocks needs a bitmap of " + MiB(bytes) + "; this build indexes at most 2^" +
      std::to_string(kMaxBits) + " blocks within the memory bound of " + MiB(options.memory_bytes) +
      " (--memory-mb): cut the volume into pieces closer to a cube");
}

}  // namespace

Result<HzBuildReport> ConvertToHz(const DenseStore& f1, const std::string& out_path,
                                  const HzBuildOptions& options) {
  const auto start = Clock::now();
  SDB_RETURN_IF_ERROR(CheckBlockBitmap(f1.dimension(), f1.header().dims,
                                       f1.header().domain_bits, options, true, out_path,
                                       f1.path()));
  if (f1.dimension() == 3) return Convert<3>(f1, out_path, options, start);
  return Convert<4>(f1, out_path, options, start);
}

Result<HzBuildReport> BuildHzStore(const VolumeInfo& input, const std::string& out_path,
                                   const HzBuildOptions& options) {
  const auto start = Clock::now();
  // Check the output before the long part.
  SDB_RETURN_IF_ERROR(PrepareOutput(out_path));
  if (input.dimension == 3 || input.dimension == 4) {
    SDB_RETURN_IF_ERROR(CheckBlockBitmap(input.dimension, input.dims,
                                         std::max(1, DomainBitsFor(input.dimension, input.dims)),
                                         options, options.mask.has_value(), out_path,
                                         input.description));
  }
  if (!options.mask && (input.dimension == 3 || input.dimension == 4)) {
    try {
      std::optional<HzBuildReport> direct;
      // The field held as its stored voxels (a byte a point for uint8).
      Result<std::optional<HzBuildReport>> built =
          WithVoxelCppType(StoredVoxelType(input, false), [&](auto voxel) {
            using V = decltype(voxel);
            return input.dimension == 3 ? BuildDirect<3, V>(input, out_path, options, start)
                                        : BuildDirect<4, V>(input, out_path, options, start);
          });
      SDB_ASSIGN_OR_RETURN(direct, std::move(built));
      if (direct) return *direct;
    } catch (const std::bad_alloc&) {
      return NotEnoughMemory("building " + out_path + " from " + input.description,
                             "the field and the diamond table; the memory budget is " +
                                 DescribeByteCount(options.memory_bytes));
    }
  }
  // Missing values or a mask: per node through format 1's engine, in a
  // scratch store beside the output.
  TemporaryFile scratch(out_path, "errors");
  DenseBuildOptions f1;
  f1.quantization = Quantization::kF32;
  f1.compression = Compression::kNone;
  f1.memory_bytes = options.memory_bytes;
  f1.threads = options.threads;
  f1.mask = options.mask;
  f1.progress = options.progress;
  SDB_RETURN_IF_ERROR(BuildDenseStore(input, scratch.path(), f1).status());
  SDB_ASSIGN_OR_RETURN(auto store, DenseStore::Open(scratch.path()));
  SDB_ASSIGN_OR_RETURN(HzBuildReport report, ConvertToHz(*store, out_path, options));
  report.method = "engine";
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

}  // namespace simplexdb
