// Query benchmarks (issue 6): selective refinement over every store, in one
// run so the ratios to in-core are measured together (seed Fig. 46).
//
//   Extract/<hierarchy>/<store>/<algorithm>
//       one extraction at 1% of the field range on a Perlin volume (HT 129^3,
//       the seed's Buckyball size; HP 33^4): counters splits/s and
//       clusters/s (cluster computations per second), simplices in the mesh,
//       and for incremental merges/s. Stores: in-memory (decoded at open:
//       the in-core case), mapped raw, zstd with a warm cache (1 GiB), zstd
//       cold (a 256 MiB cache emptied before each query: every block the
//       query touches is decoded once; the file's pages may still be in the
//       OS page cache), zstd with no cache at all (every block change
//       decodes a frame: the floor), and the lossless LMDB store.
//       Incremental times the step from the 5% mesh to the 1% mesh and back.
//       Each query gets a new source and refiner, as a program's query does
//       (query/open_store.h: AnyStore::Visit); making them takes microseconds
//       and is timed with the query.
//
//   build/release/bench/query_bench
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bench/bench_util.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/open_store.h"
#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/dense_builder.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/volume/volume.h"

namespace simplexdb {
namespace {

constexpr size_t kColdCacheBytes = size_t{256} << 20;

// The stores of one hierarchy, opened once for the whole run (so the warm
// cache stays warm across benchmarks); the cold store is opened anew per
// query from zstd_path.
struct QueryStores {
  std::vector<std::pair<const char*, AnyStore>> open;  // name, store
  std::string zstd_path;
};

AnyStore OpenOrDie(const std::string& path, const StoreOptions& options) {
  Result<AnyStore> store = AnyStore::Open(path, options);
  if (!store.ok()) std::abort();
  return *std::move(store);
}

QueryStores MakeStores(int dimension, uint32_t side) {
  QueryStores s;
  const VolumeInfo in = *OpenVolume(PerlinVolume(dimension, side));
  const std::string base = WorkDir() + "/query" + std::to_string(dimension);
  DenseBuildOptions options;
  options.compression = Compression::kNone;
  if (!BuildDenseStore(in, base + "_raw.sdb", options).ok()) std::abort();
  options.compression = Compression::kZstd;
  if (!BuildDenseStore(in, base + "_zstd.sdb", options).ok()) std::abort();
  s.zstd_path = base + "_zstd.sdb";
  StoreOptions in_memory, raw, warm, nocache;
  in_memory.in_memory = true;
  warm.cache_bytes = size_t{1} << 30;
  nocache.cache_bytes = 0;
  s.open.emplace_back("in-memory", OpenOrDie(s.zstd_path, in_memory));
  s.open.emplace_back("raw", OpenOrDie(base + "_raw.sdb", raw));
  s.open.emplace_back("zstd-warm", OpenOrDie(s.zstd_path, warm));
  s.open.emplace_back("zstd-nocache", OpenOrDie(s.zstd_path, nocache));
  // The lossless sparse store, as import --sparse.
  if (!BuildSparseStore(in, base + ".lmdb", SparseBuildOptions{}).ok()) std::abort();
  s.open.emplace_back("lmdb", OpenOrDie(base + ".lmdb", StoreOptions{}));
  return s;
}

template <int D>
Criteria<D> AtPercent(const SourceInfo& info, double pct) {
  CriteriaSpec spec;
  spec.error = {pct, true};
  return *MakeCriteria<D>(spec, info.domain_bits, info.field_range());
}

// Runs `algorithm` at `pct` percent on `mesh`, over a new source of `store`.
template <int D>
Status Query(const AnyStore& store, Algorithm algorithm, double pct, Mesh<D>& mesh, QueryStats& stats) {
  return store.Visit([&]<int E, class Source>(Source& source) -> Status {
    if constexpr (E != D) {
      return Status::InvalidArgument(store.path() + ": not of this benchmark's hierarchy");
    } else {
      Refiner<D, Source> refiner(source, AtPercent<D>(source.info(), pct));
      return refiner.Run({algorithm}, mesh, stats);
    }
  });
}

// One extraction per iteration over `shared`, or with `cold_path` over that
// store opened anew (untimed) for every iteration: an empty cache.
template <int D>
void RunExtract(benchmark::State& state, Algorithm algorithm, const AnyStore* shared,
                const std::string& cold_path) {
  std::optional<AnyStore> cold;
  const auto store = [&]() -> const AnyStore& {
    if (shared != nullptr) return *shared;
    if (!cold) {
      StoreOptions o;
      o.cache_bytes = kColdCacheBytes;
      cold.emplace(OpenOrDie(cold_path, o));
    }
    return *cold;
  };
  uint64_t splits = 0, merges = 0, clusters = 0, simplices = 0;
  Mesh<D> mesh;
  QueryStats stats;
  // The mesh incremental starts from.
  if (algorithm == Algorithm::kIncremental &&
      !Query<D>(store(), Algorithm::kDepthFirst, 5, mesh, stats).ok()) {
    state.SkipWithError("setup failed");
  }
  for (auto _ : state) {
    if (shared == nullptr) {
      state.PauseTiming();
      cold.reset();
      store();
      state.ResumeTiming();
    }
    if (algorithm == Algorithm::kIncremental) {
      // 5% -> 1% (splits), then 1% -> 5% (merges): both timed.
      if (!Query<D>(store(), algorithm, 1, mesh, stats).ok()) state.SkipWithError("query failed");
      splits += stats.splits;
      clusters += stats.cluster_computations;
      simplices = stats.simplices;
      if (!Query<D>(store(), algorithm, 5, mesh, stats).ok()) state.SkipWithError("query failed");
      merges += stats.merges;
      clusters += stats.cluster_computations;
      splits += stats.splits;
    } else {
      if (!Query<D>(store(), algorithm, 1, mesh, stats).ok()) state.SkipWithError("query failed");
      splits += stats.splits;
      clusters += stats.cluster_computations;
      simplices = stats.simplices;
    }
  }
  state.counters["splits/s"] = benchmark::Counter(static_cast<double>(splits), benchmark::Counter::kIsRate);
  state.counters["clusters/s"] = benchmark::Counter(static_cast<double>(clusters), benchmark::Counter::kIsRate);
  if (algorithm == Algorithm::kIncremental) {
    state.counters["merges/s"] = benchmark::Counter(static_cast<double>(merges), benchmark::Counter::kIsRate);
  }
  state.counters["simplices"] = static_cast<double>(simplices);
}

template <int D>
void Register(const char* name, uint32_t side) {
  static QueryStores stores = MakeStores(D, side);
  for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kIncremental,
                      Algorithm::kSaturated}) {
    const auto add = [&](const char* store_name, const AnyStore* shared) {
      benchmark::RegisterBenchmark(
          (std::string("Extract/") + name + "/" + store_name + "/" + AlgorithmName(a)).c_str(),
          [a, shared](benchmark::State& state) { RunExtract<D>(state, a, shared, stores.zstd_path); })
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
    };
    // The order of the report: in-core first, the cold store before LMDB.
    for (const auto& [store_name, store] : stores.open) {
      if (std::string(store_name) == "lmdb") add("zstd-cold", nullptr);
      add(store_name, &store);
    }
  }
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  simplexdb::Register<3>("ht129", 129);
  simplexdb::Register<4>("hp33", 33);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
