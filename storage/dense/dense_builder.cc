#include "storage/dense/dense_builder.h"

#include <algorithm>
#include <chrono>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <thread>
#include <type_traits>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/dense_build_internal.h"
#include "storage/dense/dense_writer.h"
#include "storage/error/quantize.h"
#include "storage/common/field_loader.h"
#include "storage/common/parallel_run.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"  // StoredVoxelType
#include "storage/io/file.h"
#include "util/big_array.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace dense_build {

std::string MiB(uint64_t bytes) {
  return std::to_string((bytes + (uint64_t{1} << 20) - 1) >> 20) + " MiB";
}

Status CheckBlockBitmap(int dimension, const std::array<uint32_t, 4>& dims, int k,
                        const DenseBuildOptions& options, bool finest_stored,
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


DenseHeader ParamsFor(int dimension, const VolumeInfo& input, const DenseBuildOptions& options,
                      VoxelType stored, int k, double fmin, double fmax) {
  DenseHeader params;
  params.dimension = static_cast<uint8_t>(dimension);
  params.quantization = options.quantization;
  params.voxel_type = stored;
  params.domain_bits = static_cast<uint8_t>(k);
  params.block_bits = static_cast<uint8_t>(options.block_bits);
  params.brick_bits = static_cast<uint8_t>(DenseDefaultBrickBits(dimension));
  params.dims = input.dims;
  params.spacing = input.spacing;
  params.origin = input.origin;
  params.field_min = fmin;
  params.field_max = fmax;
  params.scale_slope = input.scale;
  params.scale_intercept = input.shift;
  params.source = DescribeSource(input);
  return params;
}

DenseWriteOptions WriteOptionsFor(const DenseBuildOptions& options, int threads) {
  DenseWriteOptions write;
  write.compression = options.compression;
  write.zstd_level = options.zstd_level;
  write.threads = threads;
  return write;
}

namespace {

// The direct build: the whole field in memory (as V, the stored voxel
// type's C++ type), diamond errors octave by octave on every core
// (storage/error/diamond_errors.h), then the writer. When the field and the
// table exceed the memory bound, the streamed build, or ResourceExhausted
// when even that does not fit.
template <int D, class V>
Result<DenseBuildReport> BuildDirect(const VolumeInfo& input, const std::string& out,
                                     const DenseBuildOptions& options, Clock::time_point start) {
  std::array<int64_t, D> dims{};
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = input.dims[a];
    n *= input.dims[a];
  }
  const int k = std::max(1, DomainBitsFor(D, input.dims));
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  constexpr uint64_t kChunk = uint64_t{1} << 20;  // voxels a worker reads at a time
  const uint64_t field_bytes = n * sizeof(V);
  const uint64_t table_bytes = DiamondErrors<D, V>::TableBytes(dims, k);
  const uint64_t writer_bytes = uint64_t(threads) * (uint64_t{1} << options.block_bits) * 40;
  const uint64_t reader_bytes =
      uint64_t(threads) * std::min(n, kChunk) * sizeof(double) *
      ((std::is_same_v<V, double> ? 0 : 1) + (options.mask ? 1 : 0));
  if (field_bytes + table_bytes + writer_bytes + reader_bytes > options.memory_bytes ||
      options.stream) {
    // The field a window at a time, when the grid is large enough for it
    // (every grid that does not fit is).
    std::string streamed;
    if (const auto bytes = StreamedBytes<D, V>(input, options, k, threads)) {
      if (*bytes <= options.memory_bytes) return BuildStreamed<D, V>(input, out, options, start, k, threads);
      streamed = "; streamed, a window of planes at a time, it needs " + MiB(*bytes);
    }
    return Status::ResourceExhausted(
        out + ": the field needs " + MiB(field_bytes) + ", the diamond table " + MiB(table_bytes) +
        ", the reader and the writer " + MiB(reader_bytes + writer_bytes) + streamed +
        ", more than the memory bound of " + MiB(options.memory_bytes) + " (--memory-mb)");
  }

  // The field, checked as every store's (finite, float32 range) and held
  // as the store keeps it (a scaled volume's values rounded to float32; a
  // masked integer volume as float32, so masked points hold NaN), so the
  // errors are those of the stored values.
  const VoxelType stored = StoredVoxelType(input, options.mask.has_value());
  LoadFieldOptions load;
  load.stored = stored;
  load.threads = threads;
  load.start = start;
  load.progress = options.progress;
  SDB_ASSIGN_OR_RETURN(LoadedField<V> loaded, LoadField<V>(input, options.mask, load));
  const BigArray<V>& field = loaded.values;
  const double fmin = loaded.min, fmax = loaded.max;
  const bool missing = loaded.missing;
  if (missing && !options.mask) {
    SDB_RETURN_IF_ERROR(CheckBlockBitmap(D, input.dims, k, options, true, out, input.description));
  }

  // With missing values every diamond is scanned (DiamondErrors), the
  // finest octave's too: the store keeps them all.
  DiamondErrors<D, V> diamonds(field.data(), dims, k, !IsFloatType(stored), fmax - fmin, threads,
                               true, missing);
  diamonds.Allocate();
  // Work items: the coarser octaves' slabs (the table), then each grid
  // brick's largest finest error (the store keeps that, not the errors:
  // its reader computes them as these do).
  const BrickGrid grid(D, input.dims, k, DenseDefaultBrickBits(D));
  std::vector<double> finest_max(missing ? 0 : grid.Count(0), 0.0);
  const uint64_t slabs = diamonds.item_count();
  SDB_RETURN_IF_ERROR(RunParallel(slabs + finest_max.size(), threads, "errors", start,
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

  DenseHeader params = ParamsFor(D, input, options, stored, k, fmin, fmax);
  const HzOrder<D> order(k);
  DenseWriteOptions write = WriteOptionsFor(options, threads);
  write.progress = options.progress;
  if (missing) params.flags = kDenseFinestStored;  // the reader's stencils cannot compute them
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
  DenseBuildReport report;
  SDB_ASSIGN_OR_RETURN(report.header,
                       WriteDenseStore(out, params, write, fill, field.data(),
                                       missing ? nullptr : finest_max.data()));
  report.grid_points = n;
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

}  // namespace
}  // namespace dense_build

using dense_build::CheckBlockBitmap;

Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options) {
  const auto start = dense_build::Clock::now();
  // Check the output before the long part.
  SDB_RETURN_IF_ERROR(PrepareOutput(out_path));
  if (input.dimension != 3 && input.dimension != 4) {
    return Status::InvalidArgument(input.description + ": volumes must be 3D or 4D");
  }
  if (options.mask) {
    SDB_RETURN_IF_ERROR(CheckMaskGrid(*options.mask, input.dimension, input.dims,
                                      "the volume " + input.description + " is"));
  }
  const int k = std::max(1, DomainBitsFor(input.dimension, input.dims));
  const int max_bits = input.dimension == 3 ? 18 : 13;
  if (k > max_bits) {
    return Status::InvalidArgument(
        input.description + ": a grid of this size needs a domain of side 2^" +
        std::to_string(k) + ", beyond the deepest level a 64-bit location code holds (2^" +
        std::to_string(max_bits) + " per axis)");
  }
  // A mask means missing values, whose finest errors are stored; NaN in the
  // input, found while reading, are checked again then.
  SDB_RETURN_IF_ERROR(CheckBlockBitmap(input.dimension, input.dims, k, options,
                                       options.mask.has_value(), out_path, input.description));
  try {
    // The field held as its stored voxels (a byte a point for uint8).
    return WithVoxelCppType(StoredVoxelType(input, options.mask.has_value()), [&](auto voxel) {
      using V = decltype(voxel);
      return input.dimension == 3 ? dense_build::BuildDirect<3, V>(input, out_path, options, start)
                                  : dense_build::BuildDirect<4, V>(input, out_path, options, start);
    });
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory("building " + out_path + " from " + input.description,
                           "the field and the diamond table; the memory budget is " +
                               DescribeByteCount(options.memory_bytes));
  }
}

}  // namespace simplexdb
