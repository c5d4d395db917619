#include "storage/dense/dense_builder.h"

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>

#include "hierarchy/geometry.h"
#include "storage/dense/dense_build_internal.h"
#include "storage/dense/dense_writer.h"
#include "storage/error/mask.h"  // StoredVoxelType, CheckMaskGrid
#include "storage/io/file.h"
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

}  // namespace dense_build

namespace {

// What every build and plan checks first: a 3D or 4D volume, a mask of its
// grid, a domain a location code holds, a block bitmap within bounds.
// Returns the domain bits.
Result<int> CheckInput(const VolumeInfo& input, const std::string& out_path,
                       const DenseBuildOptions& options) {
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
  SDB_RETURN_IF_ERROR(dense_build::CheckBlockBitmap(input.dimension, input.dims, k, options,
                                                    options.mask.has_value(), out_path,
                                                    input.description));
  return k;
}

int ThreadsFor(const DenseBuildOptions& options) {
  return options.threads > 0 ? options.threads
                             : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

}  // namespace

Result<DenseBuildPlan> PlanDenseBuild(const VolumeInfo& input, const std::string& out_path,
                                      const DenseBuildOptions& options) {
  SDB_ASSIGN_OR_RETURN(const int k, CheckInput(input, out_path, options));
  return WithVoxelCppType(StoredVoxelType(input, options.mask.has_value()), [&](auto voxel) {
    using V = decltype(voxel);
    return input.dimension == 3 ? dense_build::PlanWindows<3, V>(input, out_path, options, k, ThreadsFor(options))
                                : dense_build::PlanWindows<4, V>(input, out_path, options, k, ThreadsFor(options));
  });
}

Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options) {
  const auto start = dense_build::Clock::now();
  // Check the output before the long part (rank 0 of a group: the others
  // may run on other machines, where rank 0's temporary looks abandoned).
  ProcessGroup* group = options.group;
  Status ready = group == nullptr || group->rank() == 0 ? PrepareOutput(out_path) : Status::OK();
  if (group != nullptr) ready = group->Agree(ready);
  SDB_RETURN_IF_ERROR(ready);
  SDB_ASSIGN_OR_RETURN(const int k, CheckInput(input, out_path, options));
  try {
    // The field held as its stored voxels (a byte a point for uint8).
    return WithVoxelCppType(StoredVoxelType(input, options.mask.has_value()), [&](auto voxel) {
      using V = decltype(voxel);
      const int threads = ThreadsFor(options);
      return input.dimension == 3
                 ? dense_build::BuildWindowed<3, V>(input, out_path, options, start, k, threads)
                 : dense_build::BuildWindowed<4, V>(input, out_path, options, start, k, threads);
    });
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory("building " + out_path + " from " + input.description,
                           "the field and the diamond tables; the memory budget is " +
                               DescribeByteCount(options.memory_bytes));
  }
}

}  // namespace simplexdb
