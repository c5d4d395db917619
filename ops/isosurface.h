// Isosurface: the surface at --iso of the leaves `extract --iso V --error
// E` returns (marching tetrahedra over them: query/isosurface.h), written
// as .vtp or .ply; `simplexdb isosurface`. The refinement is Extract's
// (ops/extract.h) with ExtractRequest::surface set.
//
// Thread safety: reentrant over a const AnyStore. Lifetimes: nothing is
// kept.
//
// Errors: SurfaceFormatOf's InvalidArgument naming the path; Extract's
// (CheckExtract's naming the option as the command spells it); the
// writers' (query/surface_io.h).
#pragma once

#include <string>

#include "ops/extract.h"
#include "query/open_store.h"
#include "util/status.h"

namespace simplexdb {

// "vtp", "ply" or "pvtp" (pieces: one .vtp per piece beside it), as the
// path's extension names it.
Result<std::string> SurfaceFormatOf(const std::string& path);

// Piece r's file of the .pvtp `path`: PATH-without-.pvtp_<r>.vtp.
std::string PvtpPieceFile(const std::string& path, int piece);
// The .pvtp naming pieces 0..pieces-1 (query/pvd_writer.h), atomically.
Status WritePvtpOf(const std::string& path, int pieces);

// The .ply header's comment line for a surface at `iso` of the store at
// `store_path`.
std::string SurfaceComment(double iso, const std::string& store_path);

// The isosurface of `request` (its iso, error, box, time, units) over
// `store`, written to `path` (.vtp or .ply) atomically; the result holds
// the surface and the statistics. For .pvtp, piece request.piece of
// request.pieces (with an `exchange`, as Extract's): its .vtp
// (PvtpPieceFile), and the .pvtp too when the surface is one piece; else
// the caller writes it (WritePvtpOf) once every piece is.
Result<ExtractResult> IsosurfaceToFile(const AnyStore& store, ExtractRequest request, const std::string& path,
                                       const PieceExchange& exchange = {});

}  // namespace simplexdb
