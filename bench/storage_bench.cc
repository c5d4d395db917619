// Dense store benchmarks (issue 4):
//
//   ErrorLookup/<store>/<order>   ns per error lookup on a Perlin 129^3 store:
//                                 in memory, mapped raw, zstd with a warm cache
//                                 and with no cache (every new block decoded),
//                                 random codes or a depth-first walk.
//   Build/<volume>                build throughput (grid points/s) and peak
//                                 memory of `simplexdb import` (a child process).
//   ErrorLookup/sparse-<order>    the same codes on the lossless sparse store
//                                 of format 2 (decoded blocks in its cache).
//   Size/<volume>/<mode>          bytes per grid point on disk for each
//                                 quantization and compression (and the
//                                 lossless sparse store), against the
//                                 seed's 14n (u16) and 7n (u8) bytes in the
//                                 HT, 50n and 25n in the HP.
//
//   build/release/bench/storage_bench --benchmark_filter=ErrorLookup
//
// Volumes are generated into a temporary directory (fixed seeds) or read
// from ../shared/data when it is there.
#include <benchmark/benchmark.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/error/finest_diamonds.h"
#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"
#include "bench/bench_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;

// --- lookups ------------------------------------------------------------------

struct LookupStores {
  std::unique_ptr<DenseStore> in_memory, raw, zstd_warm, zstd_cold;
  std::unique_ptr<SparseStore> sparse;  // lossless, from the same volume
  std::vector<TetCode> random, depth_first;
};

LookupStores& Stores() {
  static LookupStores s = [] {
    LookupStores l;
    const VolumeInfo in = *OpenVolume(PerlinVolume(3, 129));
    DenseBuildOptions options;
    options.compression = Compression::kNone;
    const std::string raw = WorkDir() + "/lookup_raw.sdb", zstd = WorkDir() + "/lookup_zstd.sdb";
    if (!BuildDenseStore(in, raw, options).ok()) std::abort();
    options.compression = Compression::kZstd;
    if (!BuildDenseStore(in, zstd, options).ok()) std::abort();
    DenseStore::Options o;
    l.raw = *DenseStore::Open(raw, o);
    o.cache_bytes = size_t{1} << 30;
    l.zstd_warm = *DenseStore::Open(zstd, o);
    o.cache_bytes = 0;
    l.zstd_cold = *DenseStore::Open(zstd, o);
    o.in_memory = true;
    l.in_memory = *DenseStore::Open(zstd, o);
    const std::string sparse = WorkDir() + "/lookup.lmdb";
    if (!BuildSparseStore(in, sparse, SparseBuildOptions{}).ok()) std::abort();
    l.sparse = *SparseStore::Open(sparse, SparseStore::Options{});
    const int leaf = l.raw->header().leaf_level();
    std::mt19937_64 rng(1);
    for (int i = 0; i < (1 << 16); ++i) {
      const int level = static_cast<int>(rng() % leaf);
      l.random.push_back(TetCode::FromPath(static_cast<int>(rng() % 6),
                                           level ? rng() >> (64 - level) : 0, level));
    }
    std::function<void(TetCode)> walk = [&](TetCode c) {
      if (c.level() >= leaf || l.depth_first.size() >= (1u << 20)) return;
      l.depth_first.push_back(c);
      walk(c.child(0));
      walk(c.child(1));
    };
    walk(TetCode::Root(2));
    return l;
  }();
  return s;
}

// Error lookups of `codes`, round and round, through one reader of
// `store`; blocks decoded per lookup as a counter.
template <class Store>
void MeasureLookups(benchmark::State& state, const Store& store, const std::vector<TetCode>& codes) {
  typename Store::template Reader<3> reader(store);
  const uint64_t decoded_before = store.stats().blocks_decoded;
  size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(reader.ErrorBound(codes[i]));
    if (++i == codes.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["blocks_decoded"] = benchmark::Counter(
      static_cast<double>(store.stats().blocks_decoded - decoded_before), benchmark::Counter::kAvgIterations);
}

void RegisterLookups() {
  const std::pair<const char*, std::unique_ptr<DenseStore> LookupStores::*> stores[] = {
      {"in-memory", &LookupStores::in_memory},
      {"mapped-raw", &LookupStores::raw},
      {"zstd-warm", &LookupStores::zstd_warm},
      {"zstd-cold", &LookupStores::zstd_cold}};
  for (const auto& [name, member] : stores) {
    for (const bool random : {true, false}) {
      const std::string label =
          std::string("ErrorLookup/") + name + (random ? "/random" : "/depth-first");
      benchmark::RegisterBenchmark(label.c_str(), [member = member, random](benchmark::State& state) {
        LookupStores& s = Stores();
        MeasureLookups(state, *(s.*member), random ? s.random : s.depth_first);
      });
    }
  }
}

// The sparse store of format 2, lossless: the lookups of the dense ones, a
// finest diamond's error computed from rebuilt values (remembered in its
// decoded block after the first time).
void RegisterSparseLookups() {
  for (const bool random : {true, false}) {
    const std::string label = std::string("ErrorLookup/sparse") + (random ? "/random" : "/depth-first");
    benchmark::RegisterBenchmark(label.c_str(), [random](benchmark::State& state) {
      LookupStores& s = Stores();
      MeasureLookups(state, *s.sparse, random ? s.random : s.depth_first);
    });
  }
}

// --- builds and sizes -------------------------------------------------------

nlohmann::json Import(const std::string& input, const std::string& args, const std::string& out) {
  const std::string report =
      Capture(std::string(SIMPLEXDB_CLI) + " import " + input + " -o " + out + " --json -q " + args);
  const std::string info = Capture(std::string(SIMPLEXDB_CLI) + " info " + out + " --json");
  nlohmann::json j = nlohmann::json::parse(report.empty() ? "{}" : report);
  j["info"] = nlohmann::json::parse(info.empty() ? "{}" : info);
  return j;
}

void RegisterBuilds() {
  struct Volume {
    const char* name;
    std::function<std::string()> path;
  };
  const Volume volumes[] = {
      {"ht129_perlin", [] { return PerlinVolume(3, 129); }},
      {"ht257_perlin", [] { return PerlinVolume(3, 257); }},
      {"hp33_perlin", [] { return PerlinVolume(4, 33); }},
  };
  for (const Volume& v : volumes) {
    benchmark::RegisterBenchmark((std::string("Build/") + v.name).c_str(),
                                 [v](benchmark::State& state) {
                                   const std::string input = v.path();
                                   nlohmann::json j;
                                   for (auto _ : state) {
                                     j = Import(input, "", WorkDir() + "/build.sdb");
                                   }
                                   state.counters["grid_points_per_s"] =
                                       j.value("grid_points_per_second", 0.0);
                                   state.counters["peak_MiB"] =
                                       j.value("peak_memory_bytes", 0.0) / (1 << 20);
                                   state.counters["build_s"] = j.value("seconds", 0.0);
                                 })
        ->Iterations(1)
        ->Unit(benchmark::kSecond);
  }
}

void RegisterSizes() {
  std::vector<std::pair<std::string, std::function<std::string()>>> volumes = {
      {"plasma64_perlin65", [] { return PerlinVolume(3, 65); }},
      {"perlin33_4d", [] { return PerlinVolume(4, 33); }},
      {"blob129", [] { return PerlinVolume(3, 129, /*blob=*/true); }}};
  const std::string data = SIMPLEXDB_SHARED_DATA;
  const std::pair<const char*, const char*> real[] = {
      {"bucky", "/bucky/bucky_32x32x32_uint8.raw --dims 32,32,32 --type uint8"},
      {"neghip", "/neghip/neghip_64x64x64_uint8.raw --dims 64,64,64 --type uint8"},
      {"headsq", "/headsq/headsq_64x64x93_int16le.raw --dims 64,64,93 --type int16"},
      {"tooth", "/tooth/tooth_103x94x161_uint8.raw --dims 103,94,161 --type uint8"},
      {"lidc2", "/lidc2/LIDC2_256x256x133_uint8.raw --dims 256,256,133 --type uint8"},
      {"fmri_4d", "/fmri_example4d/example4d.nii"},
      {"dwi_4d", "/dwi_small_101D/small_101D.nii"},
  };
  if (fs::exists(data)) {
    for (const auto& [name, args] : real) {
      const std::string a = data + args;
      volumes.emplace_back(name, [a] { return a; });
    }
  }
  const char* modes[] = {"u16 zstd", "u16 none", "u8 zstd", "u8 none", "f32 zstd", "u16 sparse"};
  for (const auto& [name, path] : volumes) {
    for (const char* mode : modes) {
      std::string m = mode;
      const std::string q = m.substr(0, m.find(' ')), c = m.substr(m.find(' ') + 1);
      benchmark::RegisterBenchmark(
          ("Size/" + name + "/" + q + "-" + c).c_str(),
          [path = path, q, c](benchmark::State& state) {
            nlohmann::json j;
            for (auto _ : state) {
              j = c == "sparse" ? Import(path(), "--quantization " + q + " --sparse",
                                         WorkDir() + "/size.lmdb")
                                : Import(path(), "--quantization " + q + " --compression " + c,
                                         WorkDir() + "/size.sdb");
            }
            const nlohmann::json& info = j["info"];
            const double points = info.value("grid_points", 1.0);
            state.counters["bytes_per_point"] = info.value("bytes_per_grid_point", 0.0);
            if (c == "sparse") {  // the lossless sparse store: vertices kept
              state.counters["kept"] = info.value("kept", 0.0);
              state.counters["domain_vertices"] = info.value("domain_vertices", 0.0);
              return;
            }
            state.counters["error_bytes_per_point"] = info.value("stored_error_bytes", 0.0) / points;
            state.counters["field_bytes_per_point"] = info.value("stored_field_bytes", 0.0) / points;
            // The rest: the 4 KiB header and the block index (40 bytes a
            // block, empty ones included).
            state.counters["index_bytes_per_point"] =
                (info.value("file_bytes", 0.0) - info.value("stored_error_bytes", 0.0) -
                 info.value("stored_field_bytes", 0.0)) / points;
            // The seed's costs with n grid points: 12n error bytes + 2n field
            // bytes in the HT (14n, 7n at one byte a value; section 3.1.3),
            // 48n error bytes in the HP (section 4.1), so 50n, or 25n at one
            // byte a value.
            const bool hp = info.value("hierarchy", "") == "hp";
            state.counters["seed_bytes_per_point"] = hp ? (q == "u8" ? 25 : 50) : (q == "u8" ? 7 : 14);
          })
          ->Iterations(1)
          ->Unit(benchmark::kSecond);
    }
  }
}

// Format 2's finest diamonds: the error of one vertex of the finest octave
// by its stencil (storage/error/finest_diamonds.h), over a random field in
// memory; vertices cycle through the finest octave of the grid.
template <int D>
void RegisterFinestDiamonds(uint32_t side) {
  benchmark::RegisterBenchmark(
      (std::string(D == 3 ? "FinestDiamondError/ht" : "FinestDiamondError/hp") + std::to_string(side)).c_str(),
      [side](benchmark::State& state) {
        int k = 1;
        while ((uint32_t{1} << k) + 1 < side) ++k;
        std::array<int64_t, D> dims{};
        uint64_t n = 1;
        for (int a = 0; a < D; ++a) {
          dims[a] = side;
          n *= side;
        }
        std::vector<double> values(n);
        std::mt19937_64 rng(1);
        for (double& v : values) v = static_cast<double>(rng() % 256);
        const auto field = [&](const std::array<int64_t, D>& p) {
          uint64_t i = 0;
          for (int a = D - 1; a >= 0; --a) i = i * side + static_cast<uint64_t>(p[a]);
          return values[i];
        };
        std::vector<std::array<int64_t, D>> vertices;
        for (uint64_t i = 0; i < n && vertices.size() < 65536; ++i) {
          std::array<int64_t, D> g{};
          uint64_t r = i;
          bool odd = false;
          for (int a = 0; a < D; ++a, r /= side) {
            g[a] = static_cast<int64_t>(r % side);
            odd = odd || (g[a] & 1);
          }
          if (odd) vertices.push_back(g);
        }
        const auto& diamonds = FinestDiamonds<D>::Get();
        size_t i = 0;
        for (auto _ : state) {
          benchmark::DoNotOptimize(diamonds.Error(vertices[i], k, dims, field));
          i = (i + 1) % vertices.size();
        }
      });
  // The flat stencils over the same field, interior vertices only.
  benchmark::RegisterBenchmark(
      (std::string(D == 3 ? "FinestDiamondStencil/ht" : "FinestDiamondStencil/hp") + std::to_string(side)).c_str(),
      [side](benchmark::State& state) {
        std::array<int64_t, D> strides{};
        uint64_t n = 1;
        for (int a = 0; a < D; ++a) {
          strides[a] = static_cast<int64_t>(n);
          n *= side;
        }
        std::vector<double> values(n);
        std::mt19937_64 rng(1);
        for (double& v : values) v = static_cast<double>(rng() % 256);
        struct Vertex {
          uint64_t index;
          uint32_t odd, parity;
        };
        std::vector<Vertex> vertices;
        for (uint64_t i = 0; i < n && vertices.size() < 65536; ++i) {
          uint32_t odd = 0, parity = 0;
          bool interior = true;
          for (int a = 0; a < D; ++a) {
            const int64_t g = static_cast<int64_t>(i / static_cast<uint64_t>(strides[a]) % side);
            interior = interior && g >= 2 && g + 3 <= static_cast<int64_t>(side);
            odd |= static_cast<uint32_t>(g & 1) << a;
            parity |= static_cast<uint32_t>((g >> 1) & 1) << a;
          }
          if (interior && odd != 0) vertices.push_back({i, odd, parity});
        }
        const DiamondStencils<D> stencils(FinestDiamonds<D>::Get(), strides);
        size_t i = 0;
        for (auto _ : state) {
          const Vertex& v = vertices[i];
          benchmark::DoNotOptimize(stencils.InteriorError(values.data() + v.index, v.odd, v.parity));
          i = (i + 1) % vertices.size();
        }
      });
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) {
  simplexdb::RegisterLookups();
  simplexdb::RegisterSparseLookups();
  simplexdb::RegisterBuilds();
  simplexdb::RegisterSizes();
  simplexdb::RegisterFinestDiamonds<3>(65);
  simplexdb::RegisterFinestDiamonds<4>(17);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::filesystem::remove_all(simplexdb::WorkDir());
  return 0;
}
