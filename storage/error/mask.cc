#include "storage/error/mask.h"

#include <cmath>
#include <limits>

namespace simplexdb {

VoxelType StoredVoxelType(VoxelType input, bool masked) {
  return masked && !IsFloatType(input) ? VoxelType::kF32 : input;
}

VoxelType StoredVoxelType(const VolumeInfo& input, bool masked) {
  return StoredVoxelType(input.type, masked || input.scaled());
}

void ApplyMask(const double* mask, size_t count, double* values) {
  for (size_t i = 0; i < count; ++i) {
    if (mask[i] == 0 || std::isnan(mask[i])) values[i] = std::numeric_limits<double>::quiet_NaN();
  }
}

Status CheckMaskGrid(const VolumeInfo& mask, int dimension, const std::array<uint32_t, 4>& dims,
                     const std::string& holder) {
  bool same = mask.dimension == dimension;
  for (int c = 0; c < dimension && same; ++c) same = mask.dims[c] == dims[c];
  if (same) return Status::OK();
  return Status::InvalidArgument("the mask " + mask.description + " is " +
                                 FormatDims(mask.dimension, mask.dims) + "; " + holder + " " +
                                 FormatDims(dimension, dims));
}

}  // namespace simplexdb
