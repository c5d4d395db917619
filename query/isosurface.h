// Isosurfaces straight from the hierarchy (issue 43): marching tetrahedra
// over the leaves of an extracted mesh (the minimal conforming mesh under
// the isovalue criterion: query/criteria.h), without the tetrahedral mesh
// ever being collected: the leaves are walked with their vertices' values
// carried down (ForEachLeaf), and only those whose values straddle the
// isovalue are cut.
//
// The rule (DESIGN.md's contract, "Isosurfaces"):
//   - a vertex is inside where its value >= V; an edge is cut when one end
//     is inside and the other not;
//   - the cut point of an edge from a to b, a its end first in (z, y, x)
//     order (the smaller-numbered grid point), is a + t (b - a) with
//     t = (V - f(a)) / (f(b) - f(a)); where the inside end's value is V
//     exactly the point is that vertex;
//   - points are merged by what names them (the cut edge's two ends, or the
//     vertex), so triangles of neighbouring tetrahedra share their points
//     and the surface is watertight but where it leaves the domain;
//   - a tetrahedron with two vertices inside is cut in a quadrilateral,
//     split by the diagonal through its corner whose cut edge comes first
//     (edges ordered by their first end, then their second, in (z, y, x)
//     order);
//   - triangles with a repeated point or of zero area are dropped, and so
//     are both copies of a triangle that two tetrahedra contribute (a face
//     at V exactly between two outsides: a sheet that bounds nothing);
//   - triangles are oriented so that their normals (right-hand rule) point
//     toward increasing values.
// Per point the normal is the field's gradient (the piecewise-linear field
// of the leaves, averaged over the point's triangles weighted by area),
// of unit length; per triangle the error bound of the tetrahedron it was
// cut from.
//
// The HT's leaves that reach past the grid (the hierarchy covers a padded
// cube) are clipped to it first (query/clip.h), as the .vtu output is; an
// HP's time slice (query/slice.h) is cut into tetrahedra and clipped, then
// contoured.
//
// Thread safety: a SurfaceBuilder is one thread's; the walks use the
// caller's source (one thread's: query/source.h).
//
// Lifetimes: results are values; meshes and sources are read during the
// call only.
//
// Errors: the source's (Corruption, IOError), and Corruption when the store
// has no field value at a corner of the domain (ForEachLeaf); std::bad_alloc
// when the surface outgrows memory.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <unordered_map>
#include <vector>

#include "hierarchy/geometry.h"
#include "query/clip.h"
#include "query/mesh.h"
#include "query/mesh_io.h"
#include "query/slice.h"
#include "query/source.h"
#include "util/status.h"

namespace simplexdb {

// A triangle mesh with its arrays, as .vtp and .ply hold it.
struct SurfaceData {
  std::vector<double> points;      // x, y, z per point: grid units, physical after PlaceSurface
  std::vector<float> normals;      // x, y, z per point: the unit gradient (zero where it vanishes)
  std::vector<int64_t> triangles;  // 3 point indices per triangle
  std::vector<double> error;       // per triangle: its tetrahedron's error bound
  uint64_t point_count() const { return points.size() / 3; }
  uint64_t triangle_count() const { return triangles.size() / 3; }
};

// A tetrahedron's vertex for SurfaceBuilder::Add: what names it (equal ids
// are one point), where it is (grid units) and its value.
struct SurfaceVertex {
  uint64_t id;
  std::array<double, 3> p;
  double f;
};

// Marching tetrahedra by the rule above, one tetrahedron at a time.
class SurfaceBuilder {
 public:
  // `expected_points`: room to make at once (a guess; 0: grow as needed).
  explicit SurfaceBuilder(double iso, uint64_t expected_points = 0);
  ~SurfaceBuilder();
  SurfaceBuilder(const SurfaceBuilder&) = delete;
  SurfaceBuilder& operator=(const SurfaceBuilder&) = delete;

  double iso() const { return iso_; }
  // Whether a tetrahedron with these values has no triangle (every vertex
  // inside, or none).
  bool Misses(const std::array<double, 4>& f) const {
    const bool in0 = f[0] >= iso_;
    return (f[1] >= iso_) == in0 && (f[2] >= iso_) == in0 && (f[3] >= iso_) == in0;
  }
  // The triangles of one tetrahedron of a conforming mesh (any orientation;
  // `error` its cell value). Amortised O(1).
  void Add(const std::array<SurfaceVertex, 4>& v, double error);
  // The surface: sheets removed, normals made unit, unused points dropped.
  SurfaceData Finish();

 private:
  struct Table;
  int64_t VertexPoint(const SurfaceVertex& a);
  int64_t EdgePoint(const SurfaceVertex& inside, const SurfaceVertex& outside);
  void Triangle(std::array<int64_t, 3> t, const std::array<double, 3>& outside, const std::array<double, 3>& gradient,
                double error);

  double iso_;
  std::unique_ptr<Table> points_;          // what names a point -> its index
  std::vector<double> xyz_, normal_sum_;   // per point
  std::vector<uint8_t> at_vertex_;         // per point: it is a mesh vertex
  std::vector<int64_t> triangles_;
  std::vector<double> error_;
  std::map<std::array<int64_t, 3>, uint64_t> vertex_triangles_;  // a triangle of vertices -> its number
  std::vector<uint64_t> dropped_;  // the first copies of sheets' triangles
};

// Contours the tetrahedra of `mesh` (points shared, as CollectTetMesh and
// SliceHpMesh make them), naming point i id_of(i).
template <class IdOf>
void ContourTetMesh(const TetMeshData& mesh, SurfaceBuilder& builder, const IdOf& id_of) {
  for (uint64_t c = 0; c < mesh.cells(); ++c) {
    std::array<SurfaceVertex, 4> v;
    std::array<double, 4> f;
    for (int i = 0; i < 4; ++i) {
      const int64_t p = mesh.connectivity[4 * c + i];
      f[i] = mesh.field[p];
      v[i] = {id_of(p), {mesh.points[3 * p], mesh.points[3 * p + 1], mesh.points[3 * p + 2]}, f[i]};
    }
    if (!builder.Misses(f)) builder.Add(v, mesh.error[c]);
  }
}

// The isosurface at `iso` of the HT mesh's leaves (those `keep` keeps),
// clipped to the grid, in grid units. O(leaves) with one error lookup per
// leaf the surface crosses.
template <ReadSource<3> Source, class Keep = KeepAll>
Result<SurfaceData> ContourHtMesh(const Mesh<3>& mesh, Source& source, double iso, const Keep& keep = {}) {
  const SourceInfo& info = source.info();
  const double scale = std::ldexp(1.0, -(kCoordBits<3> - info.domain_bits));
  std::array<int32_t, 3> last{};  // the grid's last point per axis, in lattice units
  for (int a = 0; a < 3; ++a) last[a] = static_cast<int32_t>((info.dims[a] - 1)) << (kCoordBits<3> - info.domain_bits);
  // About one point per six leaves on the surfaces measured (bench/README.md).
  SurfaceBuilder builder(iso, mesh.leaf_count() / 6);
  // The leaves that reach past the grid, to be clipped, points shared.
  TetMeshData boundary;
  std::unordered_map<uint64_t, int64_t> boundary_index;
  SDB_RETURN_IF_ERROR(ForEachLeaf<3>(
      mesh, source,
      [&](SimplexCode<3> code, const SimplexVertices<3>& v, const std::array<double, 4>& f) -> Status {
        if (builder.Misses(f)) return Status::OK();
        SDB_ASSIGN_OR_RETURN(const double e, source.Error(code));
        bool inside = true;
        for (int i = 0; i < 4; ++i) {
          for (int a = 0; a < 3; ++a) inside = inside && v[i][a] <= last[a];
        }
        if (inside) {
          std::array<SurfaceVertex, 4> sv;
          for (int i = 0; i < 4; ++i) sv[i] = {internal::Pack<3>(v[i]), {v[i][0] * scale, v[i][1] * scale, v[i][2] * scale}, f[i]};
          builder.Add(sv, e);
          return Status::OK();
        }
        for (int i = 0; i < 4; ++i) {
          const auto [it, fresh] =
              boundary_index.emplace(internal::Pack<3>(v[i]), static_cast<int64_t>(boundary_index.size()));
          if (fresh) {
            for (int a = 0; a < 3; ++a) boundary.points.push_back(v[i][a] * scale);
            boundary.field.push_back(f[i]);
          }
          boundary.connectivity.push_back(it->second);
        }
        if (!PositivelyOriented(v)) std::swap(boundary.connectivity.end()[-4], boundary.connectivity.end()[-3]);
        boundary.error.push_back(e);
        boundary.level.push_back(static_cast<uint8_t>(code.level()));
        boundary.code.push_back(code.key());
        return Status::OK();
      },
      keep));
  if (boundary.cells() > 0) {
    const TetMeshData clipped = ClipToGrid(std::move(boundary), info.dims);
    // A point of the clipped mesh at a grid point is named as the leaves
    // inside name it (its packed lattice point); a cut point by its index.
    ContourTetMesh(clipped, builder, [&](int64_t p) {
      Point<3> lattice{};
      for (int a = 0; a < 3; ++a) {
        const double g = clipped.points[3 * p + a];
        if (g != std::floor(g)) return (uint64_t{1} << 63) | static_cast<uint64_t>(p);
        lattice[a] = static_cast<int32_t>(g / scale);
      }
      return internal::Pack<3>(lattice);
    });
  }
  return builder.Finish();
}

// The isosurface at `iso` of the HP mesh's time slice at lattice time `t`
// (SliceHpMesh; the pentatopes `keep` keeps), clipped to the grid, in grid
// units. The slice's tetrahedra are collected first.
template <ReadSource<4> Source, class Keep = KeepAll>
Result<SurfaceData> ContourHpSlice(const Mesh<4>& mesh, Source& source, double iso, double t,
                                   const Keep& keep = {}) {
  SDB_ASSIGN_OR_RETURN(TetMeshData slice, SliceHpMesh(mesh, source, t, keep));
  const TetMeshData clipped = ClipToGrid(std::move(slice), source.info().dims);
  SurfaceBuilder builder(iso);
  ContourTetMesh(clipped, builder, [](int64_t p) { return static_cast<uint64_t>(p); });
  return builder.Finish();
}

// Moves the surface from grid units to physical ones (as PlacePhysically:
// x = origin + x * spacing per axis); the normals become the physical
// gradient's direction, and an odd number of flipped axes reverses every
// triangle so that normals still point toward increasing values. O(points
// + triangles).
void PlaceSurface(SurfaceData& surface, const SourceInfo& info);

}  // namespace simplexdb
