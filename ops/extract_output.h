// The files an extraction writes (`simplexdb extract -o OUT --format F`,
// and the Python package's Mesh.save), from ops/extract.h's result, in one
// place:
//   codes  the leaves' codes, "T:bits" a line ("-": standard output)
//   vtu    the tetrahedra as a VTK XML unstructured grid (an HP: the slice
//          at --time)
//   pvtu   the same in pieces (request.piece of request.pieces: under MPI
//          one per rank): OUT_<piece>.vtu each beside OUT, and OUT (a
//          parallel grid naming them) once every piece is written
//   pvd    an HP's time slices (--slices): OUT_<i>.vtu each beside OUT and
//          OUT (a ParaView collection) naming them with their physical times;
//          in pieces OUT_<i>_<piece>.vtu, then (WritePiecesPvd) OUT_<i>.pvtu
//          per slice and OUT naming those
//   json   the statistics (ExtractStatsJson), indented ("-": the caller
//          prints them)
// Each file is written atomically (storage/io/file.h); a .pvd is written
// after every file it names.
//
// Thread safety: reentrant. Lifetimes: nothing is kept.
//
// Errors: ResolveExtractFormat and CheckExtractOutput return InvalidArgument
// naming the option as the command spells it (--format, -o, --time,
// --slices); the writers' errors (the errno of the failing call naming the
// file, ResourceExhausted for a full disk), and Extract's.
#pragma once

#include <span>
#include <string>

#include "ops/extract.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "util/status.h"

namespace simplexdb {

// --format as given, else the one the output's extension names (.vtu, .pvd,
// .json, .codes or .txt), else json; a --format the extension contradicts,
// or an unknown one, is an error. `path` "-" is standard output.
Result<std::string> ResolveExtractFormat(const std::string& format, const std::string& path);

// Whether `format` (resolved) can be written to `path` for `request` over
// the store `info` describes: vtu and pvd need a file, an HP's vtu needs
// --time, pvd needs an HP and --slices. O(1).
Status CheckExtractOutput(const SourceInfo& info, const ExtractRequest& request,
                          const std::string& format, const std::string& path);

// `request` asking for what `format` writes (leaves for codes, the
// tetrahedra for vtu, the slice's count for json).
ExtractRequest RequestFor(ExtractRequest request, const std::string& format);

// Extract(store, RequestFor(request, format), ..., exchange) with
// CheckExtractOutput first, writing `format` to `path` (a json file too;
// for "-" the caller prints ExtractStatsJson, and codes go to standard
// output). The slices of pvd are written as they are cut, one in memory at
// a time. For pvtu this piece's .vtu (PvtuPieceFile), and the .pvtu too
// when the mesh is one piece; else the caller writes it (WritePvtuOf) once
// every piece is.
Result<ExtractResult> ExtractToFile(const AnyStore& store, const ExtractRequest& request,
                                    const std::string& format, const std::string& path,
                                    const PieceExchange& exchange = {});

// Piece r's file of the .pvtu `path`: PATH-without-.pvtu_<r>.vtu (the
// whole path when it does not end in .pvtu).
std::string PvtuPieceFile(const std::string& path, int piece);
// The .pvtu naming pieces 0..pieces-1 (query/pvd_writer.h), atomically.
Status WritePvtuOf(const std::string& path, int pieces);
// Piece r's file of slice i of the .pvd `path`: PATH-without-.pvd_<i>_<r>.vtu,
// a piece of slice i's PATH-without-.pvd_<i>.pvtu.
std::string PvdPieceFile(const std::string& path, size_t slice, int piece);
// For a .pvd in pieces (ExtractResult::slice_times): OUT_<i>.pvtu per slice
// naming its pieces, then the .pvd naming those at their times.
Status WritePiecesPvd(const std::string& path, int pieces, std::span<const double> times);

// A mesh to `path` by its extension: .vtu (WriteVtu), or .pvd: the mesh as
// PATH-without-.pvd.vtu beside it, then the collection naming it at `time`.
// InvalidArgument for another extension.
Status WriteMeshFile(const TetMeshData& mesh, const std::string& path, double time);

}  // namespace simplexdb
