// The field a builder reads: a volume's voxels as a store keeps them, with a
// mask's points removed (missing, NaN) and every value checked as storable
// (storage/error/field_values.h). One reader for every builder: the dense
// store's (the whole field, or a plane at a time when it streams) and the
// sparse store's.
//
//   MaskedReader r(input, mask);                 // one per worker
//   Status s = r.Read(first, count, values);     // doubles, NaN where masked
//
//   PlaneReader p(input, mask, threads);         // planes of the last axis
//   Status s = p.Read(lo, hi, "field", start, progress, sink);  // on every worker
//
//   LoadFieldOptions o{.stored = StoredVoxelType(input, masked), .threads = 4};
//   Result<LoadedField<uint8_t>> f = LoadField<uint8_t>(input, mask, o);
//   Result<FieldRange> r = ScanPlanes(input, mask, o, sink);  // no values kept
//
// Thread safety: a MaskedReader is one thread's (it keeps its readers and a
// buffer), a PlaneReader one caller's; PlaneReader::Read and LoadField run
// their own workers and call `progress` from the calling thread.
// Lifetimes: `input` and `mask` are read during the calls only (a
// MaskedReader keeps copies of their descriptions); a LoadedField owns its
// values.
// Errors: those of opening and reading the volume and the mask
// (storage/volume/volume.h: NotFound, IOError, Corruption), and
// CheckStorableValues's InvalidArgument for the first value in file order a
// store cannot hold (an infinity, beyond float32's range), CheckFieldRange's
// for values whose range is beyond float32's. LoadField throws
// std::bad_alloc when the field does not fit in memory (builders catch it
// and report their need).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "storage/error/progress.h"
#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"
#include "util/big_array.h"
#include "util/status.h"

namespace simplexdb {

// Reads runs of a volume's voxels (x fastest), the points its mask marks 0
// (or NaN) as NaN. Opens the readers on first use.
class MaskedReader {
 public:
  MaskedReader(const VolumeInfo& input, const std::optional<VolumeInfo>& mask)
      : input_(input), mask_(mask) {}

  // Voxels [first, first + count) into `out`.
  // REQUIRES: `out` holds count doubles; first + count <= voxel count.
  Status Read(uint64_t first, size_t count, double* out);

 private:
  VolumeInfo input_;
  std::optional<VolumeInfo> mask_;
  std::unique_ptr<VolumeReader> reader_, mask_reader_;
  std::vector<double> mask_values_;
};

// Reads planes of the last axis of a volume (with `mask` applied) on
// `threads` workers (one for a gzip-encoded input: each reader would
// inflate everything before its planes), each with its own MaskedReader
// kept from call to call, so a builder holding a window of planes reads
// each plane once.
class PlaneReader {
 public:
  PlaneReader(const VolumeInfo& input, const std::optional<VolumeInfo>& mask, int threads);

  // Points per plane: the product of every axis's size but the last.
  uint64_t plane_points() const { return plane_; }

  // Calls sink(worker, z, values) for every plane z in [lo, hi), on the
  // workers in any order, `values` the plane's plane_points() doubles
  // (x fastest, NaN where missing), the sink's to change. `phase`,
  // `start`, `progress` as RunParallel's.
  // REQUIRES: 0 <= lo <= hi <= the last axis's size.
  using PlaneSink = std::function<Status(int worker, int64_t z, double* values)>;
  Status Read(int64_t lo, int64_t hi, const char* phase, std::chrono::steady_clock::time_point start,
              const std::function<void(const BuildProgress&)>& progress, const PlaneSink& sink);

 private:
  uint64_t plane_ = 1;
  std::vector<MaskedReader> readers_;
  std::vector<std::vector<double>> buffers_;
};

struct LoadFieldOptions {
  // The voxel type the store keeps (StoredVoxelType): values are rounded to
  // float32 when it is kF32, so the errors are those of the stored values.
  VoxelType stored = VoxelType::kF64;
  int threads = 1;  // workers reading (one for a gzip-encoded input)
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::function<void(const BuildProgress&)> progress;  // phase "field"
  // ScanPlanes: the planes [first_plane, end_plane) of the last axis (-1:
  // to the last), a process's part of a field several share.
  int64_t first_plane = 0, end_plane = -1;
};

// What a pass over a field finds: the range of the values present (both 0
// when none is: `present` false) and whether any is missing.
struct FieldRange {
  double min = 0, max = 0;
  bool missing = false;
  bool present = false;
};

// Reads every plane of the last axis of `input` (those options names) once (with `mask` applied,
// PlaneReader on options.threads workers), checks every value as LoadField
// does, and returns the field's range, each value rounded to float32 first
// when options.stored is kF32. sink(z, values) sees each plane's values so
// rounded (NaN where missing), on the workers, distinct planes at once.
// Errors: LoadField's. Cost: one pass over the input; a plane of doubles
// per worker (twice that with a mask).
Result<FieldRange> ScanPlanes(const VolumeInfo& input, const std::optional<VolumeInfo>& mask,
                              const LoadFieldOptions& options,
                              const std::function<void(int64_t z, const double* values)>& sink);

// The field of a volume, x fastest, as V (the stored type's C++ type: the
// values are exact in it).
template <class V>
struct LoadedField {
  BigArray<V> values;       // NaN where missing (only float V can hold it)
  double min = 0, max = 0;  // over the values present; both 0 when none is
  bool missing = false;     // some value is missing
};

// Reads the whole of `input` (with `mask` applied) in chunks on
// options.threads workers. A missing value in an integer V (a mask on an
// integer type that is not stored as float32) is InvalidArgument.
// Cost: one pass over the input; memory the field (voxels x sizeof(V)) and
// a chunk of 2^20 doubles per worker (twice that with a mask).
template <class V>
Result<LoadedField<V>> LoadField(const VolumeInfo& input, const std::optional<VolumeInfo>& mask,
                                 const LoadFieldOptions& options);

#define SDB_LOAD_FIELD_(V)                                                                    \
  extern template Result<LoadedField<V>> LoadField<V>(                                        \
      const VolumeInfo&, const std::optional<VolumeInfo>&, const LoadFieldOptions&);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_LOAD_FIELD_)
#undef SDB_LOAD_FIELD_

}  // namespace simplexdb
