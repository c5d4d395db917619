// The field a builder reads: a volume's voxels as a store keeps them, with a
// mask's points removed (missing, NaN) and every value checked as storable
// (storage/error/field_values.h). One reader for every builder: the dense
// store's (the whole field, or a plane at a time when it streams) and the
// sparse store's.
//
//   MaskedReader r(input, mask);                 // one per worker
//   Status s = r.Read(first, count, values);     // doubles, NaN where masked
//
//   LoadFieldOptions o{.stored = StoredVoxelType(input, masked), .threads = 4};
//   Result<LoadedField<uint8_t>> f = LoadField<uint8_t>(input, mask, o);
//
// Thread safety: a MaskedReader is one thread's (it keeps its readers and a
// buffer); LoadField runs its own workers and calls `progress` from the
// calling thread.
// Lifetimes: `input` and `mask` are read during the calls only (a
// MaskedReader keeps copies of their descriptions); a LoadedField owns its
// values.
// Errors: those of opening and reading the volume and the mask
// (storage/volume/volume.h: NotFound, IOError, Corruption), and
// CheckStorableValues's InvalidArgument for the first value in file order a
// store cannot hold (an infinity, beyond float32's range). LoadField throws
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

struct LoadFieldOptions {
  // The voxel type the store keeps (StoredVoxelType): values are rounded to
  // float32 when it is kF32, so the errors are those of the stored values.
  VoxelType stored = VoxelType::kF64;
  int threads = 1;  // workers reading (one for a gzip-encoded input)
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::function<void(const BuildProgress&)> progress;  // phase "field"
};

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
