// What the volume writers share (internal to storage/volume): the checks of
// an image before anything is written, the text of a double in a header,
// and the voxels' bytes. Not part of the API; no caller outside storage/volume should
// include it.
//
// Thread safety: pure functions.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "storage/io/file.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb::volume_internal {

// Shortest text that reads back as the same double ("0.5", "2.2", "nan").
std::string FormatDouble(double v);

// InvalidArgument naming `path` for an image a writer must refuse: a voxel
// type that is not one of the six, a dimension other than 3 or 4, a used
// axis of 0 samples or an unused one of more than 1, a spacing of a used
// axis that is not positive and finite, an origin (when given) that is not
// finite, values.size() not the voxel count, or a value not representable
// as `type` (the first is named with its voxel index). O(values).
Status CheckImage(const std::string& path, int dimension, const std::array<uint32_t, 4>& dims,
                  VoxelType type, std::span<const double> values,
                  const std::array<double, 4>& spacing,
                  const std::optional<std::array<double, 3>>& origin);

// Appends the values to `file` as little-endian `type`, 64 Ki voxels at a
// time. Errors: those of AtomicFileWriter::Append (storage/io/file.h).
Status AppendVoxels(AtomicFileWriter& file, VoxelType type, std::span<const double> values);

}  // namespace simplexdb::volume_internal
