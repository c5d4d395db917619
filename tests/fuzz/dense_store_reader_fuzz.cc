// libFuzzer target for the format-2 store reader: header, presence bitmap,
// index and block decoding (storage/dense/dense_store.cc, dense_format.cc).
//
// Each input is a store file. It is opened as given, and again with every
// checksum repaired (tests/fuzz/dense_checksums.h), so that mutations get past
// the checksums and reach the structural checks behind them. Either way the
// reader must answer or fail cleanly: no crash, no read out of bounds, no
// unbounded allocation.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target dense_store_reader_fuzz
//                  build/fuzz/tests/dense_store_reader_fuzz tests/fuzz/corpus/dense_store_reader
//   Replay (ctest): dense_store_reader_fuzz_replay runs every saved input.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "storage/dense/dense_store.h"
#include "tests/fuzz/dense_checksums.h"
#include "tests/fuzz/memory_file.h"
#include "tests/fuzz/store_probe.h"

namespace simplexdb {
namespace {

template <int D>
void Exercise(const DenseStore& store) {
  DenseStore::Reader<D> reader(store);
  fuzz::ForSampledNodes<D>(store.header().leaf_level(), 4096, [&](SimplexCode<D> c) {
    (void)reader.ErrorBound(c);
    (void)reader.ErrorBoundForThreshold(c, 1.0);
  });
  fuzz::ForSampledPoints<D>(store.header().domain_bits, 512, [&](const auto& p) { (void)reader.Field(p); });
  (void)store.Verify();
}

void OpenAndRead(const uint8_t* data, size_t size) {
  const fuzz::MemoryFile file(data, size);
  if (!file.ok()) return;
  const std::string& path = file.path();
  for (const bool in_memory : {false, true}) {
    DenseStore::Options options;
    options.cache_bytes = 64 << 10;
    options.in_memory = in_memory;
    Result<std::unique_ptr<DenseStore>> store = DenseStore::Open(path, options);
    if (!store.ok()) continue;
    if ((*store)->header().dimension == 3) {
      Exercise<3>(**store);
    } else {
      Exercise<4>(**store);
    }
  }
}

}  // namespace
}  // namespace simplexdb

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  simplexdb::OpenAndRead(data, size);
  std::vector<uint8_t> repaired(data, data + size);
  simplexdb::fuzz::RepairDenseChecksums(repaired);
  simplexdb::OpenAndRead(repaired.data(), repaired.size());
  return 0;
}
