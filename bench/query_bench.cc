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
//
//   build/release/bench/query_bench
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "bench/bench_util.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"

namespace simplexdb {
namespace {

struct QueryStores {
  std::unique_ptr<DenseStore> in_memory, raw, zstd_warm, zstd_nocache;
  std::string zstd_path;
  std::unique_ptr<SparseStore> sparse;
};

constexpr size_t kColdCacheBytes = size_t{256} << 20;

QueryStores MakeStores(int dimension, uint32_t side) {
  QueryStores s;
  const VolumeInfo in = *OpenVolume(PerlinVolume(dimension, side));
  const std::string base = WorkDir() + "/query" + std::to_string(dimension);
  DenseBuildOptions options;
  options.compression = Compression::kNone;
  if (!BuildDenseStore(in, base + "_raw.sdb", options).ok()) std::abort();
  options.compression = Compression::kZstd;
  if (!BuildDenseStore(in, base + "_zstd.sdb", options).ok()) std::abort();
  DenseStore::Options o;
  s.raw = *DenseStore::Open(base + "_raw.sdb", o);
  o.cache_bytes = size_t{1} << 30;
  s.zstd_warm = *DenseStore::Open(base + "_zstd.sdb", o);
  o.cache_bytes = 0;
  s.zstd_nocache = *DenseStore::Open(base + "_zstd.sdb", o);
  s.zstd_path = base + "_zstd.sdb";
  o.in_memory = true;
  s.in_memory = *DenseStore::Open(base + "_zstd.sdb", o);
  if (!ConvertDenseToSparse(*s.zstd_warm, base + ".lmdb", SparseBuildOptions{}).ok()) std::abort();
  s.sparse = *SparseStore::Open(base + ".lmdb");
  return s;
}

template <int D>
Criteria<D> AtPercent(const SourceInfo& info, double pct) {
  CriteriaSpec spec;
  spec.error = {pct, true};
  return *MakeCriteria<D>(spec, info.domain_bits, info.field_range());
}

// One extraction per iteration over the source `make()` returns. With
// `cold`, every iteration gets a new source from `make()` (untimed), which
// opens the store anew: an empty cache.
template <int D, class Make>
void RunExtract(benchmark::State& state, Algorithm algorithm, bool cold, Make make) {
  auto source = make();
  using Source = typename decltype(source)::element_type;
  const auto criteria = [&](double pct) { return AtPercent<D>(source->info(), pct); };
  auto refiner = std::make_unique<Refiner<D, Source>>(*source, criteria(1));
  auto back = std::make_unique<Refiner<D, Source>>(*source, criteria(5));
  uint64_t splits = 0, merges = 0, clusters = 0, simplices = 0;
  Mesh<D> mesh;
  QueryStats stats;
  const auto start = [&] {  // the mesh the query starts from
    if (algorithm != Algorithm::kIncremental) return;
    mesh = Mesh<D>();
    if (!back->Run({Algorithm::kDepthFirst}, mesh, stats).ok()) state.SkipWithError("setup failed");
  };
  start();
  for (auto _ : state) {
    if (cold) {
      state.PauseTiming();
      refiner.reset();
      back.reset();
      source = make();
      refiner = std::make_unique<Refiner<D, Source>>(*source, criteria(1));
      back = std::make_unique<Refiner<D, Source>>(*source, criteria(5));
      state.ResumeTiming();
    }
    if (algorithm == Algorithm::kIncremental) {
      // 5% -> 1% (splits), then 1% -> 5% (merges): both timed.
      if (!refiner->Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
      splits += stats.splits;
      clusters += stats.cluster_computations;
      simplices = stats.simplices;
      if (!back->Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
      merges += stats.merges;
      clusters += stats.cluster_computations;
      splits += stats.splits;
    } else {
      if (!refiner->Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
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
  const std::pair<const char*, DenseStore*> dense[] = {{"in-memory", stores.in_memory.get()},
                                                       {"raw", stores.raw.get()},
                                                       {"zstd-warm", stores.zstd_warm.get()},
                                                       {"zstd-nocache", stores.zstd_nocache.get()}};
  for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kIncremental,
                      Algorithm::kSaturated}) {
    const auto add = [&](const char* store_name, auto make, bool cold) {
      benchmark::RegisterBenchmark(
          (std::string("Extract/") + name + "/" + store_name + "/" + AlgorithmName(a)).c_str(),
          [a, make, cold](benchmark::State& state) { RunExtract<D>(state, a, cold, make); })
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
    };
    for (const auto& [store_name, store] : dense) {
      DenseStore* st = store;
      add(store_name, [st] { return std::make_unique<DenseSource<D>>(*st); }, false);
    }
    // Opened anew for each query, so its cache starts empty. The store lives
    // as long as the source: both in one holder.
    struct ColdSource : DenseSource<D> {
      explicit ColdSource(std::unique_ptr<DenseStore> s) : DenseSource<D>(*s), store(std::move(s)) {}
      std::unique_ptr<DenseStore> store;
    };
    add("zstd-cold", [] {
      DenseStore::Options o;
      o.cache_bytes = kColdCacheBytes;
      return std::make_unique<ColdSource>(*DenseStore::Open(stores.zstd_path, o));
    }, true);
    add("lmdb", [] { return std::make_unique<SparseSource<D>>(*SparseSource<D>::Create(*stores.sparse)); },
        false);
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
