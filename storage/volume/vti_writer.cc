#include "storage/volume/vti_writer.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <vector>

#include "storage/volume/writer_internal.h"
#include "util/little_endian.h"

namespace simplexdb {
namespace {

using volume_internal::FormatDouble;

const char* VtkTypeName(VoxelType type) {
  switch (type) {
    case VoxelType::kU8: return "UInt8";
    case VoxelType::kI8: return "Int8";
    case VoxelType::kU16: return "UInt16";
    case VoxelType::kI16: return "Int16";
    case VoxelType::kF32: return "Float32";
    case VoxelType::kF64: return "Float64";
  }
  return "";
}

}  // namespace

Result<std::unique_ptr<AtomicFileWriter>> PrepareVti(const std::string& path,
                                                     std::array<uint32_t, 3> dims,
                                                     VoxelType type,
                                                     std::span<const double> values,
                                                     std::array<double, 3> spacing,
                                                     std::array<double, 3> origin) {
  SDB_RETURN_IF_ERROR(volume_internal::CheckImage(path, 3, {dims[0], dims[1], dims[2], 1}, type, values,
                                                  {spacing[0], spacing[1], spacing[2], 1}, origin));
  const std::string extent = "0 " + std::to_string(dims[0] - 1) + " 0 " +
                             std::to_string(dims[1] - 1) + " 0 " + std::to_string(dims[2] - 1);
  std::string xml =
      "<?xml version=\"1.0\"?>\n"
      "<!-- Written by SimplexDB. -->\n"
      "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n";
  xml += "<ImageData WholeExtent=\"" + extent + "\" Origin=\"" + FormatDouble(origin[0]) + " " +
         FormatDouble(origin[1]) + " " + FormatDouble(origin[2]) + "\" Spacing=\"" +
         FormatDouble(spacing[0]) + " " + FormatDouble(spacing[1]) + " " +
         FormatDouble(spacing[2]) + "\">\n";
  xml += "<Piece Extent=\"" + extent + "\">\n<PointData Scalars=\"field\">\n";
  xml += "<DataArray type=\"" + std::string(VtkTypeName(type)) +
         "\" Name=\"field\" format=\"appended\" offset=\"0\"/>\n";
  xml += "</PointData>\n<CellData/>\n</Piece>\n</ImageData>\n<AppendedData encoding=\"raw\">\n_";
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<AtomicFileWriter> file, AtomicFileWriter::Create(path));
  uint8_t size[8];
  StoreLittle<uint64_t>(size, static_cast<uint64_t>(values.size()) * VoxelSize(type));
  SDB_ASSIGN_OR_RETURN(uint64_t at, file->Append(xml));
  SDB_ASSIGN_OR_RETURN(at, file->Append(std::span<const uint8_t>(size, 8)));
  SDB_RETURN_IF_ERROR(volume_internal::AppendVoxels(*file, type, values));
  SDB_ASSIGN_OR_RETURN(at, file->Append(std::string_view("\n</AppendedData>\n</VTKFile>\n")));
  (void)at;
  return file;
}

}  // namespace simplexdb
