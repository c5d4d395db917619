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
#include "hierarchy/hz_order.h"
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

template <int D>
std::vector<SimplexCode<D>> RandomCodes(int level, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<SimplexCode<D>> out(kCodes);
  for (auto& c : out) c = RandomCode<D>(rng, level);
  return out;
}

// Codes whose scan for `type` reads every group and that have a neighbor:
// built from the bottom, the tail among the bits it climbs out of, then each
// group below the top among the bits where the type sought there continues,
// the top group at random; kept when the neighbor exists (found in the top
// group or under another root). A chain that continues as type 1 stops in
// the next group (the sibling), so only the group below the top may turn
// one into type 1 (as type 2's chain must, to have a neighbor). Type 1 never
// climbs: its codes are random.
template <int D>
std::vector<SimplexCode<D>> WorstCaseCodes(int level, int type) {
  const uint64_t seed = 1000 + level * 10 + type;
  if (type == 1) return RandomCodes<D>(level, seed);
  std::mt19937_64 rng(seed);
  const auto& table = Api<D>::Table();
  const int r = level % D, groups = level / D;
  std::vector<SimplexCode<D>> out;
  while (out.size() < kCodes) {
    const uint64_t tail = rng() & ((uint64_t{1} << r) - 1);
    const TailStep t = TailSteps<D>::kTable[r][tail][type - 1];
    if (t.flip != 0 || (t.type == 1 && groups > 1)) continue;
    int k = t.type;
    uint64_t q = 0;
    for (int m = 0; m < groups; ++m) {
      std::vector<uint64_t> climbing;
      for (uint64_t bits = 0; bits < (uint64_t{1} << D); ++bits) {
        const GroupStep g = table[bits][k - 1];
        if (!g.stop && (g.value != 1 || m == groups - 2)) climbing.push_back(bits);
      }
      const uint64_t bits = m == groups - 1 ? rng() & ((uint64_t{1} << D) - 1)
                                            : climbing[rng() % climbing.size()];
      q |= bits << (D * m);
      const GroupStep g = table[bits][k - 1];
      if (g.stop) break;
      k = g.value;
    }
    const auto c = SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots),
                                            q << r | tail, level);
    if (!NeighborScan<D>(c, type).is_none()) out.push_back(c);
  }
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
    // Format 2's code -> record: the split vertex by octave tables, against
    // the split midpoint from Vertices() (what it replaces).
    benchmark::RegisterBenchmark(
        (name + "SplitVertex/depth:" + std::to_string(level)).c_str(), [level](benchmark::State& s) {
          const auto codes = RandomCodes<D>(level, 5);
          RunOverCodes(s, codes, [](SimplexCode<D> c) { return SplitVertex(c); });
        });
    benchmark::RegisterBenchmark(
        (name + "SplitMidpointOfVertices/depth:" + std::to_string(level)).c_str(),
        [level](benchmark::State& s) {
          const auto codes = RandomCodes<D>(level, 5);
          RunOverCodes(s, codes, [](SimplexCode<D> c) { return SplitMidpoint<D>(c, Vertices(c)); });
        });
  }
  // A depth-first walk's lookups: the children of each node, then deeper
  // (paths random, depths around `level`). The cursor reuses shared octaves.
  for (int level : vertex_levels) {
    const auto walk = [level] {
      std::vector<SimplexCode<D>> out;
      std::mt19937_64 rng(level);
      SimplexCode<D> c = SimplexCode<D>::Root(0);
      while (out.size() < kCodes) {
        if (c.level() >= level) c = c.ancestor(static_cast<int>(rng() % (level / 2 + 1)) + level / 2);
        out.push_back(c.child(0));
        out.push_back(c.child(1));
        c = c.child(static_cast<int>(rng() & 1));
      }
      out.resize(kCodes);
      return out;
    };
    benchmark::RegisterBenchmark(
        (name + "SplitVertexWalk/depth:" + std::to_string(level)).c_str(), [walk](benchmark::State& s) {
          const auto codes = walk();
          RunOverCodes(s, codes, [](SimplexCode<D> c) { return SplitVertex(c); });
        });
    benchmark::RegisterBenchmark(
        (name + "SplitVertexCursorWalk/depth:" + std::to_string(level)).c_str(),
        [walk](benchmark::State& s) {
          const auto codes = walk();
          SplitVertexCursor<D> cursor;
          RunOverCodes(s, codes, [&cursor](SimplexCode<D> c) { return cursor.Of(c); });
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
