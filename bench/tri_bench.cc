// Triangle quadtree micro-benchmarks (seed chapter 2): ns per equal-size
// neighbor call, the nearest-common-ancestor scan (2.2, 2.3) against the
// constant-time algorithm (2.4, 2.5), for each direction and solid, on
// random codes and on worst-case codes; point location; neighbors of
// greater or equal size in a sorted leaf list (2.6).
//
//   build/release/bench/tri_bench --benchmark_min_time=0.3
//
// The IcosaLeafStore benchmarks time the same through the LMDB leaf store
// (storage/tri/tri_leaf_store.h): a durable refine, and the reads that each
// take one read transaction and one or two B-tree searches.
//
// "worst" codes have only the two child types that lie along the sought
// edge (left 00/01, right 00/11, vertical 01/11): the scan climbs to the
// base face, crosses to the next face and rewrites every level; the
// constant-time algorithm carries out of the path and fixes the result
// (reflects it on the solid's mirrored or flipped edges). Each iteration is
// one call; codes cycle through 4096 pre-generated ones (fixed seeds).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "bench/bench_util.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_neighbors.h"
#include "storage/tri/tri_leaf_store.h"

namespace simplexdb {
namespace {

constexpr size_t kCodes = 4096;  // a power of two: the index wraps with a mask

template <Polyhedron P>
const char* SolidName() {
  return P == Polyhedron::kIcosahedron  ? "Icosa"
         : P == Polyhedron::kOctahedron ? "Octa"
                                        : "Tetra";
}

template <Polyhedron P>
std::vector<TriCode<P>> Codes(int level, int d, bool worst, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<TriCode<P>> out(kCodes);
  const auto ends = tri::kEdgeEndChild[d];
  for (auto& c : out) {
    uint64_t path = 0;
    if (worst) {
      for (int l = 0; l < level; ++l) path = path << 2 | ends[rng() & 1];
    } else if (level > 0) {
      path = rng() >> (64 - 2 * level);
    }
    c = TriCode<P>::FromPath(static_cast<int>(rng() % TriCode<P>::kFaces), path, level);
  }
  return out;
}

template <class T, class Fn>
void RunOver(benchmark::State& state, const std::vector<T>& items, Fn fn) {
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(fn(items[i]));
    i = (i + 1) & (kCodes - 1);
  }
}

template <Polyhedron P>
void RegisterNeighbors(std::initializer_list<int> levels) {
  static const char* kDir[] = {"left", "right", "vertical"};
  for (int level : levels) {
    for (int d = 0; d < 3; ++d) {
      for (const bool worst : {false, true}) {
        const auto codes = Codes<P>(level, d, worst, 100 * level + 10 * d + worst);
        const auto dir = static_cast<TriDirection>(d);
        const std::string suffix = std::string("/") + kDir[d] + (worst ? "/worst" : "/random") +
                                   "/depth:" + std::to_string(level);
        const std::string prefix = std::string(SolidName<P>()) + "Neighbor/";
        benchmark::RegisterBenchmark((prefix + "scan" + suffix).c_str(),
                                     [codes, dir](benchmark::State& s) {
                                       RunOver(s, codes, [dir](TriCode<P> c) {
                                         return TriNeighborScan(c, dir);
                                       });
                                     });
        benchmark::RegisterBenchmark((prefix + "constant" + suffix).c_str(),
                                     [codes, dir](benchmark::State& s) {
                                       RunOver(s, codes, [dir](TriCode<P> c) {
                                         return TriNeighbor(c, dir);
                                       });
                                     });
      }
    }
  }
}

// A walk of dependent steps in random directions (latency, where the
// benchmarks above measure throughput).
template <Polyhedron P>
void RegisterWalks(std::initializer_list<int> levels) {
  for (int level : levels) {
    benchmark::RegisterBenchmark(
        (std::string(SolidName<P>()) + "Walk/depth:" + std::to_string(level)).c_str(),
        [level](benchmark::State& s) {
          std::mt19937_64 rng(9 + level);
          std::vector<TriDirection> dirs(kCodes);
          for (auto& d : dirs) d = static_cast<TriDirection>(rng() % 3);
          TriCode<P> c = Codes<P>(level, 0, false, 3)[0];
          size_t i = 0;
          for (auto _ : s) {
            c = TriNeighbor(c, dirs[i]);
            benchmark::DoNotOptimize(c);
            i = (i + 1) & (kCodes - 1);
          }
        });
  }
}

template <Polyhedron P>
void RegisterGeometry(std::initializer_list<int> levels) {
  const std::string name = SolidName<P>();
  for (int level : levels) {
    benchmark::RegisterBenchmark(
        (name + "LatLngToCode/depth:" + std::to_string(level)).c_str(),
        [level](benchmark::State& s) {
          std::mt19937_64 rng(4);
          std::uniform_real_distribution<double> lat(-90, 90), lng(-180, 180);
          std::vector<LatLng> points(kCodes);
          for (auto& p : points) p = {lat(rng), lng(rng)};
          RunOver(s, points, [level](LatLng p) { return LatLngToCode<P>(p, level); });
        });
    benchmark::RegisterBenchmark(
        (name + "SphereVertices/depth:" + std::to_string(level)).c_str(),
        [level](benchmark::State& s) {
          RunOver(s, Codes<P>(level, 0, false, 5),
                  [](TriCode<P> c) { return SphereVertices(c); });
        });
  }
}

// 2.6 over a sorted list of about 70,000 leaves: the icosahedron to
// level 4, with a patch refined to level 8 and a chain down to the maximum.
void RegisterGreaterOrEqual() {
  benchmark::RegisterBenchmark("IcosaGreaterOrEqualNeighbor/leaves", [](benchmark::State& s) {
    using Code = IcosaCode;
    std::vector<Code> leaves;
    std::mt19937_64 rng(12);
    const Code deep = Codes<Polyhedron::kIcosahedron>(Code::kMaxLevel, 0, false, 6)[0];
    std::vector<Code> work;
    for (int f = 0; f < Code::kFaces; ++f) work.push_back(Code::Face(f));
    while (!work.empty()) {
      const Code c = work.back();
      work.pop_back();
      const bool patch = c.face() == 3 && c.level() < 8;
      if (c.level() < 4 || patch || (c.contains(deep) && c != deep)) {
        for (int t = 0; t < 4; ++t) work.push_back(c.child(t));
      } else {
        leaves.push_back(c);
      }
    }
    std::sort(leaves.begin(), leaves.end());
    std::vector<Code> queries(kCodes);
    std::vector<TriDirection> dirs(kCodes);
    for (size_t i = 0; i < kCodes; ++i) {
      queries[i] = leaves[rng() % leaves.size()];
      dirs[i] = static_cast<TriDirection>(rng() % 3);
    }
    size_t i = 0;
    for (auto _ : s) {
      benchmark::DoNotOptimize(TriNeighborOfGreaterOrEqualSize<Polyhedron::kIcosahedron>(
          std::span<const Code>(leaves), queries[i], dirs[i]));
      i = (i + 1) & (kCodes - 1);
    }
    s.counters["leaves"] = static_cast<double>(leaves.size());
  });
}

// The LMDB leaf store: an icosahedron refined at 1000 random level-12
// triangles (about 27,000 leaves), in the benchmarks' scratch directory.
void RegisterLeafStore() {
  using Store = TriLeafStore<Polyhedron::kIcosahedron>;
  const auto make = [](const char* name) {
    const std::string path = WorkDir() + "/" + name;
    std::filesystem::remove(path);
    std::filesystem::remove(path + "-lock");
    std::unique_ptr<Store> store = Store::Create(path).value();
    std::mt19937_64 rng(1);
    for (int i = 0; i < 1000; ++i) {
      if (!store->Refine(Codes<Polyhedron::kIcosahedron>(12, 0, false, rng())[0]).ok()) abort();
    }
    return store;
  };
  const auto cleanup = [](const Store& store) {
    std::filesystem::remove(store.path());
    std::filesystem::remove(store.path() + "-lock");
  };
  benchmark::RegisterBenchmark("IcosaLeafStore/Refine", [=](benchmark::State& s) {
    std::unique_ptr<Store> store = make("refine.tri");
    const auto codes = Codes<Polyhedron::kIcosahedron>(16, 0, false, 8);
    size_t i = 0;
    for (auto _ : s) {
      if (!store->Refine(codes[i]).ok()) s.SkipWithError("refine failed");
      i = (i + 1) & (kCodes - 1);
    }
    s.counters["leaves"] = static_cast<double>(store->LeafCount().value());
    cleanup(*store);
  });
  benchmark::RegisterBenchmark("IcosaLeafStore/Neighbor", [=](benchmark::State& s) {
    std::unique_ptr<Store> store = make("neighbor.tri");
    const std::vector<IcosaCode> leaves = store->Leaves().value();
    std::mt19937_64 rng(2);
    std::vector<IcosaCode> queries(kCodes);
    for (auto& q : queries) q = leaves[rng() % leaves.size()];
    size_t i = 0;
    for (auto _ : s) {
      benchmark::DoNotOptimize(store->Neighbor(queries[i], static_cast<TriDirection>(i % 3)));
      i = (i + 1) & (kCodes - 1);
    }
    s.counters["leaves"] = static_cast<double>(leaves.size());
    cleanup(*store);
  });
  benchmark::RegisterBenchmark("IcosaLeafStore/LeafAt", [=](benchmark::State& s) {
    std::unique_ptr<Store> store = make("leafat.tri");
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> lat(-90, 90), lng(-180, 180);
    std::vector<LatLng> points(kCodes);
    for (auto& p : points) p = {lat(rng), lng(rng)};
    RunOver(s, points, [&](LatLng p) { return store->LeafAt(p); });
    cleanup(*store);
  });
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  using namespace simplexdb;
  RegisterNeighbors<Polyhedron::kIcosahedron>({6, 16, IcosaCode::kMaxLevel});
  RegisterNeighbors<Polyhedron::kOctahedron>({OctaCode::kMaxLevel});
  RegisterNeighbors<Polyhedron::kTetrahedron>({TetraCode::kMaxLevel});
  RegisterWalks<Polyhedron::kIcosahedron>({6, 16, IcosaCode::kMaxLevel});
  RegisterGeometry<Polyhedron::kIcosahedron>({6, 16, IcosaCode::kMaxLevel});
  RegisterGreaterOrEqual();
  RegisterLeafStore();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
