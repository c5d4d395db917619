// Face neighbors in the Hierarchy of Tetrahedra (seed sections 3.2 and 3.3).
//
// Two algorithms, same answers (tests/hierarchy/ht_neighbors_test.cc):
//
//   NeighborScan(code, k)   the nearest-common-ancestor scan driven by the
//                           table of Fig. 38, one 3-bit group at a time.
//                           O(level / 3).
//   Neighbor(code, k)       the constant-time algorithm of section 3.3: a
//   TetCursor::Step(k)      carry through the whole location code finds the
//                           group where the scan would stop. TetCursor keeps
//                           the neighbor mask and updates it in O(1) per
//                           step (UPDATE_MASK, 3.3.5); Neighbor() derives the
//                           mask from the code first (five shift-xors).
//
// Both return TetCode::None() when the face lies on the cube's boundary.
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
// Cost notes (bench/ht_bench.cc has the figures): Step() is about twenty
// ALU operations and one table load, independent of the level.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <string_view>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"

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

// One Fig. 38 entry, decoded.
struct GroupStep {
  bool stop;      // true: `value` is the neighbor's group bits
  uint8_t value;  // stop ? group bits : the type to continue with
};

constexpr GroupStep ParseFig38Entry(std::string_view entry) {
  if (entry.substr(0, 5) == "Cont ") {
    return GroupStep{false, static_cast<uint8_t>(entry[5] - '0')};
  }
  uint8_t bits = 0;
  for (char c : entry) bits = static_cast<uint8_t>(bits << 1 | (c - '0'));
  return GroupStep{true, bits};
}

inline constexpr auto kGroupSteps = [] {
  std::array<std::array<GroupStep, 4>, 8> t{};
  for (int bits = 0; bits < 8; ++bits) {
    for (int k = 0; k < 4; ++k) t[bits][k] = ParseFig38Entry(kFig38[bits][k]);
  }
  return t;
}();

// Position masks over Q (3.3.2): bit 1, 2 and 3 of every group.
inline constexpr uint64_t kPos1Mask = 0x4924924924924924ULL;  // ...100100
inline constexpr uint64_t kPos2Mask = kPos1Mask >> 1;              // ...010010
inline constexpr uint64_t kPos3Mask = kPos1Mask >> 2;              // ...001001

static_assert((kPos1Mask & 0x7) == 0x4 && (kPos2Mask & 0x7) == 0x2 &&
              (kPos3Mask & 0x7) == 0x1);
static_assert((kPos1Mask | kPos2Mask | kPos3Mask) == (~uint64_t{0} >> 1));

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

// The neighbor mask of a code, over its group word Q = path >> (level % 3).
constexpr uint64_t NeighborMask(TetCode code) {
  return NeighborMaskOfGroups(code.path() >> (code.level() % 3));
}

// The grouped nearest-common-ancestor scan (3.2, Fig. 38).
// REQUIRES: code.is_valid(), 1 <= type <= 4.
constexpr TetCode NeighborScan(TetCode code, int type) {
  assert(type >= 1 && type <= 4);
  const int level = code.level();
  const int r = level % 3;
  const uint64_t path = code.path();
  int k = type;
  if (r != 0) {
    const TailStep s =
        TailSteps<3>::kTable[r][path & ((uint64_t{1} << r) - 1)][type - 1];
    if (s.flip >= 0) return code.with_path(path ^ (uint64_t{1} << s.flip));
    k = s.type;
  }
  for (int shift = r; shift < level; shift += 3) {
    const GroupStep s = kGroupSteps[(path >> shift) & 7][k - 1];
    if (s.stop) {
      return code.with_path((path & ~(uint64_t{7} << shift)) |
                            uint64_t{s.value} << shift);
    }
    k = s.value;
  }
  const int root = kRootFaceToRoot<3>[code.top()][k - 1];
  return root < 0 ? TetCode::None() : code.with_top(root);
}

// The constant-time algorithm on the unpacked state of a code. On success
// updates `top`, `path` and `mask` in place and returns true; on the
// boundary returns false and changes nothing.
// REQUIRES: `mask` is NeighborMask() of (path, level); 1 <= type <= 4.
constexpr bool StepInPlace(int& top, uint64_t& path, int level, uint64_t& mask,
                           int type) {
  assert(type >= 1 && type <= 4);
  const int r = level % 3;
  int k = type;
  if (r != 0) {
    const TailStep s =
        TailSteps<3>::kTable[r][path & ((uint64_t{1} << r) - 1)][type - 1];
    if (s.flip >= 0) {  // inside the tail: the group word is unchanged
      path ^= uint64_t{1} << s.flip;
      return true;
    }
    k = s.type;
  }
  const uint64_t q = path >> r;
  const int n = level - r;  // bits in the group word
  const uint64_t groups = (uint64_t{1} << n) - 1;
  uint64_t flip;
  switch (k) {
    case 1:  // NEIGHBOR_1: the sibling of the tetrahedron at level 3G.
      if (n == 0) return false;  // a root's type-1 face is on the boundary
      flip = 1;
      break;
    case 2: {  // NEIGHBOR_2 (3.3.2)
      // Type 2 stops at the deepest group whose bit 1 is 1, as type 1 of the
      // tetrahedron above that group: flip bit 3 of the group above.
      const uint64_t test = q & kPos1Mask & groups;
      flip = (~test + 1) & test;  // lowest set bit; 0 when none
      flip <<= 1;
      // No group stops, or the stop is above the top group: a root face of
      // type 2 or 1, both on the cube's boundary (SEED-ERRATA item 3).
      if (flip == 0 || flip > groups) return false;
      break;
    }
    default: {  // NEIGHBOR_3 and NEIGHBOR_4 (3.3.3, 3.3.4)
      // Type 3 stops where bit 2 is 0 (flip bit 1); type 4 where bit 1 equals
      // bit 3 (flip bit 2). The mask tells which type each group sees.
      uint64_t test = q ^ ((q & kPos3Mask) << 2);  // bit1 ^ bit3 at bit 1
      test = ~test;                                // equality at bit 1, ~bit2 at bit 2
      test &= mask ^ (k == 3 ? kPos2Mask : kPos1Mask);
      test |= test << 1;
      test &= kPos1Mask & groups;
      flip = (~test + 1) & test;
      if (flip == 0) {
        // The carry ran past the top group: cross to another root with the
        // type that reaches level 0 (mask bit n holds the total parity).
        const bool swapped = (mask >> n) & 1;
        const int root_type = (k == 3) != swapped ? 3 : 4;
        const int root = kRootFaceToRoot<3>[top][root_type - 1];
        if (root < 0) return false;
        top = root;
        return true;
      }
      // Type 4 in the stopping group: flip bit 2 instead of bit 1.
      if (((flip & mask) != 0) == (k == 3)) flip >>= 1;
      break;
    }
  }
  // UPDATE_MASK (3.3.5): flipping a bit 1 toggles the parity above it.
  if (flip & kPos1Mask) mask ^= (~flip + 1) << 1;
  path ^= flip << r;
  return true;
}

// A code together with its neighbor mask, for walks that take many neighbor
// steps (clusters, edge walks, refinement).
class TetCursor {
 public:
  // O(1): derives the mask from the code.
  // REQUIRES: code.is_valid().
  explicit constexpr TetCursor(TetCode code)
      : top_(code.top()),
        level_(code.level()),
        path_(code.path()),
        mask_(NeighborMask(code)) {}

  constexpr TetCode code() const { return TetCode::FromPath(top_, path_, level_); }
  constexpr uint64_t mask() const { return mask_; }

  // Moves to the neighbor across the face of `type`. Returns false, and
  // stays, when that face is on the cube's boundary. O(1).
  // REQUIRES: 1 <= type <= 4.
  constexpr bool Step(int type) {
    return StepInPlace(top_, path_, level_, mask_, type);
  }

 private:
  int top_;
  int level_;
  uint64_t path_;
  uint64_t mask_;
};

// The constant-time neighbor of `code` across the face of `type`, or
// TetCode::None() on the boundary.
// REQUIRES: code.is_valid(), 1 <= type <= 4.
constexpr TetCode Neighbor(TetCode code, int type) {
  int top = code.top();
  uint64_t path = code.path();
  const int level = code.level();
  // Types 1 and 2 can turn into 3 or 4 in the tail, so the mask is always
  // needed.
  uint64_t mask = NeighborMask(code);
  if (!StepInPlace(top, path, level, mask, type)) return TetCode::None();
  return TetCode::FromPath(top, path, level);
}

}  // namespace ht

// The HT's face neighbor for generic code (query/, cluster walks): the
// constant-time algorithm.
constexpr TetCode Neighbor(TetCode code, int type) { return ht::Neighbor(code, type); }

}  // namespace simplexdb
