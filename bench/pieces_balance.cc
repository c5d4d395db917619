// A mesh in pieces (query/pieces.h) on a real store: for 1 to N pieces, the
// rounds of exchange, the splits sent between pieces, the largest piece
// against the mean (issue 42's balance target: at most 1.5x), and the time
// of all pieces run one after the other in this process against the
// one-process walk. The union is checked against the one-process mesh.
//
//   pieces_balance STORE.sdb ERROR_PERCENT MAX_PIECES [CACHE_MB]
//
// Prints one JSON object per piece count. CACHE_MB 0 (the default) opens
// the store in memory.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "query/pieces.h"
#include "query/refine.h"
#include "query/source.h"

namespace simplexdb {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

template <int D>
int Run(const DenseStore& store, double percent, int max_pieces) {
  using Code = SimplexCode<D>;
  DenseSource<D> source(store);
  CriteriaSpec spec;
  spec.error = {percent, true};
  const Result<Criteria<D>> c = MakeCriteria<D>(spec, store.header().domain_bits, source.info().field_range());
  if (!c.ok()) {
    std::fprintf(stderr, "%s\n", c.status().ToString().c_str());
    return 2;
  }
  auto start = std::chrono::steady_clock::now();
  Refiner<D, DenseSource<D>> one(source, *c);
  Mesh<D> mesh;
  QueryStats stats;
  if (const Status s = one.Run({Algorithm::kDepthFirst}, mesh, stats); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.ToString().c_str());
    return 1;
  }
  const double one_seconds = Seconds(start);
  const std::vector<Code> want = mesh.Leaves();
  for (int n = 1; n <= max_pieces; ++n) {
    start = std::chrono::steady_clock::now();
    const Result<Partition<D>> plan = PlanPieces<D>(source, *c, n);
    const double plan_seconds = Seconds(start);
    if (!plan.ok()) {
      std::fprintf(stderr, "%s\n", plan.status().ToString().c_str());
      return 1;
    }
    std::vector<DenseSource<D>*> sources(static_cast<size_t>(n), &source);
    std::vector<std::unique_ptr<PieceWalk<D, DenseSource<D>>>> walks;
    start = std::chrono::steady_clock::now();
    const Result<PiecesStats> run =
        ExtractPieces<D, DenseSource<D>>(std::span<DenseSource<D>* const>(sources), *c, *plan, walks);
    const double all_seconds = Seconds(start);
    if (!run.ok()) {
      std::fprintf(stderr, "%s\n", run.status().ToString().c_str());
      return 1;
    }
    std::vector<Code> all;
    uint64_t largest = 0;
    for (const auto& walk : walks) {
      const std::vector<Code> piece = walk->Leaves();
      largest = std::max<uint64_t>(largest, piece.size());
      all.insert(all.end(), piece.begin(), piece.end());
    }
    nlohmann::json j;
    j["pieces"] = n;
    j["level"] = plan->level();
    j["simplices"] = want.size();
    j["same_mesh"] = all == want;
    j["rounds"] = run->rounds;
    j["splits_sent"] = run->splits_sent;
    j["largest_over_mean"] = static_cast<double>(largest) * n / static_cast<double>(want.size());
    j["plan_seconds"] = plan_seconds;
    j["one_process_seconds"] = one_seconds;
    j["all_pieces_seconds"] = all_seconds;
    j["slowest_piece_seconds"] = *std::max_element(run->piece_seconds.begin(), run->piece_seconds.end());
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  using namespace simplexdb;
  if (argc < 4) {
    std::fprintf(stderr, "usage: pieces_balance STORE.sdb ERROR_PERCENT MAX_PIECES [CACHE_MB]\n");
    return 2;
  }
  DenseStore::Options options;
  const double cache_mb = argc > 4 ? std::atof(argv[4]) : 0;
  if (cache_mb > 0) {
    options.cache_bytes = static_cast<size_t>(cache_mb * 1048576);
  } else {
    options.in_memory = true;
  }
  Result<std::unique_ptr<DenseStore>> store = DenseStore::Open(argv[1], options);
  if (!store.ok()) {
    std::fprintf(stderr, "%s\n", store.status().ToString().c_str());
    return 1;
  }
  const double percent = std::atof(argv[2]);
  const int max_pieces = std::atoi(argv[3]);
  return (*store)->dimension() == 3 ? Run<3>(**store, percent, max_pieces) : Run<4>(**store, percent, max_pieces);
}
