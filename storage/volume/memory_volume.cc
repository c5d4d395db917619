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
  SDB_ASSIGN_OR_RETURN(VolumeInfo info,
                       volume_internal::DescribeGrid(description, dimension, dims, type, order));
  if (bytes == nullptr) return Status::InvalidArgument(description + ": no voxels (a null buffer)");
  info.encoding = VolumeInfo::Encoding::kMemory;
  info.memory = std::move(bytes);
  info.description = std::move(description);
  return info;
}

}  // namespace simplexdb
