// The finest octave's diamond templates against the hierarchy: at every
// finest vertex of larger domains (boundaries included) the template's
// simplices in the domain are exactly the cluster of the nodes creating it,
// and the stencil error equals the brute-force seed error of that cluster.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <vector>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/error/finest_diamonds.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TestVolume;

// Every node of the finest octave of a domain of side 2^k, by the vertex it
// creates.
template <int D>
std::map<std::array<int64_t, D>, SimplexCode<D>> FinestCreators(int k) {
  std::map<std::array<int64_t, D>, SimplexCode<D>> out;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = D * (k - 1); l < D * k; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) {
        const SimplexCode<D> c = SimplexCode<D>::FromPath(top, p, l);
        out.emplace(LatticeToGrid<D>(SplitVertex(c), k), c);
      }
    }
  }
  return out;
}

using Simplex = std::vector<std::vector<int64_t>>;  // sorted vertices

template <int D>
Simplex Sorted(const std::array<std::array<int64_t, D>, D + 1>& v) {
  Simplex s;
  for (const auto& p : v) s.emplace_back(p.begin(), p.end());
  std::sort(s.begin(), s.end());
  return s;
}

template <int D>
void ExpectTemplatesAreTheClusters(int k) {
  SCOPED_TRACE("k = " + std::to_string(k));
  const auto& diamonds = FinestDiamonds<D>::Get();
  const int64_t side = int64_t{1} << k;
  for (const auto& [g, code] : FinestCreators<D>(k)) {
    std::set<Simplex> cluster, from_template;
    for (const auto m : Cluster(code)) {
      std::array<std::array<int64_t, D>, D + 1> v{};
      const auto lattice = Vertices<D>(m);
      for (int i = 0; i <= D; ++i) v[i] = LatticeToGrid<D>(lattice[i], k);
      cluster.insert(Sorted<D>(v));
    }
    uint32_t odd = 0, parity = 0;
    for (int a = 0; a < D; ++a) {
      odd |= static_cast<uint32_t>(g[a] & 1) << a;
      parity |= static_cast<uint32_t>((g[a] >> 1) & 1) << a;
    }
    for (const auto& s : diamonds.Of(odd, parity).simplices) {
      std::array<std::array<int64_t, D>, D + 1> v{};
      bool inside = true;
      for (int i = 0; i <= D; ++i) {
        for (int a = 0; a < D; ++a) {
          v[i][a] = g[a] + s.vertex[i][a];
          inside = inside && v[i][a] >= 0 && v[i][a] <= side;
        }
      }
      if (inside) from_template.insert(Sorted<D>(v));
    }
    ASSERT_EQ(from_template, cluster) << code.ToString();
  }
}

TEST(FinestDiamonds, HtTemplatesAreTheClusters) {
  for (int k = 2; k <= 5; ++k) ExpectTemplatesAreTheClusters<3>(k);
}
TEST(FinestDiamonds, HpTemplatesAreTheClusters) {
  for (int k = 2; k <= 4; ++k) ExpectTemplatesAreTheClusters<4>(k);
}

// The stencil error against the brute-force error of the cluster's nodes,
// padding and clamped vertex values included.
template <int D>
void ExpectErrorsAreTheBruteForce(const TestVolume& volume) {
  int k = 1;
  uint32_t largest = 0;
  for (int a = 0; a < D; ++a) largest = std::max(largest, volume.dims[a]);
  while ((int64_t{1} << k) + 1 < largest) ++k;
  std::array<int64_t, D> dims{};
  for (int a = 0; a < D; ++a) dims[a] = volume.dims[a];
  const auto field = [&](const std::array<int64_t, D>& p) {
    std::array<int64_t, 4> q = {0, 0, 0, 0};
    for (int a = 0; a < D; ++a) q[a] = p[a];
    return volume.At(q);
  };
  const auto& diamonds = FinestDiamonds<D>::Get();
  int checked = 0;
  for (const auto& [g, code] : FinestCreators<D>(k)) {
    long double exact = 0;
    for (const auto m : Cluster(code)) exact = std::max(exact, testing::BruteForceError<D>(m, k, volume));
    const double e = diamonds.Error(g, k, dims, field);
    ASSERT_NEAR(static_cast<double>(exact), e, 1e-9 * 65536) << code.ToString();
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(FinestDiamonds, HtErrorsAreTheBruteForce) {
  ExpectErrorsAreTheBruteForce<3>(TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kU8, 1));
  ExpectErrorsAreTheBruteForce<3>(TestVolume::Random(3, {11, 6, 17, 1}, VoxelType::kF32, 2));
}
TEST(FinestDiamonds, HpErrorsAreTheBruteForce) {
  ExpectErrorsAreTheBruteForce<4>(TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 3));
  ExpectErrorsAreTheBruteForce<4>(TestVolume::Random(4, {7, 5, 6, 3}, VoxelType::kU8, 4));
}

// The flat stencils give the generic error at every vertex whose diamond
// lies inside the real grid.
template <int D>
void ExpectInteriorStencilsAgree(uint32_t side, uint64_t seed) {
  const TestVolume volume = TestVolume::Random(D, {side, side, side, D == 4 ? side : 1}, VoxelType::kU16, seed);
  int k = 1;
  while ((int64_t{1} << k) + 1 < side) ++k;
  std::array<int64_t, D> dims{}, strides{};
  int64_t stride = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = side;
    strides[a] = stride;
    stride *= side;
  }
  const auto field = [&](const std::array<int64_t, D>& p) {
    int64_t i = 0;
    for (int a = 0; a < D; ++a) i += p[a] * strides[a];
    return volume.values[static_cast<size_t>(i)];
  };
  const auto& diamonds = FinestDiamonds<D>::Get();
  const DiamondStencils<D> stencils(diamonds, strides);
  int checked = 0;
  for (int64_t i = 0; i < stride; ++i) {
    std::array<int64_t, D> g{};
    bool interior = true, finest = false;
    uint32_t odd = 0, parity = 0;
    for (int a = 0; a < D; ++a) {
      g[a] = (i / strides[a]) % side;
      interior = interior && g[a] >= 2 && g[a] + 2 <= side - 1;
      finest = finest || (g[a] & 1);
      odd |= static_cast<uint32_t>(g[a] & 1) << a;
      parity |= static_cast<uint32_t>((g[a] >> 1) & 1) << a;
    }
    if (!interior || !finest) continue;
    const double generic = diamonds.Error(g, k, dims, field);
    const double flat = stencils.InteriorError(volume.values.data() + i, odd, parity);
    ASSERT_NEAR(flat, generic, 1e-9 * 65536) << i;
    ++checked;
  }
  EXPECT_GT(checked, 1000);
}

TEST(FinestDiamonds, HtInteriorStencilsAgree) { ExpectInteriorStencilsAgree<3>(33, 5); }
TEST(FinestDiamonds, HpInteriorStencilsAgree) { ExpectInteriorStencilsAgree<4>(11, 6); }

// The split edge and the diamond's vertices, scaled to every octave, against
// the geometry of the nodes themselves: for every node of a domain of side
// 2^k, its split edge's ends are its split vertex v -/+ 2^s SplitOffset, and
// its vertices are among v + 2^s VertexOffsets; over the node's cluster, the
// vertices are exactly the offsets that land in the domain.
template <int D>
void ExpectSplitEdgesAreTheNodes(int k) {
  SCOPED_TRACE("k = " + std::to_string(k));
  const auto& diamonds = FinestDiamonds<D>::Get();
  const int64_t side = int64_t{1} << k;
  std::map<std::array<int64_t, D>, SimplexCode<D>> creators;
  int nodes = 0;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < D * k; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) {
        const SimplexCode<D> c = SimplexCode<D>::FromPath(top, p, l);
        const std::array<int64_t, D> v = LatticeToGrid<D>(SplitVertex(c), k);
        creators.emplace(v, c);
        const DiamondShape shape = ShapeOfVertex<D>(v);
        const int64_t h = int64_t{1} << shape.scale_bits;
        std::array<std::array<int64_t, D>, D + 1> g{};
        const auto lattice = Vertices<D>(c);
        for (int i = 0; i <= D; ++i) g[i] = LatticeToGrid<D>(lattice[i], k);
        const auto edge = SplitEdge<D>(c);
        const auto& o = diamonds.SplitOffset(shape.odd, shape.parity);
        std::array<int64_t, D> lo{}, hi{};
        for (int a = 0; a < D; ++a) {
          lo[a] = v[a] - h * o[a];
          hi[a] = v[a] + h * o[a];
        }
        const std::set<std::array<int64_t, D>> ends = {g[edge[0]], g[edge[1]]};
        ASSERT_EQ(ends, (std::set<std::array<int64_t, D>>{lo, hi})) << c.ToString();
        for (int i = 0; i <= D; ++i) {
          bool found = false;
          for (const auto& w : diamonds.VertexOffsets(shape.odd, shape.parity)) {
            bool same = true;
            for (int a = 0; a < D; ++a) same = same && g[i][a] == v[a] + h * w[a];
            found = found || same;
          }
          ASSERT_TRUE(found) << c.ToString() << " vertex " << i;
        }
        ++nodes;
      }
    }
  }
  for (const auto& [v, code] : creators) {
    std::set<std::array<int64_t, D>> from_cluster, from_offsets;
    for (const auto m : Cluster(code)) {
      const auto lattice = Vertices<D>(m);
      for (int i = 0; i <= D; ++i) from_cluster.insert(LatticeToGrid<D>(lattice[i], k));
    }
    const DiamondShape shape = ShapeOfVertex<D>(v);
    const int64_t h = int64_t{1} << shape.scale_bits;
    for (const auto& w : diamonds.VertexOffsets(shape.odd, shape.parity)) {
      std::array<int64_t, D> p{};
      bool inside = true;
      for (int a = 0; a < D; ++a) {
        p[a] = v[a] + h * w[a];
        inside = inside && p[a] >= 0 && p[a] <= side;
      }
      if (inside) from_offsets.insert(p);
    }
    ASSERT_EQ(from_offsets, from_cluster) << code.ToString();
  }
  EXPECT_GT(nodes, 0);
}

TEST(FinestDiamonds, HtSplitEdgesAreTheNodes) {
  for (int k = 1; k <= 4; ++k) ExpectSplitEdgesAreTheNodes<3>(k);
}
TEST(FinestDiamonds, HpSplitEdgesAreTheNodes) {
  for (int k = 1; k <= 3; ++k) ExpectSplitEdgesAreTheNodes<4>(k);
}

}  // namespace
}  // namespace simplexdb
