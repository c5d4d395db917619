// Geometry of the triangles of a triangle quadtree on the sphere (seed 2.1).
//
// Exact form: a vertex is given by integer barycentric weights over its base
// face's (apex, left, right) vertices, summing to kTriScale = 2^28. Every
// vertex of every triangle down to TriCode<P>::kMaxLevel (27 or 28) is such a
// lattice point, since each level halves the edges once. The weights are
// exact; tests compare vertices across base faces by mapping them to weights
// over the polyhedron's own vertices.
//
// Triangles are labeled (apex, left, right) as the base faces are
// (hierarchy/tri_polyhedron.h). With m_al, m_ar, m_lr the midpoints of the
// edges apex-left, apex-right, left-right, the children are (section 2.1,
// Fig. 1, for both orientations):
//
//   00 (a, m_al, m_ar)    01 (m_al, l, m_lr)    11 (m_ar, m_lr, r)
//   10 (m_lr, m_al, m_ar)  -- the center: apex on the parent's horizontal edge
//
// so the left edge of a triangle is apex-left, the right edge apex-right and
// the vertical edge left-right, at every level and in both orientations.
//
// Points on the sphere: a triangle on the polyhedron projects to the sphere
// along rays from the center (gnomonic). PointToCode() inverts that: the ray
// through a point meets one face of the solid, and the descent picks the
// child holding the meeting point, level by level. Cost: O(level) for
// vertices and point location; no allocation.
//
// Thread safety: pure functions.
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>

#include "hierarchy/tri_code.h"
#include "hierarchy/tri_polyhedron.h"

namespace simplexdb {

inline constexpr int kTriScaleBits = 28;
inline constexpr int32_t kTriScale = int32_t{1} << kTriScaleBits;
static_assert(IcosaCode::kMaxLevel <= kTriScaleBits && OctaCode::kMaxLevel <= kTriScaleBits &&
              TetraCode::kMaxLevel <= kTriScaleBits);

// Barycentric weights over the base face's (apex, left, right); they sum to
// kTriScale.
using TriWeights = std::array<int32_t, 3>;
// A triangle's (apex, left, right).
using TriWeightVertices = std::array<TriWeights, 3>;

using Vec3 = std::array<double, 3>;
using TriPoints = std::array<Vec3, 3>;

struct LatLng {
  double lat_degrees = 0;
  double lng_degrees = 0;
};

namespace tri_internal {

constexpr TriWeights Mid(const TriWeights& a, const TriWeights& b) {
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

}  // namespace tri_internal

// The child's (apex, left, right) from its parent's. O(1).
// REQUIRES: 0 <= type <= 3; the parent above the deepest level.
constexpr TriWeightVertices ChildWeights(const TriWeightVertices& v, int type) {
  using tri_internal::Mid;
  switch (type) {
    case 0b00: return {v[0], Mid(v[0], v[1]), Mid(v[0], v[2])};
    case 0b01: return {Mid(v[0], v[1]), v[1], Mid(v[1], v[2])};
    case 0b10: return {Mid(v[1], v[2]), Mid(v[0], v[1]), Mid(v[0], v[2])};
    default: return {Mid(v[0], v[2]), Mid(v[1], v[2]), v[2]};
  }
}

// Exact (apex, left, right) of `code` in its base face's weights. O(level).
template <Polyhedron P>
constexpr TriWeightVertices VertexWeights(TriCode<P> code) {
  assert(code.is_valid());
  TriWeightVertices v = {{{kTriScale, 0, 0}, {0, kTriScale, 0}, {0, 0, kTriScale}}};
  for (int l = 1; l <= code.level(); ++l) v = ChildWeights(v, code.child_type_at(l));
  return v;
}

// The point of base face `face` with weights `w`, on the polyhedron.
template <Polyhedron P>
Vec3 PolyhedronPoint(int face, const TriWeights& w) {
  const auto ids = FaceVertexIds<P>(face);
  Vec3 p{0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    const Vec3& c = PolyhedronVertex<P>(ids[i]);
    for (int k = 0; k < 3; ++k) p[k] += static_cast<double>(w[i]) * c[k];
  }
  for (double& x : p) x /= kTriScale;
  return p;
}

inline Vec3 Normalized(const Vec3& p) {
  const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  return {p[0] / n, p[1] / n, p[2] / n};
}

// (apex, left, right) of `code` on the polyhedron (inscribed in the unit
// sphere). O(level).
template <Polyhedron P>
TriPoints PolyhedronVertices(TriCode<P> code) {
  const TriWeightVertices w = VertexWeights(code);
  return {PolyhedronPoint<P>(code.face(), w[0]), PolyhedronPoint<P>(code.face(), w[1]),
          PolyhedronPoint<P>(code.face(), w[2])};
}

// The same vertices projected to the unit sphere. O(level).
template <Polyhedron P>
TriPoints SphereVertices(TriCode<P> code) {
  TriPoints v = PolyhedronVertices(code);
  for (Vec3& p : v) p = Normalized(p);
  return v;
}

inline Vec3 LatLngToPoint(LatLng ll) {
  constexpr double kDeg = 3.14159265358979323846 / 180;
  const double lat = ll.lat_degrees * kDeg, lng = ll.lng_degrees * kDeg;
  return {std::cos(lat) * std::cos(lng), std::cos(lat) * std::sin(lng), std::sin(lat)};
}

// REQUIRES: p != 0 (any length).
inline LatLng PointToLatLng(const Vec3& p) {
  constexpr double kDeg = 180 / 3.14159265358979323846;
  return {std::atan2(p[2], std::hypot(p[0], p[1])) * kDeg, std::atan2(p[1], p[0]) * kDeg};
}

// The triangle at `level` whose (closed) projection holds the direction `p`.
// Points on an edge go to one of the triangles sharing it. O(level + faces).
// REQUIRES: p != 0 (any length), 0 <= level <= TriCode<P>::kMaxLevel.
template <Polyhedron P>
TriCode<P> PointToCode(const Vec3& p, int level) {
  assert(level >= 0 && level <= TriCode<P>::kMaxLevel);
  const auto det = [](const Vec3& a, const Vec3& b, const Vec3& c) {
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
  };
  // The ray from the center meets the face whose center is nearest in
  // angle: all faces are at the same distance from the center.
  static const auto kFaceCenters = [] {
    std::array<Vec3, TriCode<P>::kFaces> centers{};
    for (int f = 0; f < TriCode<P>::kFaces; ++f) {
      Vec3 c{0, 0, 0};
      for (uint8_t id : FaceVertexIds<P>(f)) {
        const Vec3& v = PolyhedronVertex<P>(id);
        for (int k = 0; k < 3; ++k) c[k] += v[k];
      }
      centers[f] = Normalized(c);
    }
    return centers;
  }();
  int face = 0;
  double best = -2;
  for (int f = 0; f < TriCode<P>::kFaces; ++f) {
    const Vec3& c = kFaceCenters[f];
    const double dot = c[0] * p[0] + c[1] * p[1] + c[2] * p[2];
    if (dot > best) best = dot, face = f;
  }
  // Barycentric coordinates of where the ray meets the face's plane (Cramer's
  // rule: each is the volume spanned by the ray and the opposite edge, over
  // the face's own, which is negative on tip-down faces).
  const auto ids = FaceVertexIds<P>(face);
  const Vec3 &a = PolyhedronVertex<P>(ids[0]), &l = PolyhedronVertex<P>(ids[1]),
             &r = PolyhedronVertex<P>(ids[2]);
  const double whole = det(a, l, r);
  double w[3] = {std::max(0.0, det(p, l, r) / whole), std::max(0.0, det(a, p, r) / whole),
                 std::max(0.0, det(a, l, p) / whole)};
  const double sum = w[0] + w[1] + w[2];
  for (double& x : w) x /= sum;
  // Descend. Doubling and subtracting 1 is exact in binary floating point,
  // so the descent adds no rounding of its own.
  uint64_t path = 0;
  for (int i = 0; i < level; ++i) {
    int type;
    if (w[0] >= 0.5) {
      type = 0b00, w[0] = 2 * w[0] - 1, w[1] *= 2, w[2] *= 2;
    } else if (w[1] >= 0.5) {
      type = 0b01, w[0] *= 2, w[1] = 2 * w[1] - 1, w[2] *= 2;
    } else if (w[2] >= 0.5) {
      type = 0b11, w[0] *= 2, w[1] *= 2, w[2] = 2 * w[2] - 1;
    } else {
      // The center (m_lr, m_al, m_ar): apex weight 1 - 2a, left 1 - 2r,
      // right 1 - 2l.
      type = 0b10;
      const double a0 = w[0], l0 = w[1], r0 = w[2];
      w[0] = 1 - 2 * a0, w[1] = 1 - 2 * r0, w[2] = 1 - 2 * l0;
    }
    path = path << 2 | static_cast<uint64_t>(type);
  }
  return TriCode<P>::FromPath(face, path, level);
}

template <Polyhedron P>
TriCode<P> LatLngToCode(LatLng ll, int level) {
  return PointToCode<P>(LatLngToPoint(ll), level);
}

// The centroid of the triangle on the polyhedron, projected to the sphere.
template <Polyhedron P>
Vec3 SphereCentroid(TriCode<P> code) {
  const TriPoints v = PolyhedronVertices(code);
  return Normalized({v[0][0] + v[1][0] + v[2][0], v[0][1] + v[1][1] + v[2][1],
                     v[0][2] + v[1][2] + v[2][2]});
}

}  // namespace simplexdb
