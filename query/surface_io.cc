#include "query/surface_io.h"

#include <cstdint>
#include <cstring>
#include <new>
#include <vector>

#include "query/vtk_xml_internal.h"
#include "util/out_of_memory.h"

namespace simplexdb {

using internal::AppendedArray;
using internal::Element;
using internal::OutputFile;
using internal::Stored;

namespace {

Status WriteCompressedVtp(const SurfaceData& s, const std::string& path) {
  const internal::VtuOptions options = internal::DefaultVtuOptions();
  const uint64_t n_points = s.point_count(), n_cells = s.triangle_count();
  std::vector<AppendedArray> arrays;
  arrays.push_back(Stored(Element("Float32", "Normals", 3), s.normals));
  arrays.push_back(Stored(Element("Float64", "error"), s.error));
  arrays.push_back(Stored(Element("Float64", nullptr, 3), s.points));
  internal::AddCellArrays(arrays, s.triangles, 3, n_points, options.int32_limit);
  return internal::WriteAppendedVtk(path, arrays, options, [&](const std::vector<std::string>& e) {
    std::string xml;
    xml += "<?xml version=\"1.0\"?>\n";
    xml += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\" "
           "compressor=\"vtkZLibDataCompressor\">\n";
    xml += "<PolyData>\n";
    xml += "<Piece NumberOfPoints=\"" + std::to_string(n_points) +
           "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
           std::to_string(n_cells) + "\">\n";
    xml += "<PointData Normals=\"Normals\">\n" + e[0];
    xml += "</PointData>\n<CellData Scalars=\"error\">\n" + e[1];
    xml += "</CellData>\n<Points>\n" + e[2];
    xml += "</Points>\n<Polys>\n" + e[3] + e[4];
    xml += "</Polys>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_";
    return xml;
  });
}

}  // namespace

Status WriteVtp(const SurfaceData& surface, const std::string& path) {
  try {
    return WriteCompressedVtp(surface, path);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path + ": the compressed arrays of " + std::to_string(surface.triangle_count()) +
                               " triangles",
                           "about 20 bytes a triangle");
  }
}

Status WritePly(const SurfaceData& surface, const std::string& path, const std::string& comment) {
  const uint64_t n_points = surface.point_count(), n_faces = surface.triangle_count();
  if (n_points > uint64_t{INT32_MAX}) {
    return Status::InvalidArgument(path + ": " + std::to_string(n_points) +
                                   " points do not fit PLY's int vertex indices (at most 2^31 - 1); write .vtp");
  }
  SDB_ASSIGN_OR_RETURN(OutputFile out, OutputFile::Open(path));
  std::string header = "ply\nformat binary_little_endian 1.0\n";
  if (!comment.empty()) {
    std::string line = comment;  // one header line: no control characters
    for (char& c : line) c = static_cast<unsigned char>(c) < 0x20 ? '?' : c;
    header += "comment " + line + "\n";
  }
  header += "element vertex " + std::to_string(n_points) +
            "\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty float nz\n"
            "element face " + std::to_string(n_faces) + "\nproperty list uchar int vertex_indices\nend_header\n";
  SDB_RETURN_IF_ERROR(out.Write(header));
  for (uint64_t p = 0; p < n_points; ++p) {
    float v[6];
    for (int a = 0; a < 3; ++a) {
      v[a] = static_cast<float>(surface.points[3 * p + a]);
      v[3 + a] = surface.normals[3 * p + a];
    }
    SDB_RETURN_IF_ERROR(out.Write(v, sizeof v));
  }
  for (uint64_t t = 0; t < n_faces; ++t) {
    uint8_t face[13];
    face[0] = 3;
    for (int k = 0; k < 3; ++k) {
      const int32_t i = static_cast<int32_t>(surface.triangles[3 * t + k]);
      std::memcpy(face + 1 + 4 * k, &i, 4);
    }
    SDB_RETURN_IF_ERROR(out.Write(face, sizeof face));
  }
  return out.Commit();
}

}  // namespace simplexdb
