#include "query/mesh_io.h"

#include <bit>
#include <cstdio>
#include <cstring>
#include <memory>

#include "storage/io/file.h"

namespace simplexdb {
namespace {

// Buffers text or bytes and appends them to an AtomicFileWriter in large
// pieces (or writes them to stdout).
class Output {
 public:
  static Result<Output> Open(const std::string& path) {
    Output o;
    if (path != "-") {
      SDB_ASSIGN_OR_RETURN(o.file_, AtomicFileWriter::Create(path));
    }
    return o;
  }
  Status Write(const void* data, size_t n) {
    const auto* p = static_cast<const uint8_t*>(data);
    buffer_.insert(buffer_.end(), p, p + n);
    if (buffer_.size() >= (size_t{4} << 20)) return Flush();
    return Status::OK();
  }
  Status Write(std::string_view s) { return Write(s.data(), s.size()); }
  Status Commit() {
    SDB_RETURN_IF_ERROR(Flush());
    if (!file_) {
      if (std::fflush(stdout) != 0) return Status::IOError("writing to standard output failed");
      return Status::OK();
    }
    return file_->Commit();
  }

 private:
  Status Flush() {
    if (buffer_.empty()) return Status::OK();
    if (file_) {
      SDB_ASSIGN_OR_RETURN(const uint64_t at, file_->Append(buffer_));
      (void)at;
    } else if (std::fwrite(buffer_.data(), 1, buffer_.size(), stdout) != buffer_.size()) {
      return Status::IOError("writing to standard output failed");
    }
    buffer_.clear();
    return Status::OK();
  }

  std::unique_ptr<AtomicFileWriter> file_;
  std::vector<uint8_t> buffer_;
};

template <class T>
Status AppendArray(Output& out, const std::vector<T>& v) {
  const uint64_t bytes = v.size() * sizeof(T);  // the 64-bit header VTK expects
  SDB_RETURN_IF_ERROR(out.Write(&bytes, sizeof bytes));
  return out.Write(v.data(), bytes);
}

}  // namespace

template <int D>
Status WriteCodes(std::span<const SimplexCode<D>> codes, const std::string& path) {
  SDB_ASSIGN_OR_RETURN(Output out, Output::Open(path));
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

Status WriteVtu(const TetMeshData& mesh, const std::string& path) {
  static_assert(std::endian::native == std::endian::little, "VTK files here are little-endian");
  const uint64_t n_points = mesh.field.size(), n_cells = mesh.cells();
  std::vector<int64_t> offsets(n_cells);
  for (uint64_t i = 0; i < n_cells; ++i) offsets[i] = static_cast<int64_t>(4 * (i + 1));
  const std::vector<uint8_t> types(n_cells, 10);  // VTK_TETRA
  // Appended-data offsets: each array is an 8-byte size and its bytes.
  uint64_t at = 0;
  const auto next = [&](uint64_t bytes) {
    const uint64_t here = at;
    at += 8 + bytes;
    return std::to_string(here);
  };
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  xml += "<UnstructuredGrid>\n";
  xml += "<Piece NumberOfPoints=\"" + std::to_string(n_points) + "\" NumberOfCells=\"" + std::to_string(n_cells) +
         "\">\n";
  xml += "<PointData Scalars=\"field\">\n";
  xml += "<DataArray type=\"Float64\" Name=\"field\" format=\"appended\" offset=\"" + next(n_points * 8) + "\"/>\n";
  xml += "</PointData>\n<CellData Scalars=\"error\">\n";
  xml += "<DataArray type=\"Float64\" Name=\"error\" format=\"appended\" offset=\"" + next(n_cells * 8) + "\"/>\n";
  xml += "<DataArray type=\"UInt8\" Name=\"level\" format=\"appended\" offset=\"" + next(n_cells) + "\"/>\n";
  xml += "<DataArray type=\"UInt64\" Name=\"code\" format=\"appended\" offset=\"" + next(n_cells * 8) + "\"/>\n";
  xml += "</CellData>\n<Points>\n";
  xml += "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"" +
         next(n_points * 24) + "\"/>\n";
  xml += "</Points>\n<Cells>\n";
  xml += "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"" + next(n_cells * 32) +
         "\"/>\n";
  xml += "<DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"" + next(n_cells * 8) + "\"/>\n";
  xml += "<DataArray type=\"UInt8\" Name=\"types\" format=\"appended\" offset=\"" + next(n_cells) + "\"/>\n";
  xml += "</Cells>\n</Piece>\n</UnstructuredGrid>\n<AppendedData encoding=\"raw\">\n_";

  SDB_ASSIGN_OR_RETURN(Output out, Output::Open(path));
  SDB_RETURN_IF_ERROR(out.Write(xml));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.field));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.error));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.level));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.code));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.points));
  SDB_RETURN_IF_ERROR(AppendArray(out, mesh.connectivity));
  SDB_RETURN_IF_ERROR(AppendArray(out, offsets));
  SDB_RETURN_IF_ERROR(AppendArray(out, types));
  SDB_RETURN_IF_ERROR(out.Write("\n</AppendedData>\n</VTKFile>\n"));
  return out.Commit();
}

}  // namespace simplexdb
