// Independent references for the HT tests: the split rules of section 3.1.2
// written out literally with named vertices (not using split_rules.h), for
// the recursive bisection of tests/hierarchy/simplex_reference.h that
// enumerates every code with its vertices, and the volume with exact integer
// arithmetic.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "tests/hierarchy/simplex_reference.h"

namespace simplexdb::testing {

using P3 = Point<3>;
using Tet = SimplexVertices<3>;  // v1, v2, v3, v4

// Section 3.1.2, literally. `parent_bit` is the child index of t's parent
// (SEED-ERRATA item 1: it decides the 1/4-pyramid rule).
inline std::array<Tet, 2> SplitLiteral(const Tet& t, int level, int parent_bit) {
  const P3& v1 = t[0];
  const P3& v2 = t[1];
  const P3& v3 = t[2];
  const P3& v4 = t[3];
  const P3 vm = Mid<3>(v3, v4);
  switch (level % 3) {
    case 0:  // 1/8 pyramid (and the roots)
      return {Tet{vm, v1, v2, v4}, Tet{vm, v2, v1, v3}};
    case 1:  // 1/2 pyramid
      return {Tet{vm, v1, v2, v3}, Tet{vm, v1, v2, v4}};
    default:  // 1/4 pyramid
      if (parent_bit == 0) return {Tet{vm, v1, v2, v3}, Tet{vm, v1, v2, v4}};
      return {Tet{vm, v1, v2, v4}, Tet{vm, v1, v2, v3}};
  }
}

// The six roots, literally: v4 at the origin, v3 at the far corner,
// v1 = e_a, v2 = e_a + e_b for the axis permutations (a, b, c) in
// lexicographic order.
inline Tet RootLiteral(int top) {
  static constexpr int kPerm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                      {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  const int s = kDomainSide<3>;
  P3 v1{0, 0, 0};
  v1[kPerm[top][0]] = s;
  P3 v2 = v1;
  v2[kPerm[top][1]] = s;
  return Tet{v1, v2, P3{s, s, s}, P3{0, 0, 0}};
}

template <>
struct LiteralRules<3> {
  // g: the child index of t's parent (decides the 1/4-pyramid rule).
  static std::array<Tet, 2> Split(const Tet& t, int level, int g, int /*p*/) { return SplitLiteral(t, level, g); }
  static Tet Root(int top) { return RootLiteral(top); }
};

// Six times the signed volume.
inline int64_t Det(const P3& a, const P3& b, const P3& c, const P3& d) {
  const int64_t u[3] = {int64_t{b[0]} - a[0], int64_t{b[1]} - a[1], int64_t{b[2]} - a[2]};
  const int64_t v[3] = {int64_t{c[0]} - a[0], int64_t{c[1]} - a[1], int64_t{c[2]} - a[2]};
  const int64_t w[3] = {int64_t{d[0]} - a[0], int64_t{d[1]} - a[1], int64_t{d[2]} - a[2]};
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
         u[2] * (v[0] * w[1] - v[1] * w[0]);
}

}  // namespace simplexdb::testing
