// HP vertex geometry against Fig. 52 written out literally and against
// geometry: longest-edge bisection (with ties), tiling of the hypercube.
#include <gtest/gtest.h>

#include <map>
#include <random>

#include "hierarchy/geometry.h"
#include "tests/hierarchy/geometry_checks.h"
#include "tests/hierarchy/hp_reference.h"

namespace simplexdb {
namespace {

using testing::Abs128;
using testing::Int128;
using testing::Det4;
using testing::Dist2;
using testing::ForEachLiteral;
using testing::P4;
using testing::Penta;

constexpr int kExhaustiveLevel = 10;

TEST(HpGeometry, VerticesEqualRecursiveBisectionEveryCodeToLevel10) {
  testing::CheckVerticesEqualLiteral<4>(kExhaustiveLevel);
}

// Every split bisects a longest edge; e-pentatopes have three longest edges
// of equal length (v3v4, v3v5, v4v5), SEED-ERRATA item 7.
TEST(HpGeometry, EverySplitBisectsALongestEdge) {
  std::map<int, std::map<int, int>> ties;  // level % 4 -> number of longest edges -> count
  ForEachLiteral<4>(kExhaustiveLevel, [&](PentaCode c, const Penta& t) {
    SCOPED_TRACE(c.ToString());
    const auto edge = SplitEdge(c);
    const int64_t split = Dist2(t[edge[0]], t[edge[1]]);
    int longest = 0;
    for (int i = 0; i < 5; ++i) {
      for (int j = i + 1; j < 5; ++j) {
        ASSERT_LE(Dist2(t[i], t[j]), split);
        longest += Dist2(t[i], t[j]) == split;
      }
    }
    ties[c.level() % 4][longest]++;
  });
  EXPECT_EQ(ties[0].size(), 1u);
  EXPECT_EQ(ties[0].begin()->first, 1);  // h: unique
  EXPECT_EQ(ties[1].begin()->first, 1);  // c
  EXPECT_EQ(ties[2].begin()->first, 1);  // s
  EXPECT_EQ(ties[3].size(), 1u);
  EXPECT_EQ(ties[3].begin()->first, 3);  // e: three equal longest edges
}

TEST(HpGeometry, ChildrenHalveTheParent) {
  ForEachLiteral<4>(8, [&](PentaCode c, const Penta& t) {
    if (c.level() == 8) return;
    const Int128 vp = Abs128(Det4(t));
    ASSERT_GT(vp, 0);
    ASSERT_TRUE(2 * Abs128(Det4(Vertices(c.child(0)))) == vp) << c.ToString();
    ASSERT_TRUE(2 * Abs128(Det4(Vertices(c.child(1)))) == vp) << c.ToString();
  });
}

// ChildVertices (one split, for descents) agrees with Vertices.
TEST(HpGeometry, ChildVerticesFromTheParent) { testing::CheckChildVertices<4>(9); }

TEST(HpGeometry, ShapesCycleEveryFourLevels) { testing::CheckShapesCycle<4>(5, 8); }

TEST(HpGeometry, RootsAreTheSeedsLabeling) {
  for (int top = 0; top < 24; ++top) {
    EXPECT_EQ(Vertices(PentaCode::Root(top)), testing::RootLiteral4(top));
  }
}

TEST(HpGeometry, RootsTileTheHypercube) {
  const Int128 s = kDomainSide<4>;
  Int128 volume24 = 0;
  for (int top = 0; top < 24; ++top) volume24 += Abs128(Det4(Vertices(PentaCode::Root(top))));
  EXPECT_TRUE(volume24 == 24 * s * s * s * s);

  // Points with distinct coordinates lie strictly inside exactly one root:
  // replace each vertex by the point and compare signs.
  std::mt19937_64 rng(17);
  for (int i = 0; i < 5000; ++i) {
    P4 p{};
    bool distinct;
    do {
      for (int a = 0; a < 4; ++a) p[a] = 1 + static_cast<int32_t>(rng() % (s - 1));
      distinct = true;
      for (int a = 0; a < 4; ++a) {
        for (int b = a + 1; b < 4; ++b) distinct = distinct && p[a] != p[b];
      }
    } while (!distinct);
    int inside = 0;
    for (int top = 0; top < 24; ++top) {
      const Penta t = Vertices(PentaCode::Root(top));
      const Int128 d = Det4(t);
      bool in = true;
      for (int v = 0; v < 5 && in; ++v) {
        Penta u = t;
        u[v] = p;
        const Int128 dv = Det4(u);
        in = dv != 0 && ((dv > 0) == (d > 0));
      }
      inside += in;
    }
    ASSERT_EQ(inside, 1);
  }
}

}  // namespace
}  // namespace simplexdb
