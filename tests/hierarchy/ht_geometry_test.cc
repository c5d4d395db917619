// HT vertex geometry against the seed's split rules written out literally,
// and against geometry itself: longest-edge bisection, tiling.
#include <gtest/gtest.h>

#include <random>

#include "hierarchy/geometry.h"
#include "tests/hierarchy/geometry_checks.h"
#include "tests/hierarchy/ht_reference.h"

namespace simplexdb {
namespace {

using testing::Det;
using testing::Dist2;
using testing::ForEachLiteral;
using testing::P3;
using testing::Tet;

constexpr int kExhaustiveLevel = 12;

TEST(HtGeometry, VerticesEqualRecursiveBisectionEveryCodeToLevel12) {
  testing::CheckVerticesEqualLiteral<3>(kExhaustiveLevel);
}

TEST(HtGeometry, EverySplitBisectsTheUniqueLongestEdge) {
  ForEachLiteral<3>(kExhaustiveLevel, [&](TetCode c, const Tet& t) {
    SCOPED_TRACE(c.ToString());
    const auto edge = SplitEdge(c);
    const int64_t split = Dist2(t[edge[0]], t[edge[1]]);
    for (int i = 0; i < 4; ++i) {
      for (int j = i + 1; j < 4; ++j) {
        if (i == edge[0] && j == edge[1]) continue;
        ASSERT_LT(Dist2(t[i], t[j]), split) << "edge v" << i + 1 << "v" << j + 1;
      }
    }
    // The seed orders vertices so the longest edge is v3v4.
    ASSERT_EQ(edge[0], 2);
    ASSERT_EQ(edge[1], 3);
  });
}

TEST(HtGeometry, ChildrenHalveTheParent) {
  ForEachLiteral<3>(9, [&](TetCode c, const Tet& t) {
    if (c.level() == 9) return;
    const Tet a = Vertices(c.child(0));
    const Tet b = Vertices(c.child(1));
    const int64_t vp = std::abs(Det(t[0], t[1], t[2], t[3]));
    ASSERT_GT(vp, 0);
    ASSERT_EQ(2 * std::abs(Det(a[0], a[1], a[2], a[3])), vp) << c.ToString();
    ASSERT_EQ(2 * std::abs(Det(b[0], b[1], b[2], b[3])), vp) << c.ToString();
  });
}

// ChildVertices (one split, for descents) agrees with Vertices.
TEST(HtGeometry, ChildVerticesFromTheParent) { testing::CheckChildVertices<3>(11); }

// Shapes repeat every three levels at half the size (3.1.1): the level-3
// descendants of a root are congruent to it, scaled by 1/2.
TEST(HtGeometry, ShapesCycleEveryThreeLevels) { testing::CheckShapesCycle<3>(0, 9); }

TEST(HtGeometry, RootsAreTheSeedsLabeling) {
  const int s = kDomainSide<3>;
  for (int top = 0; top < 6; ++top) {
    const Tet t = Vertices(TetCode::Root(top));
    EXPECT_EQ(t[3], (P3{0, 0, 0})) << "v4 is the origin";
    EXPECT_EQ(t[2], (P3{s, s, s})) << "v3 is the far corner";
    EXPECT_EQ(t, testing::RootLiteral(top));
  }
}

// The six roots tile the cube: their volumes add up to the cube's, and every
// point with distinct coordinates (off every face) lies strictly inside
// exactly one of them.
TEST(HtGeometry, RootsTileTheCube) {
  const int64_t s = kDomainSide<3>;
  int64_t volume6 = 0;
  for (int top = 0; top < 6; ++top) {
    const Tet t = Vertices(TetCode::Root(top));
    volume6 += std::abs(Det(t[0], t[1], t[2], t[3]));
  }
  EXPECT_EQ(volume6, 6 * s * s * s);

  std::mt19937_64 rng(7);
  for (int i = 0; i < 20000; ++i) {
    P3 p{};
    do {
      for (int a = 0; a < 3; ++a) p[a] = 1 + static_cast<int32_t>(rng() % (s - 1));
    } while (p[0] == p[1] || p[1] == p[2] || p[0] == p[2]);
    int inside = 0;
    for (int top = 0; top < 6; ++top) {
      const Tet t = Vertices(TetCode::Root(top));
      const int64_t d = Det(t[0], t[1], t[2], t[3]);
      const int64_t d0 = Det(p, t[1], t[2], t[3]);
      const int64_t d1 = Det(t[0], p, t[2], t[3]);
      const int64_t d2 = Det(t[0], t[1], p, t[3]);
      const int64_t d3 = Det(t[0], t[1], t[2], p);
      const auto same = [&](int64_t x) { return (x > 0) == (d > 0) && x != 0; };
      if (same(d0) && same(d1) && same(d2) && same(d3)) ++inside;
    }
    ASSERT_EQ(inside, 1) << p[0] << "," << p[1] << "," << p[2];
  }
}

// SEED-ERRATA item 4: the children of a 1/8 pyramid are [vm,v1,v2,v4] and
// [vm,v2,v1,v3], so they share face v1v2v3 with v2 and v3 exchanged: the
// shared face has the same type on both sides but not the same positions.
TEST(HtGeometry, SiblingsOfAOneEighthPyramidSwapV2AndV3) {
  for (int level : {0, 3, 6}) {
    const TetCode c = TetCode::FromPath(4, 0, level);
    const Tet a = Vertices(c.child(0));
    const Tet b = Vertices(c.child(1));
    EXPECT_EQ(a[0], b[0]);
    EXPECT_EQ(a[1], b[2]);
    EXPECT_EQ(a[2], b[1]);
    EXPECT_NE(a[1], b[1]);
  }
}

TEST(HtGeometry, DeepVerticesAreExactLatticePoints) {
  std::mt19937_64 rng(11);
  for (int i = 0; i < 20000; ++i) {
    const int level = TetCode::kMaxLevel - static_cast<int>(rng() % 4);
    const TetCode c = TetCode::FromPath(static_cast<int>(rng() % 6),
                                        rng() >> (64 - level), level);
    const Tet t = Vertices(c);
    // The split edge of the parent has an even coordinate sum, so its
    // midpoint is exact: check the child's vertices halve the parent's volume.
    const Tet p = Vertices(c.parent());
    ASSERT_EQ(2 * std::abs(Det(t[0], t[1], t[2], t[3])),
              std::abs(Det(p[0], p[1], p[2], p[3])))
        << c.ToString();
    ASSERT_GT(std::abs(Det(t[0], t[1], t[2], t[3])), 0) << c.ToString();
  }
}

}  // namespace
}  // namespace simplexdb
