// Diamond errors (store format 2) against per-simplex errors: what a query
// extracts when a node's error is the largest error of its cluster, from
// the errors of a format-1 store and from a format-2 store made of it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <set>

#include "hierarchy/cluster.h"
#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_store.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::SplitKeys;
using testing::TempDir;
using testing::TestVolume;

// Errors of a format-1 store made diamond errors: a node reports the
// largest error of its cluster.
template <int D>
class DiamondOf {
 public:
  static constexpr bool kFieldComplete = true;
  explicit DiamondOf(const DenseStore& store) : inner_(store) {}
  const SourceInfo& info() const { return inner_.info(); }
  SourceStats stats() const { return inner_.stats(); }
  Result<double> Error(SimplexCode<D> code) {
    double e = 0;
    if (code.level() >= info().leaf_level()) return e;
    for (const auto m : Cluster(code)) {
      SDB_ASSIGN_OR_RETURN(const double x, inner_.Error(m));
      e = std::max(e, x);
    }
    return e;
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>& p) { return inner_.Field(p); }
  void Descend(SimplexCode<D>) {}

 private:
  DenseSource<D> inner_;
};

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

// For a uniform threshold, diamond errors extract exactly the mesh of
// per-simplex errors (itself the brute-force minimal mesh: refine_test.cc):
// a cluster splits when any member must. For every criterion, the mesh under
// diamond errors is the brute-force least fixed point under diamond errors.
template <int D>
void CheckDiamondMeshes(uint32_t side, uint64_t seed, bool smooth) {
  SCOPED_TRACE("side " + std::to_string(side) + ", seed " + std::to_string(seed) + (smooth ? ", smooth" : ", random"));
  TempDir dir;
  std::array<uint32_t, 4> dims = {side, side, side, D == 4 ? side : 1};
  const TestVolume volume = smooth ? Smooth(D, dims, seed) : TestVolume::Random(D, dims, VoxelType::kU8, seed);
  auto store = testing::BuildDense(volume, dir.path(), "v");
  const int k = store->header().domain_bits;
  DenseSource<D> simplex(*store);
  DiamondOf<D> diamond(*store);
  // The same diamond errors from a format-2 store made of this one.
  HzBuildOptions hz_options;
  hz_options.block_bits = 8;
  ASSERT_TRUE(ConvertToHz(*store, dir / "v2.sdb", hz_options).ok());
  const auto hz_store = *HzStore::Open(dir / "v2.sdb");
  HzSource<D> hz(*hz_store);
  const SourceInfo& info = simplex.info();
  const double range = info.field_range();
  for (double pct : {0.5, 2.0, 5.0, 10.0, 25.0}) {
    SCOPED_TRACE(std::to_string(pct) + "%");
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    const Criteria<D> c = *MakeCriteria<D>(uniform, k, range);
    Mesh<D> per_simplex, per_diamond;
    QueryStats stats;
    ASSERT_TRUE((Refiner<D, DenseSource<D>>(simplex, c).Run({Algorithm::kDepthFirst}, per_simplex, stats).ok()));
    ASSERT_TRUE((Refiner<D, DiamondOf<D>>(diamond, c).Run({Algorithm::kDepthFirst}, per_diamond, stats).ok()));
    EXPECT_EQ(SplitKeys(per_diamond), SplitKeys(per_simplex));
    Mesh<D> from_store;
    ASSERT_TRUE((Refiner<D, HzSource<D>>(hz, c).Run({Algorithm::kDepthFirst}, from_store, stats).ok()));
    EXPECT_EQ(SplitKeys(from_store), SplitKeys(per_simplex));
    if (pct != 2.0 && pct != 10.0) continue;  // the brute force below is slow

    std::vector<std::pair<std::string, CriteriaSpec>> others;
    CriteriaSpec box = uniform;
    const double s = std::ldexp(1.0, k);
    box.box = std::vector<double>{s * 0.2, s * 0.3, s * 0.1, s * 0.55, s * 0.6, s * 0.45};
    others.emplace_back("box", box);
    CriteriaSpec iso = uniform;
    iso.iso = info.field_min + range / 3;
    others.emplace_back("iso", iso);
    if constexpr (D == 4) {
      CriteriaSpec time = uniform;
      time.time = s * 0.375;
      others.emplace_back("time", time);
    }
    for (const auto& [name, spec] : others) {
      SCOPED_TRACE(name);
      const Criteria<D> criteria = *MakeCriteria<D>(spec, k, range);
      Mesh<D> df, pr;
      ASSERT_TRUE((Refiner<D, DiamondOf<D>>(diamond, criteria).Run({Algorithm::kDepthFirst}, df, stats).ok()));
      ASSERT_TRUE((Refiner<D, DiamondOf<D>>(diamond, criteria).Run({Algorithm::kPriority}, pr, stats).ok()));
      const auto fails = [&](SimplexCode<D> code) {
        const double e = *diamond.Error(code);
        if (!(e > criteria.threshold)) return false;
        const auto v = Vertices<D>(code);
        std::array<double, D + 1> values{};
        for (int i = 0; i <= D; ++i) values[i] = **simplex.Field(LatticeToGrid<D>(v[i], k));
        return Applies<D>(criteria, v, &values, e);
      };
      const std::set<uint64_t> truth = testing::BruteForceMinimalSplits<D>(info.leaf_level(), fails);
      EXPECT_EQ(SplitKeys(df), truth);
      EXPECT_EQ(SplitKeys(pr), truth);
      Mesh<D> store_df, store_pr, store_lo, lo;
      ASSERT_TRUE((Refiner<D, HzSource<D>>(hz, criteria).Run({Algorithm::kDepthFirst}, store_df, stats).ok()));
      ASSERT_TRUE((Refiner<D, HzSource<D>>(hz, criteria).Run({Algorithm::kPriority}, store_pr, stats).ok()));
      // Level order: in HZ order over the store, in key order otherwise.
      ASSERT_TRUE((Refiner<D, HzSource<D>>(hz, criteria).Run({Algorithm::kLevelOrder}, store_lo, stats).ok()));
      ASSERT_TRUE((Refiner<D, DiamondOf<D>>(diamond, criteria).Run({Algorithm::kLevelOrder}, lo, stats).ok()));
      EXPECT_EQ(SplitKeys(store_df), truth);
      EXPECT_EQ(SplitKeys(store_pr), truth);
      EXPECT_EQ(SplitKeys(store_lo), truth);
      EXPECT_EQ(SplitKeys(lo), truth);
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
