// The raw reader, OpenRawVolume (volume.h): headerless voxels that the
// caller describes.
#include "storage/volume/volume.h"

#include <string>

#include "storage/volume/volume_info_internal.h"

namespace simplexdb {

using volume_internal::CheckDataFiles;
using volume_internal::DropSingleTimeStep;
using volume_internal::TruncatedRaw;

Result<VolumeInfo> OpenRawVolume(const std::string& path, int dimension,
                                 std::array<uint32_t, 4> dims, VoxelType type,
                                 ByteOrder order, uint64_t offset) {
  if (!IsValidVoxelType(type)) {
    return Status::NotSupported(path + ": voxel type code " +
                                std::to_string(static_cast<int>(type)) +
                                " is not one of the six supported types");
  }
  VolumeInfo info;
  info.dimension = dimension;
  info.dims = dims;
  info.type = type;
  info.order = order;
  info.encoding = VolumeInfo::Encoding::kRaw;
  info.files = {path};
  info.offset = offset;
  info.description = "raw file " + path;
  DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(path, info.dimension, info.dims));
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedRaw));
  return info;
}

}  // namespace simplexdb
