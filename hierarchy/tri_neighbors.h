// Edge neighbors in the triangle quadtrees on the sphere (seed 2.2-2.6).
//
//   TriNeighbor(code, dir)      the triangle of the same level across the
//                               left, right or vertical edge: the
//                               constant-time algorithm of 2.4 (CONSTANT_
//                               RIGHT/LEFT/VERTICAL on the right-aligned
//                               path, the carry or borrow out of the path
//                               meaning "another base face", 2.4.5 and 2.5).
//                               O(1): about ten bit operations, one table
//                               read, no loop.
//   TriNeighborScan(code, dir)  the nearest-common-ancestor scan of 2.2 with
//                               STOPTAB/NEXTTAB, extended to the whole solid
//                               as in 2.3 (NEXTTOP/NEXTOCT/NEXTTET and the
//                               edge maps, REFLTOP among them). O(level).
//   TriNeighborOfGreaterOrEqualSize(leaves, code, dir)
//                               2.6: the neighbor in a variable-resolution
//                               set of leaves kept sorted by key (the seed's
//                               list L): the equal-size one, a larger leaf
//                               holding it, or the equal-size non-leaf when
//                               several smaller leaves touch the edge.
//                               O(log |leaves|).
//
// The sphere is closed: every triangle has a neighbor in every direction.
// The neighbor across an edge shares it as its own edge of direction
// TriNeighborEdge(code, dir): the opposite side (left <-> right, vertical
// <-> vertical) inside a face and across most base face edges; the same
// side across the tetrahedron's flipped edges (hierarchy/tri_polyhedron.h).
//
// All algorithms agree on every code (tests/hierarchy/tri_neighbors_test.cc,
// which also checks them against the geometry); bench/README.md has their
// costs.
//
// Thread safety: pure functions.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <span>

#include "hierarchy/tri_code.h"
#include "hierarchy/tri_polyhedron.h"
#include "util/macros.h"

namespace simplexdb {

namespace tri_internal {

// Alternating masks over right-aligned pairs: the low bit of every pair (the
// seed's EVENBITMASK) and the high bit (ODDBITMASK).
inline constexpr uint64_t kLowBits = 0x5555555555555555ULL;
inline constexpr uint64_t kHighBits = 0xAAAAAAAAAAAAAAAAULL;

// The bits of `level` pairs. REQUIRES: level <= 28 (2 * level < 64).
constexpr uint64_t LowPairs(int level) { return (uint64_t{1} << (2 * level)) - 1; }

// MAKE_IDMASK_00ID11: 11 on every pair that is 00.
constexpr uint64_t Id00To11(uint64_t p) {
  const uint64_t t = ~(p | p >> 1) & kLowBits;
  return t | t << 1;
}
// MAKE_IDMASK_01ID01: 01 on every pair that is 01.
constexpr uint64_t Id01To01(uint64_t p) { return (~p & kHighBits) >> 1 & p; }
// MAKE_IDMASK_?0ID10: 10 on every pair whose low bit is 0.
constexpr uint64_t IdX0To10(uint64_t p) { return (~p & kLowBits) << 1; }
// CONSTANT_REFLECTION: flips the high bit of every ?1 pair (01 <-> 11).
constexpr uint64_t Reflect(uint64_t p) { return p ^ (p & kLowBits) << 1; }

}  // namespace tri_internal

// The constant-time neighbor of equal size (2.4, 2.4.5, 2.5). The path of
// `level` pairs sits right-aligned in a 64-bit word with room above it, so
// the bit just above the path is the seed's "overflow bit": set by a carry
// (right), a borrow (left) or the absence of a ?0 pair (vertical) when the
// neighbor is on another base face.
// REQUIRES: code.is_valid().
template <Polyhedron P>
SDB_ALWAYS_INLINE constexpr TriCode<P> TriNeighbor(TriCode<P> code, TriDirection dir) {
  using namespace tri_internal;
  using Code = TriCode<P>;
  assert(code.is_valid());
  const int n = code.level();
  const uint64_t low = LowPairs(n);
  const uint64_t p = code.path();
  uint64_t x;
  bool over;
  switch (dir) {
    case TriDirection::kRight: {  // CONSTANT_RIGHT
      const uint64_t id = Id00To11(p) & low;
      x = ((p ^ id) + 1) ^ id;
      x &= ~id | kLowBits;
      over = (x >> (2 * n)) & 1;
      break;
    }
    case TriDirection::kLeft: {  // CONSTANT_LEFT
      const uint64_t id = Id01To01(p);
      x = ((p ^ id) - 1) ^ id;
      x &= ~(id << 1);
      over = (x >> (2 * n)) & 1;
      break;
    }
    default: {  // CONSTANT_VERTICAL: flip the high bit of the lowest ?0 pair
      const uint64_t id = IdX0To10(p) & low;
      const uint64_t m = id & (~id + 1);
      x = p ^ m;
      over = m == 0;
      break;
    }
  }
  x &= low;
  if (!over) return Code::FromPath(code.face(), x, n);
  const tri::FaceCrossing& c = tri::kCrossings<P>[code.face()][static_cast<int>(dir)];
  // kPlanar: the result as is (2.4.5); kMirror: reflect the input (2.4.5);
  // kReversed: reflect the result (2.5.2). Selects, not branches: on the
  // icosahedron the kind depends on the face.
  const uint64_t source = c.kind == TriEdgeKind::kMirror ? p : x;
  return Code::FromPath(c.face, c.kind == TriEdgeKind::kPlanar ? x : Reflect(source), n);
}

// The nearest-common-ancestor scan (2.2, EXT_FIND_NEIGHBOR of 2.3): climb
// while STOPTAB says the sibling is not across the edge, change the stop's
// child type by NEXTTAB, and reflect the rest of the path by NEXTTAB; when
// the climb reaches the base face, cross by the solid's table and map every
// child type by the edge map (REFLTOP where the seed uses it). O(level).
// REQUIRES: code.is_valid().
template <Polyhedron P>
constexpr TriCode<P> TriNeighborScan(TriCode<P> code, TriDirection dir) {
  assert(code.is_valid());
  const int d = static_cast<int>(dir);
  const int n = code.level();
  uint64_t path = code.path();
  const auto type_at = [&](int depth) { return static_cast<int>(path >> 2 * (n - depth) & 3); };
  const auto set_at = [&](int depth, int t) {
    const int s = 2 * (n - depth);
    path = (path & ~(uint64_t{3} << s)) | static_cast<uint64_t>(t) << s;
  };
  int depth = n;  // STEP_ONE / EXT_STEP_ONE
  while (depth > 0 && !tri::kStopTab[d][type_at(depth)]) --depth;
  if (depth > 0) {
    for (int l = depth; l <= n; ++l) set_at(l, tri::kNextTab[d][type_at(l)]);  // steps 2, 3
    return TriCode<P>::FromPath(code.face(), path, n);
  }
  const tri::FaceCrossing& c = tri::kCrossings<P>[code.face()][d];
  for (int l = 1; l <= n; ++l) set_at(l, c.map[type_at(l)]);  // EXT_STEP_THREE
  return TriCode<P>::FromPath(c.face, path, n);
}

// Which edge of TriNeighbor(code, dir) is the shared one. O(1).
// REQUIRES: code.is_valid().
template <Polyhedron P>
constexpr TriDirection TriNeighborEdge(TriCode<P> code, TriDirection dir) {
  const uint64_t p = code.path();
  const int n = code.level();
  // On the base face's edge of this direction exactly when the path has only
  // that edge's two child types: then the neighbor is on the other face.
  const auto ends = tri::kEdgeEndChild[static_cast<int>(dir)];
  const uint64_t ones = tri_internal::kLowBits & tri_internal::LowPairs(n);
  const uint64_t a = ends[0] * ones, b = ends[1] * ones;
  const uint64_t diff_a = p ^ a, diff_b = p ^ b;
  // A pair differs from both ends when it is nonzero in both differences.
  const uint64_t nz_a = (diff_a | diff_a >> 1) & tri_internal::kLowBits;
  const uint64_t nz_b = (diff_b | diff_b >> 1) & tri_internal::kLowBits;
  if ((nz_a & nz_b) == 0) return tri::kCrossings<P>[code.face()][static_cast<int>(dir)].edge;
  return dir == TriDirection::kVertical ? dir
         : dir == TriDirection::kLeft   ? TriDirection::kRight
                                        : TriDirection::kLeft;
}

// What TriNeighborOfGreaterOrEqualSize found.
enum class TriNeighborSize : uint8_t {
  kEqual,    // a leaf of the same level
  kLarger,   // a leaf above the equal-size neighbor (shallower level)
  kSmaller,  // the equal-size neighbor is subdivided: several smaller leaves
             // touch the edge; `code` is that non-leaf (its descendants in
             // the list are the leaves)
};

template <Polyhedron P>
struct TriSizedNeighbor {
  TriCode<P> code;
  TriNeighborSize size;
};

// 2.6: the neighbor of `code` in direction `dir` among `leaves`, a set of
// triangles sorted by key that tiles the sphere (every point in exactly one
// leaf). Searches for the largest leaf whose key is at most the equal-size
// neighbor's: with preorder keys that is the neighbor's ancestor-or-self
// leaf when there is one. O(log |leaves|).
// REQUIRES: code.is_valid(); leaves sorted, tiling the sphere.
template <Polyhedron P>
TriSizedNeighbor<P> TriNeighborOfGreaterOrEqualSize(std::span<const TriCode<P>> leaves,
                                                    TriCode<P> code, TriDirection dir) {
  const TriCode<P> q = TriNeighbor(code, dir);
  auto it = std::upper_bound(leaves.begin(), leaves.end(), q);
  if (it != leaves.begin()) {
    const TriCode<P> before = *--it;
    if (before == q) return {q, TriNeighborSize::kEqual};
    if (before.contains(q)) return {before, TriNeighborSize::kLarger};
  }
  return {q, TriNeighborSize::kSmaller};
}

}  // namespace simplexdb
