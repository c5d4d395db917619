#include "query/mesh_io.h"

#include <new>

#include "query/mesh_io_internal.h"
#include "query/vtk_xml_internal.h"
#include "util/out_of_memory.h"

namespace simplexdb {

using internal::AppendedArray;
using internal::Element;
using internal::Made;
using internal::OutputFile;
using internal::Stored;

template <int D>
Status WriteCodes(std::span<const SimplexCode<D>> codes, const std::string& path) {
  SDB_ASSIGN_OR_RETURN(OutputFile out, OutputFile::Open(path));
  std::string line;
  for (const SimplexCode<D> c : codes) {
    line = c.ToString();
    line.push_back('\n');
    SDB_RETURN_IF_ERROR(out.Write(line));
  }
  return out.Commit();
}

template Status WriteCodes<3>(std::span<const SimplexCode<3>>, const std::string&);
template Status WriteCodes<4>(std::span<const SimplexCode<4>>, const std::string&);

namespace internal {

// Level and block size, measured on a 5.0M-tetrahedron mesh (perlin 129^3
// float32 at --error 1%: 320 MB uncompressed), one thread, CPU seconds:
//
//   block    level 1           level 6
//   32 KiB   54.4 MB  2.3 s    52.7 MB  9.4 s
//   64 KiB   53.5 MB  2.2 s    51.8 MB 10.2 s
//   256 KiB  52.9 MB  1.6 s    51.0 MB 10.8 s
//   1 MiB    52.7 MB  1.6 s
//
// Level 6 saves 3-4% for five to seven times the time, so level 1 (level
// 2: 52.0 MB, 1.8 s). Blocks of 256 KiB rather than VTK's 32 KiB: each block
// pays a deflateReset and starts without history, which costs 3% in size
// and 40% in time at 32 KiB; past 256 KiB nothing is left to gain, and
// VTK's reader holds one block at a time, so blocks stay small beside the
// arrays. A mesh of a million tetrahedra still makes some 170 blocks to share
// among the threads.
constexpr size_t kVtuBlockBytes = size_t{256} << 10;
constexpr int kVtuLevel = 1;

VtuOptions DefaultVtuOptions() { return {kVtuBlockBytes, kVtuLevel, INT32_MAX, 0}; }

namespace {

// The mesh's arrays in the order of the file, and the XML around them.
// May throw std::bad_alloc.
Status WriteCompressedVtu(const TetMeshData& mesh, const std::string& path, const VtuOptions& options) {
  const uint64_t n_points = mesh.field.size(), n_cells = mesh.cells();
  std::vector<AppendedArray> arrays;
  arrays.push_back(Stored(Element("Float64", "field"), mesh.field));
  arrays.push_back(Stored(Element("Float64", "error"), mesh.error));
  arrays.push_back(Stored(Element("UInt8", "level"), mesh.level));
  arrays.push_back(Stored(Element("UInt64", "code"), mesh.code));
  arrays.push_back(Stored(Element("Float64", nullptr, 3), mesh.points));
  // Point indices are below n_points (CollectTetMesh, SliceHpMesh).
  internal::AddCellArrays(arrays, mesh.connectivity, 4, n_points, options.int32_limit);
  arrays.push_back(Made<uint8_t>(Element("UInt8", "types"), n_cells, [](uint64_t) { return 10; }));  // VTK_TETRA
  return WriteAppendedVtk(path, arrays, options, [&](const std::vector<std::string>& e) {
    std::string xml;
    xml += "<?xml version=\"1.0\"?>\n";
    xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\" "
           "compressor=\"vtkZLibDataCompressor\">\n";
    xml += "<UnstructuredGrid>\n";
    xml += "<Piece NumberOfPoints=\"" + std::to_string(n_points) + "\" NumberOfCells=\"" + std::to_string(n_cells) +
           "\">\n";
    xml += "<PointData Scalars=\"field\">\n" + e[0];
    xml += "</PointData>\n<CellData Scalars=\"error\">\n" + e[1] + e[2] + e[3];
    xml += "</CellData>\n<Points>\n" + e[4];
    xml += "</Points>\n<Cells>\n" + e[5] + e[6] + e[7];
    xml += "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";
    return xml;
  });
}

}  // namespace

Status WriteVtu(const TetMeshData& mesh, const std::string& path, const VtuOptions& options) {
  try {
    return WriteCompressedVtu(mesh, path, options);
  } catch (const std::bad_alloc&) {
    // The compressed arrays, the headers or the output buffer.
    return NotEnoughMemory(path + ": the compressed arrays of " + std::to_string(mesh.cells()) + " tetrahedra",
                           "about 11 bytes a tetrahedron");
  }
}

}  // namespace internal

Status WriteVtu(const TetMeshData& mesh, const std::string& path) {
  return internal::WriteVtu(mesh, path, internal::DefaultVtuOptions());
}

}  // namespace simplexdb
