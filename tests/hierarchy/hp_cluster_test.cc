// HP clusters against brute force: the same-level pentatopes whose split
// edge is a given edge, found by matching coordinates.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <unordered_map>

#include "hierarchy/cluster.h"
#include "hierarchy/neighbors.h"
#include "tests/hierarchy/hp_reference.h"

namespace simplexdb {
namespace {

using testing::PointsHash;

using testing::EdgeOf;
using Edge4 = testing::Edge<4>;

TEST(HpCluster, ClustersEqualThePentatopesSharingTheSplitEdge) {
  std::map<std::pair<int, size_t>, size_t> sizes;  // (shape + 10 if on the boundary, size)
  for (int level = 0; level <= 10; ++level) {
    const auto pentas = testing::AllAtLevel<4>(level);
    // Every edge -> the pentatopes containing it, and those splitting it.
    std::unordered_map<Edge4, std::set<PentaCode>, PointsHash> containing, splitting;
    for (const auto& [code, t] : pentas) {
      for (int i = 0; i < 5; ++i) {
        for (int j = i + 1; j < 5; ++j) containing[EdgeOf(t, i, j)].insert(code);
      }
      const auto e = SplitEdge(code);
      splitting[EdgeOf(t, e[0], e[1])].insert(code);
    }
    for (const auto& [code, t] : pentas) {
      SCOPED_TRACE(code.ToString());
      const PentaCluster cluster = Cluster(code);
      ASSERT_EQ(cluster.front(), code);
      const std::set<PentaCode> got(cluster.begin(), cluster.end());
      ASSERT_EQ(got.size(), cluster.size()) << "a member appears twice";
      const auto e = SplitEdge(code);
      const Edge4 split = EdgeOf(t, e[0], e[1]);
      ASSERT_EQ(got, splitting.at(split));
      // Every pentatope at this level around the edge splits it too.
      ASSERT_EQ(containing.at(split), splitting.at(split));
      const bool boundary = testing::OnDomainBoundary(split);
      sizes[{level % 4 + (boundary ? 10 : 0), cluster.size()}]++;
    }
  }
  // Interior: h 24, c 12, s 16, e 48. Boundary: c 6, s 4 or 8, e 6, 12 or
  // 24; h never (SEED-ERRATA item 10).
  std::set<std::pair<int, size_t>> kinds;
  for (const auto& [k, n] : sizes) kinds.insert(k);
  const std::set<std::pair<int, size_t>> expected = {
      {0, 24}, {1, 12}, {2, 16}, {3, 48}, {11, 6}, {12, 4}, {12, 8}, {13, 6}, {13, 12}, {13, 24}};
  EXPECT_EQ(kinds, expected);
}

TEST(HpCluster, RootClusterIsAllTwentyFourRoots) {
  EXPECT_EQ(Cluster(PentaCode::Root(0)).size(), 24u);
}

}  // namespace
}  // namespace simplexdb
