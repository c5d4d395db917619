// Writing extracted meshes: leaf codes as text, and VTK XML unstructured
// grids (.vtu) any VTK reader opens.
//
// Files are written under a temporary name and renamed when complete
// (storage/io/file.h), so a failed or interrupted write never leaves a partial
// file under the real name. "-" means standard output for text.
//
// Thread safety: free functions; WriteCodes and WriteVtu may run in several
// threads at once (on different paths); the walks use the caller's source,
// which is one thread's (query/source.h).
//
// Lifetimes: results are values; spans and meshes passed in are read during
// the call only. ForEachLeaf's vertices and values are valid during the
// callback only.
//
// Errors: WriteCodes and WriteVtu return the writer's errors
// (storage/io/file.h: the errno of the failing call as a Status naming the
// file, ResourceExhausted for a full disk), IOError when writing to standard
// output fails; nothing is left under the path then. ForEachLeaf returns the
// first error of the callback or the source, and Corruption when the store
// has no field value at a corner of the domain; CollectTetMesh the same.
#pragma once

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "hierarchy/geometry.h"
#include "query/mesh.h"
#include "query/refine.h"
#include "query/source.h"
#include "util/status.h"

namespace simplexdb {

// The codes in text form ("T:bits"), one per line.
template <int D>
Status WriteCodes(std::span<const SimplexCode<D>> codes, const std::string& path);

// A tetrahedral mesh with its arrays, as .vtu holds it.
struct TetMeshData {
  std::vector<double> points;       // x, y, z per point, in grid units
  std::vector<double> field;        // per point
  std::vector<int64_t> connectivity;  // 4 point indices per cell
  std::vector<double> error;        // per cell: the stored error bound
  std::vector<uint8_t> level;       // per cell
  std::vector<uint64_t> code;       // per cell: the packed location code
  uint64_t cells() const { return connectivity.size() / 4; }
};

// VTK XML UnstructuredGrid, binary appended data compressed with zlib
// (vtkZLibDataCompressor, little-endian, 64-bit headers; Int32 connectivity
// and offsets when they fit, else Int64): point array "field", cell arrays
// "error", "level" and "code", cell type VTK_TETRA. Holds the compressed
// arrays in memory until written: also ResourceExhausted when they do not fit.
Status WriteVtu(const TetMeshData& mesh, const std::string& path);

// Every node: ForEachLeaf's default `keep`.
struct KeepAll {
  template <class Code>
  bool operator()(Code) const { return true; }
};

// Walks the leaves of `mesh` depth-first, carrying vertices and their field
// values down from the roots: calls leaf(code, vertices, values). Nodes
// for which keep(code) is false are skipped with their subtrees (a piece
// of the mesh: query/pieces.h, PieceWalk::Keeps).
template <int D, ReadSource<D> Source, class Leaf, class Keep = KeepAll>
Status ForEachLeaf(const Mesh<D>& mesh, Source& source, Leaf&& leaf, const Keep& keep = {}) {
  using Code = SimplexCode<D>;
  VertexValues<D, Source> values(source);
  struct Frame {
    Code code;
    SimplexVertices<D> v;
    std::array<double, D + 1> f;
  };
  std::vector<Frame> stack;
  for (int t = Code::kRoots - 1; t >= 0; --t) {
    Frame fr{Code::Root(t), RootVertices<D>(t), {}};
    SDB_RETURN_IF_ERROR(values.RootValues(t, fr.v, fr.f));
    stack.push_back(fr);
  }
  while (!stack.empty()) {
    const Frame fr = stack.back();
    stack.pop_back();
    if (!keep(fr.code)) continue;
    if (!mesh.is_split(fr.code)) {
      SDB_RETURN_IF_ERROR(leaf(fr.code, fr.v, fr.f));
      continue;
    }
    SDB_ASSIGN_OR_RETURN(const double mid, values.Midpoint(fr.code, fr.v));
    for (int i = 1; i >= 0; --i) {
      Frame child{fr.code.child(i), ChildVertices<D>(fr.code, fr.v, i), {}};
      internal::Split<D>(fr.f, SplitRules<D>::CaseOf(fr.code.level(), fr.code.path()), i, child.f,
                         [&](double, double) { return mid; });
      stack.push_back(child);
    }
  }
  return Status::OK();
}

// Whether the tetrahedron v has positive orientation as VTK counts it: v3
// on the side (v1 - v0) x (v2 - v0) points to. Exact: lattice coordinates
// of at most 20 bits make every term of the determinant under 2^61.
inline bool PositivelyOriented(const SimplexVertices<3>& v) {
  static_assert(kCoordBits<3> <= 20);
  std::array<std::array<int64_t, 3>, 3> e{};
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 3; ++a) e[i][a] = int64_t{v[i + 1][a]} - v[0][a];
  }
  const int64_t det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                       e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                       e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  return det > 0;
}

// The HT mesh's leaves (those `keep` keeps) with their field and errors,
// points shared. Each
// tetrahedron is written with positive orientation (half of them, in code
// order, are not: their first two vertices are swapped).
template <ReadSource<3> Source, class Keep = KeepAll>
Result<TetMeshData> CollectTetMesh(const Mesh<3>& mesh, Source& source, const Keep& keep = {}) {
  TetMeshData out;
  std::unordered_map<uint64_t, int64_t> index;
  const double scale = std::ldexp(1.0, -(kCoordBits<3> - source.info().domain_bits));
  SDB_RETURN_IF_ERROR(ForEachLeaf<3>(
      mesh, source,
      [&](SimplexCode<3> code, const SimplexVertices<3>& v, const std::array<double, 4>& f) -> Status {
        for (int i = 0; i < 4; ++i) {
          const auto [it, fresh] = index.emplace(internal::Pack<3>(v[i]), static_cast<int64_t>(index.size()));
          if (fresh) {
            for (int a = 0; a < 3; ++a) out.points.push_back(v[i][a] * scale);
            out.field.push_back(f[i]);
          }
          out.connectivity.push_back(it->second);
        }
        if (!PositivelyOriented(v)) std::swap(out.connectivity.end()[-4], out.connectivity.end()[-3]);
        SDB_ASSIGN_OR_RETURN(const double e, source.Error(code));
        out.error.push_back(e);
        out.level.push_back(static_cast<uint8_t>(code.level()));
        out.code.push_back(code.key());
        return Status::OK();
      },
      keep));
  return out;
}

}  // namespace simplexdb
