// The parts of the HT and HP references (tests/hierarchy/ht_reference.h,
// hp_reference.h) that are the same in every dimension: midpoints,
// distances, edges and faces as keys that ignore vertex order, the
// domain's boundary, and the recursive bisection that enumerates every code
// with its vertices by a dimension's literal split rules (LiteralRules<D>,
// written out in its reference header, not using split_rules.h).
// Thread safety: pure functions.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"

namespace simplexdb::testing {

// The literal split rules and roots of dimension D, specialized by
// ht_reference.h and hp_reference.h:
//   static std::array<SimplexVertices<D>, 2> Split(const SimplexVertices<D>& t, int level, int g, int p);
//   static SimplexVertices<D> Root(int top);
// where g is the child index of t's parent and p that of t (0 where no rule
// reads them).
template <int D>
struct LiteralRules;

template <int D>
Point<D> Mid(const Point<D>& a, const Point<D>& b) {
  Point<D> m{};
  for (int i = 0; i < D; ++i) m[i] = (a[i] + b[i]) / 2;
  return m;
}

// (The functions below take std::array's size_t sizes, so that they deduce
// them from the points; Point<D> is std::array<int32_t, D>.)
template <size_t D>
int64_t Dist2(const std::array<int32_t, D>& a, const std::array<int32_t, D>& b) {
  int64_t s = 0;
  for (size_t i = 0; i < D; ++i) {
    const int64_t d = int64_t{a[i]} - b[i];
    s += d * d;
  }
  return s;
}

// Edge v_{i+1} v_{j+1} of t, sorted: a key that ignores order.
template <int D>
using Edge = std::array<Point<D>, 2>;
template <size_t V, size_t D>
std::array<std::array<int32_t, D>, 2> EdgeOf(const std::array<std::array<int32_t, D>, V>& t, int i, int j) {
  std::array<std::array<int32_t, D>, 2> e{t[i], t[j]};
  std::sort(e.begin(), e.end());
  return e;
}

// The face of type k (1..D+1), which omits vertex position D+1-k: in
// position order, or sorted (a key that ignores order).
template <int D>
using Face = std::array<Point<D>, D>;
template <size_t V, size_t D>
std::array<std::array<int32_t, D>, V - 1> FaceOf(const std::array<std::array<int32_t, D>, V>& t, int type,
                                                 bool sorted = true) {
  const int omit = static_cast<int>(V) - type;
  std::array<std::array<int32_t, D>, V - 1> f{};
  int n = 0;
  for (int i = 0; i < static_cast<int>(V); ++i) {
    if (i != omit) f[n++] = t[i];
  }
  if (sorted) std::sort(f.begin(), f.end());
  return f;
}

// True when every point lies on one face of the domain's cube (hypercube).
template <size_t N, size_t D>
bool OnDomainBoundary(const std::array<std::array<int32_t, D>, N>& pts) {
  for (size_t axis = 0; axis < D; ++axis) {
    for (int side : {0, kDomainSide<static_cast<int>(D)>}) {
      bool all = true;
      for (const auto& p : pts) all = all && p[axis] == side;
      if (all) return true;
    }
  }
  return false;
}

// A hash of points, and of arrays of points (edges, faces).
struct PointsHash {
  template <size_t D>
  size_t operator()(const std::array<int32_t, D>& p) const {
    uint64_t h = 0;
    for (int v : p) h = h * 0x9E3779B97F4A7C15ULL + static_cast<uint32_t>(v);
    return std::hash<uint64_t>()(h);
  }
  template <size_t N, size_t D>
  size_t operator()(const std::array<std::array<int32_t, D>, N>& a) const {
    size_t h = 0;
    for (const auto& p : a) h = h * 1000003u ^ (*this)(p);
    return h;
  }
};

// Calls visit(code, vertices) for every code of level <= max_level, in
// depth-first preorder, computing vertices by recursive bisection with
// LiteralRules<D>.
template <int D>
void ForEachLiteral(int max_level, const std::function<void(SimplexCode<D>, const SimplexVertices<D>&)>& visit) {
  std::function<void(SimplexCode<D>, const SimplexVertices<D>&, int, int)> rec =
      [&](SimplexCode<D> c, const SimplexVertices<D>& t, int g, int p) {
        visit(c, t);
        if (c.level() == max_level) return;
        const auto kids = LiteralRules<D>::Split(t, c.level(), g, p);
        rec(c.child(0), kids[0], p, 0);
        rec(c.child(1), kids[1], p, 1);
      };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    rec(SimplexCode<D>::Root(top), LiteralRules<D>::Root(top), 0, 0);
  }
}

// All codes of exactly `level`, with their vertices (by the literal rules).
template <int D>
std::vector<std::pair<SimplexCode<D>, SimplexVertices<D>>> AllAtLevel(int level) {
  std::vector<std::pair<SimplexCode<D>, SimplexVertices<D>>> out;
  ForEachLiteral<D>(level, [&](SimplexCode<D> c, const SimplexVertices<D>& t) {
    if (c.level() == level) out.emplace_back(c, t);
  });
  return out;
}

}  // namespace simplexdb::testing
