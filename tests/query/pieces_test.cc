// One mesh in pieces (query/pieces.h): the partition's ranges against the
// descendants enumerated by child(), and the pieces' union against the
// one-process depth-first mesh, cell for cell, for uniform, box and
// isovalue (and in the HP time) queries, 1 to 5 pieces; the union is
// conforming by the geometry (query/conformity.h), no cell is in two
// pieces, and the pieces are balanced.
#include <gtest/gtest.h>

#include <algorithm>
#include <barrier>
#include <cmath>
#include <thread>

#include "query/conformity.h"
#include "query/pieces.h"
#include "query/refine.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// Range() is the index range, at the partition's level, of the node's
// descendants there (or of its ancestor there), found by walking child().
template <int D>
void CheckRanges(int level) {
  using Code = SimplexCode<D>;
  std::vector<uint64_t> weights(uint64_t{Code::kRoots} << level, 0);
  const Partition<D> p = Partition<D>::Weighted(level, weights, 3);
  // The level's simplices in depth-first order: their index is their rank.
  std::vector<Code> at_level, stack;
  for (int t = Code::kRoots - 1; t >= 0; --t) stack.push_back(Code::Root(t));
  while (!stack.empty()) {
    const Code c = stack.back();
    stack.pop_back();
    if (c.level() == level) {
      at_level.push_back(c);
      continue;
    }
    stack.push_back(c.child(1));
    stack.push_back(c.child(0));
  }
  ASSERT_EQ(at_level.size(), weights.size());
  for (uint64_t i = 0; i < at_level.size(); ++i) {
    const Code c = at_level[i];
    SCOPED_TRACE(c.key());
    EXPECT_EQ(p.Range(c), std::make_pair(i, i));
    // Every ancestor's range holds i; every descendant's is i.
    for (int l = 0; l < level; ++l) {
      const auto [first, last] = p.Range(c.ancestor(l));
      EXPECT_LE(first, i);
      EXPECT_GE(last, i);
      EXPECT_EQ(last - first + 1, uint64_t{1} << (level - l));
    }
    EXPECT_EQ(p.Range(c.child(1).child(0)), std::make_pair(i, i));
  }
  // Pieces cover the level, in order, none empty; owners agree with ranges.
  uint64_t next = 0;
  for (int r = 0; r < p.pieces(); ++r) {
    const auto [begin, end] = p.Simplices(r);
    EXPECT_EQ(begin, next);
    EXPECT_LT(begin, end);
    next = end;
    for (uint64_t i = begin; i < end; ++i) {
      EXPECT_EQ(p.Owner(at_level[i]), r);
      EXPECT_TRUE(p.IsRelevant(at_level[i], r));
      EXPECT_FALSE(p.IsRelevant(at_level[i], (r + 1) % p.pieces()));
    }
  }
  EXPECT_EQ(next, at_level.size());
}

TEST(Partition, RangesAreTheDescendantsHt) { CheckRanges<3>(6); }
TEST(Partition, RangesAreTheDescendantsHp) { CheckRanges<4>(4); }

TEST(Partition, WeightsSplitEvenly) {
  // 96 simplices, all the weight in the last eight: four pieces, each
  // non-empty, the heavy ones apart.
  std::vector<uint64_t> w(96, 0);
  for (int i = 88; i < 96; ++i) w[static_cast<size_t>(i)] = 1000;
  const auto p = Partition<3>::Weighted(4, w, 4);
  ASSERT_EQ(p.pieces(), 4);
  EXPECT_EQ(p.Simplices(0).first, 0u);
  EXPECT_EQ(p.Simplices(3).second, 96u);
  for (int r = 0; r < 4; ++r) EXPECT_LT(p.Simplices(r).first, p.Simplices(r).second);
  // The last three pieces share the eight heavy simplices (2 or 3 each).
  EXPECT_GE(p.Simplices(1).second, 88u);
  EXPECT_LE(p.Simplices(3).second - p.Simplices(3).first, 3u);
  // More pieces than simplices with weight: still none empty.
  const auto many = Partition<3>::Weighted(4, w, 90);
  for (int r = 0; r < 90; ++r) EXPECT_LT(many.Simplices(r).first, many.Simplices(r).second);
}

// Each piece on its own thread with its own source, exchanging through
// mailboxes at a barrier per round (the shape of the MPI exchange).
template <int D>
std::vector<std::vector<SimplexCode<D>>> ThreadedPieces(const DenseStore& store, const Criteria<D>& c,
                                                         const Partition<D>& plan) {
  using Code = SimplexCode<D>;
  const size_t n = static_cast<size_t>(plan.pieces());
  std::vector<std::vector<std::vector<Code>>> mail(n, std::vector<std::vector<Code>>(n));  // [to][from]
  std::vector<uint64_t> sent(n, 0);
  std::barrier sync(static_cast<std::ptrdiff_t>(n));
  std::vector<std::vector<Code>> out(n);
  std::vector<std::thread> threads;
  for (size_t r = 0; r < n; ++r) {
    threads.emplace_back([&, r] {
      DenseSource<D> source(store);
      PieceWalk<D, DenseSource<D>> walk(source, c, plan, static_cast<int>(r));
      const auto exchange = [&](std::vector<std::vector<Code>>& outbox, bool failed,
                                bool* quiet) -> Result<std::vector<Code>> {
        EXPECT_FALSE(failed);
        sent[r] = 0;
        for (size_t s = 0; s < n; ++s) {
          sent[r] += outbox[s].size();
          mail[s][r] = std::move(outbox[s]);
        }
        sync.arrive_and_wait();
        std::vector<Code> inbox;
        uint64_t total = 0;
        for (size_t s = 0; s < n; ++s) {
          inbox.insert(inbox.end(), mail[r][s].begin(), mail[r][s].end());
          total += sent[s];
        }
        sync.arrive_and_wait();  // all read before the next round writes
        *quiet = total == 0;
        return inbox;
      };
      const Result<PiecesStats> stats = WalkPiece<D>(walk, static_cast<int>(n), exchange);
      EXPECT_TRUE(stats.ok());
      out[r] = walk.Leaves();
    });
  }
  for (auto& t : threads) t.join();
  return out;
}

template <int D>
void CheckPiecesMakeTheMesh(uint32_t side, size_t cache) {
  using Code = SimplexCode<D>;
  TempDir dir;
  testing::BuildDense(testing::Structured(D, side), dir.path(), "z");  // uneven work
  DenseStore::Options options;
  options.cache_bytes = cache;
  const auto store = *DenseStore::Open(dir.path() + "/z.sdb", options);
  DenseSource<D> source(*store);
  const int k = store->header().domain_bits;
  const double range = source.info().field_range();
  for (const double pct : {1.0, 5.0}) {
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    auto specs = testing::OtherCriteria<D>(uniform, k, source.info().field_min + range * 0.4 + 1.0 / 3);
    specs.emplace(specs.begin(), "uniform", uniform);
    for (const auto& [name, spec] : specs) {
      SCOPED_TRACE(name + " " + std::to_string(pct) + "%");
      const Criteria<D> c = *MakeCriteria<D>(spec, k, range);
      Refiner<D, DenseSource<D>> one(source, c);
      Mesh<D> mesh;
      QueryStats stats;
      ASSERT_TRUE(one.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
      const std::vector<Code> want = mesh.Leaves();
      for (int n = 1; n <= 5; ++n) {
        SCOPED_TRACE(std::to_string(n) + " pieces");
        const Result<Partition<D>> plan = PlanPieces<D>(source, c, n);
        ASSERT_TRUE(plan.ok()) << plan.status().ToString();
        ASSERT_EQ(plan->pieces(), n);
        std::vector<DenseSource<D>*> sources(static_cast<size_t>(n), &source);
        std::vector<std::unique_ptr<PieceWalk<D, DenseSource<D>>>> walks;
        const Result<PiecesStats> rounds =
            ExtractPieces<D, DenseSource<D>>(std::span<DenseSource<D>* const>(sources), c, *plan, walks);
        ASSERT_TRUE(rounds.ok()) << rounds.status().ToString();
        std::vector<std::vector<Code>> pieces;
        for (const auto& w : walks) pieces.push_back(w->Leaves());
        // The same pieces from one thread per piece, trading splits as MPI
        // ranks do (WalkPiece).
        if (n > 1) {
          EXPECT_EQ(ThreadedPieces<D>(*store, c, *plan), pieces);
        }
        std::vector<Code> all;
        size_t largest = 0;
        for (int r = 0; r < n; ++r) {
          const auto& piece = pieces[static_cast<size_t>(r)];
          EXPECT_FALSE(piece.empty());
          largest = std::max(largest, piece.size());
          for (const Code leaf : piece) EXPECT_EQ(plan->Owner(leaf), r);
          all.insert(all.end(), piece.begin(), piece.end());
        }
        // Each piece is in depth-first order and pieces follow each other:
        // their concatenation is the one-process mesh, cell for cell.
        EXPECT_EQ(testing::Keys(all), testing::Keys(want));
        const ConformityReport report = CheckConformity<D>(all);
        EXPECT_TRUE(report.ok) << report.problem;
        if (n > 1) {
          EXPECT_GE(rounds->rounds, 2);  // one that sends, one that hears
        }
        // Balanced where the mesh has room for it.
        if (want.size() >= 2000 * static_cast<size_t>(n)) {
          EXPECT_LE(static_cast<double>(largest), 1.5 * static_cast<double>(want.size()) / n);
        }
      }
    }
  }
}

TEST(Pieces, UnionIsTheOneProcessMeshHt) { CheckPiecesMakeTheMesh<3>(33, size_t{64} << 20); }
TEST(Pieces, UnionIsTheOneProcessMeshHp) { CheckPiecesMakeTheMesh<4>(9, size_t{64} << 20); }
// Out of core with a small cache (the region walk does not run in pieces).
TEST(Pieces, UnionIsTheOneProcessMeshSmallCacheHt) { CheckPiecesMakeTheMesh<3>(33, size_t{16} << 10); }

}  // namespace
}  // namespace simplexdb
