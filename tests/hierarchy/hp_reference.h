// Independent references for the HP tests: the split rules of Fig. 52
// written out literally with named vertices (not using split_rules.h), the
// 24 roots, a recursive bisection enumerating every code with its vertices,
// and exact geometric predicates in 4D.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"

namespace simplexdb::testing {

// Exact 4D volumes need more than 64 bits in the worst case.
__extension__ typedef __int128 Int128;

using P4 = Point<4>;
using Penta = SimplexVertices<4>;  // v1..v5

inline P4 Mid4(const P4& a, const P4& b) {
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2, (a[3] + b[3]) / 2};
}

// Fig. 52, literally. `g` is the child index of the parent of `t`, `p` that
// of `t` itself (both 0 where no rule reads them).
inline std::array<Penta, 2> SplitLiteral4(const Penta& t, int level, int g, int p) {
  const P4 &v1 = t[0], &v2 = t[1], &v3 = t[2], &v4 = t[3], &v5 = t[4];
  switch (level % 4) {
    case 0: {  // case 1: h-pentatope, split v4v5
      const P4 vm = Mid4(v4, v5);
      return {Penta{vm, v1, v2, v3, v5}, Penta{vm, v1, v2, v3, v4}};
    }
    case 1:
      if (p == 0) {  // case 2: c-pentatope, child 0, split v4v5
        const P4 vm = Mid4(v4, v5);
        return {Penta{vm, v1, v2, v3, v5}, Penta{vm, v1, v2, v3, v4}};
      } else {  // case 3: c-pentatope, child 1, split v2v5
        const P4 vm = Mid4(v2, v5);
        return {Penta{vm, v1, v5, v3, v4}, Penta{vm, v1, v2, v3, v4}};
      }
    case 2:
      if (g == 0 && p == 0) {  // case 4: split v4v5
        const P4 vm = Mid4(v4, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v3, v5}};
      } else if (g == 0 && p == 1) {  // case 5: split v3v5
        const P4 vm = Mid4(v3, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v5, v4}};
      } else if (g == 1 && p == 0) {  // case 6: split v3v4
        const P4 vm = Mid4(v3, v4);
        return {Penta{vm, v1, v2, v5, v3}, Penta{vm, v1, v2, v5, v4}};
      } else {  // case 7: split v3v5
        const P4 vm = Mid4(v3, v5);
        return {Penta{vm, v1, v2, v3, v4}, Penta{vm, v1, v2, v5, v4}};
      }
    default: {  // case 8: e-pentatope, split v4v5
      const P4 vm = Mid4(v4, v5);
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

// Calls visit(code, vertices) for every code of level <= max_level, in
// preorder, by recursive bisection with the literal rules.
inline void ForEachPentaLiteral(int max_level,
                                const std::function<void(PentaCode, const Penta&)>& visit) {
  std::function<void(PentaCode, const Penta&, int, int)> rec =
      [&](PentaCode c, const Penta& t, int g, int p) {
        visit(c, t);
        if (c.level() == max_level) return;
        const std::array<Penta, 2> kids = SplitLiteral4(t, c.level(), g, p);
        rec(c.child(0), kids[0], p, 0);
        rec(c.child(1), kids[1], p, 1);
      };
  for (int top = 0; top < 24; ++top) rec(PentaCode::Root(top), RootLiteral4(top), 0, 0);
}

inline std::vector<std::pair<PentaCode, Penta>> AllPentasAtLevel(int level) {
  std::vector<std::pair<PentaCode, Penta>> out;
  ForEachPentaLiteral(level, [&](PentaCode c, const Penta& t) {
    if (c.level() == level) out.emplace_back(c, t);
  });
  return out;
}

inline int64_t Dist2(const P4& a, const P4& b) {
  int64_t s = 0;
  for (int i = 0; i < 4; ++i) {
    const int64_t d = int64_t{a[i]} - b[i];
    s += d * d;
  }
  return s;
}

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

// Face type k (1..5) omits vertex position 5-k; FaceOf4 keeps positions.
using Face4 = std::array<P4, 4>;
inline Face4 FaceOf4(const Penta& t, int type, bool sorted) {
  const int omit = 5 - type;
  Face4 f{};
  int n = 0;
  for (int i = 0; i < 5; ++i) {
    if (i != omit) f[n++] = t[i];
  }
  if (sorted) std::sort(f.begin(), f.end());
  return f;
}

template <size_t N>
bool OnHypercubeBoundary(const std::array<P4, N>& pts) {
  for (int axis = 0; axis < 4; ++axis) {
    for (int side : {0, kDomainSide<4>}) {
      bool all = true;
      for (const P4& p : pts) all = all && p[axis] == side;
      if (all) return true;
    }
  }
  return false;
}

struct P4Hash {
  size_t operator()(const P4& p) const {
    uint64_t h = 0;
    for (int v : p) h = h * 0x9E3779B97F4A7C15ULL + static_cast<uint32_t>(v);
    return std::hash<uint64_t>()(h);
  }
};
template <size_t N>
struct Points4Hash {
  size_t operator()(const std::array<P4, N>& a) const {
    size_t h = 0;
    for (const P4& p : a) h = h * 1000003u ^ P4Hash()(p);
    return h;
  }
};

}  // namespace simplexdb::testing
