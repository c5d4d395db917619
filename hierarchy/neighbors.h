// Face neighbors of equal size in the HT (D = 3) and the HP (D = 4).
//
//   Neighbor(code, k)       the simplex at the same level sharing the face of
//                           type k (1..D+1; hierarchy/split_rules.h names the
//                           faces), or SimplexCode<D>::None() when that face
//                           lies on the domain's boundary. The constant-time
//                           algorithm of sections 3.3 / 4.4.
//   NeighborCursor<D>       the same algorithm for walks: the code travels
//                           with its neighbor mask, which each Step() updates
//                           in O(1) (UPDATE_MASK, 3.3.5; the swaps of Fig. 56,
//                           4.4.4). Clusters and refinement walk with it.
//   NeighborScan(code, k)   the nearest-common-ancestor scan driven by the
//                           seed's tables (Fig. 38 / Fig. 53), O(level / D).
//   NeighborByLevelScan()   (hierarchy/level_scan.h) the per-level reference.
//
// All of them agree on every code (tests/hierarchy/*_neighbors_test.cc);
// bench/README.md has their costs. The constant-time step is branch-free:
// 5.5-7.5 ns on this project's machines, whatever the code or depth.
//
// Thread safety: values and pure functions; a cursor is not shared between
// threads without external synchronization.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>

#include "hierarchy/group_scan.h"
#include "hierarchy/hp_neighbor_tables.h"
#include "hierarchy/ht_neighbor_tables.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"
#include "util/macros.h"

namespace simplexdb {

namespace internal {

// What the cursor keeps of the neighbor mask: the HT's mask word itself; for
// the HP one selector word per initial type (hp::Selectors). And how it keeps
// the group word and the root: the HT as they are, the HP as the group
// word's stop tests (hp::StopsOfGroups) and the root times hp::kCrossingRow.
template <int D>
struct MaskState;
template <>
struct MaskState<3> {
  using Type = uint64_t;
  static constexpr Type Of(uint64_t q, int /*n*/) { return ht::NeighborMaskOfGroups(q); }
  static constexpr uint64_t Mask(const Type& m, int /*n*/) { return m; }
  static constexpr uint64_t Word(uint64_t q) { return q; }
  static constexpr uint64_t Groups(uint64_t word) { return word; }
  static constexpr int TopWord(int top) { return top; }
  static constexpr int Top(int word) { return word; }
};
template <>
struct MaskState<4> {
  using Type = hp::Selectors;
  static constexpr Type Of(uint64_t q, int n) {
    return hp::SelectorsOfMask(hp::NeighborMaskOfGroups(q, n), n);
  }
  static constexpr uint64_t Mask(const Type& s, int n) { return hp::MaskOfSelectors(s, n); }
  static constexpr uint64_t Word(uint64_t q) { return hp::StopsOfGroups(q); }
  static constexpr uint64_t Groups(uint64_t word) { return hp::GroupsOfStops(word); }
  static constexpr int TopWord(int top) { return top * hp::kCrossingRow; }
  static constexpr int Top(int word) { return word / hp::kCrossingRow; }
};

}  // namespace internal

// A location code with its neighbor mask, for walks of many neighbor steps.
template <int D>
class NeighborCursor {
 public:
  // O(1): derives the mask from the code (no loop over the levels).
  // REQUIRES: code.is_valid().
  explicit constexpr NeighborCursor(SimplexCode<D> code)
      : shape_((assert(code.is_valid()), code.level())),
        top_(internal::MaskState<D>::TopWord(code.top())),
        word_(internal::MaskState<D>::Word(code.path() >> shape_.r)),
        row_((code.path() & ((uint64_t{1} << shape_.r) - 1)) * kTailRow),
        mask_(internal::MaskState<D>::Of(code.path() >> shape_.r, shape_.n)) {}

  constexpr SimplexCode<D> code() const {
    const uint64_t q = internal::MaskState<D>::Groups(word_);
    return SimplexCode<D>::FromPath(internal::MaskState<D>::Top(top_),
                                    q << shape_.r | row_ / kTailRow, level());
  }
  constexpr int level() const { return shape_.n + shape_.r; }

  // The neighbor mask in the seed's form, as maintained (tests compare it
  // with NeighborMask(code())).
  constexpr uint64_t mask() const { return internal::MaskState<D>::Mask(mask_, shape_.n); }

  // Moves to the neighbor across the face of `type`. Returns false, and
  // stays, when that face is on the domain's boundary. O(1).
  // REQUIRES: 1 <= type <= D + 1.
  SDB_ALWAYS_INLINE constexpr bool Step(int type) {
    if constexpr (D == 3) {
      return ht::StepInPlace(top_, word_, row_, mask_, shape_, type);
    } else {
      return hp::StepInPlace(top_, word_, row_, mask_, shape_, type);
    }
  }

 private:
  LevelShape<D> shape_;
  int top_;        // the root, as MaskState<D>::TopWord keeps it
  uint64_t word_;  // the group word path >> r, as MaskState<D>::Word keeps it
  uint64_t row_;   // the last r bits of the path, times kTailRow (see TailRows)
  typename internal::MaskState<D>::Type mask_;
};

using TetCursor = NeighborCursor<3>;
using PentaCursor = NeighborCursor<4>;

// The constant-time neighbor of `code` across the face of `type`, or None()
// on the boundary.
// REQUIRES: code.is_valid(), 1 <= type <= D + 1.
template <int D>
constexpr SimplexCode<D> Neighbor(SimplexCode<D> code, int type) {
  NeighborCursor<D> cursor(code);
  return cursor.Step(type) ? cursor.code() : SimplexCode<D>::None();
}

// The grouped nearest-common-ancestor scan driven by Fig. 38 (HT) or Fig. 53
// (HP). O(level / D).
// REQUIRES: code.is_valid(), 1 <= type <= D + 1.
template <int D>
constexpr SimplexCode<D> NeighborScan(SimplexCode<D> code, int type) {
  if constexpr (D == 3) {
    return GroupScan<3>(code, type, ht::kGroupSteps);
  } else {
    return GroupScan<4>(code, type, hp::kGroupSteps);
  }
}

// The neighbor mask of `code` in the seed's form (see the internal headers).
// REQUIRES: code.is_valid().
template <int D>
constexpr uint64_t NeighborMask(SimplexCode<D> code) {
  const int r = code.level() % D;
  const uint64_t q = code.path() >> r;
  if constexpr (D == 3) {
    return ht::NeighborMaskOfGroups(q);
  } else {
    return hp::NeighborMaskOfGroups(q, code.level() - r);
  }
}

}  // namespace simplexdb
