// Exact vertex geometry of the simplices in an HT (D = 3) or HP (D = 4).
//
// Coordinates are integers on a lattice of side 2^kCoordBits<D> covering the
// unit cube (hypercube): the unit-cube coordinate is x / 2^kCoordBits. Every
// vertex of every simplex down to SimplexCode<D>::kMaxLevel is a lattice
// point, because D levels of bisection halve the cube exactly once.
//
//   HT: kCoordBits = 19 (55 levels = 18 full periods + 1).
//   HP: kCoordBits = 14 (53 levels = 13 full periods + 1).
//
// Vertices come from the split rules (hierarchy/split_rules.h) applied from
// the root down: O(level) per call, no allocation. Traversals that descend
// the tree should carry the parent's vertices and call ChildVertices() for
// O(1) per step.
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cstdint>
#include <type_traits>

#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"

namespace simplexdb {

template <int D>
inline constexpr int kCoordBits =
    (SimplexCode<D>::kMaxLevel + D - 1) / D;

template <int D>
inline constexpr int32_t kDomainSide = int32_t{1} << kCoordBits<D>;

template <int D>
using Point = std::array<int32_t, D>;

// v1..v_{D+1}, in the seed's order for this simplex.
template <int D>
using SimplexVertices = std::array<Point<D>, D + 1>;

// The axis permutation of root `top`: roots are numbered by the lexicographic
// order of the permutations of 0..D-1.
template <int D>
constexpr std::array<int, D> RootPermutation(int top) {
  std::array<int, D> perm{};
  for (int i = 0; i < D; ++i) perm[i] = i;
  for (int i = 0; i < top; ++i) std::next_permutation(perm.begin(), perm.end());
  return perm;
}

// REQUIRES: 0 <= top < SimplexCode<D>::kRoots.
template <int D>
constexpr SimplexVertices<D> RootVertices(int top) {
  const std::array<int, D> perm = RootPermutation<D>(top);
  SimplexVertices<D> v{};
  for (int i = 0; i <= D; ++i) {
    for (int j = 0; j < SplitRules<D>::kRootVertexHotness[i]; ++j) {
      v[i][perm[j]] = kDomainSide<D>;
    }
  }
  return v;
}

namespace internal {

// One bisection, on any representation of the vertices: `out` gets the
// midpoint of the split edge (by `mid`) and the parent's vertices the rule
// keeps, in the rule's order.
template <int D, class V, class Mid>
constexpr void Split(const std::array<V, D + 1>& parent, int split_case, int child,
                     std::array<V, D + 1>& out, Mid mid) {
  const auto& edge = SplitRules<D>::kCaseToSplitEdge[split_case];
  const auto& from = SplitRules<D>::kCaseChildToParentVertex[split_case][child];
  out[0] = mid(parent[edge[0]], parent[edge[1]]);
  for (int j = 0; j < D; ++j) out[j + 1] = parent[from[j]];
}

}  // namespace internal

// The vertices of child `child` of `parent`, whose vertices are
// `parent_vertices`: lattice points (SimplexVertices), or grid points of a
// store (int64 coordinates; split-edge midpoints are grid points above the
// leaf level). O(1): descents carry the parent's vertices and call this per
// child.
template <int D, class V>
constexpr std::array<V, D + 1> ChildVertices(SimplexCode<D> parent,
                                             const std::array<V, D + 1>& parent_vertices,
                                             int child) {
  std::array<V, D + 1> out{};
  internal::Split<D>(parent_vertices, SplitRules<D>::CaseOf(parent.level(), parent.path()),
                     child, out, [](const V& a, const V& b) {
                       V m{};
                       for (int i = 0; i < D; ++i) m[i] = (a[i] + b[i]) / 2;
                       return m;
                     });
  return out;
}

namespace internal {

// Points packed into one word, D fields of kPackBits<D> bits (x lowest), so a
// split is a handful of register operations. The midpoint of two packed
// points is (a + b) >> 1: a field sum is at most 2 * 2^kCoordBits, which
// needs kCoordBits + 2 bits, and it is even (the midpoints of split edges
// are lattice points), so no bit crosses a field.
template <int D>
inline constexpr int kPackBits = 64 / D;  // 21 (HT), 16 (HP)
static_assert(kCoordBits<3> + 2 <= kPackBits<3> && kCoordBits<4> + 2 <= kPackBits<4>);

template <int D>
constexpr uint64_t Pack(const Point<D>& p) {
  uint64_t w = 0;
  for (int i = 0; i < D; ++i) w |= static_cast<uint64_t>(p[i]) << (i * kPackBits<D>);
  return w;
}

template <int D>
constexpr Point<D> Unpack(uint64_t w) {
  constexpr uint64_t kField = (uint64_t{1} << kPackBits<D>) - 1;
  Point<D> p{};
  for (int i = 0; i < D; ++i) p[i] = static_cast<int32_t>((w >> (i * kPackBits<D>)) & kField);
  return p;
}

template <int D>
using PackedVertices = std::array<uint64_t, D + 1>;

template <int D>
inline constexpr auto kPackedRoots = [] {
  std::array<PackedVertices<D>, SimplexCode<D>::kRoots> t{};
  for (int r = 0; r < SimplexCode<D>::kRoots; ++r) {
    const SimplexVertices<D> v = RootVertices<D>(r);
    for (int i = 0; i <= D; ++i) t[r][i] = Pack<D>(v[i]);
  }
  return t;
}();

}  // namespace internal

// The vertices of `code`. O(level): one split per level, in registers.
// REQUIRES: code.is_valid().
template <int D>
constexpr SimplexVertices<D> Vertices(SimplexCode<D> code) {
  assert(code.is_valid());
  // Two buffers used in turn: each level reads one and writes the other
  // word by word. (Copying the array back would go through vector moves
  // that stall on the word stores just made.)
  internal::PackedVertices<D> buf[2] = {internal::kPackedRoots<D>[code.top()], {}};
  const int level = code.level();
  const uint64_t path = code.path();
  for (int l = 0; l < level; ++l) {
    const uint64_t prefix = path >> (level - l);  // the path of the level-l ancestor
    const int child = static_cast<int>((path >> (level - l - 1)) & 1);
    internal::Split<D>(buf[l & 1], SplitRules<D>::CaseOf(l, prefix), child, buf[(l + 1) & 1],
                       [](uint64_t a, uint64_t b) { return (a + b) >> 1; });
  }
  SimplexVertices<D> out{};
  for (int i = 0; i <= D; ++i) out[i] = internal::Unpack<D>(buf[level & 1][i]);
  return out;
}

// The vertex positions of the edge that splitting `code` bisects.
template <int D>
constexpr std::array<uint8_t, 2> SplitEdge(SimplexCode<D> code) {
  return SplitRules<D>::kCaseToSplitEdge[SplitRules<D>::CaseOf(code.level(), code.path())];
}

// Lattice point `v` as a point of the grid [0, 2^domain_bits]^D (stores
// address grid points; the lattice is that grid refined to kCoordBits).
// REQUIRES: v is on that grid (true of every vertex above the leaf level of
// a domain of side 2^domain_bits), 0 <= domain_bits <= kCoordBits<D>.
template <int D>
constexpr std::array<int64_t, D> LatticeToGrid(const Point<D>& v, int domain_bits) {
  std::array<int64_t, D> g{};
  for (int i = 0; i < D; ++i) g[i] = int64_t{v[i]} >> (kCoordBits<D> - domain_bits);
  return g;
}

// The smallest k with 2^k + 1 >= every used dimension of a grid of
// `dims[0..dimension)` points per axis: the hierarchy's domain is the cube
// (hypercube) of side 2^k covering it, the grid's point 0 at its origin.
// O(k).
constexpr int DomainBitsFor(int dimension, const std::array<uint32_t, 4>& dims) {
  uint32_t largest = 2;
  for (int a = 0; a < dimension; ++a) largest = std::max(largest, dims[a]);
  int k = 0;
  while ((uint64_t{1} << k) + 1 < largest) ++k;
  return k;
}

// The vertex that splitting `code`, whose vertices are `v`, creates: the
// midpoint of its split edge.
template <int D>
constexpr Point<D> SplitMidpoint(SimplexCode<D> code,
                                 const std::type_identity_t<SimplexVertices<D>>& v) {
  const auto edge = SplitEdge<D>(code);
  Point<D> m{};
  for (int i = 0; i < D; ++i) m[i] = (v[edge[0]][i] + v[edge[1]][i]) / 2;
  return m;
}

// Root adjacency, derived from the root geometry at compile time:
// kRootFaceToRoot<D>[top][k-1] is the root across face type k of root `top`,
// or -1 when that face lies on the boundary of the cube. With the seed's
// labeling the face has the same type on both sides and the rest of a path
// stays the same across roots (SEED-ERRATA item 3); tests check both.
template <int D>
constexpr std::array<std::array<int8_t, D + 1>, SimplexCode<D>::kRoots>
DeriveRootFaceToRoot() {
  constexpr int kRoots = SimplexCode<D>::kRoots;
  std::array<SimplexVertices<D>, kRoots> roots{};
  for (int r = 0; r < kRoots; ++r) roots[r] = RootVertices<D>(r);
  std::array<std::array<int8_t, D + 1>, kRoots> table{};
  for (int r = 0; r < kRoots; ++r) {
    const SimplexVertices<D>& a = roots[r];
    for (int k = 1; k <= D + 1; ++k) {
      table[r][k - 1] = -1;
      const int omit = OmittedVertex<D>(k);
      for (int s = 0; s < kRoots; ++s) {
        if (s == r) continue;
        const SimplexVertices<D>& b = roots[s];
        // Same face type, vertex by vertex: stricter than the same vertex
        // set, and what crossing between roots with the rest of the path
        // unchanged needs (SEED-ERRATA item 3).
        bool same = true;
        for (int i = 0; i <= D && same; ++i) {
          if (i == omit) continue;
          same = a[i] == b[i];
        }
        if (same) table[r][k - 1] = static_cast<int8_t>(s);
      }
    }
  }
  return table;
}

template <int D>
inline constexpr auto kRootFaceToRoot = DeriveRootFaceToRoot<D>();

// The constant-time algorithms rely on this: root faces of types 1 and 2 lie
// on the domain's boundary, every other root face is shared.
template <int D>
constexpr bool RootFacesOneAndTwoAreTheBoundary() {
  for (const auto& faces : kRootFaceToRoot<D>) {
    if (faces[0] != -1 || faces[1] != -1) return false;
    for (int k = 3; k <= D + 1; ++k) {
      if (faces[k - 1] < 0) return false;
    }
  }
  return true;
}
static_assert(RootFacesOneAndTwoAreTheBoundary<3>() && RootFacesOneAndTwoAreTheBoundary<4>());

}  // namespace simplexdb
