// What the HT and HP neighbor algorithms share: the seed's per-group tables
// (Fig. 38 for the HT, Fig. 53 for the HP) and the grouped nearest-common-
// ancestor scan they drive, and the per-level constants of the constant-time
// algorithms.
//
// A code at level L = D*G + r has G full groups of D bits (one period of
// shapes) above r tail bits. Group m (m = 0 deepest) of the group word
// Q = path >> r holds its bit 1 (the shallowest level, most significant) at
// position D*m + D - 1 and its bit D at D*m.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <string_view>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"

namespace simplexdb {

// One entry of Fig. 38 / Fig. 53, decoded.
struct GroupStep {
  bool stop;      // true: `value` is the neighbor's group bits
  uint8_t value;  // stop ? group bits : the type to continue with
};

// "0101" -> stop with those bits; "Cont 3" -> continue with type 3 of the
// simplex at the start of the group (SEED-ERRATA item 2).
constexpr GroupStep ParseGroupStep(std::string_view entry) {
  if (entry.substr(0, 5) == "Cont ") {
    return GroupStep{false, static_cast<uint8_t>(entry[5] - '0')};
  }
  uint8_t bits = 0;
  for (char c : entry) bits = static_cast<uint8_t>(bits << 1 | (c - '0'));
  return GroupStep{true, bits};
}

// [group bits][type-1]
template <int D>
using GroupStepTable = std::array<std::array<GroupStep, D + 1>, (1 << D)>;

template <int D>
constexpr GroupStepTable<D> ParseGroupSteps(const std::string_view (&figure)[1 << D][D + 1]) {
  GroupStepTable<D> t{};
  for (int bits = 0; bits < (1 << D); ++bits) {
    for (int k = 0; k < D + 1; ++k) t[bits][k] = ParseGroupStep(figure[bits][k]);
  }
  return t;
}

// The grouped nearest-common-ancestor scan (3.2 / 4.3): the tail one level at
// a time (TailSteps), then one group per step, deepest first, by `table`;
// past the top group, to another root by table or the boundary. O(L / D).
// REQUIRES: code.is_valid(), 1 <= type <= D + 1.
template <int D>
constexpr SimplexCode<D> GroupScan(SimplexCode<D> code, int type,
                                   const GroupStepTable<D>& table) {
  assert(type >= 1 && type <= D + 1);
  constexpr uint64_t kGroup = (uint64_t{1} << D) - 1;
  const int level = code.level();
  const int r = level % D;
  const uint64_t path = code.path();
  const TailStep s = TailSteps<D>::kTable[r][path & ((uint64_t{1} << r) - 1)][type - 1];
  if (s.flip != 0) return code.with_path(path ^ s.flip);
  int k = s.type;
  for (int shift = r; shift < level; shift += D) {
    const GroupStep g = table[(path >> shift) & kGroup][k - 1];
    if (g.stop) {
      return code.with_path((path & ~(kGroup << shift)) | uint64_t{g.value} << shift);
    }
    k = g.value;
  }
  const int root = kRootFaceToRoot<D>[code.top()][k - 1];
  return root < 0 ? SimplexCode<D>::None() : code.with_top(root);
}

// Bit j of every group of a group word (j = 1 is the shallowest level).
template <int D>
constexpr uint64_t GroupBitMask(int j) {
  uint64_t m = 0;
  for (int p = D - j; p < 64; p += D) m |= uint64_t{1} << p;
  return m;
}

// The tail steps (TailSteps<D>) as a cursor reads them: for each r one flat
// array with a row of kTailRow entries per tail value, so that the row of
// tail bits `tail` starts at entry tail * kTailRow, and with each flip scaled
// to the same units: a step that flips tail bit f moves a cursor's row offset
// by f * kTailRow, an XOR, and the next step reads its entry with one load.
inline constexpr int kTailRow = 8;

template <int D>
struct TailRows {
  static_assert(D + 1 <= kTailRow && (kTailRow << (D - 2)) < 256);  // flips fit a byte
  using Table = std::array<std::array<TailStep, kTailRow << (D - 1)>, D>;

  static constexpr Table Derive() {
    Table t{};
    for (int r = 0; r < D; ++r) {
      for (int bits = 0; bits < (1 << r); ++bits) {
        for (int k = 0; k < D + 1; ++k) {
          const TailStep s = TailSteps<D>::kTable[r][bits][k];
          t[r][bits * kTailRow + k] = TailStep{static_cast<uint8_t>(s.flip * kTailRow), s.type};
        }
      }
    }
    return t;
  }

  static constexpr Table kTable = Derive();
};

// What a constant-time step needs that depends only on the level, which
// never changes along a walk: computed once per cursor.
template <int D>
struct LevelShape {
  explicit constexpr LevelShape(int level)
      : r(level % D),
        n(level - r),
        groups((uint64_t{1} << n) - 1),
        pos1(GroupBitMask<D>(1) & groups),
        root_bit(uint64_t{1} << n),
        tail(TailRows<D>::kTable[r].data()) {}

  int r;            // levels in the tail (below the last full group)
  int n;            // bits in the group word Q = path >> r
  uint64_t groups;    // (1 << n) - 1
  uint64_t pos1;      // bit 1 of every group of Q
  uint64_t root_bit;  // bit n: where the neighbor mask keeps the root's slot
  const TailStep* tail;  // TailRows<D>::kTable[r]
};

}  // namespace simplexdb
