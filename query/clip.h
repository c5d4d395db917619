// Fitting an extracted tetrahedral mesh to the real grid, for output.
//
// A hierarchy covers a padded cube of side 2^k (grid units) while the
// input's grid is X x Y x Z points, so a mesh's coarse cells reach past the
// grid's last points. ClipToGrid cuts the mesh by the planes x = X - 1,
// y = Y - 1 and z = Z - 1 in turn: cells wholly outside are left out, cells
// across a plane are replaced by the tetrahedra of their part inside, with
// the field interpolated linearly along the cut edges (the mesh's own
// interpolant, so values inside are unchanged).
//
// The result stays conforming. Each clipped cell's inside part is a convex
// polytope whose faces are the cell's faces clipped (and the cut), and it is
// cut into tetrahedra by one global rule: every polygonal face is fanned from
// its smallest point, and the polytope is coned from its smallest point over
// the triangles of the faces that do not hold it. A face shared by two cells
// is the same polygon on both sides (its points are the same: a cut point is
// named by the edge it cuts), so both fan it alike. Points are ordered by
// position (x, then y, then z), and a cut point is computed from its edge's
// smaller end: so a piece of a mesh (query/pieces.h) is clipped exactly as
// the same cells of the whole mesh, and the pieces stay conforming.
//
// Thread safety: free functions over values.
//
// Cost: O(cells + points) with a hash map of the cut edges; a cell across a
// plane becomes at most a dozen tetrahedra.
#pragma once

#include <array>
#include <cstdint>

#include "query/mesh_io.h"
#include "query/source.h"

namespace simplexdb {

// The part of `mesh` (points in grid units, a conforming mesh of positively
// oriented tetrahedra of the domain [0, 2^k]^3) inside [0, dims[a] - 1] on
// each axis a < 3. Cell arrays (error, level, code) are the cut cell's.
// Tetrahedra are positively oriented; points no cell uses are dropped.
// REQUIRES: dims[a] >= 2 on the axes to clip (a single-point axis has no
// volume inside).
TetMeshData ClipToGrid(TetMeshData mesh, const std::array<uint32_t, 4>& dims);

// Moves points from grid units to physical ones: x = origin + x * spacing
// per axis (info.spacing and info.origin, axes 0..2). A negative spacing
// (a flipped axis) mirrors the mesh; when an odd number of axes is flipped
// two vertices of every cell are swapped, so cells stay positive. O(points
// + cells).
void PlacePhysically(TetMeshData& mesh, const SourceInfo& info);

}  // namespace simplexdb
