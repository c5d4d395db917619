// Masks: where the field is available. A mask is a volume of the input's
// grid, 0 (or NaN) where the field is missing; masked points become missing
// values (NaN) before any error is computed, in every builder and in the
// sparse store's update alike (docs/format/dense-store.md, "Errors").
//
// Thread safety: pure functions; reentrant.
// Lifetimes: nothing is kept; ApplyMask writes the caller's buffer only.
// Errors: CheckMaskGrid returns InvalidArgument (below); the others cannot
// fail.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// The voxel type a store of an `input` volume keeps: float32 for integers
// with a mask, so masked points can hold NaN (exact for every 8- and 16-bit
// value); `input` otherwise.
VoxelType StoredVoxelType(VoxelType input, bool masked);
// The same for a volume: also float32 for a scaled() integer volume (its
// values are not integers any more); a scaled float64 volume stays float64.
VoxelType StoredVoxelType(const VolumeInfo& input, bool masked);

// values[i] becomes NaN where mask[i] is 0 or NaN, for i < count.
// REQUIRES: both buffers hold `count` values.
void ApplyMask(const double* mask, size_t count, double* values);

// OK when `mask` has the grid `dimension`/`dims`; otherwise
// InvalidArgument "the mask M is AxB; <holder> CxD" (holder: "the volume V
// is", "the store S holds").
Status CheckMaskGrid(const VolumeInfo& mask, int dimension, const std::array<uint32_t, 4>& dims,
                     const std::string& holder);

}  // namespace simplexdb
