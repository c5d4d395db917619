// The HZ order and split vertices against geometry: SplitVertex against the
// vertices the split rules give, creation levels against the codes that
// create each vertex, diamonds against clusters, and positions against a
// Morton order written out bit by bit.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <vector>

#include "hierarchy/cluster.h"
#include "hierarchy/hz_order.h"

namespace simplexdb {
namespace {

template <int D>
std::vector<SimplexCode<D>> CodesAbove(int levels) {
  std::vector<SimplexCode<D>> out;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < levels; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) out.push_back(SimplexCode<D>::FromPath(top, p, l));
    }
  }
  return out;
}

template <int D>
void ExpectSplitVertexIsTheSplitMidpoint(int levels) {
  for (const SimplexCode<D> c : CodesAbove<D>(levels)) {
    ASSERT_EQ(SplitVertex(c), SplitMidpoint<D>(c, Vertices(c))) << c.ToString();
  }
  std::mt19937_64 rng(7);
  for (int i = 0; i < 200000; ++i) {
    const int level = static_cast<int>(rng() % SimplexCode<D>::kMaxLevel);
    const int top = static_cast<int>(rng() % SimplexCode<D>::kRoots);
    const uint64_t path = level == 0 ? 0 : rng() >> (64 - level);
    const SimplexCode<D> c = SimplexCode<D>::FromPath(top, path, level);
    ASSERT_EQ(SplitVertex(c), SplitMidpoint<D>(c, Vertices(c))) << c.ToString();
  }
}

TEST(HzOrder, HtSplitVertexEqualsTheSplitEdgeMidpoint) { ExpectSplitVertexIsTheSplitMidpoint<3>(13); }
TEST(HzOrder, HpSplitVertexEqualsTheSplitEdgeMidpoint) { ExpectSplitVertexIsTheSplitMidpoint<4>(12); }

// The cursor reuses the octaves a code shares with the previous one: the
// same answers in any order (depth-first, random, roots switching, levels
// going up and down).
template <int D>
void ExpectCursorAgreesWithSplitVertex() {
  SplitVertexCursor<D> cursor;
  for (const SimplexCode<D> c : CodesAbove<D>(11)) ASSERT_EQ(cursor.Of(c), SplitVertex(c)) << c.ToString();
  std::mt19937_64 rng(5);
  SimplexCode<D> c = SimplexCode<D>::Root(0);
  for (int i = 0; i < 300000; ++i) {
    const uint64_t pick = rng() % 8;
    if (pick < 3 && c.level() < SimplexCode<D>::kMaxLevel) {
      c = c.child(static_cast<int>(rng() & 1));
    } else if (pick < 5 && c.level() > 0) {
      c = c.ancestor(static_cast<int>(rng() % c.level()));
    } else if (pick < 6 && c.level() > 0) {
      c = c.sibling();
    } else {
      const int level = static_cast<int>(rng() % SimplexCode<D>::kMaxLevel);
      c = SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots),
                                   level == 0 ? 0 : rng() >> (64 - level), level);
    }
    ASSERT_EQ(cursor.Of(c), SplitVertex(c)) << c.ToString();
  }
}

TEST(HzOrder, HtCursorAgreesWithSplitVertex) { ExpectCursorAgreesWithSplitVertex<3>(); }
TEST(HzOrder, HpCursorAgreesWithSplitVertex) { ExpectCursorAgreesWithSplitVertex<4>(); }

// Bit by bit: bit b of coordinate a is bit D * b + a.
template <int D>
uint64_t NaiveMorton(const std::array<int64_t, D>& u) {
  uint64_t m = 0;
  for (int b = 0; b < 64 / D; ++b) {
    for (int a = 0; a < D; ++a) m |= static_cast<uint64_t>(u[a] >> b & 1) << (D * b + a);
  }
  return m;
}

template <int D>
void ExpectMortonRoundTrips() {
  std::mt19937_64 rng(11);
  for (int i = 0; i < 100000; ++i) {
    std::array<int64_t, D> u{};
    for (int a = 0; a < D; ++a) u[a] = static_cast<int64_t>(rng() >> (64 - 64 / D));
    const uint64_t m = internal::Morton<D>(u);
    ASSERT_EQ(m, NaiveMorton<D>(u));
    ASSERT_EQ(internal::FromMorton<D>(m), u);
  }
}

TEST(HzOrder, HtMortonMatchesBitByBitInterleaving) { ExpectMortonRoundTrips<3>(); }
TEST(HzOrder, HpMortonMatchesBitByBitInterleaving) { ExpectMortonRoundTrips<4>(); }

template <int D>
void ForEachGridPoint(int k, const std::function<void(const std::array<int64_t, D>&)>& f) {
  const int64_t n = (int64_t{1} << k) + 1;
  int64_t total = 1;
  for (int a = 0; a < D; ++a) total *= n;
  for (int64_t i = 0; i < total; ++i) {
    std::array<int64_t, D> g{};
    int64_t r = i;
    for (int a = 0; a < D; ++a, r /= n) g[a] = r % n;
    f(g);
  }
}

// Every grid point that is not a corner of the domain is the split vertex of
// the nodes of exactly one cluster, all at the level HzOrder::Level names;
// corners are the split vertex of no node.
template <int D>
void ExpectEveryVertexIsOneDiamond(int k) {
  SCOPED_TRACE("k = " + std::to_string(k));
  const HzOrder<D> order(k);
  std::map<std::array<int64_t, D>, std::set<uint64_t>> creators;
  for (const SimplexCode<D> c : CodesAbove<D>(D * k)) {
    creators[LatticeToGrid<D>(SplitVertex(c), k)].insert(c.key());
  }
  int corners = 0;
  ForEachGridPoint<D>(k, [&](const std::array<int64_t, D>& g) {
    const int level = order.Level(g);
    const auto it = creators.find(g);
    if (level < 0) {
      ++corners;
      ASSERT_EQ(it, creators.end());
      return;
    }
    ASSERT_NE(it, creators.end()) << "no node creates a grid point";
    const SimplexCode<D> first = SimplexCode<D>::FromKey(*it->second.begin());
    std::set<uint64_t> cluster;
    for (const auto m : Cluster(first)) cluster.insert(m.key());
    ASSERT_EQ(it->second, cluster) << first.ToString();
    for (const uint64_t key : it->second) ASSERT_EQ(SimplexCode<D>::FromKey(key).level(), level);
  });
  EXPECT_EQ(corners, 1 << D);
  EXPECT_EQ(creators.size(), static_cast<size_t>(std::pow((1 << k) + 1, D)) - (1 << D));
}

TEST(HzOrder, HtEveryVertexIsTheSplitVertexOfOneCluster) {
  for (int k = 1; k <= 4; ++k) ExpectEveryVertexIsOneDiamond<3>(k);
}
TEST(HzOrder, HpEveryVertexIsTheSplitVertexOfOneCluster) {
  for (int k = 1; k <= 2; ++k) ExpectEveryVertexIsOneDiamond<4>(k);
}

// Positions: a bijection between the grid points and the positions that are
// vertices, sorted by (level, odd pattern, Morton order of the cube), with
// the corners first; every octave starts at 2^(D (o + 1)).
template <int D>
void ExpectPositionsAreTheHzOrder(int k) {
  SCOPED_TRACE("k = " + std::to_string(k));
  const HzOrder<D> order(k);
  using Key = std::tuple<int, int, uint64_t>;
  std::vector<std::pair<Key, uint64_t>> points;
  ForEachGridPoint<D>(k, [&](const std::array<int64_t, D>& g) {
    const int level = order.Level(g);
    const uint64_t p = order.Position(g);
    ASSERT_LT(p, order.size());
    ASSERT_EQ(order.LevelAt(p), level);
    ASSERT_GE(p, order.LevelBegin(level));
    ASSERT_LT(p, order.LevelEnd(level));
    ASSERT_TRUE(order.IsVertex(p));
    ASSERT_EQ(order.PointAt(p), g);
    Key key;
    if (level < 0) {
      int corner = 0;
      for (int a = 0; a < D; ++a) corner |= static_cast<int>(g[a] >> k) << a;
      key = {-1, corner, 0};
    } else {
      const int s = k - 1 - level / D;
      std::array<int64_t, D> u{};
      int odd = 0;
      for (int a = 0; a < D; ++a) {
        u[a] = g[a] >> (s + 1);
        odd |= static_cast<int>(g[a] >> s & 1) << a;
      }
      key = {level, odd, NaiveMorton<D>(u)};
      if (level % D == 0) {
        ASSERT_GE(p, uint64_t{1} << (D * (level / D + 1)));
      }
    }
    points.emplace_back(key, p);
  });
  std::sort(points.begin(), points.end());
  for (size_t i = 1; i < points.size(); ++i) ASSERT_LT(points[i - 1].second, points[i].second);
  uint64_t vertices = 0;
  for (uint64_t p = 0; p < order.size(); ++p) vertices += order.IsVertex(p);
  EXPECT_EQ(vertices, points.size());
}

TEST(HzOrder, HtPositionsAreABijectionInHzOrder) {
  for (int k = 1; k <= 4; ++k) ExpectPositionsAreTheHzOrder<3>(k);
}
TEST(HzOrder, HpPositionsAreABijectionInHzOrder) {
  for (int k = 1; k <= 3; ++k) ExpectPositionsAreTheHzOrder<4>(k);
}

// What a brick-by-brick builder relies on: inside an aligned cube of side
// 2^b, the vertices of one level and pattern whose cells lie in the cube
// fill an aligned run of 2^(D (b - s - 1)) positions (s + 1 <= b).
template <int D>
void ExpectBricksAreAlignedRuns(int k, int b) {
  SCOPED_TRACE("k = " + std::to_string(k) + ", b = " + std::to_string(b));
  const HzOrder<D> order(k);
  // (brick, level, pattern) -> positions
  std::map<std::tuple<std::array<int64_t, D>, int, int>, std::vector<uint64_t>> runs;
  ForEachGridPoint<D>(k, [&](const std::array<int64_t, D>& g) {
    const int level = order.Level(g);
    if (level < 0) return;
    const int s = k - 1 - level / D;
    if (s + 1 > b) return;
    std::array<int64_t, D> brick{};
    int odd = 0;
    for (int a = 0; a < D; ++a) {
      brick[a] = g[a] >> b;
      odd |= static_cast<int>(g[a] >> s & 1) << a;
    }
    runs[{brick, level, odd}].push_back(order.Position(g));
  });
  for (auto& [key, positions] : runs) {
    const int s = k - 1 - std::get<1>(key) / D;
    const uint64_t size = uint64_t{1} << (D * (b - s - 1));
    std::sort(positions.begin(), positions.end());
    bool inside = true;  // bricks on the upper faces hold only a face
    for (int a = 0; a < D; ++a) inside = inside && std::get<0>(key)[a] < (int64_t{1} << (k - b));
    if (inside) {
      ASSERT_EQ(positions.size(), size);
    }
    ASSERT_EQ(positions.front() % size, 0u);
    ASSERT_LT(positions.back(), positions.front() - positions.front() % size + size);
  }
}

TEST(HzOrder, HtBricksAreAlignedRuns) {
  for (int b = 1; b <= 3; ++b) ExpectBricksAreAlignedRuns<3>(4, b);
}
TEST(HzOrder, HpBricksAreAlignedRuns) {
  for (int b = 1; b <= 2; ++b) ExpectBricksAreAlignedRuns<4>(3, b);
}

template <int D>
void ExpectPositionOfCodeIsItsSplitVertex(int k) {
  const HzOrder<D> order(k);
  for (const SimplexCode<D> c : CodesAbove<D>(D * k)) {
    const auto g = LatticeToGrid<D>(SplitMidpoint<D>(c, Vertices(c)), k);
    ASSERT_EQ(order.PositionOf(c), order.Position(g)) << c.ToString();
  }
}

TEST(HzOrder, HtPositionOfACodeIsThePositionOfItsSplitVertex) { ExpectPositionOfCodeIsItsSplitVertex<3>(4); }
TEST(HzOrder, HpPositionOfACodeIsThePositionOfItsSplitVertex) { ExpectPositionOfCodeIsItsSplitVertex<4>(3); }

// The coarse levels come first and are small: a read of the levels above
// the finest octave is a prefix of the order.
TEST(HzOrder, LevelsAreContiguousAndGrowByTheOctave) {
  const HzOrder<3> order(5);
  EXPECT_EQ(order.LevelBegin(-1), 0u);
  EXPECT_EQ(order.LevelBegin(0), 8u);
  for (int c = 0; c < order.levels(); ++c) {
    EXPECT_EQ(order.LevelEnd(c) - order.LevelBegin(c), HzOrder<3>::LevelSize(c));
    if (c + 1 < order.levels()) {
      EXPECT_EQ(order.LevelEnd(c), order.LevelBegin(c + 1));
    }
  }
  EXPECT_EQ(HzOrder<3>::LevelSize(0), 8u);       // 1 pattern, 2^3 cubes
  EXPECT_EQ(HzOrder<3>::LevelSize(1), 3u * 8);   // face centres
  EXPECT_EQ(HzOrder<3>::LevelSize(3), 64u);      // next octave
  EXPECT_EQ(HzOrder<4>::LevelSize(2), 6u * 16);  // two odd axes of four
}

}  // namespace
}  // namespace simplexdb
