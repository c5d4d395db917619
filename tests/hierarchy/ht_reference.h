// Independent references for the HT tests: the split rules of section 3.1.2
// written out literally with named vertices (not using split_rules.h), a
// recursive bisection that enumerates every code with its vertices, and
// geometric predicates with exact integer arithmetic.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"

namespace simplexdb::testing {

using P3 = Point<3>;
using Tet = SimplexVertices<3>;  // v1, v2, v3, v4

inline P3 Mid(const P3& a, const P3& b) {
  return {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
}

// Section 3.1.2, literally. `parent_bit` is the child index of t's parent
// (SEED-ERRATA item 1: it decides the 1/4-pyramid rule).
inline std::array<Tet, 2> SplitLiteral(const Tet& t, int level, int parent_bit) {
  const P3& v1 = t[0];
  const P3& v2 = t[1];
  const P3& v3 = t[2];
  const P3& v4 = t[3];
  const P3 vm = Mid(v3, v4);
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

// Calls visit(code, vertices) for every code of level <= max_level, in
// depth-first preorder, computing vertices by recursive bisection.
inline void ForEachTetLiteral(int max_level,
                              const std::function<void(TetCode, const Tet&)>& visit) {
  // `parent_bit` is the child index of c's parent (0 above level 2, where
  // no rule reads it).
  std::function<void(TetCode, const Tet&, int, int)> rec =
      [&](TetCode c, const Tet& t, int my_bit, int parent_bit) {
        visit(c, t);
        if (c.level() == max_level) return;
        const std::array<Tet, 2> kids = SplitLiteral(t, c.level(), parent_bit);
        rec(c.child(0), kids[0], 0, my_bit);
        rec(c.child(1), kids[1], 1, my_bit);
      };
  for (int top = 0; top < 6; ++top) rec(TetCode::Root(top), RootLiteral(top), 0, 0);
}

// All codes of exactly `level`, with their vertices (by the literal rules).
inline std::vector<std::pair<TetCode, Tet>> AllTetsAtLevel(int level) {
  std::vector<std::pair<TetCode, Tet>> out;
  ForEachTetLiteral(level, [&](TetCode c, const Tet& t) {
    if (c.level() == level) out.emplace_back(c, t);
  });
  return out;
}

inline int64_t Dist2(const P3& a, const P3& b) {
  int64_t s = 0;
  for (int i = 0; i < 3; ++i) {
    const int64_t d = int64_t{a[i]} - b[i];
    s += d * d;
  }
  return s;
}

// Six times the signed volume.
inline int64_t Det(const P3& a, const P3& b, const P3& c, const P3& d) {
  const int64_t u[3] = {int64_t{b[0]} - a[0], int64_t{b[1]} - a[1], int64_t{b[2]} - a[2]};
  const int64_t v[3] = {int64_t{c[0]} - a[0], int64_t{c[1]} - a[1], int64_t{c[2]} - a[2]};
  const int64_t w[3] = {int64_t{d[0]} - a[0], int64_t{d[1]} - a[1], int64_t{d[2]} - a[2]};
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
         u[2] * (v[0] * w[1] - v[1] * w[0]);
}

// The vertices of face type k (1..4), sorted: a key that ignores order.
using FaceKey = std::array<P3, 3>;
inline FaceKey FaceOf(const Tet& t, int type) {
  const int omit = 4 - type;  // type k omits position D+1-k
  FaceKey f{};
  int n = 0;
  for (int i = 0; i < 4; ++i) {
    if (i != omit) f[n++] = t[i];
  }
  std::sort(f.begin(), f.end());
  return f;
}

// True when every point lies on one face of the cube.
template <size_t N>
bool OnCubeBoundary(const std::array<P3, N>& pts) {
  for (int axis = 0; axis < 3; ++axis) {
    for (int side : {0, kDomainSide<3>}) {
      bool all = true;
      for (const P3& p : pts) all = all && p[axis] == side;
      if (all) return true;
    }
  }
  return false;
}

struct P3Hash {
  size_t operator()(const P3& p) const {
    return std::hash<uint64_t>()((uint64_t(uint32_t(p[0])) << 42) ^
                                 (uint64_t(uint32_t(p[1])) << 21) ^ uint32_t(p[2]));
  }
};
template <size_t N>
struct PointsHash {
  size_t operator()(const std::array<P3, N>& a) const {
    size_t h = 0;
    for (const P3& p : a) h = h * 1000003u ^ P3Hash()(p);
    return h;
  }
};

}  // namespace simplexdb::testing
