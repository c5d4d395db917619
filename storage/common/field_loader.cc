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

Result<FieldRange> ScanPlanes(const VolumeInfo& input, const std::optional<VolumeInfo>& mask,
                              const LoadFieldOptions& options,
                              const std::function<void(int64_t z, const double* values)>& sink) {
  // What a plane finds is kept by plane, and the first failure's in file
  // order is reported, as a one-thread read would.
  struct PlaneResult {
    Status status;
    bool missing = false;
    double min = std::numeric_limits<double>::infinity(), max = -min;
  };
  const int64_t planes = input.dims[input.dimension - 1];
  std::vector<PlaneResult> found(static_cast<size_t>(planes));
  PlaneReader reader(input, mask, options.threads);
  const uint64_t n = reader.plane_points();
  SDB_RETURN_IF_ERROR(reader.Read(0, planes, "field", options.start, options.progress,
                                  [&](int, int64_t z, double* values) -> Status {
    PlaneResult& result = found[static_cast<size_t>(z)];
    result.status = CheckStorableValues(input, static_cast<uint64_t>(z) * n, values, n);
    for (uint64_t i = 0; i < n && result.status.ok(); ++i) {
      double& v = values[i];
      if (std::isnan(v)) {
        result.missing = true;
        if (!IsFloatType(options.stored)) {
          result.status = Status::InvalidArgument(
              input.description + ": a missing value at voxel " + std::to_string(z * n + i) +
              " in a field stored as integers");
        }
        continue;
      }
      if (options.stored == VoxelType::kF32) v = static_cast<float>(v);
      result.min = std::min(result.min, v);
      result.max = std::max(result.max, v);
    }
    if (result.status.ok()) sink(z, values);
    return Status::OK();
  }));
  FieldRange range;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const PlaneResult& r : found) {
    if (!r.status.ok()) return r.status;
    range.missing = range.missing || r.missing;
    lo = std::min(lo, r.min);
    hi = std::max(hi, r.max);
  }
  if (lo <= hi) {
    range.min = lo;
    range.max = hi;
  }
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
  // chunks). What a chunk finds is kept by chunk, and the first chunk's in
  // file order is reported, as a one-thread read would.
  constexpr uint64_t kChunk = uint64_t{1} << 20;
  const uint64_t chunks = (n + kChunk - 1) / kChunk;
  struct ChunkResult {
    Status status;
    bool missing = false;
    double min = std::numeric_limits<double>::infinity(), max = -min;
  };
  std::vector<ChunkResult> found(chunks);
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
    ChunkResult& result = found[c];
    result.status = CheckStorableValues(input, first, values, count);
    if (!result.status.ok()) return Status::OK();
    V* to = field.values.data() + first;
    for (size_t i = 0; i < count; ++i) {
      double v = values[i];
      if (std::isnan(v)) {
        result.missing = true;
        if constexpr (std::is_floating_point_v<V>) {
          to[i] = std::numeric_limits<V>::quiet_NaN();
        } else {
          result.status = Status::InvalidArgument(
              input.description + ": a missing value at voxel " + std::to_string(first + i) +
              " in a field stored as integers");
          return Status::OK();
        }
        continue;
      }
      if (options.stored == VoxelType::kF32) v = static_cast<float>(v);
      to[i] = static_cast<V>(v);  // exact: V is the stored type
      result.min = std::min(result.min, v);
      result.max = std::max(result.max, v);
    }
    return Status::OK();
  };
  SDB_RETURN_IF_ERROR(
      RunParallel(chunks, readers, "field", options.start, options.progress, read_chunk));
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const ChunkResult& c : found) {
    if (!c.status.ok()) return c.status;
    field.missing = field.missing || c.missing;
    lo = std::min(lo, c.min);
    hi = std::max(hi, c.max);
  }
  if (lo <= hi) {
    field.min = lo;
    field.max = hi;
  }
  return field;
}

#define SDB_LOAD_FIELD_(V)                                           \
  template Result<LoadedField<V>> LoadField<V>(                      \
      const VolumeInfo&, const std::optional<VolumeInfo>&, const LoadFieldOptions&);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_LOAD_FIELD_)
#undef SDB_LOAD_FIELD_

}  // namespace simplexdb
