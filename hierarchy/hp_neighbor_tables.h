// The HP's face-neighbor tables and steps (seed sections 4.3, 4.4): Figs. 53
// and 56, the neighbor mask and the constant-time step. The public entry
// points are in hierarchy/neighbors.h (NeighborCursor<4>, Neighbor,
// NeighborScan, NeighborMask), whose inline cursor needs these definitions,
// so this header is installed with it; what it defines lives in
// simplexdb::internal and is not an API (names and layouts change with the
// cursor).
//
// Groups. A code at level L = 4G + r has r tail levels (c-, s- and
// e-pentatope levels of an unfinished period), stepped through with
// TailSteps<4> first (4.4 only treats h-pentatopes; SEED-ERRATA item 6). The
// group word Q = path >> r holds group m (m = 0 deepest) in bits 4m..4m+3:
// bit 1 (the c-pentatope child index) at 4m+3 down to bit 4 at 4m.
//
// What a group does to the sought type (Fig. 53, 4.4.4). Types 1 and 2 are
// as in the HT: type 1 is the sibling, type 2 stops where bit 1 is 1 and
// continues as type 1 of the group's top. Types 3, 4 and 5 stop at
//   type 3: bit 2 = 1        (flip bit 1)
//   type 4: bit 1 = bit 3    (flip bit 2)
//   type 5: bit 2 = bit 4    (flip bit 3)
// and otherwise continue permuted by the group's bits 1-2:
//   00: identity   01: 4 <-> 5   10: 3 <-> 5   11: 3 -> 5 -> 4 -> 3.
//
// Neighbor mask (4.4.4, SEED-ERRATA item 9). Group m of the mask holds the
// composition P_m of the permutations of the groups below it, as two 2-bit
// codes (01 = type 3, 10 = type 4, 11 = type 5): bits 4m+3..4m+2 are P_m(3),
// bits 4m+1..4m are P_m(4), and P_m(5) is their XOR. Lane G (bits n..n+3,
// n = 4G) is the root's own slot: the type that reaches level 0.
//
// Computing the mask from scratch. The permutations of {3, 4, 5} are the
// affine maps x -> e*x + s over Z3 (types 3, 4, 5 as 0, 1, 2; e = +-1). A
// group reflects (e = -1) iff its bits 1 and 2 differ, and shifts by
// s = 2 * bit 1. So P_m(x) = E_m * (x + S_m) with E_m the product of the
// signs below m and S_m = sum over groups j < m of E_{j+1} * s_j: a prefix
// XOR and a prefix sum mod 3, both bit-parallel over 4-bit lanes. No loop
// over the groups: NeighborMaskOfGroups() is O(log(word size)).
#pragma once

#include <array>
#include <bit>
#include <cassert>
#include <cstdint>
#include <string_view>

#include "hierarchy/geometry.h"
#include "hierarchy/group_scan.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"
#include "util/macros.h"

namespace simplexdb {
namespace hp {

// Fig. 53 as printed: [current bits b1b2b3b4, b1 the shallowest][type-1].
inline constexpr std::string_view kFig53[16][5] = {
    // Neighbor 1  Neighbor 2  Neighbor 3  Neighbor 4  Neighbor 5
    {"0001", "Cont 2", "Cont 3", "0100", "0010"},      // 0000
    {"0000", "Cont 2", "Cont 3", "0101", "Cont 5"},    // 0001
    {"0011", "Cont 2", "Cont 3", "Cont 4", "0000"},    // 0010
    {"0010", "Cont 2", "Cont 3", "Cont 4", "Cont 5"},  // 0011
    {"0101", "Cont 2", "1100", "0000", "Cont 4"},      // 0100
    {"0100", "Cont 2", "1101", "0001", "0111"},        // 0101
    {"0111", "Cont 2", "1110", "Cont 5", "Cont 4"},    // 0110
    {"0110", "Cont 2", "1111", "Cont 5", "0101"},      // 0111
    {"1001", "Cont 1", "Cont 5", "Cont 4", "1010"},    // 1000
    {"1000", "Cont 1", "Cont 5", "Cont 4", "Cont 3"},  // 1001
    {"1011", "Cont 1", "Cont 5", "1110", "1000"},      // 1010
    {"1010", "Cont 1", "Cont 5", "1111", "Cont 3"},    // 1011
    {"1101", "Cont 1", "0100", "Cont 3", "Cont 4"},    // 1100
    {"1100", "Cont 1", "0101", "Cont 3", "1111"},      // 1101
    {"1111", "Cont 1", "0110", "1010", "Cont 4"},      // 1110
    {"1110", "Cont 1", "0111", "1011", "1101"},        // 1111
};

inline constexpr GroupStepTable<4> kGroupSteps = ParseGroupSteps<4>(kFig53);

// Fig. 56 as printed: [bits 1-2 of a group before][after] -> how the types
// sought above that group change when those bits change.
inline constexpr std::string_view kFig56[4][4] = {
    // To 00         To 01           To 10           To 11
    {"No change", "Swap 4 and 5", "Swap 3 and 5", "Not possible"},  // 00
    {"Swap 4 and 5", "No change", "Not possible", "Swap 3 and 5"},  // 01
    {"Swap 3 and 5", "Not possible", "No change", "Swap 3 and 4"},  // 10
    {"Not possible", "Swap 3 and 5", "Swap 3 and 4", "No change"},  // 11
};

// Position masks over Q: bit j of every group.
inline constexpr uint64_t kPos1Mask = GroupBitMask<4>(1);
inline constexpr uint64_t kPos2Mask = GroupBitMask<4>(2);
inline constexpr uint64_t kPos3Mask = GroupBitMask<4>(3);
inline constexpr uint64_t kPos4Mask = GroupBitMask<4>(4);
inline constexpr uint64_t kPos12Mask = kPos1Mask | kPos2Mask;
inline constexpr uint64_t kPos34Mask = kPos3Mask | kPos4Mask;
inline constexpr uint64_t kLaneLow = kPos4Mask;  // bit 0 of every 4-bit lane

// Lane-wise v mod 3 for lanes holding 0..4.
constexpr uint64_t Mod3Lanes(uint64_t v) {
  const uint64_t ge3 = ((v >> 2) | ((v >> 1) & v)) & kLaneLow;
  return v - ge3 * 3;
}

// The neighbor mask of the group word `q` with `n` bits (lanes 0..n/4, the
// last the root's slot). See the header comment for the algebra.
// REQUIRES: n % 4 == 0, n <= 52, q < 2^n.
constexpr uint64_t NeighborMaskOfGroups(uint64_t q, int n) {
  assert(n % 4 == 0 && n <= 52 && (q >> n) == 0);
  const uint64_t b1 = (q >> 3) & kLaneLow;
  const uint64_t b2 = (q >> 2) & kLaneLow;
  // odd_j: the signs of groups 0..j multiply to -1 (E_{j+1} = -1).
  uint64_t odd = b1 ^ b2;
  odd ^= odd << 4;
  odd ^= odd << 8;
  odd ^= odd << 16;
  odd ^= odd << 32;
  // E_{j+1} * s_j mod 3 with s_j = 2 * bit 1: 2 or, with odd sign, 1.
  uint64_t sum = (b1 & odd) | (b1 & ~odd) << 1;
  sum = Mod3Lanes(sum + (sum << 4));  // inclusive prefix sums mod 3
  sum = Mod3Lanes(sum + (sum << 8));
  sum = Mod3Lanes(sum + (sum << 16));
  sum = Mod3Lanes(sum + (sum << 32));
  // Lane m gets the groups strictly below it.
  const uint64_t e_odd = odd << 4;
  const uint64_t s = sum << 4;
  // P_m(3) = E_m * S_m; P_m(4) = E_m * (1 + S_m) = P_m(3) + E_m.
  const uint64_t nonzero = (s | s >> 1) & kLaneLow;
  const uint64_t p3 = s ^ (nonzero & e_odd) * 3;           // negate where E_m = -1
  const uint64_t p4 = Mod3Lanes(p3 + kLaneLow + e_odd);    // + 1, or + 2 = -1
  const uint64_t lanes = (uint64_t{1} << (n + 4)) - 1;
  return ((p3 + kLaneLow) << 2 | (p4 + kLaneLow)) & lanes;  // codes are type - 2
}

// The cursor keeps the neighbor mask expanded: for each initial type k in
// {3, 4, 5}, a selector word with one bit per group (and the root's slot) at
// the position of the stop test of the type k becomes there: bit 2 for type
// 3, bit 3 for type 4, bit 4 for type 5 (the positions where `stops` in
// StepInPlace holds the tests). Same information as the seed's 2-bit codes,
// decoded once instead of on every step. The root's slot is kept in lane 15
// (bits 60-63), whatever the level: no group word reaches it (n <= 52), and
// a step reads it with a constant shift.
struct Selectors {
  // of[3], of[4], of[5]: the selectors; of[2] = bit 1 of every group, the
  // stop test of type 2 (4.4.2), and of[1] = kSiblingTest, the test of
  // type 1, neither of which ever changes; of[0] = 0 (a flip in the tail).
  uint64_t of[6];
};

inline constexpr int kRootSlot = 60;  // the selectors' root lane
inline constexpr uint64_t kBelowRootSlot = (uint64_t{1} << kRootSlot) - 1;
// NEIGHBOR_1 (4.4.1) flips bit 4 of group 0 (the sibling of the pentatope at
// level 4G) whatever the group holds. Its test is bit 63, above the root's
// slot (bits 60-62), set in type 1's selector and always in a cursor's
// `stops`; the step rotates the tests left by one, which brings it to bit 0.
inline constexpr uint64_t kSiblingTest = uint64_t{1} << 63;

// From the seed's codes (a 2-bit code per lane at bits 1-2) to selectors.
constexpr uint64_t SelectorOfCodes(uint64_t codes) {
  const uint64_t hi = codes & kPos1Mask, lo = codes & kPos2Mask;
  return (lo & ~(hi >> 1))           // 01: type 3, test at bit 2
         | ((hi >> 2) & ~(lo >> 1))  // 10: type 4, test at bit 3
         | ((hi >> 3) & (lo >> 2));  // 11: type 5, test at bit 4
}

// And back: the code of the type a selector marks, at bits 1-2.
constexpr uint64_t CodesOfSelector(uint64_t sel) {
  const uint64_t at2 = sel & kPos2Mask, at3 = sel & kPos3Mask, at4 = sel & kPos4Mask;
  return (at3 << 2 | at4 << 3) | (at2 | at4 << 2);
}

// The neighbor mask of `n` group bits (root's slot in lane n / 4) as
// selectors, and back. The conversions work lane by lane, so the root's
// slot moves once, in the mask.
// REQUIRES: n % 4 == 0, n <= 52.
constexpr Selectors SelectorsOfMask(uint64_t mask, int n) {
  assert(n % 4 == 0 && n <= 52);
  const uint64_t groups = (uint64_t{1} << n) - 1;
  const uint64_t moved = (mask & groups) | (mask >> n) << kRootSlot;
  const uint64_t pair1 = moved & kPos12Mask;         // P(3)
  const uint64_t pair2 = (moved & kPos34Mask) << 2;  // P(4), moved to bits 1-2
  return Selectors{{0, kSiblingTest, kPos1Mask & groups, SelectorOfCodes(pair1),
                    SelectorOfCodes(pair2), SelectorOfCodes(pair1 ^ pair2)}};
}

constexpr uint64_t MaskOfSelectors(const Selectors& s, int n) {
  const uint64_t moved = CodesOfSelector(s.of[3]) | CodesOfSelector(s.of[4]) >> 2;
  return (moved & kBelowRootSlot) | (moved >> kRootSlot) << n;
}

// The cursor keeps the group word as its stop tests (see StepInPlace): the
// word `stops` has, at each group's bit 1, 2, 3 and 4 position, bit 1, bit 2,
// bit 1 == bit 3 and bit 2 == bit 4. A flip changes it by a few bits, so a
// step updates it instead of recomputing it. Bits 1 and 2 are kept as they
// are, so the map is one-to-one. Bit 63 holds the sibling's test
// (kSiblingTest), which always passes.
constexpr uint64_t StopsOfGroups(uint64_t q) {
  return (((~q & kPos12Mask) >> 2) ^ q) | kSiblingTest;
}
constexpr uint64_t GroupsOfStops(uint64_t stops) {
  const uint64_t bits12 = stops & kPos12Mask & ~kSiblingTest;
  return bits12 | ((stops ^ (~bits12 & kPos12Mask) >> 2) & kPos34Mask);
}

inline constexpr int kCrossingRow = 16;

// The tables a step reads, in one object so that a step needs one base
// address for all of them.
struct StepTables {
  // For a sought type k in {3, 4, 5} (0: a tail flip), the two other types
  // of {3, 4, 5}, one of which trades its selector with k's after a type-3
  // or type-4 stop (unused for k < 3, which never trade: see StepInPlace).
  uint8_t partners[6][2];
  // Where a step that ran past the top group goes, at root * kCrossingRow +
  // the selector's top four bits (4, 2 or 1: type 3, 4 or 5 reaches level 0;
  // 0 or 8, the sibling's test: types 0-2, which never cross):
  // (root ^ the root across) * kCrossingRow, or 0 on the boundary (a root's
  // neighbor is never itself). A cursor keeps its root times kCrossingRow,
  // so the root's row needs no multiplication, and the XOR form lets a step
  // update it without a second lookup or a select on the sought type.
  uint16_t crossing[24 * kCrossingRow];
};

inline constexpr StepTables kStepTables = [] {
  StepTables t{};
  for (int k = 0; k < 6; ++k) {
    t.partners[k][0] = k == 3 ? 4 : 3;
    t.partners[k][1] = k == 5 ? 4 : 5;
  }
  for (int top = 0; top < 24; ++top) {
    for (const int slot : {4, 2, 1}) {
      const int type = slot == 4 ? 3 : slot == 2 ? 4 : 5;
      const int other = kRootFaceToRoot<4>[top][type - 1];
      t.crossing[top * kCrossingRow + slot] =
          static_cast<uint16_t>(other < 0 ? 0 : (top ^ other) * kCrossingRow);
    }
  }
  return t;
}();

// The constant-time algorithm of 4.4 on a code split into its group word,
// kept as `stops` = StopsOfGroups(path >> r), and its tail, kept as the
// offset `row` = tail * kTailRow of its row in shape.tail. On success updates
// `top` (the root times kCrossingRow), `stops`, `row` and `sel` in place and
// returns true; on the boundary returns false and changes nothing.
// Branch-free, like the HT's: every candidate is computed and the right one
// selected. The per-type choices are table loads rather than compares, and
// the partner that trades selectors is chosen with masks, not by an index,
// which would put two more loads on the path from one step to the next (a
// walk's latency: bench/README.md).
// REQUIRES: `sel` is SelectorsOfMask(NeighborMaskOfGroups(q, shape.n), shape.n)
//           for the group word q; `shape` is LevelShape<4>(level);
//           1 <= type <= 5.
SDB_ALWAYS_INLINE constexpr bool StepInPlace(int& top, uint64_t& stops, uint64_t& row,
                                             Selectors& sel, const LevelShape<4>& shape,
                                             int type) {
  assert(type >= 1 && type <= 5);
  const TailStep t = shape.tail[row + type - 1];
  const int k = t.type;  // the type sought at level 4G; 0 after a tail flip
  row ^= t.flip;

  // NEIGHBOR_2 to _5 (4.4.2, 4.4.3; Figs. 54, 55), all stop tests at once:
  // bit 1 at bit 1 (type 2), bit 2 at bit 2 (type 3), bit 1 == bit 3 at bit 3
  // (type 4), bit 2 == bit 4 at bit 4 (type 5). The selector keeps the test
  // of the type each group sees. The stop flips the bit one above the test:
  // bit 4 of the group above (type 2, as type 1 of the group's top), bit 1,
  // 2 or 3. Past the top, type 2 meets root faces 2 or 1: the boundary.
  // NEIGHBOR_1 is bit 0, the rotated kSiblingTest. Only the lowest
  // candidate counts, so the root's slot, above every group, needs no
  // masking before it is found; `groups` then cuts a flip past the top.
  const uint64_t sk = sel.of[k];  // 0 for type 0 (a flip in the tail)
  const uint64_t candidates = std::rotl(stops & sk, 1);
  const uint64_t flip = candidates & (0 - candidates) & shape.groups;

  // 4.4.5: past the top group (flip == 0 for k >= 3) the root's slot tells
  // the type at level 0. A tail flip, a flip in the groups or a crossing:
  // anything else is the boundary, where every change below is zero (no
  // flip, no trade, a crossing of 0), so the step needs no branch.
  const uint64_t crossing = kStepTables.crossing[top + (sk >> kRootSlot)];
  const bool moved = (t.flip | flip | crossing) != 0;
  top ^= flip == 0 ? static_cast<int>(crossing) : 0;

  // UPDATE (4.4.4, Fig. 56). Only a type-3 stop flips bit 1 (its bit 2 is 1:
  // 01 <-> 11, "swap 3 and 5") and only a type-4 stop flips bit 2 (00 <-> 01
  // "swap 4 and 5", 10 <-> 11 "swap 3 and 4"). Either way, above the group
  // the initial types that trade places are k and the one that sees, in
  // that group, type 4 (after a type-3 stop) or type 5 (after a type-4
  // stop): its selector has the bit at flip >> 2 there, and it is one of k's
  // two partners. Any other flip (every flip for k < 3) leaves `above`
  // empty and the selectors as they are.
  const uint64_t flip12 = flip & kPos12Mask;
  const uint64_t probe = flip12 >> 2;
  stops ^= flip ^ probe;  // the flipped bit's test, and for bits 1 and 2 the test two below
  // The lanes above the group, the root's slot included. After a bit-2 flip
  // this also takes in the group's own bit-1 position, where only the
  // never-traded type-2 selector has bits.
  const uint64_t above = 0 - (flip12 << 1);
  const int a = kStepTables.partners[k][0], b = kStepTables.partners[k][1];
  const uint64_t sa = sel.of[a], sb = sel.of[b];
  // Which one: a mask from the probe bit up (the trade lies above it), or 0.
  // Masks, not selects: GCC turns the selects into a branch, which random
  // codes mispredict.
  const uint64_t a_trades = 0 - (sa & probe);
  const uint64_t trade_a = (sk ^ sa) & above & a_trades;
  const uint64_t trade_b = (sk ^ sb) & above & ~a_trades;
  sel.of[k] ^= trade_a | trade_b;
  sel.of[a] ^= trade_a;
  sel.of[b] ^= trade_b;
  return moved;
}

}  // namespace hp
}  // namespace simplexdb
