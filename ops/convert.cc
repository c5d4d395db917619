#include "ops/convert.h"

#include <chrono>
#include <cmath>
#include <cstddef>
#include <memory>
#include <new>
#include <vector>

#include <fmt/format.h>

#include "ops/amount.h"
#include "ops/process_memory.h"
#include "ops/read_grid.h"
#include "storage/io/file.h"
#include "storage/volume/volume.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// `s` with `suffix` after its message, the same code.
Status WithSuffix(const Status& s, std::string_view suffix) {
  const std::string m = std::string(s.message()) + std::string(suffix);
  switch (s.code()) {
    case Status::Code::kNotFound: return Status::NotFound(m);
    case Status::Code::kCorruption: return Status::Corruption(m);
    case Status::Code::kIOError: return Status::IOError(m);
    case Status::Code::kNotSupported: return Status::NotSupported(m);
    case Status::Code::kResourceExhausted: return Status::ResourceExhausted(m);
    default: return Status::InvalidArgument(m);
  }
}

// The store's field as a volume in memory of its voxel type, placed and
// named as the store: read one plane of its last axis at a time (the
// doubles of one plane besides the voxels), so the same values reach the
// builder as a file of them would. `missing` counts NaN values.
Result<VolumeInfo> FieldInMemory(const AnyStore& store, const ConvertOptions& options,
                                 Clock::time_point start, uint64_t* missing) {
  const SourceInfo& info = store.info();
  const VoxelType type = StoreVoxelType(store);
  const int last = info.dimension - 1;
  const uint64_t planes = info.dims[last];
  uint64_t n = 1;
  for (int a = 0; a < info.dimension; ++a) n *= info.dims[a];
  const uint64_t per_plane = n / planes;
  std::shared_ptr<std::byte[]> bytes;
  try {
    bytes.reset(new std::byte[n * VoxelSize(type)]);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory("the field of " + info.path, n * VoxelSize(type));
  }
  ExportBox plane = WholeGrid(info);
  *missing = 0;
  for (uint64_t k = 0; k < planes; ++k) {
    plane.lo[last] = plane.hi[last] = static_cast<int64_t>(k);
    SDB_ASSIGN_OR_RETURN(const std::vector<double> values, ReadGridBox(store, plane));
    for (const double v : values) *missing += std::isnan(v) ? 1 : 0;
    if (*missing == 0 || IsFloatType(type)) {
      EncodeVoxels(type, NativeByteOrder(), values.data(), values.size(),
                   bytes.get() + k * per_plane * VoxelSize(type));
    }
    if (options.progress) options.progress({"reading", k + 1, planes, SecondsSince(start)});
  }
  std::shared_ptr<const std::byte> view(bytes, bytes.get());
  const std::string source = store.dense() ? store.dense()->header().source : store.sparse()->header().source;
  SDB_ASSIGN_OR_RETURN(VolumeInfo volume, MemoryVolume(info.dimension, info.dims, type,
                                                       NativeByteOrder(), std::move(view), source));
  volume.spacing = info.spacing;  // the store's placement
  volume.origin = info.origin;
  return volume;
}

}  // namespace

Result<StoreKind> ParseStoreKind(std::string_view text) {
  if (text == "dense") return StoreKind::kDense;
  if (text == "sparse") return StoreKind::kSparse;
  return Status::InvalidArgument(fmt::format("--to: expected dense or sparse, not '{}'", text));
}

Status CheckConvert(const std::string& input, StoreKind from, const ConvertOptions& options) {
  SDB_RETURN_IF_ERROR(CheckAmount(options.tolerance, "--tolerance"));
  if (options.to == StoreKind::kSparse) {
    if (from == StoreKind::kSparse) {
      return Status::InvalidArgument(input + " is already a sparse store; convert it --to dense first");
    }
  } else {
    if (options.tolerance.value != 0) {
      return Status::InvalidArgument("--tolerance applies to --to sparse");
    }
    if (from != StoreKind::kSparse) {
      return Status::InvalidArgument(input +
                                     " is not a sparse store; only sparse stores convert --to dense");
    }
  }
  if (options.threads < 0) {
    return Status::InvalidArgument(
        fmt::format("--threads: expected a count >= 0 (0: one per core), not {}", options.threads));
  }
  return Status::OK();
}

Result<ConvertReport> Convert(const std::string& input, const std::string& output,
                              const ConvertOptions& options) {
  const Clock::time_point start = Clock::now();
  SDB_RETURN_IF_ERROR(CheckConvert(input, ProbeStoreKind(input), options));
  SDB_ASSIGN_OR_RETURN(const AnyStore store, AnyStore::Open(input));
  const SourceInfo& info = store.info();
  uint64_t n = 1;
  for (int a = 0; a < info.dimension; ++a) n *= info.dims[a];
  const bool to_sparse = options.to == StoreKind::kSparse;
  if (options.memory_bytes != 0 && n * sizeof(double) > options.memory_bytes) {
    return Status::ResourceExhausted(fmt::format(
        "{}: converting to a {} store reads the field into memory, {}, more than the bound of {} "
        "(--memory-mb)",
        input, to_sparse ? "sparse" : "dense", HumanBytes(n * sizeof(double)),
        HumanBytes(options.memory_bytes)));
  }
  SDB_RETURN_IF_ERROR(PrepareOutput(output));
  if (!to_sparse) {
    // A store that fails its checksums is not converted (a damaged block the
    // field never reads would otherwise pass unseen).
    const Status verified = store.sparse()->Verify([&](uint64_t done, uint64_t total) {
      if (options.progress) options.progress({"verifying", done, total, SecondsSince(start)});
    });
    if (!verified.ok()) return WithSuffix(verified, "; not converted");
  }
  uint64_t missing = 0;
  SDB_ASSIGN_OR_RETURN(const VolumeInfo field, FieldInMemory(store, options, start, &missing));
  if (to_sparse && missing != 0) {
    return Status::NotSupported(input + ": the field has missing values (NaN); the sparse store "
                                        "does not take them yet (keep the dense store)");
  }
  ImportOptions build;
  build.sparse = to_sparse;
  build.quantization = store.dense() ? store.dense()->header().quantization : store.sparse()->header().quantization;
  build.compression = options.compression;
  build.tolerance = options.tolerance;
  build.memory_bytes = options.memory_bytes;
  build.threads = options.threads;
  build.progress = options.progress;
  SDB_ASSIGN_OR_RETURN(ImportReport built, ImportVolume(field, output, build));
  ConvertReport report;
  report.dense = std::move(built.dense);
  report.sparse = std::move(built.sparse);
  report.seconds = SecondsSince(start);
  return report;
}

}  // namespace simplexdb
