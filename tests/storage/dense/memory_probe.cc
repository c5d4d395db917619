// memory_probe STORE CACHE_BYTES LOOKUPS: opens a dense store with a cache
// budget, looks up the errors of LOOKUPS random nodes (random levels, every
// root) and the field at LOOKUPS random points, and prints the process's
// anonymous memory (RssAnon) before opening and after the lookups, in KiB,
// with the number of blocks decoded:
//
//   anon_before_kib=1234 anon_after_kib=2345 blocks_decoded=678
//
// A separate process, so the measurement starts from a clean heap (see
// memory_test.cc, which runs it).
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>

#include "storage/dense/dense_store.h"

namespace simplexdb {
namespace {

long AnonKib() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "RssAnon:") {
      long kib = -1;
      status >> kib;
      return kib;
    }
    status.ignore(1 << 16, '\n');
  }
  return -1;
}

template <int D, class Store>
Status Lookups(const Store& store, uint64_t count) {
  typename Store::template Reader<D> reader(store);
  std::mt19937_64 rng(7);
  const int leaf = store.header().leaf_level();
  const int64_t side = int64_t{1} << store.header().domain_bits;
  for (uint64_t i = 0; i < count; ++i) {
    const int level = static_cast<int>(rng() % leaf);
    const uint64_t path = level == 0 ? 0 : rng() >> (64 - level);
    const auto code =
        SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots), path, level);
    SDB_ASSIGN_OR_RETURN(const double error, reader.ErrorBound(code));
    std::array<int64_t, D> p{};
    for (auto& x : p) x = static_cast<int64_t>(rng() % static_cast<uint64_t>(side + 1));
    SDB_ASSIGN_OR_RETURN(const double value, reader.Field(p));
    if (error < 0 || value != value) return Status::Corruption("impossible answer");
  }
  return Status::OK();
}

// Opens the store with the cache budget, runs the lookups, prints the line.
template <class Store>
int Probe(const char* path, size_t cache_bytes, uint64_t count, long before) {
  typename Store::Options options;
  options.cache_bytes = cache_bytes;
  auto store = Store::Open(path, options);
  if (!store.ok()) {
    std::fprintf(stderr, "%s\n", store.status().ToString().c_str());
    return 1;
  }
  const Status s = (*store)->dimension() == 3 ? Lookups<3>(**store, count)
                                              : Lookups<4>(**store, count);
  if (!s.ok()) {
    std::fprintf(stderr, "%s\n", s.ToString().c_str());
    return 1;
  }
  std::printf("anon_before_kib=%ld anon_after_kib=%ld blocks_decoded=%llu\n", before, AnonKib(),
              static_cast<unsigned long long>((*store)->stats().blocks_decoded));
  return 0;
}

int Main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: memory_probe STORE CACHE_BYTES LOOKUPS\n");
    return 2;
  }
  const long before = AnonKib();
  const size_t cache_bytes = std::strtoull(argv[2], nullptr, 10);
  const uint64_t count = std::strtoull(argv[3], nullptr, 10);
  return Probe<DenseStore>(argv[1], cache_bytes, count, before);
}

}  // namespace
}  // namespace simplexdb

int main(int argc, char** argv) { return simplexdb::Main(argc, argv); }
