#include "storage/error/field_values.h"

#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

namespace simplexdb {

Status CheckStorableValues(const VolumeInfo& volume, uint64_t first, const double* values,
                           size_t count) {
  constexpr double kMax = std::numeric_limits<float>::max();
  for (size_t i = 0; i < count; ++i) {
    const double v = values[i];
    if (std::isnan(v) || std::fabs(v) <= kMax) continue;
    // Voxel coordinates, x fastest.
    uint64_t index = first + i;
    std::string at;
    for (int c = 0; c < volume.dimension; ++c) {
      const uint64_t n = volume.dims[static_cast<size_t>(c)];
      at += (c > 0 ? ", " : "") + std::to_string(index % n);
      index /= n;
    }
    std::string file = volume.description;
    if (volume.files.size() > 1) {
      file += " (data file " + volume.files[(first + i) / volume.voxels_per_file()] + ")";
    }
    return Status::InvalidArgument(fmt::format(
        "{}: value {} at voxel ({}){} is {}; a store holds finite float32 values (NaN marks a "
        "missing one)",
        file, v, at, volume.scaled() ? " (after scaling, " + FormatScaling(volume) + ")" : "",
        std::isinf(v) ? "infinite" : fmt::format("beyond float32's range (+-{:.6g})", kMax)));
  }
  return Status::OK();
}

Status CheckFieldRange(const VolumeInfo& volume, double min, double max) {
  const double range = max - min;
  if (range <= std::numeric_limits<float>::max()) return Status::OK();
  return Status::InvalidArgument(fmt::format(
      "{}: the values run from {:.6g} to {:.6g}, a range of {:.6g}, beyond float32's (+-{:.6g}), in which a "
      "store keeps its errors; scale the values down (a NRRD or NIfTI scaling, or coarser units)",
      volume.description, min, max, range, std::numeric_limits<float>::max()));
}

}  // namespace simplexdb
