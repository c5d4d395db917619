// Writing isosurfaces (query/isosurface.h): VTK XML PolyData (.vtp) that
// any VTK reader opens, and binary PLY (.ply) for tools outside VTK.
//
// Files are written under a temporary name and renamed when complete
// (storage/io/file.h): a failed write leaves nothing under the real name.
//
// Thread safety: free functions; may run in several threads at once on
// different paths. Lifetimes: the surface is read during the call only.
//
// Errors: the writer's (the errno of the failing call naming the file,
// ResourceExhausted for a full disk or when the compressed arrays do not
// fit in memory); WritePly: InvalidArgument for a surface of 2^31 points or
// more (PLY's int indices).
#pragma once

#include <string>

#include "query/isosurface.h"
#include "util/status.h"

namespace simplexdb {

// VTK XML PolyData, binary appended data compressed with zlib (as WriteVtu):
// Float64 points, triangles as polys (Int32 connectivity and offsets when
// they fit, else Int64), point array "Normals" (Float32, 3 components, the
// unit gradient), cell array "error" (Float64).
Status WriteVtp(const SurfaceData& surface, const std::string& path);

// PLY, binary little-endian: per vertex float x, y, z, nx, ny, nz; per face
// a uchar count (3) and int vertex indices; `comment` lines first.
Status WritePly(const SurfaceData& surface, const std::string& path, const std::string& comment);

}  // namespace simplexdb
