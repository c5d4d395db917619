#include "ops/isosurface.h"

#include <vector>

#include <fmt/format.h>

#include "query/pvd_writer.h"
#include "query/surface_io.h"

namespace simplexdb {

Result<std::string> SurfaceFormatOf(const std::string& path) {
  const size_t dot = path.rfind('.');
  const size_t slash = path.rfind('/');
  const std::string ext =
      dot == std::string::npos || (slash != std::string::npos && dot < slash) ? "" : path.substr(dot + 1);
  if (ext == "vtp" || ext == "ply" || ext == "pvtp") return ext;
  return Status::InvalidArgument(fmt::format(
      "{}: {}: name the file .vtp (VTK PolyData, for ParaView), .pvtp (in pieces) or .ply", path,
      ext.empty() ? "no extension names what to write" : "the extension ." + ext + " is no surface format"));
}

std::string SurfaceComment(double iso, const std::string& store_path) {
  return fmt::format("SimplexDB isosurface at {} of {}", iso, store_path);
}

std::string PvtpPieceFile(const std::string& path, int piece) {
  const std::string stem = path.size() > 5 && path.compare(path.size() - 5, 5, ".pvtp") == 0
                               ? path.substr(0, path.size() - 5) : path;
  return fmt::format("{}_{}.vtp", stem, piece);
}

Status WritePvtpOf(const std::string& path, int pieces) {
  std::vector<std::string> names;
  for (int r = 0; r < pieces; ++r) {
    const std::string f = PvtpPieceFile(path, r);
    names.push_back(f.substr(f.rfind('/') + 1));  // beside the .pvtp
  }
  return WritePvtp(names, path);
}

Result<ExtractResult> IsosurfaceToFile(const AnyStore& store, ExtractRequest request, const std::string& path,
                                       const PieceExchange& exchange) {
  SDB_ASSIGN_OR_RETURN(const std::string format, SurfaceFormatOf(path));
  request.surface = true;
  request.leaves = false;
  request.tetrahedra = false;
  SDB_ASSIGN_OR_RETURN(ExtractResult r, Extract(store, request, {}, exchange));
  if (format == "pvtp") {
    SDB_RETURN_IF_ERROR(WriteVtp(*r.surface, PvtpPieceFile(path, request.piece)));
    if (request.pieces == 1) SDB_RETURN_IF_ERROR(WritePvtpOf(path, 1));
  } else if (format == "vtp") {
    SDB_RETURN_IF_ERROR(WriteVtp(*r.surface, path));
  } else {
    SDB_RETURN_IF_ERROR(WritePly(*r.surface, path, SurfaceComment(*request.iso, r.info.path)));
  }
  return r;
}

}  // namespace simplexdb
