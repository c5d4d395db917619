#include "storage/common/field_loader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>

#include "storage/common/parallel_run.h"
#include "storage/error/field_values.h"
#include "storage/error/mask.h"

namespace simplexdb {

Status MaskedReader::Read(uint64_t first, size_t count, double* out) {
  if (reader_ == nullptr) {
    SDB_ASSIGN_OR_RETURN(reader_, VolumeReader::Open(input_));
  }
  SDB_RETURN_IF_ERROR(reader_->Read(first, count, out));
  if (!mask_) return Status::OK();
  if (mask_reader_ == nullptr) {
    SDB_ASSIGN_OR_RETURN(mask_reader_, VolumeReader::Open(*mask_));
  }
  mask_values_.resize(count);
  SDB_RETURN_IF_ERROR(mask_reader_->Read(first, count, mask_values_.data()));
  ApplyMask(mask_values_.data(), count, out);
  return Status::OK();
}

PlaneReader::PlaneReader(const VolumeInfo& input, const std::optional<VolumeInfo>& mask, int threads) {
  for (int a = 0; a + 1 < input.dimension; ++a) plane_ *= input.dims[a];
  const int workers = input.encoding == VolumeInfo::Encoding::kGzip ? 1 : std::max(1, threads);
  for (int w = 0; w < workers; ++w) readers_.emplace_back(input, mask);
  buffers_.resize(static_cast<size_t>(workers));
}

Status PlaneReader::Read(int64_t lo, int64_t hi, const char* phase,
                         std::chrono::steady_clock::time_point start,
                         const std::function<void(const BuildProgress&)>& progress,
                         const PlaneSink& sink) {
  if (lo >= hi) return Status::OK();
  return RunParallel(static_cast<uint64_t>(hi - lo), static_cast<int>(readers_.size()), phase, start,
                     progress, [&](int w, uint64_t i) -> Status {
    const int64_t z = lo + static_cast<int64_t>(i);
    std::vector<double>& values = buffers_[static_cast<size_t>(w)];
    values.resize(plane_);
    SDB_RETURN_IF_ERROR(
        readers_[static_cast<size_t>(w)].Read(static_cast<uint64_t>(z) * plane_, plane_, values.data()));
    return sink(w, z, values.data());
  });
}

namespace {

// What a part of the field (a chunk, a plane) finds. Parts are kept apart
// and merged in file order, so that the first failure reported is the
// first in file order, as a one-thread read would find it.
struct PartResult {
  Status status;
  bool missing = false;
  double min = std::numeric_limits<double>::infinity(), max = -min;

  // Checks values[0, count), voxels first.. of `input`, as a store keeps
  // them: each storable, rounded to float32 in place when `stored` is
  // kF32, NaN missing (refused for a field stored as integers).
  void Scan(const VolumeInfo& input, VoxelType stored, uint64_t first, double* values, size_t count) {
    status = CheckStorableValues(input, first, values, count);
    for (size_t i = 0; i < count && status.ok(); ++i) {
      double& v = values[i];
      if (std::isnan(v)) {
        missing = true;
        if (!IsFloatType(stored)) {
          status = Status::InvalidArgument(input.description + ": a missing value at voxel " +
                                           std::to_string(first + i) + " in a field stored as integers");
        }
        continue;
      }
      if (stored == VoxelType::kF32) v = static_cast<float>(v);
      min = std::min(min, v);
      max = std::max(max, v);
    }
  }
};

Result<FieldRange> Merge(const std::vector<PartResult>& parts) {
  FieldRange range;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const PartResult& r : parts) {
    if (!r.status.ok()) return r.status;
    range.missing = range.missing || r.missing;
    lo = std::min(lo, r.min);
    hi = std::max(hi, r.max);
  }
  if (lo <= hi) {
    range.present = true;
    range.min = lo;
    range.max = hi;
  }
  return range;
}

}  // namespace

Result<FieldRange> ScanPlanes(const VolumeInfo& input, const std::optional<VolumeInfo>& mask,
                              const LoadFieldOptions& options,
                              const std::function<void(int64_t z, const double* values)>& sink) {
  const int64_t planes = input.dims[input.dimension - 1];
  const int64_t lo = std::min(options.first_plane, planes);
  const int64_t hi = options.end_plane < 0 ? planes : std::clamp(options.end_plane, lo, planes);
  std::vector<PartResult> found(static_cast<size_t>(hi - lo));
  PlaneReader reader(input, mask, options.threads);
  const uint64_t n = reader.plane_points();
  SDB_RETURN_IF_ERROR(reader.Read(lo, hi, "field", options.start, options.progress,
                                  [&](int, int64_t z, double* values) -> Status {
    PartResult& result = found[static_cast<size_t>(z - lo)];
    result.Scan(input, options.stored, static_cast<uint64_t>(z) * n, values, n);
    if (result.status.ok()) sink(z, values);
    return Status::OK();
  }));
  SDB_ASSIGN_OR_RETURN(const FieldRange range, Merge(found));
  SDB_RETURN_IF_ERROR(CheckFieldRange(input, range.min, range.max));
  return range;
}

template <class V>
Result<LoadedField<V>> LoadField(const VolumeInfo& input, const std::optional<VolumeInfo>& mask,
                                 const LoadFieldOptions& options) {
  const uint64_t n = input.voxel_count();
  LoadedField<V> field;
  // Its pages are zeroed by the workers that first write them (zeroing it
  // up front, on one thread, took a twentieth of a build).
  field.values = BigArray<V>(n);
  // Read in chunks by every worker, each with its own reader (a gzip file
  // is read by one: each reader would inflate everything before its
  // chunks).
  constexpr uint64_t kChunk = uint64_t{1} << 20;
  const uint64_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<PartResult> found(chunks);
  const int readers =
      input.encoding == VolumeInfo::Encoding::kGzip ? 1 : std::max(1, options.threads);
  std::vector<MaskedReader> reader;
  for (int w = 0; w < readers; ++w) reader.emplace_back(input, mask);
  // Readers give doubles: a field of other voxels is read through a chunk
  // of them.
  std::vector<std::vector<double>> scratch(static_cast<size_t>(readers));
  const auto read_chunk = [&](int worker, uint64_t c) -> Status {
    const uint64_t first = c * kChunk;
    const size_t count = static_cast<size_t>(std::min(kChunk, n - first));
    double* values;
    if constexpr (std::is_same_v<V, double>) {
      values = field.values.data() + first;
    } else {
      auto& buffer = scratch[static_cast<size_t>(worker)];
      buffer.resize(count);
      values = buffer.data();
    }
    SDB_RETURN_IF_ERROR(reader[static_cast<size_t>(worker)].Read(first, count, values));
    PartResult& result = found[c];
    result.Scan(input, options.stored, first, values, count);
    if (!result.status.ok()) return Status::OK();
    if constexpr (!std::is_same_v<V, double>) {
      // Exact: V is the stored type; NaN only where V is a float (Scan
      // refuses it in a field stored as integers).
      V* to = field.values.data() + first;
      for (size_t i = 0; i < count; ++i) to[i] = static_cast<V>(values[i]);
    }
    return Status::OK();
  };
  SDB_RETURN_IF_ERROR(
      RunParallel(chunks, readers, "field", options.start, options.progress, read_chunk));
  SDB_ASSIGN_OR_RETURN(const FieldRange range, Merge(found));
  SDB_RETURN_IF_ERROR(CheckFieldRange(input, range.min, range.max));
  field.min = range.min;
  field.max = range.max;
  field.missing = range.missing;
  return field;
}

#define SDB_LOAD_FIELD_(V)                                           \
  template Result<LoadedField<V>> LoadField<V>(                      \
      const VolumeInfo&, const std::optional<VolumeInfo>&, const LoadFieldOptions&);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_LOAD_FIELD_)
#undef SDB_LOAD_FIELD_

}  // namespace simplexdb
