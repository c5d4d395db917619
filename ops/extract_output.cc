#include "ops/extract_output.h"

#include <cctype>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "hierarchy/simplex_code.h"
#include "query/pvd_writer.h"
#include "storage/io/file.h"

namespace simplexdb {
namespace {

std::string Folderless(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// An output file's extension, lower case ("" for none).
std::string ExtensionOf(const std::string& output) {
  const size_t slash = output.find_last_of('/'), dot = output.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = output.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// The format an output file's extension names, or "" for another one.
std::string FormatOfExtension(const std::string& output) {
  const std::string ext = ExtensionOf(output);
  if (ext == "vtu" || ext == "pvtu" || ext == "pvd" || ext == "json") return ext;
  if (ext == "codes" || ext == "txt") return "codes";
  return "";
}

// `path` without its extension when that is `ext` (lower case, no dot).
std::string StemOf(const std::string& path, const std::string& ext) {
  return ExtensionOf(path) == ext ? path.substr(0, path.size() - ext.size() - 1) : path;
}

// Slice i's .pvtu of the .pvd `path` in pieces: PATH-without-.pvd_<i>.pvtu.
std::string SlicePvtu(const std::string& path, size_t slice) {
  return fmt::format("{}_{}.pvtu", StemOf(path, "pvd"), slice);
}

template <int D>
Status WriteLeafCodes(const std::vector<uint64_t>& keys, const std::string& path) {
  std::vector<SimplexCode<D>> codes;
  codes.reserve(keys.size());
  for (const uint64_t k : keys) codes.push_back(SimplexCode<D>::FromKey(k));
  return WriteCodes<D>(codes, path);
}

}  // namespace

Result<std::string> ResolveExtractFormat(const std::string& format, const std::string& path) {
  if (path.empty()) return Status::InvalidArgument("the output path is empty: name a file to write");
  const std::string implied = path == "-" ? "" : FormatOfExtension(path);
  if (format.empty() && path != "-" && implied.empty()) {
    // Writing statistics into mesh.vtk would look like success.
    const std::string ext = ExtensionOf(path);
    return Status::InvalidArgument(fmt::format(
        "{}: {}: name the file .vtu (the mesh, for ParaView), .pvtu (the mesh in pieces), .pvd (HP time "
        "slices), .json (the statistics) or .codes (the leaf codes), or give --format",
        path, ext.empty() ? "no extension names what to write" : "the extension ." + ext + " is no format extract writes"));
  }
  const std::string chosen = format.empty() ? (implied.empty() ? "json" : implied) : format;
  if (!format.empty() && !implied.empty() && implied != format) {
    return Status::InvalidArgument(
        fmt::format("--format {} contradicts the output's extension: {} names {} (leave --format out, "
                    "or name the file for what it holds)",
                    format, path, implied));
  }
  if (chosen != "codes" && chosen != "json" && chosen != "vtu" && chosen != "pvtu" && chosen != "pvd") {
    return Status::InvalidArgument(fmt::format("--format {}: expected codes, vtu, pvtu, pvd or json", chosen));
  }
  return chosen;
}

Status CheckExtractOutput(const SourceInfo& info, const ExtractRequest& request,
                          const std::string& format, const std::string& path) {
  if ((format == "vtu" || format == "pvtu" || format == "pvd") && path == "-") {
    return Status::InvalidArgument(fmt::format("--format {} needs -o FILE", format));
  }
  if ((format == "vtu" || format == "pvtu") && info.dimension == 4 && !request.time) {
    return Status::InvalidArgument(
        fmt::format("--format {} of an HP writes the 3D mesh of a time slice: give --time T", format));
  }
  if (format == "pvd") {
    if (info.dimension != 4) {
      return Status::InvalidArgument("--format pvd writes a series of HP time slices; the HT has no time");
    }
    if (request.slices.empty()) {
      return Status::InvalidArgument("--format pvd needs --slices T1,T2,... (times in --units)");
    }
  }
  return Status::OK();
}

ExtractRequest RequestFor(ExtractRequest request, const std::string& format) {
  request.leaves = format == "codes";
  request.tetrahedra = format == "vtu" || format == "pvtu";
  request.count_slice = format == "vtu" || format == "pvtu" || format == "json";
  if (format != "pvd") request.slices.clear();
  return request;
}

std::string PvtuPieceFile(const std::string& path, int piece) {
  return fmt::format("{}_{}.vtu", StemOf(path, "pvtu"), piece);
}

std::string PvdPieceFile(const std::string& path, size_t slice, int piece) {
  return PvtuPieceFile(SlicePvtu(path, slice), piece);
}

Status WritePiecesPvd(const std::string& path, int pieces, std::span<const double> times) {
  std::vector<PvdDataSet> pvd;
  for (size_t i = 0; i < times.size(); ++i) {
    SDB_RETURN_IF_ERROR(WritePvtuOf(SlicePvtu(path, i), pieces));
    pvd.push_back({times[i], Folderless(SlicePvtu(path, i))});
  }
  return WritePvd(pvd, path);
}

Status WritePvtuOf(const std::string& path, int pieces) {
  std::vector<std::string> names;
  for (int r = 0; r < pieces; ++r) names.push_back(Folderless(PvtuPieceFile(path, r)));
  return WritePvtu(names, path);
}

Result<ExtractResult> ExtractToFile(const AnyStore& store, const ExtractRequest& request,
                                    const std::string& format, const std::string& path,
                                    const PieceExchange& exchange) {
  SDB_RETURN_IF_ERROR(CheckExtractOutput(store.info(), request, format, path));
  // OUTPUT.pvd and one OUTPUT_<i>.vtu per time beside it (in pieces:
  // OUTPUT_<i>_<piece>.vtu; WritePiecesPvd names them).
  const std::string stem = StemOf(path, "pvd");
  std::vector<PvdDataSet> pvd;
  const SliceSink write_slice = [&](size_t i, ExtractSlice&& slice) -> Status {
    const std::string file =
        request.pieces > 1 ? PvdPieceFile(path, i, request.piece) : fmt::format("{}_{}.vtu", stem, i);
    SDB_RETURN_IF_ERROR(WriteVtu(slice.mesh, file));
    pvd.push_back({slice.time, Folderless(file)});
    return Status::OK();
  };
  SDB_ASSIGN_OR_RETURN(ExtractResult result,
                       Extract(store, RequestFor(request, format), format == "pvd" ? write_slice : SliceSink{},
                               exchange));
  if (format == "codes") {
    SDB_RETURN_IF_ERROR(result.info.dimension == 3 ? WriteLeafCodes<3>(result.leaves, path)
                                                   : WriteLeafCodes<4>(result.leaves, path));
  } else if (format == "vtu") {
    SDB_RETURN_IF_ERROR(WriteVtu(*result.mesh, path));
  } else if (format == "pvtu") {
    SDB_RETURN_IF_ERROR(WriteVtu(*result.mesh, PvtuPieceFile(path, request.piece)));
    if (request.pieces == 1) SDB_RETURN_IF_ERROR(WritePvtuOf(path, 1));
  } else if (format == "pvd") {
    for (const PvdDataSet& d : pvd) result.slice_times.push_back(d.timestep);
    if (request.pieces == 1) SDB_RETURN_IF_ERROR(WritePvd(pvd, path));
  } else if (format == "json" && path != "-") {
    SDB_RETURN_IF_ERROR(WriteFileAtomically(path, ExtractStatsJson(result).dump(2) + "\n"));
  }
  return result;
}

Status WriteMeshFile(const TetMeshData& mesh, const std::string& path, double time) {
  const std::string ext = ExtensionOf(path);
  if (ext == "vtu") return WriteVtu(mesh, path);
  if (ext != "pvd") {
    return Status::InvalidArgument(path + ": a mesh is saved as .vtu (an unstructured grid) or .pvd (a "
                                          "ParaView collection of one .vtu), named by the extension");
  }
  const std::string vtu = path.substr(0, path.size() - 4) + ".vtu";
  // The .vtu first: the collection never names a missing file.
  SDB_RETURN_IF_ERROR(WriteVtu(mesh, vtu));
  const PvdDataSet set{time, Folderless(vtu)};
  return WritePvd({&set, 1}, path);
}

}  // namespace simplexdb
