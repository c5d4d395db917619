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

// "vtp" or "ply", as the path's extension names it.
Result<std::string> SurfaceFormatOf(const std::string& path);

// The .ply header's comment line for a surface at `iso` of the store at
// `store_path`.
std::string SurfaceComment(double iso, const std::string& store_path);

// The isosurface of `request` (its iso, error, box, time, units) over
// `store`, written to `path` (.vtp or .ply) atomically; the result holds
// the surface and the statistics.
Result<ExtractResult> IsosurfaceToFile(const AnyStore& store, ExtractRequest request, const std::string& path);

}  // namespace simplexdb
