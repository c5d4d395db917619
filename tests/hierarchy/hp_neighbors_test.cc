// HP face neighbors. Geometry is the judge (every code to level 10, faces
// matched by coordinates, with the same vertex positions on both sides); the
// Fig. 53 scan against the per-level scan; the constant-time algorithm
// against the scan on a million random codes (ten million in the long run);
// the neighbor mask, its bit-parallel construction and its Fig. 56 updates
// against definitions.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <unordered_map>

#include "hierarchy/neighbors.h"
#include "hierarchy/level_scan.h"
#include "tests/hierarchy/hp_reference.h"
#include "tests/hierarchy/neighbors_test_util.h"
#include "tests/util/long_run.h"

namespace simplexdb {
namespace {

constexpr int kExhaustiveLevel = 10;

PentaCode P(const char* text) { return PentaCode::Parse(text).value(); }

const testing::NamedNeighbor<4> kAlgorithms[] = {
    {"level scan", &NeighborByLevelScan<4>},
    {"Fig. 53 scan", &NeighborScan<4>},
    {"constant time", &Neighbor<4>},
    {"cursor", &testing::ByCursor<4>},
};

TEST(HpNeighbors, EveryCodeToLevel10SharesTheNamedFaceWithTheSameVertexPositions) {
  testing::CheckNeighborsByGeometry<4>(kExhaustiveLevel, kAlgorithms, true);
}

TEST(HpNeighbors, RandomDeepCodesShareTheFaceGeometrically) {
  testing::CheckRandomNeighborsGeometrically<4>(31, 100000, true);
}

TEST(HpNeighbors, SeedExamples) {
  for (const auto& alg : kAlgorithms) {
    SCOPED_TRACE(alg.name);
    // 4.3.1-4.3.2: type 4 of 9010110 is 9010010.
    EXPECT_EQ(alg.fn(P("9:010110"), 4), P("9:010010"));
    // Fig. 54: type 2 of 710100110101100100011 is 710100111101100100011.
    EXPECT_EQ(alg.fn(P("7:10100110101100100011"), 2), P("7:10100111101100100011"));
    // Fig. 55: type 3 of the same code is 711100110101100100011.
    EXPECT_EQ(alg.fn(P("7:10100110101100100011"), 3), P("7:11100110101100100011"));
  }
}

// Fig. 55, step 5 prints the neighbor mask of 710100110101100100011 (below
// the root digit): our mask, without the root's own slot, is that string.
TEST(HpNeighbors, Fig55NeighborMask) {
  const PentaCode c = P("7:10100110101100100011");
  const uint64_t mask = NeighborMask(c);
  const uint64_t printed = 0b10111110011001100110;
  EXPECT_EQ(mask & ((uint64_t{1} << 20) - 1), printed);
}

// Composes four per-level steps of the split rules over a group and renders
// the outcome the way Fig. 53 prints it.
std::string ComposeGroup(int bits, int type) {
  int k = type;
  for (int l = 4; l >= 1; --l) {
    const int shift = 4 - l;
    const int next = ClimbOneLevel<4>(l, static_cast<uint64_t>(bits) >> shift, k);
    if (next == 0) {
      std::string s;
      for (int i = 3; i >= 0; --i) s.push_back(static_cast<char>('0' + ((bits ^ (1 << shift)) >> i & 1)));
      return s;
    }
    k = next;
  }
  return "Cont " + std::to_string(k);
}

TEST(HpNeighbors, Fig53FollowsFromTheSplitRules) {
  for (int bits = 0; bits < 16; ++bits) {
    for (int k = 1; k <= 5; ++k) {
      EXPECT_EQ(ComposeGroup(bits, k), hp::kFig53[bits][k - 1]) << bits << " type " << k;
    }
  }
}

// SEED-ERRATA item 6: the sibling is the type-1 neighbor only for h- and
// c-pentatopes; for s-pentatopes it is across face 1 or 3, for e-pentatopes
// across face 1 or 2.
TEST(HpNeighbors, SiblingFaceTypeDependsOnTheShape) {
  std::map<int, std::set<int>> sibling_types;  // level % 4 -> face types
  std::mt19937_64 rng(41);
  for (int i = 0; i < 20000; ++i) {
    const int level = 1 + static_cast<int>(rng() % 40);
    const PentaCode c = PentaCode::FromPath(static_cast<int>(rng() % 24), rng() >> (64 - level), level);
    for (int k = 1; k <= 5; ++k) {
      if (Neighbor(c, k) == c.sibling()) sibling_types[level % 4].insert(k);
    }
  }
  EXPECT_EQ(sibling_types[0], (std::set<int>{1}));     // h
  EXPECT_EQ(sibling_types[1], (std::set<int>{1}));     // c
  EXPECT_EQ(sibling_types[2], (std::set<int>{1, 3}));  // s
  EXPECT_EQ(sibling_types[3], (std::set<int>{1, 2}));  // e
}

// The permutation of the sought type {3,4,5} a group's bits 1-2 apply when
// the scan continues, read off Fig. 53 (completed to a bijection where type
// 3 stops: 4.4.4's "assume type 3 / 5").
std::array<int, 6> GroupPermutation(int b1b2) {
  std::array<int, 6> perm{};  // perm[t] for t in 3..5
  std::set<int> used;
  for (int t = 3; t <= 5; ++t) {
    // Bits 3-4 chosen so that t continues, if it can.
    for (int low = 0; low < 4; ++low) {
      const GroupStep s = hp::kGroupSteps[b1b2 << 2 | low][t - 1];
      if (!s.stop) {
        perm[t] = s.value;
        break;
      }
    }
    if (perm[t] != 0) used.insert(perm[t]);
  }
  for (int t = 3; t <= 5; ++t) {
    if (perm[t] == 0) {
      for (int v = 3; v <= 5; ++v) {
        if (!used.count(v)) perm[t] = v;
      }
    }
  }
  return perm;
}

// 4.4.4's reading of Fig. 53: 00 identity, 01 swaps 4 and 5, 10 swaps 3 and
// 5, 11 rotates; and Fig. 56 is T_after composed with T_before's inverse.
TEST(HpNeighbors, Fig56IsTheChangeOfTheGroupPermutation) {
  EXPECT_EQ(GroupPermutation(0b00), (std::array<int, 6>{0, 0, 0, 3, 4, 5}));
  EXPECT_EQ(GroupPermutation(0b01), (std::array<int, 6>{0, 0, 0, 3, 5, 4}));
  EXPECT_EQ(GroupPermutation(0b10), (std::array<int, 6>{0, 0, 0, 5, 4, 3}));
  EXPECT_EQ(GroupPermutation(0b11), (std::array<int, 6>{0, 0, 0, 5, 3, 4}));
  for (int from = 0; from < 4; ++from) {
    for (int to = 0; to < 4; ++to) {
      const std::string_view printed = hp::kFig56[from][to];
      if (from == to) {
        EXPECT_EQ(printed, "No change");
        continue;
      }
      if ((from ^ to) == 3) {
        EXPECT_EQ(printed, "Not possible");  // one flip changes one bit
        continue;
      }
      const auto before = GroupPermutation(from), after = GroupPermutation(to);
      std::set<int> moved;  // values v with after(before^-1(v)) != v
      for (int t = 3; t <= 5; ++t) {
        if (after[t] != before[t]) moved.insert(before[t]);
      }
      ASSERT_EQ(moved.size(), 2u);
      const std::string expected =
          "Swap " + std::to_string(*moved.begin()) + " and " + std::to_string(*moved.rbegin());
      EXPECT_EQ(printed, expected) << from << " -> " << to;
    }
  }
}

// The neighbor mask by its definition: walk the groups from the bottom,
// composing the permutations of Fig. 53.
uint64_t MaskByDefinition(PentaCode c) {
  const int r = c.level() % 4;
  const uint64_t q = c.path() >> r;
  const int groups = (c.level() - r) / 4;
  std::array<int, 6> p = {0, 0, 0, 3, 4, 5};  // P_0 = identity
  uint64_t mask = 0;
  for (int m = 0; m <= groups; ++m) {
    mask |= static_cast<uint64_t>((p[3] - 2) << 2 | (p[4] - 2)) << (4 * m);
    if (m == groups) break;
    const auto t = GroupPermutation(static_cast<int>(q >> (4 * m + 2) & 3));
    for (int x = 3; x <= 5; ++x) p[x] = t[p[x]];
  }
  return mask;
}

TEST(HpNeighbors, BitParallelMaskEqualsItsDefinition) {
  std::mt19937_64 rng(51);
  for (int i = 0; i < 200000; ++i) {
    const int level = static_cast<int>(rng() % (PentaCode::kMaxLevel + 1));
    const PentaCode c = PentaCode::FromPath(0, level ? rng() >> (64 - level) : 0, level);
    ASSERT_EQ(NeighborMask(c), MaskByDefinition(c)) << c.ToString();
  }
}

PentaCode LongChainCode(std::mt19937_64& rng, int level, double p_continue) {
  uint64_t path = 0;
  for (int l = 0; l < level; l += 4) {
    // Groups in which some of types 2..5 continue.
    static constexpr uint8_t kContinue[] = {0b0000, 0b0011, 0b1001, 0b0110, 0b1100, 0b0010};
    const uint64_t g = std::uniform_real_distribution<>(0, 1)(rng) < p_continue
                           ? kContinue[rng() % 6]
                           : rng() & 15;
    path = path << 4 | g;
  }
  path >>= 4 * ((level + 3) / 4) - level;
  return PentaCode::FromPath(static_cast<int>(rng() % 24), path, level);
}

// A million codes; ten million in the long run (`ctest -L long`).
TEST(HpNeighbors, ConstantTimeEqualsScanOnRandomCodes) {
  std::mt19937_64 rng(20261122);
  const int codes = testing::LongRun() ? 10'000'000 : 1'000'000;
  for (int i = 0; i < codes; ++i) {
    const int level = static_cast<int>(rng() % (PentaCode::kMaxLevel + 1));
    const PentaCode c = (i % 4 == 0)
                            ? LongChainCode(rng, level, 0.9)
                            : PentaCode::FromPath(static_cast<int>(rng() % 24),
                                                  level ? rng() >> (64 - level) : 0, level);
    PentaCursor cursor(c);
    for (int k = 1; k <= 5; ++k) {
      PentaCursor step = cursor;
      const PentaCode fast = step.Step(k) ? step.code() : PentaCode::None();
      const PentaCode scan = NeighborScan(c, k);
      if (fast != scan) {
        FAIL() << c.ToString() << " type " << k << ": constant time " << fast.ToString()
               << ", scan " << scan.ToString();
      }
    }
  }
}

TEST(HpNeighbors, Fig53ScanEqualsLevelScanOnRandomDeepCodes) {
  testing::CheckScanEqualsLevelScan<4>(61, [](std::mt19937_64& rng, int level) {
    return LongChainCode(rng, level, 0.5);
  });
}

// The mask a cursor updates by the swaps of Fig. 56 stays equal to the mask
// derived from scratch, along long random walks.
TEST(HpNeighbors, CursorMaskStaysExactAlongRandomWalks) {
  testing::CheckCursorMaskAlongWalks<4>(71, [](std::mt19937_64& rng, int level) {
    return LongChainCode(rng, level, 0.7);
  });
}

TEST(HpNeighbors, RootTable) { testing::CheckRootTable<4>(); }

}  // namespace
}  // namespace simplexdb
