#include "ops/isosurface.h"

#include <fmt/format.h>

#include "query/surface_io.h"

namespace simplexdb {

Result<std::string> SurfaceFormatOf(const std::string& path) {
  const size_t dot = path.rfind('.');
  const size_t slash = path.rfind('/');
  const std::string ext =
      dot == std::string::npos || (slash != std::string::npos && dot < slash) ? "" : path.substr(dot + 1);
  if (ext == "vtp" || ext == "ply") return ext;
  return Status::InvalidArgument(fmt::format(
      "{}: {}: name the file .vtp (VTK PolyData, for ParaView) or .ply", path,
      ext.empty() ? "no extension names what to write" : "the extension ." + ext + " is no surface format"));
}

std::string SurfaceComment(double iso, const std::string& store_path) {
  return fmt::format("SimplexDB isosurface at {} of {}", iso, store_path);
}

Result<ExtractResult> IsosurfaceToFile(const AnyStore& store, ExtractRequest request, const std::string& path) {
  SDB_ASSIGN_OR_RETURN(const std::string format, SurfaceFormatOf(path));
  request.surface = true;
  request.leaves = false;
  request.tetrahedra = false;
  SDB_ASSIGN_OR_RETURN(ExtractResult r, Extract(store, request));
  if (format == "vtp") {
    SDB_RETURN_IF_ERROR(WriteVtp(*r.surface, path));
  } else {
    SDB_RETURN_IF_ERROR(WritePly(*r.surface, path, SurfaceComment(*request.iso, r.info.path)));
  }
  return r;
}

}  // namespace simplexdb
