// The HT's face-neighbor tables and steps (seed sections 3.2, 3.3): Fig. 38,
// the neighbor mask and the constant-time step. The public entry points are
// in hierarchy/neighbors.h (NeighborCursor<3>, Neighbor, NeighborScan,
// NeighborMask), whose inline cursor needs these definitions, so this header
// is installed with it; what it defines lives in simplexdb::internal and is
// not an API (names and layouts change with the cursor).
//
// Words and groups. A code at level L = 3G + r has r "tail" levels below the
// last full group (the 1/2 or 1/4 pyramid levels of an unfinished group).
// The tail is handled first with TailSteps<3> (at most two steps, as 3.3
// says); the groups are then processed in the word Q = path >> r, whose
// group m (m = 0 deepest) holds bit 1 (the 1/2-pyramid child index, most
// significant) at position 3m+2, bit 2 at 3m+1 and bit 3 at 3m.
//
// Neighbor mask (3.3.5, SEED-ERRATA item 8): bit p of the mask is the parity
// of the bit-1 positions of Q strictly below p. Neighbor types 3 and 4 swap
// whenever the scan leaves a group whose bit 1 is 1, so the mask tells, for
// every group at once, which of the two is sought there: type k at the
// bottom is type k at group m when mask bit 3m+2 is 0, and 7-k otherwise.
// Bit 3G says which one reaches the root.
//
// Cost notes (bench/hierarchy_bench.cc and bench/README.md have the
// figures): a step is about seventy ALU operations and three loads,
// independent of the level, and has no data-dependent branch.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <string_view>

#include "hierarchy/geometry.h"
#include "hierarchy/group_scan.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"
#include "util/macros.h"

namespace simplexdb {
namespace ht {

// Fig. 38 as printed: [current bits b1b2b3, b1 the shallowest level][type-1].
// "Cont k" means: continue with neighbor type k of the tetrahedron at the
// start of the group (SEED-ERRATA item 2). Any other entry is the group's
// bits in the neighbor.
inline constexpr std::string_view kFig38[8][4] = {
    // Neighbor 1  Neighbor 2  Neighbor 3  Neighbor 4
    {"001", "Cont 2", "100", "010"},        // 000
    {"000", "Cont 2", "101", "Cont 4"},     // 001
    {"011", "Cont 2", "Cont 3", "000"},     // 010
    {"010", "Cont 2", "Cont 3", "Cont 4"},  // 011
    {"101", "Cont 1", "000", "Cont 3"},     // 100
    {"100", "Cont 1", "001", "111"},        // 101
    {"111", "Cont 1", "Cont 4", "Cont 3"},  // 110
    {"110", "Cont 1", "Cont 4", "101"},     // 111
};

inline constexpr GroupStepTable<3> kGroupSteps = ParseGroupSteps<3>(kFig38);

// Position masks over Q (3.3.2): bit 1, 2 and 3 of every group.
inline constexpr uint64_t kPos1Mask = GroupBitMask<3>(1);  // ...100100
inline constexpr uint64_t kPos2Mask = GroupBitMask<3>(2);  // ...010010
inline constexpr uint64_t kPos3Mask = GroupBitMask<3>(3);  // ...001001

static_assert((kPos1Mask & 0x7) == 0x4 && (kPos2Mask & 0x7) == 0x2 &&
              (kPos3Mask & 0x7) == 0x1);
static_assert((kPos1Mask | kPos2Mask | kPos3Mask) == ~uint64_t{0});

// The neighbor mask of the group word `q` (see the header comment).
constexpr uint64_t NeighborMaskOfGroups(uint64_t q) {
  uint64_t x = q & kPos1Mask;
  // Prefix XOR upwards over positions 3 apart: x_p = parity of bit-1
  // positions <= p. Then spread each parity to the three positions above.
  x ^= x << 3;
  x ^= x << 6;
  x ^= x << 12;
  x ^= x << 24;
  x ^= x << 48;
  return x << 1 | x << 2 | x << 3;
}

// The constant-time algorithm of 3.3 on a code split into its group word
// `q` (path >> r) and its tail (the last r bits), kept as the offset `row`
// = tail * kTailRow of its row in shape.tail. On success updates `top`,
// `q`, `row` and `mask` in place and returns true; on the boundary returns
// false and changes nothing.
//
// Written without data-dependent branches: the candidate answers (a flip in
// the tail; NEIGHBOR_1, _2 and _3/_4 in the groups; a crossing to another
// root) are all computed and the right one is selected at the end, so
// random codes cost what worst-case codes cost (bench/hierarchy_bench.cc).
// REQUIRES: `mask` is NeighborMaskOfGroups(q); `shape` is LevelShape<3>(level);
//           1 <= type <= 4.
SDB_ALWAYS_INLINE constexpr bool StepInPlace(int& top, uint64_t& q, uint64_t& row,
                                             uint64_t& mask, const LevelShape<3>& shape,
                                             int type) {
  assert(type >= 1 && type <= 4);
  // The tail first (for r = 0 its table row continues with `type`).
  const TailStep t = shape.tail[row + type - 1];
  const int k = t.type;  // the type sought at level 3G; 0 after a tail flip

  // NEIGHBOR_1 (3.3.1): the sibling of the tetrahedron at level 3G; none for
  // a root (its type-1 face is on the boundary, and `groups` is empty).
  const uint64_t flip1 = shape.groups & 1;

  // NEIGHBOR_2 (3.3.2): stops at the deepest group whose bit 1 is 1, as type
  // 1 of the tetrahedron above it: flip bit 3 of the group above. No such
  // group, or the stop above the top group, means a root face of type 2 or
  // 1, both on the boundary (SEED-ERRATA item 3).
  const uint64_t test2 = q & shape.pos1;
  const uint64_t flip2 = ((test2 & (0 - test2)) << 1) & shape.groups;

  // NEIGHBOR_3 and NEIGHBOR_4 (3.3.3, 3.3.4), at the bit-1 position of
  // every group: type 3 stops where bit 2 is 0 (flip bit 1), type 4 where
  // bit 1 equals bit 3 (flip bit 2). The mask says which type each group
  // sees; seeking type 4 at the bottom inverts it. A zero flip means the
  // carry ran past the top group.
  const uint64_t sees4 = mask ^ (uint64_t{0} - uint64_t{k == 4});
  const uint64_t eq13 = ~(q ^ (q << 2)) & shape.pos1;  // bit 1 == bit 3
  const uint64_t zero2 = (~q << 1) & shape.pos1;       // bit 2 == 0
  const uint64_t test34 = (zero2 & ~sees4) | (eq13 & sees4);
  uint64_t flip34 = test34 & (0 - test34);
  flip34 >>= (flip34 & sees4) != 0;  // the group sees type 4: flip bit 2

  // Select by k with masks, not branches (a compiler turns conditionals on
  // k into a jump tree). k == 0: the flip is in the tail.
  const auto when = [](bool c) { return uint64_t{0} - uint64_t{c}; };  // all ones if c
  const uint64_t flip =
      (flip1 & when(k == 1)) | (flip2 & when(k == 2)) | (flip34 & when(k >= 3));

  // 3.3.6: past the top group the type that reaches the root (k, swapped by
  // the total parity in mask bit n) picks the root across.
  // On the boundary every change below is zero (no flip, no crossing), so
  // the step needs no branch.
  const bool swapped = (mask & shape.root_bit) != 0;
  const int other_root = kRootFaceToRoot<3>[top][2 + ((k == 4) ^ swapped)];
  const bool cross = (k >= 3) & (flip == 0) & (other_root >= 0);

  row ^= t.flip;
  q ^= flip;
  top = cross ? other_root : top;
  // UPDATE_MASK (3.3.5): flipping a bit 1 toggles the parity above it.
  mask ^= (0 - (flip & kPos1Mask)) << 1;
  return (k == 0) | (flip != 0) | cross;
}

}  // namespace ht
}  // namespace simplexdb
