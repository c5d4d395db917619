// The same query over every way the shipping stores are read: the dense
// store mapped raw, with zstd blocks through a large or a small cache, or
// decoded in memory, and the lossless sparse store through a large or a
// small cache give the same mesh, vertex values and errors: the oracle's
// minimal mesh, the volume's values and its diamond errors rounded up
// (tests/query/brute_force_errors.h). (The sparse store at a tolerance:
// tests/query/sparse2_refine_test.cc.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "query/mesh_io.h"
#include "query/refine.h"
#include "query/source.h"
#include "tests/query/brute_force_errors.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// Uniform, isovalue and box queries at `percents` of the field range, each
// threshold moved to where no diamond error comes near it
// (BruteForceErrors::ClearThreshold).
template <int D>
std::vector<std::pair<std::string, Criteria<D>>> Queries(const testing::BruteForceErrors<D>& oracle, double lo,
                                                         double range, const std::vector<double>& percents) {
  const int k = oracle.domain_bits();
  std::vector<std::pair<std::string, Criteria<D>>> out;
  for (const double pct : percents) {
    CriteriaSpec s;
    s.error = {pct, true};
    out.emplace_back("uniform", *MakeCriteria<D>(s, k, range));
    CriteriaSpec iso = s;
    iso.iso = lo + range * 0.4 + 1.0 / 3;
    out.emplace_back("iso", *MakeCriteria<D>(iso, k, range));
    CriteriaSpec box = s;
    const double side = std::ldexp(1.0, k);
    box.box = std::vector<double>{0, side / 4, side / 3, side / 2, side, side * 0.6};
    out.emplace_back("box", *MakeCriteria<D>(box, k, range));
  }
  for (auto& [name, c] : out) c.threshold = oracle.ClearThreshold(c.threshold);
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

// `small` and `sparse_small`: cache budgets that hold a few of the store's
// blocks, bricks and boxes of finest errors, so that the caches evict all
// the time. Not smaller: below a walk's working set lookups decode or
// recompute the same blocks over and over (a dense cache of 16 KB made the
// HP's case 15 times slower, a sparse one of 64 KB the HT 33^3's more than
// 30 times).
template <int D>
void CheckStoresAgree(uint32_t side, const std::vector<double>& percents, size_t small, size_t sparse_small) {
  TempDir dir;
  const TestVolume volume = testing::Structured(D, side);
  const auto zstd = testing::BuildDense(volume, dir.path(), "z");
  const auto raw = testing::BuildDense(volume, dir.path(), "r", testing::ExactDenseOptions(Compression::kNone));
  DenseStore::Options in_memory;
  in_memory.in_memory = true;
  const auto resident = *DenseStore::Open(dir.path() + "/z.sdb", in_memory);
  DenseStore::Options small_cache;
  small_cache.cache_bytes = small;
  const auto starved = *DenseStore::Open(dir.path() + "/z.sdb", small_cache);
  const auto sparse = testing::BuildSparse(volume, dir.path(), "s");
  SparseStore::Options sparse_small_cache;
  sparse_small_cache.cache_bytes = sparse_small;
  const auto sparse_starved = *SparseStore::Open(dir.path() + "/s.lmdb", sparse_small_cache);
  DenseSource<D> z(*zstd), r(*raw), m(*resident), t(*starved);
  SparseSource<D> sp(*sparse), spt(*sparse_starved);
  const testing::BruteForceErrors<D> oracle(volume, zstd->header().domain_bits);
  const SourceInfo& info = z.info();
  for (const auto& [name, c] : Queries<D>(oracle, info.field_min, info.field_range(), percents)) {
    ASSERT_EQ(oracle.Ambiguous(c), 0u);
    const std::vector<uint64_t> truth = testing::Keys(testing::LeavesOf<D>(oracle.MinimalSplits(c)));
    for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kSaturated,
                        Algorithm::kLevelOrder, Algorithm::kIncremental}) {
      SCOPED_TRACE(name + " " + std::to_string(c.threshold) + " " + AlgorithmName(a));
      // The reference: in memory, against the oracle's minimal mesh (the
      // saturated baseline's is its own), diamond errors and field values.
      const Extracted<D> want = Run<D>(m, c, a);
      if (a != Algorithm::kSaturated) {
        EXPECT_EQ(testing::Keys(want.leaves), truth);
      }
      for (size_t i = 0; i < want.leaves.size(); ++i) {
        const double e = oracle.Diamond(want.leaves[i]);
        ASSERT_GE(want.errors[i], e) << want.leaves[i].ToString();
        ASSERT_LE(want.errors[i], oracle.UpperBound(e)) << want.leaves[i].ToString();
        const auto values = oracle.VertexValues(Vertices<D>(want.leaves[i]));
        ASSERT_TRUE(std::equal(values.begin(), values.end(), want.values.begin() + i * (D + 1)))
            << want.leaves[i].ToString();
      }
      const std::vector<std::pair<std::string, Extracted<D>>> others = {
          {"zstd", Run<D>(z, c, a)},           {"raw", Run<D>(r, c, a)},
          {"small cache", Run<D>(t, c, a)},    {"sparse", Run<D>(sp, c, a)},
          {"sparse, small cache", Run<D>(spt, c, a)}};
      for (const auto& [store, got] : others) {
        SCOPED_TRACE(store);
        EXPECT_EQ(testing::Keys(got.leaves), testing::Keys(want.leaves));
        EXPECT_EQ(got.errors, want.errors);
        EXPECT_EQ(got.values, want.values);
      }
    }
  }
  // The small caches did evict: they decoded (or computed) more than the
  // large ones.
  EXPECT_GT(starved->stats().blocks_decoded + starved->stats().boxes_computed,
            zstd->stats().blocks_decoded + zstd->stats().boxes_computed);
  EXPECT_GT(sparse_starved->stats().blocks_decoded, sparse->stats().blocks_decoded);
}

TEST(Stores, SameMeshOverEveryStoreHt) { CheckStoresAgree<3>(17, {0, 3, 20}, 8 << 10, 16 << 10); }
TEST(Stores, SameMeshOverEveryStoreHp) { CheckStoresAgree<4>(9, {3, 20}, 64 << 10, 32 << 10); }

// Out of core with a small cache the depth-first walk takes the last octave
// a region (grid brick) at a time (query/refine.h, DepthFirstByRegion): the
// same mesh, errors and values as the plain walk over the store in memory
// and out of core with a large cache, on stores of many regions, for
// uniform, box and isovalue queries.
template <int D>
void CheckRegionWalk(uint32_t side, size_t small) {
  TempDir dir;
  const TestVolume volume = testing::Structured(D, side);
  testing::BuildDense(volume, dir.path(), "z");
  DenseStore::Options in_memory;
  in_memory.in_memory = true;
  const auto resident = *DenseStore::Open(dir.path() + "/z.sdb", in_memory);
  DenseStore::Options small_cache, large_cache;
  small_cache.cache_bytes = small;
  large_cache.cache_bytes = size_t{1} << 30;
  const auto starved = *DenseStore::Open(dir.path() + "/z.sdb", small_cache);
  const auto roomy = *DenseStore::Open(dir.path() + "/z.sdb", large_cache);
  DenseSource<D> m(*resident), t(*starved), l(*roomy);
  // Regions with the small cache alone (DenseStore::RegionWalkPays).
  ASSERT_FALSE(m.regions());
  ASSERT_TRUE(t.regions());
  ASSERT_FALSE(l.regions());
  const int k = resident->header().domain_bits;
  const double range = m.info().field_range();
  std::set<uint64_t> regions;  // of the last octave's nodes split
  for (const double pct : {1.0, 4.0, 15.0}) {
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    CriteriaSpec iso = uniform;
    iso.iso = m.info().field_min + range * 0.4 + 1.0 / 3;
    CriteriaSpec box = uniform;
    const double s = std::ldexp(1.0, k);
    box.box = std::vector<double>{0, s / 4, s / 3, s / 2, s, s * 0.6};
    for (const auto& [name, spec] : {std::pair{"uniform", uniform}, {"iso", iso}, {"box", box}}) {
      SCOPED_TRACE(std::string(name) + " " + std::to_string(pct) + "%");
      const Criteria<D> c = *MakeCriteria<D>(spec, k, range);
      const Extracted<D> want = Run<D>(m, c, Algorithm::kDepthFirst);
      for (const SimplexCode<D> leaf : want.leaves) {
        if (leaf.level() > 0) regions.insert(t.Region(leaf.parent()));
      }
      for (auto* source : {&t, &l}) {
        const Extracted<D> got = Run<D>(*source, c, Algorithm::kDepthFirst);
        EXPECT_EQ(testing::Keys(got.leaves), testing::Keys(want.leaves));
        EXPECT_EQ(got.errors, want.errors);
        EXPECT_EQ(got.values, want.values);
      }
    }
  }
  // The walks crossed many regions: the nodes of the last octave they split
  // lie in many grid bricks.
  regions.erase(kAnyRegion);
  EXPECT_GE(regions.size(), D == 3 ? 64u : 12u);
}

TEST(Stores, RegionWalkGivesThePlainWalksMeshHt) { CheckRegionWalk<3>(65, 24 << 10); }
TEST(Stores, RegionWalkGivesThePlainWalksMeshHp) { CheckRegionWalk<4>(17, 256 << 10); }

// Per-block maxima from the dense store's index answer "does it exceed the
// threshold?" without reading a block, and change no mesh.
TEST(Stores, BlockMaximaSkipBlocksAndChangeNothing) {
  TempDir dir;
  const TestVolume volume = testing::Structured(3, 33);
  testing::BuildDense(volume, dir.path(), "z");
  DenseStore::Options in_memory;
  in_memory.in_memory = true;
  const auto resident = *DenseStore::Open(dir.path() + "/z.sdb", in_memory);
  DenseStore::Options no_cache;
  no_cache.cache_bytes = 0;
  const auto cold = *DenseStore::Open(dir.path() + "/z.sdb", no_cache);
  DenseSource<3> m(*resident), c(*cold);
  const double range = m.info().field_range();
  uint64_t skipped = 0;
  for (double pct : {0.0, 3.0, 20.0, 60.0}) {
    for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kSaturated,
                        Algorithm::kLevelOrder}) {
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
