// HT micro-benchmarks: ns per face-neighbor call, Fig. 38 scan against the
// constant-time algorithm (stateless, and with a cursor that keeps the
// neighbor mask), on random codes and on worst-case codes whose scan climbs
// to the top group or the root; vertex and cluster computation.
//
//   build/release/bench/ht_bench --benchmark_filter=HtNeighbor
//
// Each benchmark iteration is one call; codes cycle through a fixed,
// pre-generated set of 4096 (fixed seeds), so the figures compare algorithms
// on identical inputs in one run.
#include <benchmark/benchmark.h>

#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "hierarchy/ht_neighbors.h"
#include "hierarchy/level_scan.h"

namespace simplexdb {
namespace {

constexpr size_t kCodes = 4096;  // a power of two: the index wraps with a mask

TetCode RandomCode(std::mt19937_64& rng, int level) {
  return TetCode::FromPath(static_cast<int>(rng() % 6), level ? rng() >> (64 - level) : 0,
                           level);
}

// How far up the scan for `type` climbs from `code`: the number of levels
// between the code and the highest bit where it differs from its neighbor
// (the whole level when the neighbor is under another root or absent).
int ClimbLength(TetCode code, int type) {
  const TetCode n = ht::NeighborScan(code, type);
  if (n.is_none() || n.top() != code.top()) return code.level();
  const uint64_t diff = n.path() ^ code.path();
  return 63 - __builtin_clzll(diff);  // bit i is level - i
}

// Codes whose scan for `type` climbs into the top group or to the root, and
// that have a neighbor (a valid answer, not the boundary). Random groups
// drawn from the patterns in which the scan continues, then filtered.
std::vector<TetCode> WorstCaseCodes(int level, int type) {
  std::mt19937_64 rng(1000 + level * 10 + type);
  std::vector<TetCode> out;
  static constexpr uint8_t kContinue[] = {0b011, 0b001, 0b010, 0b110, 0b100, 0b000};
  const int need = level <= 3 ? 0 : level - 3;
  while (out.size() < kCodes) {
    uint64_t path = 0;
    for (int l = 0; l < level; l += 3) path = path << 3 | kContinue[rng() % 6];
    path >>= 3 * ((level + 2) / 3) - level;
    const TetCode c = TetCode::FromPath(static_cast<int>(rng() % 6), path, level);
    if (type == 1 || (ClimbLength(c, type) >= need && !ht::NeighborScan(c, type).is_none())) {
      out.push_back(c);
    }
  }
  return out;
}

std::vector<TetCode> RandomCodes(int level, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<TetCode> out(kCodes);
  for (TetCode& c : out) c = RandomCode(rng, level);
  return out;
}

template <class Fn>
void RunOverCodes(benchmark::State& state, const std::vector<TetCode>& codes, Fn fn) {
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(fn(codes[i]));
    i = (i + 1) & (kCodes - 1);
  }
}

// Generates a benchmark's codes the first time it runs, so filtered-out
// benchmarks cost nothing (worst-case codes take a search to find).
class LazyCodes {
 public:
  LazyCodes(int level, int type, bool worst) : level_(level), type_(type), worst_(worst) {}
  const std::vector<TetCode>& get() {
    std::call_once(once_, [this] {
      codes_ = worst_ ? WorstCaseCodes(level_, type_) : RandomCodes(level_, 7 * level_ + type_);
      for (const TetCode c : codes_) cursors_.emplace_back(c);
    });
    return codes_;
  }
  const std::vector<ht::TetCursor>& cursors() {
    get();
    return cursors_;
  }

 private:
  int level_, type_;
  bool worst_;
  std::once_flag once_;
  std::vector<TetCode> codes_;
  std::vector<ht::TetCursor> cursors_;
};

void RegisterNeighborBenchmarks() {
  for (int level : {6, 30, TetCode::kMaxLevel}) {
    for (int type = 1; type <= 4; ++type) {
      for (const bool worst : {false, true}) {
        const auto codes = std::make_shared<LazyCodes>(level, type, worst);
        const std::string suffix = "/type" + std::to_string(type) + (worst ? "/worst" : "/random") +
                                   "/depth:" + std::to_string(level);
        benchmark::RegisterBenchmark(("HtNeighbor/scan" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       RunOverCodes(s, codes->get(), [type](TetCode c) {
                                         return ht::NeighborScan(c, type);
                                       });
                                     });
        benchmark::RegisterBenchmark(("HtNeighbor/constant" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       RunOverCodes(s, codes->get(), [type](TetCode c) {
                                         return ht::Neighbor(c, type);
                                       });
                                     });
        // The cursor's mask is already up to date: the cost of one step in a
        // walk (cluster, refinement), mask update included. Cursors step in
        // place; crossing the same face again steps back, so the set
        // alternates between the codes and their neighbors (as hard).
        benchmark::RegisterBenchmark(("HtNeighbor/cursor" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       std::vector<ht::TetCursor> cursors = codes->cursors();
                                       size_t i = 0;
                                       for (auto _ : s) {
                                         benchmark::DoNotOptimize(cursors[i].Step(type));
                                         i = (i + 1) & (kCodes - 1);
                                       }
                                       benchmark::DoNotOptimize(cursors.data());
                                     });
        if (worst) {
          benchmark::RegisterBenchmark(("HtNeighbor/level-scan" + suffix).c_str(),
                                       [codes, type](benchmark::State& s) {
                                         RunOverCodes(s, codes->get(), [type](TetCode c) {
                                           return NeighborByLevelScan<3>(c, type);
                                         });
                                       });
        }
      }
    }
  }
}

void BM_Vertices(benchmark::State& state) {
  const auto codes = RandomCodes(static_cast<int>(state.range(0)), 5);
  RunOverCodes(state, codes, [](TetCode c) { return Vertices(c); });
}
BENCHMARK(BM_Vertices)->ArgName("depth")->Arg(6)->Arg(30)->Arg(TetCode::kMaxLevel);

// Clusters of each shape: depth 30 (1/8 pyramids, 6 members), 31 (1/2, 4),
// 32 (1/4, 8); interior codes mostly, at random.
void BM_Cluster(benchmark::State& state) {
  const auto codes = RandomCodes(static_cast<int>(state.range(0)), 6);
  size_t members = 0;
  size_t i = 0;
  for (auto _ : state) {
    const TetCluster c = Cluster(codes[i]);
    members += c.size();
    benchmark::DoNotOptimize(c);
    i = (i + 1) & (kCodes - 1);
  }
  state.counters["members"] =
      benchmark::Counter(static_cast<double>(members), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_Cluster)->ArgName("depth")->Arg(30)->Arg(31)->Arg(32)->Arg(53)->Arg(54)->Arg(55);

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  simplexdb::RegisterNeighborBenchmarks();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
