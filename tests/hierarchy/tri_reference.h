// Test helpers for the triangle quadtrees: exact points of the solid's
// surface, independent of the neighbor algorithms under test.
//
// A point of the solid is held as integer weights over all of the solid's
// vertices (at most three nonzero, summing to kTriScale). A point on an edge
// of two base faces has the same weights seen from either face, so points
// from different faces compare exactly, and "p lies on segment r1 r2" is
// exact integer arithmetic.
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <type_traits>
#include <vector>

#include <gtest/gtest.h>

#include "hierarchy/tri_code.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_polyhedron.h"

namespace simplexdb::testing {

template <Polyhedron P>
using PolyhedronTag = std::integral_constant<Polyhedron, P>;
using AllPolyhedra = ::testing::Types<PolyhedronTag<Polyhedron::kIcosahedron>,
                                      PolyhedronTag<Polyhedron::kOctahedron>,
                                      PolyhedronTag<Polyhedron::kTetrahedron>>;

// A typed-test fixture over the three solids.
template <class Tag>
class TriFixture : public ::testing::Test {
 protected:
  static constexpr Polyhedron kSolid = Tag::value;
  using CodeType = TriCode<kSolid>;
};

// Weights over the (at most 12) vertices of the solid.
using SolidPoint = std::array<int64_t, 12>;
using SolidTriangle = std::array<SolidPoint, 3>;  // (apex, left, right)

template <Polyhedron P>
SolidPoint ToSolid(int face, const TriWeights& w) {
  SolidPoint s{};
  const auto ids = FaceVertexIds<P>(face);
  for (int i = 0; i < 3; ++i) s[ids[i]] += w[i];
  return s;
}

template <Polyhedron P>
SolidTriangle SolidVertices(TriCode<P> c) {
  const TriWeightVertices w = VertexWeights(c);
  return {ToSolid<P>(c.face(), w[0]), ToSolid<P>(c.face(), w[1]), ToSolid<P>(c.face(), w[2])};
}

// The ends of the edge of direction d: left apex-left, right apex-right,
// vertical left-right.
inline std::array<SolidPoint, 2> EdgeOf(const SolidTriangle& t, int d) {
  return {t[tri::kEdgeEnds[d][0]], t[tri::kEdgeEnds[d][1]]};
}

inline bool SameEdge(const std::array<SolidPoint, 2>& a, const std::array<SolidPoint, 2>& b) {
  return (a[0] == b[0] && a[1] == b[1]) || (a[0] == b[1] && a[1] == b[0]);
}

// True when p lies on the closed segment r1 r2 (exact).
inline bool OnSegment(const SolidPoint& p, const SolidPoint& r1, const SolidPoint& r2) {
  int64_t along = 0, length = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    for (size_t j = i + 1; j < p.size(); ++j) {
      // (p - r1) parallel to (r2 - r1): every 2x2 minor vanishes. Weights are
      // below 2^28, so the products fit.
      if ((p[i] - r1[i]) * (r2[j] - r1[j]) != (p[j] - r1[j]) * (r2[i] - r1[i])) return false;
    }
    along += (p[i] - r1[i]) * (r2[i] - r1[i]);
    length += (r2[i] - r1[i]) * (r2[i] - r1[i]);
  }
  return along >= 0 && along <= length;
}

template <Polyhedron P>
std::vector<TriCode<P>> AllCodesAtLevel(int level) {
  std::vector<TriCode<P>> out;
  for (int f = 0; f < TriCode<P>::kFaces; ++f) {
    for (uint64_t p = 0; p < (uint64_t{1} << (2 * level)); ++p) {
      out.push_back(TriCode<P>::FromPath(f, p, level));
    }
  }
  return out;
}

template <Polyhedron P>
TriCode<P> RandomCode(std::mt19937_64& rng, int level) {
  return TriCode<P>::FromPath(static_cast<int>(rng() % TriCode<P>::kFaces),
                              level == 0 ? 0 : rng() >> (64 - 2 * level), level);
}

inline const char* DirectionName(int d) {
  static const char* kNames[] = {"left", "right", "vertical"};
  return kNames[d];
}

}  // namespace simplexdb::testing
