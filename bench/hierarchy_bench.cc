// Hierarchy micro-benchmarks, HT (D = 3) and HP (D = 4): ns per face-neighbor
// call, the grouped scan (Figs. 38, 53) against the constant-time algorithm
// (stateless, and with a cursor that keeps the neighbor mask), on random
// codes and on worst-case codes whose scan climbs into the top group or to
// the root; random walks of dependent steps; vertex and cluster computation.
//
//   build/release/bench/hierarchy_bench --benchmark_filter='HtNeighbor|HpNeighbor'
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
#include "hierarchy/neighbors.h"
#include "hierarchy/level_scan.h"

namespace simplexdb {
namespace {

constexpr size_t kCodes = 4096;  // a power of two: the index wraps with a mask

// The per-hierarchy pieces.
template <int D>
struct Api;
template <>
struct Api<3> {
  static constexpr const char* kName = "Ht";
  static const GroupStepTable<3>& Table() { return ht::kGroupSteps; }
};
template <>
struct Api<4> {
  static constexpr const char* kName = "Hp";
  static const GroupStepTable<4>& Table() { return hp::kGroupSteps; }
};

template <int D>
SimplexCode<D> RandomCode(std::mt19937_64& rng, int level) {
  return SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots),
                                  level ? rng() >> (64 - level) : 0, level);
}

// How far up the scan for `type` climbs from `code`: the levels between the
// code and the highest bit where it differs from its neighbor (the whole
// level when the neighbor is under another root or absent).
template <int D>
int ClimbLength(SimplexCode<D> code, int type) {
  const SimplexCode<D> n = NeighborScan<D>(code, type);
  if (n.is_none() || n.top() != code.top()) return code.level();
  return 63 - __builtin_clzll(n.path() ^ code.path());  // bit i is level - i
}

// Groups in which most face types continue (the scan climbs through them),
// read off the figure.
template <int D>
std::vector<uint64_t> ContinuingGroups() {
  std::vector<uint64_t> out;
  for (int bits = 0; bits < (1 << D); ++bits) {
    int continuing = 0;
    for (int k = 2; k <= D + 1; ++k) continuing += !Api<D>::Table()[bits][k - 1].stop;
    if (continuing >= D - 1) out.push_back(static_cast<uint64_t>(bits));
  }
  return out;
}

// Codes whose scan for `type` climbs into the top group or to the root and
// that have a neighbor (a valid answer, not the boundary).
template <int D>
std::vector<SimplexCode<D>> WorstCaseCodes(int level, int type) {
  std::mt19937_64 rng(1000 + level * 10 + type);
  const std::vector<uint64_t> groups = ContinuingGroups<D>();
  std::vector<SimplexCode<D>> out;
  const int need = level <= D ? 0 : level - D;
  while (out.size() < kCodes) {
    uint64_t path = 0;
    for (int l = 0; l < level; l += D) path = path << D | groups[rng() % groups.size()];
    path >>= D * ((level + D - 1) / D) - level;
    const auto c = SimplexCode<D>::FromPath(
        static_cast<int>(rng() % SimplexCode<D>::kRoots), path, level);
    if (type == 1 || (ClimbLength(c, type) >= need && !NeighborScan<D>(c, type).is_none())) {
      out.push_back(c);
    }
  }
  return out;
}

template <int D>
std::vector<SimplexCode<D>> RandomCodes(int level, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<SimplexCode<D>> out(kCodes);
  for (auto& c : out) c = RandomCode<D>(rng, level);
  return out;
}

template <class Code, class Fn>
void RunOverCodes(benchmark::State& state, const std::vector<Code>& codes, Fn fn) {
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(fn(codes[i]));
    i = (i + 1) & (kCodes - 1);
  }
}

// Generates a benchmark's codes the first time it runs, so filtered-out
// benchmarks cost nothing (worst-case codes take a search to find).
template <int D>
class LazyCodes {
 public:
  LazyCodes(int level, int type, bool worst) : level_(level), type_(type), worst_(worst) {}
  const std::vector<SimplexCode<D>>& get() {
    std::call_once(once_, [this] {
      codes_ = worst_ ? WorstCaseCodes<D>(level_, type_)
                      : RandomCodes<D>(level_, 7 * level_ + type_);
      for (const auto c : codes_) cursors_.emplace_back(c);
    });
    return codes_;
  }
  const std::vector<NeighborCursor<D>>& cursors() {
    get();
    return cursors_;
  }

 private:
  int level_, type_;
  bool worst_;
  std::once_flag once_;
  std::vector<SimplexCode<D>> codes_;
  std::vector<NeighborCursor<D>> cursors_;
};

template <int D>
void RegisterNeighborBenchmarks(std::initializer_list<int> levels) {
  using Code = SimplexCode<D>;
  for (int level : levels) {
    for (int type = 1; type <= D + 1; ++type) {
      for (const bool worst : {false, true}) {
        const auto codes = std::make_shared<LazyCodes<D>>(level, type, worst);
        const std::string prefix = std::string(Api<D>::kName) + "Neighbor/";
        const std::string suffix = "/type" + std::to_string(type) +
                                   (worst ? "/worst" : "/random") + "/depth:" +
                                   std::to_string(level);
        benchmark::RegisterBenchmark((prefix + "scan" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       RunOverCodes(s, codes->get(), [type](Code c) {
                                         return NeighborScan<D>(c, type);
                                       });
                                     });
        benchmark::RegisterBenchmark((prefix + "constant" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       RunOverCodes(s, codes->get(), [type](Code c) {
                                         return Neighbor<D>(c, type);
                                       });
                                     });
        // The cursor's mask is already up to date: the cost of one step in a
        // walk (cluster, refinement), mask update included. Cursors step in
        // place; crossing the same face again steps back, so the set
        // alternates between the codes and their neighbors (as hard).
        benchmark::RegisterBenchmark((prefix + "cursor" + suffix).c_str(),
                                     [codes, type](benchmark::State& s) {
                                       auto cursors = codes->cursors();
                                       size_t i = 0;
                                       for (auto _ : s) {
                                         benchmark::DoNotOptimize(cursors[i].Step(type));
                                         i = (i + 1) & (kCodes - 1);
                                       }
                                       benchmark::DoNotOptimize(cursors.data());
                                     });
        if (worst) {
          benchmark::RegisterBenchmark((prefix + "level-scan" + suffix).c_str(),
                                       [codes, type](benchmark::State& s) {
                                         RunOverCodes(s, codes->get(), [type](Code c) {
                                           return NeighborByLevelScan<D>(c, type);
                                         });
                                       });
        }
      }
    }
  }
}

// A walk: one cursor taking steps across random faces, each step starting
// from where the last one ended (dependent steps: latency, where the
// benchmarks above measure independent steps: throughput). Clusters and
// refinement walk like this.
template <int D>
void RegisterWalkBenchmarks(std::initializer_list<int> levels) {
  for (int level : levels) {
    benchmark::RegisterBenchmark(
        (std::string(Api<D>::kName) + "Walk/depth:" + std::to_string(level)).c_str(),
        [level](benchmark::State& s) {
          std::mt19937_64 rng(9 + level);
          std::vector<uint8_t> types(kCodes);
          for (auto& t : types) t = static_cast<uint8_t>(1 + rng() % (D + 1));
          NeighborCursor<D> cursor(RandomCode<D>(rng, level));
          size_t i = 0;
          for (auto _ : s) {
            benchmark::DoNotOptimize(cursor.Step(types[i]));
            i = (i + 1) & (kCodes - 1);
          }
        });
  }
}

template <int D>
void RegisterGeometryBenchmarks(std::initializer_list<int> vertex_levels,
                                std::initializer_list<int> cluster_levels) {
  const std::string name = Api<D>::kName;
  for (int level : vertex_levels) {
    benchmark::RegisterBenchmark(
        (name + "Vertices/depth:" + std::to_string(level)).c_str(), [level](benchmark::State& s) {
          const auto codes = RandomCodes<D>(level, 5);
          RunOverCodes(s, codes, [](SimplexCode<D> c) { return Vertices(c); });
        });
  }
  // Mostly interior codes, at random; the average size shows the shape.
  for (int level : cluster_levels) {
    benchmark::RegisterBenchmark(
        (name + "Cluster/depth:" + std::to_string(level)).c_str(), [level](benchmark::State& s) {
          const auto codes = RandomCodes<D>(level, 6);
          size_t members = 0;
          size_t i = 0;
          for (auto _ : s) {
            const auto c = Cluster(codes[i]);
            members += c.size();
            benchmark::DoNotOptimize(c);
            i = (i + 1) & (kCodes - 1);
          }
          s.counters["members"] = benchmark::Counter(static_cast<double>(members),
                                                     benchmark::Counter::kAvgIterations);
        });
  }
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  using namespace simplexdb;
  RegisterNeighborBenchmarks<3>({6, 30, TetCode::kMaxLevel});
  RegisterNeighborBenchmarks<4>({8, 28, PentaCode::kMaxLevel});
  RegisterWalkBenchmarks<3>({6, 30, TetCode::kMaxLevel});
  RegisterWalkBenchmarks<4>({8, 28, PentaCode::kMaxLevel});
  RegisterGeometryBenchmarks<3>({6, 30, TetCode::kMaxLevel}, {30, 31, 32, 53, 54, 55});
  RegisterGeometryBenchmarks<4>({8, 28, PentaCode::kMaxLevel}, {28, 29, 30, 31, 52, 53});
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
