// libFuzzer target for the sparse store reader of format 2: the check of the
// LMDB file before LMDB maps it (storage/io/lmdb_check.cc), the header, block
// decoding and rebuilding, lookups and Verify (storage/sparse/
// sparse_store.cc, sparse_format.cc).
//
// Each input is an LMDB file. The reader must answer or fail cleanly: no
// crash, no read out of bounds, no unbounded allocation. The input lives in
// a memfd (tests/fuzz/memory_file.h), beside which no lock file can be
// made, so the reader runs without one (MDB_NOLOCK), as on a full disk.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target sparse_store_reader_fuzz
//                  build/fuzz/tests/sparse_store_reader_fuzz tests/fuzz/corpus/sparse_store_reader
//   Replay (ctest): sparse_store_reader_fuzz_replay runs every saved input.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "hierarchy/simplex_code.h"
#include "storage/sparse/sparse_store.h"
#include "tests/fuzz/memory_file.h"
#include "tests/fuzz/store_probe.h"

namespace simplexdb {
namespace {

template <int D>
void Exercise(const SparseStore& store) {
  typename SparseStore::Reader<D> reader(store);
  fuzz::ForSampledNodes<D>(D * store.header().domain_bits, 2048,
                           [&](SimplexCode<D> c) { (void)reader.ErrorBound(c); });
  fuzz::ForSampledPoints<D>(store.header().domain_bits, 256, [&](const auto& p) { (void)reader.Field(p); });
  (void)store.Verify();
}

}  // namespace
}  // namespace simplexdb

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const simplexdb::fuzz::MemoryFile file(data, size);
  if (!file.ok()) return 0;
  simplexdb::SparseStore::Options options;
  options.cache_bytes = size_t{8} << 20;
  auto store = simplexdb::SparseStore::Open(file.path(), options);
  if (!store.ok()) return 0;
  const auto& h = (*store)->header();
  // Bounded work: the loops above, and Verify's walk over a block's positions.
  if (h.domain_bits > (h.dimension == 3 ? 8 : 5) || h.block_bits > 20) return 0;
  if (h.dimension == 3) {
    simplexdb::Exercise<3>(**store);
  } else {
    simplexdb::Exercise<4>(**store);
  }
  return 0;
}
