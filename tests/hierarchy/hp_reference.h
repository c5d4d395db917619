// Independent references for the HP tests: the split rules of Fig. 52
// written out literally with named vertices (not using split_rules.h) and
// the 24 roots, for the recursive bisection of tests/hierarchy/
// simplex_reference.h that enumerates every code with its vertices, and the
// exact 4-volume.
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

// Exact 4D volumes need more than 64 bits in the worst case.
__extension__ typedef __int128 Int128;

using P4 = Point<4>;
using Penta = SimplexVertices<4>;  // v1..v5

// Fig. 52, literally. `g` is the child index of the parent of `t`, `p` that
// of `t` itself (both 0 where no rule reads them).
inline std::array<Penta, 2> SplitLiteral4(const Penta& t, int level, int g, int p) {
  const P4 &v1 = t[0], &v2 = t[1], &v3 = t[2], &v4 = t[3], &v5 = t[4];
  switch (level % 4) {
    case 0: {  // case 1: h-pentatope, split v4v5
      const P4 vm = Mid<4>(v4, v5);
      return {Penta{vm, v1, v2, v3, v5}, Penta{vm, v1, v2, v3, v4}};
    }
    case 1:
      if (p == 0) {  // case 2: c-pentatope, child 0, split v4v5
        const P4 vm = Mid<4>(v4, v5);
        return {Penta{vm, v1, v2, v3, v5}, Penta{vm, v1, v2, v3, v4}};
      } else {  // case 3: c-pentatope, child 1, split v2v5
        const P4 vm = Mid<4>(v2, v5);
        return {Penta{vm, v1, v5, v3, v4}, Penta{vm, v1, v2, v3, v4}};
      }
    case 2:
      if (g == 0 && p == 0) {  // case 4: split v4v5
        const P4 vm = Mid<4>(v4, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v3, v5}};
      } else if (g == 0 && p == 1) {  // case 5: split v3v5
        const P4 vm = Mid<4>(v3, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v5, v4}};
      } else if (g == 1 && p == 0) {  // case 6: split v3v4
        const P4 vm = Mid<4>(v3, v4);
        return {Penta{vm, v1, v2, v5, v3}, Penta{vm, v1, v2, v5, v4}};
      } else {  // case 7: split v3v5
        const P4 vm = Mid<4>(v3, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v5, v4}};
      }
    default: {  // case 8: e-pentatope, split v4v5
      const P4 vm = Mid<4>(v4, v5);
      return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v3, v5}};
    }
  }
}

// The 24 roots: v1 three-hot, v2 two-hot, v3 one-hot, v4 the origin, v5 all
// ones, along the axis permutation (a, b, c, d) numbered lexicographically.
inline Penta RootLiteral4(int top) {
  std::array<int, 4> perm = {0, 1, 2, 3};
  for (int i = 0; i < top; ++i) std::next_permutation(perm.begin(), perm.end());
  const int s = kDomainSide<4>;
  P4 v3{0, 0, 0, 0};
  v3[perm[0]] = s;
  P4 v2 = v3;
  v2[perm[1]] = s;
  P4 v1 = v2;
  v1[perm[2]] = s;
  return Penta{v1, v2, v3, P4{0, 0, 0, 0}, P4{s, s, s, s}};
}

template <>
struct LiteralRules<4> {
  static std::array<Penta, 2> Split(const Penta& t, int level, int g, int p) { return SplitLiteral4(t, level, g, p); }
  static Penta Root(int top) { return RootLiteral4(top); }
};

// 24 times the signed 4-volume, exactly.
inline Int128 Det4(const Penta& t) {
  Int128 m[4][4];
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) m[i][j] = static_cast<Int128>(t[i + 1][j]) - t[0][j];
  }
  const auto det3 = [&](int r0, int r1, int r2, int c0, int c1, int c2) {
    return m[r0][c0] * (m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]) -
           m[r0][c1] * (m[r1][c0] * m[r2][c2] - m[r1][c2] * m[r2][c0]) +
           m[r0][c2] * (m[r1][c0] * m[r2][c1] - m[r1][c1] * m[r2][c0]);
  };
  return m[0][0] * det3(1, 2, 3, 1, 2, 3) - m[0][1] * det3(1, 2, 3, 0, 2, 3) +
         m[0][2] * det3(1, 2, 3, 0, 1, 3) - m[0][3] * det3(1, 2, 3, 0, 1, 2);
}

inline Int128 Abs128(Int128 x) { return x < 0 ? -x : x; }

}  // namespace simplexdb::testing
