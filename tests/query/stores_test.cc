// The same query over every layout of format 1's dense store: in-memory,
// mapped raw and zstd blocks give the same mesh, vertex values and errors.
// (The sparse store of format 2 against the dense one of format 2:
// tests/query/sparse2_refine_test.cc.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "query/conformity.h"
#include "query/mesh_io.h"
#include "query/refine.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

template <int D>
std::vector<std::pair<std::string, Criteria<D>>> Queries(int k, double lo, double range) {
  std::vector<std::pair<std::string, Criteria<D>>> out;
  for (double pct : {0.0, 3.0, 20.0}) {
    CriteriaSpec s;
    s.error = {pct, true};
    out.emplace_back("uniform", *MakeCriteria<D>(s, k, range));
    CriteriaSpec iso = s;
    iso.iso = lo + range * 0.4;
    out.emplace_back("iso", *MakeCriteria<D>(iso, k, range));
    CriteriaSpec box = s;
    const double side = std::ldexp(1.0, k);
    box.box = std::vector<double>{0, side / 4, side / 3, side / 2, side, side * 0.6};
    out.emplace_back("box", *MakeCriteria<D>(box, k, range));
  }
  return out;
}

template <int D>
struct Extracted {
  std::vector<SimplexCode<D>> leaves;
  // Per leaf, in order: its error and its vertex values.
  std::vector<double> errors;
  std::vector<double> values;
};

template <int D, class Source>
Extracted<D> Run(Source& source, const Criteria<D>& c, Algorithm a) {
  Refiner<D, Source> refiner(source, c);
  Mesh<D> mesh;
  QueryStats stats;
  EXPECT_TRUE(refiner.Run({a}, mesh, stats).ok());
  Extracted<D> out;
  out.leaves = mesh.Leaves();
  EXPECT_TRUE(ForEachLeaf<D>(mesh, source,
                             [&](SimplexCode<D> code, const SimplexVertices<D>&,
                                 const std::array<double, D + 1>& f) -> Status {
                               out.errors.push_back(*source.Error(code));
                               out.values.insert(out.values.end(), f.begin(), f.end());
                               return Status::OK();
                             })
                  .ok());
  return out;
}

// A field with structure at every scale and flat regions: a ramp plus a
// few bumps, clamped.
TestVolume Structured(int dimension, uint32_t side) {
  std::array<uint32_t, 4> dims = {side, side, side, dimension == 4 ? side : 1};
  TestVolume v = TestVolume::Random(dimension, dims, VoxelType::kU8, 5);
  std::mt19937_64 rng(17);
  for (size_t i = 0; i < v.values.size(); ++i) {
    size_t r = i;
    double x[4] = {0, 0, 0, 0};
    for (int a = 0; a < dimension; ++a) {
      x[a] = static_cast<double>(r % dims[a]) / (side - 1);
      r /= dims[a];
    }
    const double d = (x[0] - 0.3) * (x[0] - 0.3) + (x[1] - 0.6) * (x[1] - 0.6) + (x[2] - 0.5) * (x[2] - 0.5);
    double f = d < 0.08 ? 200 * (0.08 - d) / 0.08 : 0;  // a cone: flat outside
    if (x[0] > 0.75) f += static_cast<double>(rng() % 40);  // noise in one slab
    v.values[i] = std::round(std::min(255.0, f + 20));
  }
  return v;
}

template <int D>
void CheckStoresAgree(uint32_t side) {
  TempDir dir;
  const TestVolume volume = Structured(D, side);
  auto zstd = testing::BuildDense(volume, dir.path(), "z");
  auto raw = testing::BuildDense(volume, dir.path(), "r", /*raw=*/true);
  auto in_memory = testing::BuildDense(volume, dir.path(), "m", false, /*in_memory=*/true);
  DenseSource<D> z(*zstd), r(*raw), m(*in_memory);
  const SourceInfo& info = z.info();
  for (const auto& [name, c] : Queries<D>(info.domain_bits, info.field_min, info.field_range())) {
    for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kSaturated,
                        Algorithm::kLevelOrder}) {
      SCOPED_TRACE(name + " " + std::to_string(c.threshold) + " " + AlgorithmName(a));
      const Extracted<D> want = Run<D>(m, c, a);
      const std::vector<std::pair<std::string, Extracted<D>>> others = {
          {"zstd", Run<D>(z, c, a)}, {"raw", Run<D>(r, c, a)}};
      for (const auto& [store, got] : others) {
        SCOPED_TRACE(store);
        EXPECT_EQ(testing::Keys(got.leaves), testing::Keys(want.leaves));
        EXPECT_EQ(got.errors, want.errors);
        EXPECT_EQ(got.values, want.values);
      }
    }
  }
}

TEST(Stores, SameMeshOverEveryStoreHt) { CheckStoresAgree<3>(33); }
TEST(Stores, SameMeshOverEveryStoreHp) { CheckStoresAgree<4>(9); }

// Per-block maxima from the dense store's index answer "does it exceed the
// threshold?" without reading a block, and change no mesh.
TEST(Stores, BlockMaximaSkipBlocksAndChangeNothing) {
  TempDir dir;
  const TestVolume volume = Structured(3, 33);
  auto in_memory = testing::BuildDense(volume, dir.path(), "z", false, /*in_memory=*/true);
  DenseStore::Options no_cache;
  no_cache.cache_bytes = 0;
  auto cold = *DenseStore::Open(dir.path() + "/z.sdb", no_cache);
  DenseSource<3> m(*in_memory), c(*cold);
  const double range = m.info().field_range();
  uint64_t skipped = 0;
  for (double pct : {0.0, 3.0, 20.0, 60.0}) {
    for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kSaturated}) {
      SCOPED_TRACE(std::to_string(pct) + "% " + AlgorithmName(a));
      Criteria<3> crit;
      crit.threshold = range * pct / 100;
      Refiner<3, DenseSource<3>> rm(m, crit), rc(c, crit);
      Mesh<3> mm, mc;
      QueryStats sm, sc;
      ASSERT_TRUE(rm.Run({a}, mm, sm).ok());
      ASSERT_TRUE(rc.Run({a}, mc, sc).ok());
      EXPECT_EQ(testing::Keys(mc.Leaves()), testing::Keys(mm.Leaves()));
      skipped += sc.blocks_skipped;
    }
  }
  EXPECT_GT(skipped, 0u);
}

}  // namespace
}  // namespace simplexdb
