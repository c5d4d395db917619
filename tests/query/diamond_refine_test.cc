// Diamond errors against per-simplex errors, by brute force
// (tests/query/brute_force_errors.h): the stores that ship hold, per
// diamond, the largest per-simplex error of its cluster, rounded up; for a
// uniform threshold that extracts exactly the mesh of per-simplex errors,
// and for every criterion the mesh under diamond errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "hierarchy/cluster.h"
#include "query/refine.h"
#include "query/source.h"
#include "tests/query/brute_force_errors.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::BruteForceErrors;
using testing::RunSplits;
using testing::TempDir;
using testing::TestVolume;

// A smooth field with a few bumps: integer values, so errors are exact.
TestVolume Smooth(int dimension, std::array<uint32_t, 4> dims, uint64_t seed) {
  TestVolume v = TestVolume::Random(dimension, dims, VoxelType::kU8, seed);
  size_t i = 0;
  const double f = 0.3 + 0.1 * static_cast<double>(seed);
  for (uint32_t t = 0; t < dims[3]; ++t) {
    for (uint32_t z = 0; z < dims[2]; ++z) {
      for (uint32_t y = 0; y < dims[1]; ++y) {
        for (uint32_t x = 0; x < dims[0]; ++x, ++i) {
          v.values[i] = std::round(127 + 60 * std::sin(f * x + 0.2 * y) * std::cos(0.25 * z - f * t) +
                                   40 * std::sin(0.11 * x * y / (1.0 + z)));
        }
      }
    }
  }
  return v;
}

template <int D>
TestVolume MakeVolume(uint32_t side, uint64_t seed, bool smooth) {
  const std::array<uint32_t, 4> dims = {side, side, side, D == 4 ? side : 1};
  return smooth ? Smooth(D, dims, seed) : TestVolume::Random(D, dims, VoxelType::kU8, seed);
}

// The oracle itself: its per-simplex errors are those of another brute
// force (tests/storage/store_test_util.h: points inside by signed volumes)
// and its clusters those of hierarchy/cluster.h, on random nodes.
template <int D>
void CheckOracle(const TestVolume& volume, int k, const BruteForceErrors<D>& oracle) {
  std::mt19937_64 rng(7);
  for (int i = 0; i < 500; ++i) {
    const int level = static_cast<int>(rng() % static_cast<uint64_t>(oracle.leaf_level()));
    const SimplexCode<D> c = SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots),
                                                      rng() & ((uint64_t{1} << level) - 1), level);
    SCOPED_TRACE(c.ToString());
    ASSERT_EQ(oracle.Simplex(c), static_cast<double>(testing::BruteForceError<D>(c, k, volume)));
    std::set<uint64_t> mine, theirs;
    for (const auto m : oracle.Cluster(c)) mine.insert(m.key());
    for (const auto m : Cluster(c)) theirs.insert(m.key());
    ASSERT_EQ(mine, theirs);
    double e = 0;
    for (const auto m : oracle.Cluster(c)) e = std::max(e, oracle.Simplex(m));
    ASSERT_EQ(oracle.Diamond(c), e);
  }
}

// Every internal node's stored bound, over both stores: the oracle's
// diamond error, rounded up by at most float32's rounding.
template <int D, class Dense, class Sparse>
void CheckBounds(Dense& dense, Sparse& sparse, const BruteForceErrors<D>& oracle) {
  std::vector<SimplexCode<D>> stack;
  for (int t = 0; t < SimplexCode<D>::kRoots; ++t) stack.push_back(SimplexCode<D>::Root(t));
  uint64_t nonzero = 0;
  while (!stack.empty()) {
    const SimplexCode<D> c = stack.back();
    stack.pop_back();
    const double e = oracle.Diamond(c);
    const double d = *dense.Error(c);
    ASSERT_GE(d, e) << c.ToString();
    ASSERT_LE(d, oracle.UpperBound(e)) << c.ToString();
    ASSERT_EQ(*sparse.Error(c), d) << c.ToString();
    nonzero += e > 0;
    if (c.level() + 1 < oracle.leaf_level()) {
      stack.push_back(c.child(0));
      stack.push_back(c.child(1));
    }
  }
  EXPECT_GT(nonzero, 0u);
}

template <int D>
void CheckDiamondMeshes(uint32_t side, uint64_t seed, bool smooth) {
  SCOPED_TRACE("side " + std::to_string(side) + ", seed " + std::to_string(seed) + (smooth ? ", smooth" : ", random"));
  TempDir dir;
  const TestVolume volume = MakeVolume<D>(side, seed, smooth);
  const auto dense_store = testing::BuildDense(volume, dir.path(), "d");
  const auto sparse_store = testing::BuildSparse(volume, dir.path(), "s");
  DenseSource<D> dense(*dense_store);
  SparseSource<D> sparse(*sparse_store);
  const SourceInfo& info = dense.info();
  const int k = info.domain_bits;
  const double range = info.field_range();
  const BruteForceErrors<D> oracle(volume, k);
  ASSERT_NO_FATAL_FAILURE(CheckOracle<D>(volume, k, oracle));
  ASSERT_NO_FATAL_FAILURE(CheckBounds<D>(dense, sparse, oracle));

  for (double pct : {0.5, 2.0, 5.0, 10.0, 25.0}) {
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    Criteria<D> c = *MakeCriteria<D>(uniform, k, range);
    c.threshold = oracle.ClearThreshold(c.threshold);
    SCOPED_TRACE(std::to_string(pct) + "%, threshold " + std::to_string(c.threshold));
    ASSERT_EQ(oracle.Ambiguous(c), 0u);
    // A cluster splits when any member must: the same least fixed point.
    const std::vector<uint64_t> per_simplex =
        oracle.MinimalSplits([&](SimplexCode<D> n) { return oracle.Simplex(n) > c.threshold; });
    const std::vector<uint64_t> per_diamond = oracle.MinimalSplits(c);
    EXPECT_EQ(per_diamond, per_simplex);
    EXPECT_FALSE(per_simplex.empty());
    Mesh<D> mesh;
    QueryStats stats;
    EXPECT_EQ(RunSplits<D>(dense, c, Algorithm::kDepthFirst, mesh, stats), per_simplex);
    EXPECT_EQ(RunSplits<D>(sparse, c, Algorithm::kDepthFirst, mesh, stats), per_simplex);
    if (pct != 2.0 && pct != 10.0) continue;

    const auto others = testing::OtherCriteria<D>(uniform, k, info.field_min + range / 3 + 1.0 / 3);
    for (const auto& [name, spec] : others) {
      SCOPED_TRACE(name);
      Criteria<D> criteria = *MakeCriteria<D>(spec, k, range);
      criteria.threshold = c.threshold;
      ASSERT_EQ(oracle.Ambiguous(criteria), 0u);
      const std::vector<uint64_t> truth = oracle.MinimalSplits(criteria);
      // Level order: in HZ order over the dense store, in key order over
      // the sparse one.
      for (const Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kLevelOrder}) {
        SCOPED_TRACE(AlgorithmName(a));
        EXPECT_EQ(RunSplits<D>(dense, criteria, a, mesh, stats), truth);
        EXPECT_EQ(RunSplits<D>(sparse, criteria, a, mesh, stats), truth);
      }
    }
  }
}

TEST(DiamondRefine, Ht17UniformIsThePerSimplexMesh) {
  CheckDiamondMeshes<3>(17, 1, false);
  CheckDiamondMeshes<3>(17, 2, true);
}
TEST(DiamondRefine, Ht33UniformIsThePerSimplexMesh) { CheckDiamondMeshes<3>(33, 3, true); }
TEST(DiamondRefine, Hp9UniformIsThePerSimplexMesh) {
  CheckDiamondMeshes<4>(9, 4, false);
  CheckDiamondMeshes<4>(9, 5, true);
}

}  // namespace
}  // namespace simplexdb
