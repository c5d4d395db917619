// The time slice of an HP mesh (seed 4.6-4.7): where a conforming mesh of
// pentatopes meets the hyperplane t = T, as a conforming 3D tetrahedral mesh
// with the field interpolated along the cut edges.
//
// A pentatope whose vertices lie on both sides of the hyperplane meets it in
// a tetrahedron (4 cut points), a pyramid with a quadrilateral base (one
// vertex on the hyperplane, two on each side) or a triangular prism (two
// vertices on one side, three on the other). Pyramids and prisms are cut into
// tetrahedra by one global rule, so that two cells sharing a quadrilateral
// face split it the same way: every quadrilateral is split by the diagonal
// through its smallest point (points ordered by the edge they come from),
// which for a prism always gives three tetrahedra (Dompierre et al., "How to
// subdivide pyramids, prisms and hexahedra into tetrahedra", 1999). A
// pentatope with a whole facet on the hyperplane contributes that facet once:
// from the side t > T, or from t < T when T is the domain's last time.
// Pentatopes that touch the hyperplane in less than a 3D piece contribute
// nothing. Tetrahedra are oriented positively.
//
// Thread safety: a free function over the caller's source (one thread's:
// query/source.h).
//
// Lifetimes: the result is a value; the source and mesh are only read
// during the call.
//
// Errors: SliceHpMesh returns the source's errors (Corruption, IOError) and
// Corruption when the store has no field value at a corner of the domain.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "hierarchy/geometry.h"
#include "query/mesh.h"
#include "query/mesh_io.h"
#include "query/source.h"
#include "util/status.h"

namespace simplexdb {

// `t` is in lattice units (Criteria<4>::time). Cell arrays: the pentatope's
// error, level and code for each tetrahedron cut from it.
// The pentatopes walked are those `keep` keeps (ForEachLeaf, query/mesh_io.h).
template <ReadSource<4> Source, class Keep = KeepAll>
Result<TetMeshData> SliceHpMesh(const Mesh<4>& mesh, Source& source, double t, const Keep& keep = {}) {
  TetMeshData out;
  const int k = source.info().domain_bits;
  const double scale = std::ldexp(1.0, -(kCoordBits<4> - k));
  const double last_time = static_cast<double>(kDomainSide<4>);
  // A point of the slice: a vertex on the hyperplane (a == b) or the cut of
  // edge a-b (a < b), both packed lattice points.
  using PointKey = std::pair<uint64_t, uint64_t>;
  std::map<PointKey, int64_t> index;
  struct SlicePoint {
    PointKey key;
    std::array<double, 3> x;
    double f;
  };
  const auto add_point = [&](const SlicePoint& p) {
    const auto [it, fresh] = index.emplace(p.key, static_cast<int64_t>(index.size()));
    if (fresh) {
      for (int a = 0; a < 3; ++a) out.points.push_back(p.x[a] * scale);
      out.field.push_back(p.f);
    }
    return it->second;
  };
  const auto emit = [&](std::array<SlicePoint, 4> tet, SimplexCode<4> code, double error) {
    // Orient positively.
    std::array<double, 3> e[3];
    for (int i = 0; i < 3; ++i) {
      for (int a = 0; a < 3; ++a) e[i][a] = tet[i + 1].x[a] - tet[0].x[a];
    }
    const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                       e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                       e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    if (det == 0) return;  // cannot happen for a cut of a non-degenerate pentatope
    if (det < 0) std::swap(tet[2], tet[3]);
    for (const SlicePoint& p : tet) out.connectivity.push_back(add_point(p));
    out.error.push_back(error);
    out.level.push_back(static_cast<uint8_t>(code.level()));
    out.code.push_back(code.key());
  };
  SDB_RETURN_IF_ERROR(ForEachLeaf<4>(
      mesh, source,
      [&](SimplexCode<4> code, const SimplexVertices<4>& v, const std::array<double, 5>& f) -> Status {
        std::array<double, 5> s{};
        std::vector<int> neg, zero, pos;
        for (int i = 0; i < 5; ++i) {
          s[i] = static_cast<double>(v[i][3]) - t;
          (s[i] < 0 ? neg : s[i] > 0 ? pos : zero).push_back(i);
        }
        const auto on = [&](int i) {
          const uint64_t p = internal::Pack<4>(v[i]);
          return SlicePoint{{p, p}, {double(v[i][0]), double(v[i][1]), double(v[i][2])}, f[i]};
        };
        const auto cut = [&](int i, int j) {
          const double w = s[i] / (s[i] - s[j]);
          SlicePoint p;
          uint64_t a = internal::Pack<4>(v[i]), b = internal::Pack<4>(v[j]);
          p.key = {std::min(a, b), std::max(a, b)};
          for (int c = 0; c < 3; ++c) p.x[c] = v[i][c] + (v[j][c] - v[i][c]) * w;
          p.f = f[i] + (f[j] - f[i]) * w;
          return p;
        };
        SDB_ASSIGN_OR_RETURN(const double error, source.Error(code));
        if (neg.empty() || pos.empty()) {
          // A facet on the hyperplane: once, from one side.
          if (zero.size() == 4 && (t == last_time ? !neg.empty() : !pos.empty())) {
            emit({on(zero[0]), on(zero[1]), on(zero[2]), on(zero[3])}, code, error);
          }
          return Status::OK();
        }
        std::vector<SlicePoint> pts;
        for (int z : zero) pts.push_back(on(z));
        if (pts.size() + neg.size() * pos.size() == 4) {
          for (int i : neg) {
            for (int j : pos) pts.push_back(cut(i, j));
          }
          emit({pts[0], pts[1], pts[2], pts[3]}, code, error);
        } else if (zero.size() == 1) {
          // Pyramid: apex on the hyperplane, base the quadrilateral of the
          // cuts of a-c, a-d, b-d, b-c (cyclic), split through its smallest.
          const int a = neg[0], b = neg[1], c = pos[0], d = pos[1];
          const std::array<SlicePoint, 4> q = {cut(a, c), cut(a, d), cut(b, d), cut(b, c)};
          int m = 0;
          for (int i = 1; i < 4; ++i) {
            if (q[i].key < q[m].key) m = i;
          }
          emit({pts[0], q[m], q[(m + 1) % 4], q[(m + 2) % 4]}, code, error);
          emit({pts[0], q[m], q[(m + 2) % 4], q[(m + 3) % 4]}, code, error);
        } else {
          // Prism: the two-vertex side gives the two triangles, the
          // three-vertex side the lateral edges: V[i] = cut(x, side3[i]),
          // V[i + 3] = cut(y, side3[i]).
          const std::vector<int>& two = neg.size() == 2 ? neg : pos;
          const std::vector<int>& three = neg.size() == 2 ? pos : neg;
          std::array<SlicePoint, 6> p;
          for (int i = 0; i < 3; ++i) {
            p[i] = cut(two[0], three[i]);
            p[i + 3] = cut(two[1], three[i]);
          }
          // Renumber so the smallest point is V0 (rotating the triangles and
          // swapping them keeps the prism's structure).
          int m = 0;
          for (int i = 1; i < 6; ++i) {
            if (p[i].key < p[m].key) m = i;
          }
          std::array<int, 6> r{};
          const int base = m < 3 ? 0 : 3, other = 3 - base, rot = m % 3;
          for (int i = 0; i < 3; ++i) {
            r[i] = base + (rot + i) % 3;
            r[i + 3] = other + (rot + i) % 3;
          }
          const auto V = [&](int i) { return p[r[i]]; };
          if (std::min(V(1).key, V(5).key) < std::min(V(2).key, V(4).key)) {
            emit({V(0), V(1), V(2), V(5)}, code, error);
            emit({V(0), V(1), V(5), V(4)}, code, error);
            emit({V(0), V(4), V(5), V(3)}, code, error);
          } else {
            emit({V(0), V(1), V(2), V(4)}, code, error);
            emit({V(0), V(4), V(2), V(5)}, code, error);
            emit({V(0), V(4), V(5), V(3)}, code, error);
          }
        }
        return Status::OK();
      },
      keep));
  return out;
}

}  // namespace simplexdb
