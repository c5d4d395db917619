// Query benchmarks (issue 6): selective refinement over every store, in one
// run so the ratios to in-core are measured together (seed Fig. 46).
//
//   Extract/<hierarchy>/<store>/<algorithm>
//       one extraction at 1% of the field range on a Perlin volume (HT 129^3,
//       the seed's Buckyball size; HP 33^4): counters splits/s and
//       clusters/s (cluster computations per second), simplices in the mesh,
//       and for incremental merges/s. Stores: in-memory (decoded at open:
//       the in-core case), mapped raw, zstd with a warm cache (1 GiB), zstd
//       with no cache (every block change decodes a frame: cold), and the
//       lossless LMDB store. Incremental times the step from the 5% mesh
//       to the 1% mesh and back.
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
#include "storage/dense_builder.h"
#include "storage/dense_store.h"
#include "storage/sparse_builder.h"
#include "storage/sparse_store.h"
#include "storage/volume.h"

namespace simplexdb {
namespace {

struct QueryStores {
  std::unique_ptr<DenseStore> in_memory, raw, zstd_warm, zstd_cold;
  std::unique_ptr<SparseStore> sparse;
};

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
  s.zstd_cold = *DenseStore::Open(base + "_zstd.sdb", o);
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

template <int D, class Source>
void RunExtract(benchmark::State& state, Source& source, Algorithm algorithm) {
  const Criteria<D> fine = AtPercent<D>(source.info(), 1), coarse = AtPercent<D>(source.info(), 5);
  Refiner<D, Source> refiner(source, fine), back(source, coarse);
  uint64_t splits = 0, merges = 0, clusters = 0, simplices = 0;
  Mesh<D> mesh;
  QueryStats stats;
  if (algorithm == Algorithm::kIncremental) {
    if (!back.Run({Algorithm::kDepthFirst}, mesh, stats).ok()) state.SkipWithError("setup failed");
  }
  for (auto _ : state) {
    if (algorithm == Algorithm::kIncremental) {
      // 5% -> 1% (splits), then 1% -> 5% (merges): both timed.
      if (!refiner.Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
      splits += stats.splits;
      clusters += stats.cluster_computations;
      simplices = stats.simplices;
      if (!back.Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
      merges += stats.merges;
      clusters += stats.cluster_computations;
      splits += stats.splits;
    } else {
      if (!refiner.Run({algorithm}, mesh, stats).ok()) state.SkipWithError("query failed");
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
                                                       {"zstd-cold", stores.zstd_cold.get()}};
  for (Algorithm a : {Algorithm::kDepthFirst, Algorithm::kPriority, Algorithm::kIncremental,
                      Algorithm::kSaturated}) {
    for (const auto& [store_name, store] : dense) {
      DenseStore* st = store;
      benchmark::RegisterBenchmark(
          (std::string("Extract/") + name + "/" + store_name + "/" + AlgorithmName(a)).c_str(),
          [st, a](benchmark::State& state) {
            DenseSource<D> source(*st);
            RunExtract<D>(state, source, a);
          })
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
    }
    benchmark::RegisterBenchmark((std::string("Extract/") + name + "/lmdb/" + AlgorithmName(a)).c_str(),
                                 [a](benchmark::State& state) {
                                   auto source = *SparseSource<D>::Create(*stores.sparse);
                                   RunExtract<D>(state, source, a);
                                 })
        ->Unit(benchmark::kMillisecond)
        ->MinTime(1.0);
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
