// MemoryVolume (volume.h): a volume whose voxels are already in memory, so
// a caller holding them (the Python package's numpy arrays) builds a store
// through the same readers and builders as a file, without writing the
// voxels out first. VolumeReader reads them through a MemorySource
// (volume_reader.cc).
#include <string>
#include <utility>

#include "storage/volume/volume.h"
#include "storage/volume/volume_info_internal.h"
#include "storage/volume/voxel_type.h"

namespace simplexdb {

Result<VolumeInfo> MemoryVolume(int dimension, std::array<uint32_t, 4> dims, VoxelType type,
                                ByteOrder order, std::shared_ptr<const std::byte> bytes,
                                std::string description) {
  if (!IsValidVoxelType(type)) {
    return Status::NotSupported(description + ": voxel type code " +
                                std::to_string(static_cast<int>(type)) +
                                " is not one of the six supported types");
  }
  if (bytes == nullptr) return Status::InvalidArgument(description + ": no voxels (a null buffer)");
  VolumeInfo info;
  info.dimension = dimension;
  info.dims = dims;
  info.type = type;
  info.order = order;
  info.encoding = VolumeInfo::Encoding::kMemory;
  info.memory = std::move(bytes);
  info.description = std::move(description);
  volume_internal::DropSingleTimeStep(info);
  SDB_RETURN_IF_ERROR(ValidateGrid(info.description, info.dimension, info.dims));
  return info;
}

}  // namespace simplexdb
