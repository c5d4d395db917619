// Selective refinement against independent truth: the minimal conforming
// mesh by brute force (geometric clusters, naive fixed point), errors by
// brute force over the grid, conformity from geometry, and the seed's
// full-resolution counts.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "query/conformity.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/refine.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::BruteForceMinimalSplits;
using testing::SplitKeys;
using testing::TempDir;
using testing::TestVolume;

template <int D>
struct Fixture {
  TestVolume volume;
  int k;
  std::unique_ptr<DenseStore> store;
};

template <int D>
Fixture<D> MakeFixture(const TempDir& dir, uint32_t side, uint64_t seed) {
  std::array<uint32_t, 4> dims = {side, side, side, D == 4 ? side : 1};
  Fixture<D> s{TestVolume::Random(D, dims, VoxelType::kU8, seed), 0, nullptr};
  s.store = testing::BuildDense(s.volume, dir.path(), "v" + std::to_string(seed));
  s.k = s.store->header().domain_bits;
  return s;
}

// The criteria cases of the tests: uniform, box, isovalue (and the HP's
// time slice), at thresholds from 0 to half the field range.
template <int D>
std::vector<std::pair<std::string, Criteria<D>>> CriteriaCases(int k, double range, double mid_value) {
  std::vector<std::pair<std::string, Criteria<D>>> out;
  for (double pct : {0.0, 10.0, 25.0, 50.0}) {
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    out.emplace_back("uniform " + std::to_string(pct) + "%", *MakeCriteria<D>(uniform, k, range));
    CriteriaSpec box = uniform;
    const double side = std::ldexp(1.0, k);
    box.box = std::vector<double>{side * 0.2, side * 0.3, side * 0.1, side * 0.55, side * 0.6, side * 0.45};
    out.emplace_back("box " + std::to_string(pct) + "%", *MakeCriteria<D>(box, k, range));
    CriteriaSpec iso = uniform;
    iso.iso = mid_value;
    out.emplace_back("iso " + std::to_string(pct) + "%", *MakeCriteria<D>(iso, k, range));
    if constexpr (D == 4) {
      CriteriaSpec time = uniform;
      time.time = side * 0.375;
      out.emplace_back("time " + std::to_string(pct) + "%", *MakeCriteria<D>(time, k, range));
    }
  }
  return out;
}

template <int D>
void CheckAgainstBruteForce(uint32_t side, uint64_t seed, bool check_errors) {
  TempDir dir;
  Fixture<D> s = MakeFixture<D>(dir, side, seed);
  DenseSource<D> source(*s.store);
  const SourceInfo& info = source.info();
  for (const auto& test_case : CriteriaCases<D>(s.k, info.field_range(), info.field_min + info.field_range() / 3)) {
    // References, not a structured binding: the lambda below captures
    // criteria, which clang before 16 does not allow for a binding.
    const std::string& name = test_case.first;
    const Criteria<D>& criteria = test_case.second;
    SCOPED_TRACE(name);
    Refiner<D, DenseSource<D>> refiner(source, criteria);
    Mesh<D> df;
    QueryStats stats;
    ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, df, stats).ok());
    EXPECT_EQ(stats.simplices, df.leaf_count());

    // The same mesh as the brute-force least fixed point.
    DenseSource<D> oracle(*s.store);
    const auto fails = [&](SimplexCode<D> c) {
      const double e = *oracle.Error(c);
      if (!(e > criteria.threshold)) return false;
      const auto v = Vertices<D>(c);
      std::array<double, D + 1> values{};
      for (int i = 0; i <= D; ++i) values[i] = **oracle.Field(LatticeToGrid<D>(v[i], s.k));
      return Applies<D>(criteria, v, &values, e);
    };
    const std::set<uint64_t> truth = BruteForceMinimalSplits<D>(info.leaf_level(), fails);
    EXPECT_EQ(SplitKeys(df), truth);

    // Conforming, by geometry.
    const auto leaves = df.Leaves();
    const ConformityReport report = CheckConformity<D>(leaves);
    EXPECT_TRUE(report.ok) << report.problem;

    // Every leaf held to the threshold meets it by the brute-force error.
    if (check_errors) {
      for (const SimplexCode<D> c : leaves) {
        if (c.level() >= info.leaf_level()) continue;
        const auto v = Vertices<D>(c);
        std::array<double, D + 1> values{};
        for (int i = 0; i <= D; ++i) values[i] = **oracle.Field(LatticeToGrid<D>(v[i], s.k));
        const double e = *oracle.Error(c);
        if (!Applies<D>(criteria, v, &values, e)) continue;
        const long double truth_error = testing::BruteForceError<D>(c, s.k, s.volume);
        ASSERT_LE(truth_error, criteria.threshold) << c.ToString();
      }
    }

    // Priority to completion, incremental from the roots and level order:
    // the same mesh.
    Mesh<D> pr, inc;
    QueryStats ps, is;
    ASSERT_TRUE(refiner.Run({Algorithm::kPriority}, pr, ps).ok());
    EXPECT_EQ(SplitKeys(pr), truth);
    EXPECT_FALSE(ps.interrupted);
    ASSERT_TRUE(refiner.Run({Algorithm::kIncremental}, inc, is).ok());
    EXPECT_EQ(SplitKeys(inc), truth);
    Mesh<D> lo;
    QueryStats ls;
    ASSERT_TRUE(refiner.Run({Algorithm::kLevelOrder}, lo, ls).ok());
    EXPECT_EQ(SplitKeys(lo), truth);
    EXPECT_EQ(ls.splits, stats.splits);

    // Saturation: conforming, and never fewer simplices (a superset).
    Mesh<D> sat;
    QueryStats ss;
    ASSERT_TRUE(refiner.Run({Algorithm::kSaturated}, sat, ss).ok());
    const std::set<uint64_t> sat_keys = SplitKeys(sat);
    EXPECT_TRUE(std::includes(sat_keys.begin(), sat_keys.end(), truth.begin(), truth.end()));
    EXPECT_TRUE(CheckConformity<D>(sat.Leaves()).ok);
  }
}

TEST(Refine, Ht17MatchesBruteForce) { CheckAgainstBruteForce<3>(17, 1, true); }
TEST(Refine, Ht33MatchesBruteForce) { CheckAgainstBruteForce<3>(33, 2, false); }
TEST(Refine, Hp9MatchesBruteForce) { CheckAgainstBruteForce<4>(9, 3, true); }

// SEED-ERRATA item 11: the seed's CHECK_SPLIT leaves a leaf above the bound
// here (a 17^3 field at 25 %); re-checking every new leaf does not.
TEST(Refine, EveryNewLeafIsChecked) {
  TempDir dir;
  Fixture<3> s = MakeFixture<3>(dir, 17, 11);
  DenseSource<3> source(*s.store);
  CriteriaSpec spec;
  spec.error = {25, true};
  const Criteria<3> c = *MakeCriteria<3>(spec, s.k, source.info().field_range());
  Refiner<3, DenseSource<3>> refiner(source, c);
  Mesh<3> mesh;
  QueryStats stats;
  ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
  for (const auto leaf : mesh.Leaves()) EXPECT_LE(*source.Error(leaf), c.threshold) << leaf.ToString();
}

// The seed's full-resolution counts (3.7, 4.7).
template <int D>
uint64_t FullResolutionCount(int k) {
  testing::FullSource<D> source(k);
  Criteria<D> c;
  c.threshold = 0.5;
  Refiner<D, testing::FullSource<D>> refiner(source, c);
  Mesh<D> mesh;
  QueryStats stats;
  EXPECT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
  return mesh.leaf_count();
}

TEST(Refine, FullResolutionCounts) {
  EXPECT_EQ(FullResolutionCount<3>(6), 1'572'864u);    // 65^3
  EXPECT_EQ(FullResolutionCount<3>(7), 12'582'912u);   // 129^3
  EXPECT_EQ(FullResolutionCount<4>(5), 25'165'824u);   // 33^4
}

TEST(Refine, FullResolutionIsConforming) {
  testing::FullSource<3> source(5);
  Criteria<3> c;
  c.threshold = 0.5;
  Refiner<3, testing::FullSource<3>> refiner(source, c);
  Mesh<3> mesh;
  QueryStats stats;
  ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
  const ConformityReport r = CheckConformity<3>(mesh.Leaves());
  EXPECT_TRUE(r.ok) << r.problem;
  EXPECT_EQ(r.simplices, 6u << 15);
  EXPECT_EQ(stats.splits, (6u << 15) - 6);
}

// Incremental refinement from meshes extracted at other thresholds and
// criteria: the result conforms, meets the new criteria, and holds the
// minimal mesh (it may keep more: 3.6.3).
template <int D>
void CheckIncremental(uint32_t side, uint64_t seed) {
  TempDir dir;
  Fixture<D> s = MakeFixture<D>(dir, side, seed);
  DenseSource<D> source(*s.store);
  const auto cases = CriteriaCases<D>(s.k, source.info().field_range(), source.info().field_min + 40);
  for (size_t from = 0; from < cases.size(); from += 2) {
    for (size_t to = 1; to < cases.size(); to += 3) {
      SCOPED_TRACE(cases[from].first + " -> " + cases[to].first);
      Mesh<D> mesh;
      QueryStats stats;
      Refiner<D, DenseSource<D>> first(source, cases[from].second);
      ASSERT_TRUE(first.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
      Refiner<D, DenseSource<D>> second(source, cases[to].second);
      ASSERT_TRUE(second.Run({Algorithm::kIncremental}, mesh, stats).ok());
      Mesh<D> minimal;
      ASSERT_TRUE(second.Run({Algorithm::kDepthFirst}, minimal, stats).ok());
      const auto leaves = mesh.Leaves();
      EXPECT_TRUE(CheckConformity<D>(leaves).ok);
      for (const auto leaf : leaves) ASSERT_FALSE(*second.Fails(leaf)) << leaf.ToString();
      const auto have = SplitKeys(mesh), need = SplitKeys(minimal);
      EXPECT_TRUE(std::includes(have.begin(), have.end(), need.begin(), need.end()));
    }
  }
}

TEST(Refine, IncrementalHt) { CheckIncremental<3>(17, 21); }
TEST(Refine, IncrementalHp) { CheckIncremental<4>(9, 22); }

// Priority under a budget: the best conforming mesh within it, largest
// errors split first.
TEST(Refine, PriorityStopsAtTheBudget) {
  TempDir dir;
  Fixture<3> s = MakeFixture<3>(dir, 33, 5);
  DenseSource<3> source(*s.store);
  Criteria<3> c;
  c.threshold = 0;
  Refiner<3, DenseSource<3>> refiner(source, c);
  std::set<uint64_t> previous;
  for (uint64_t budget : {6u, 50u, 1000u, 20000u}) {
    SCOPED_TRACE(budget);
    Mesh<3> mesh;
    QueryStats stats;
    RefineOptions options{Algorithm::kPriority};
    options.max_simplices = budget;
    ASSERT_TRUE(refiner.Run(options, mesh, stats).ok());
    EXPECT_LE(mesh.leaf_count(), budget);
    EXPECT_TRUE(stats.interrupted);
    EXPECT_TRUE(CheckConformity<3>(mesh.Leaves()).ok);
    // The same order of splits each time: a larger budget goes further.
    const std::set<uint64_t> keys = SplitKeys(mesh);
    EXPECT_TRUE(std::includes(keys.begin(), keys.end(), previous.begin(), previous.end()));
    previous = keys;
  }
}

}  // namespace
}  // namespace simplexdb
