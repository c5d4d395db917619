// The raw reader, OpenRawVolume (volume.h): headerless voxels that the
// caller describes.
#include "storage/volume/volume.h"

#include <string>

#include "storage/io/read_only_file.h"
#include "storage/volume/volume_info_internal.h"
#include "storage/volume/voxel_type.h"

namespace simplexdb {

using volume_internal::CheckDataFiles;
using volume_internal::TruncatedRaw;

Result<VolumeInfo> OpenRawVolume(const std::string& path, int dimension,
                                 std::array<uint32_t, 4> dims, VoxelType type,
                                 ByteOrder order, uint64_t offset) {
  SDB_ASSIGN_OR_RETURN(VolumeInfo info,
                       volume_internal::DescribeGrid(path, dimension, dims, type, order));
  info.encoding = VolumeInfo::Encoding::kRaw;
  info.files = {path};
  info.offset = offset;
  info.description = "raw file " + path;
  SDB_RETURN_IF_ERROR(CheckDataFiles(info, TruncatedRaw));
  // Nothing may follow the voxels: a file longer than the dims and type
  // say is almost always described wrongly (another type, or larger dims),
  // and would import as a garbled volume without a word.
  SDB_ASSIGN_OR_RETURN(const ReadOnlyFile file, ReadOnlyFile::Open(path));
  SDB_ASSIGN_OR_RETURN(const uint64_t size, file.Size());
  const uint64_t bytes = info.voxel_count() * VoxelSize(type);
  if (size - offset != bytes) {
    return Status::InvalidArgument(
        path + ": has " + std::to_string(size) + " bytes, expected " + std::to_string(offset + bytes) + " (" +
        FormatDims(info.dimension, info.dims) + " " + std::string(VoxelTypeName(type)) + " = " +
        std::to_string(bytes) + " bytes after offset " + std::to_string(offset) +
        "): the dims or type given are wrong (a header before the voxels is skipped with the offset; "
        "nothing may follow them)");
  }
  return info;
}

}  // namespace simplexdb
