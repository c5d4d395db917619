// libFuzzer target for the sparse (LMDB) store reader: the check of the
// LMDB file before LMDB maps it (storage/io/lmdb_check.cc), the header, and
// lookups and verification through LMDB (storage/sparse/sparse_store.cc).
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

namespace simplexdb {
namespace {

template <int D>
void Exercise(const SparseStore& store) {
  auto reader = SparseStore::Reader<D>::Create(store);
  if (!reader.ok()) return;
  const int leaf = store.header().leaf_level();
  int budget = 2048;  // bounded work per input
  for (int top = 0; top < SimplexCode<D>::kRoots && budget > 0; ++top) {
    for (int l = 0; l < leaf && budget > 0; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l) && --budget > 0; p += 1 + (p * 5) % 7) {
        (void)reader->ErrorBound(SimplexCode<D>::FromPath(top, p, l));
      }
    }
    (void)reader->Prefetch(SimplexCode<D>::Root(top), 256);
  }
  const int64_t side = int64_t{1} << store.header().domain_bits;
  for (int64_t i = 0; i < 256; ++i) {
    std::array<int64_t, D> p{};
    for (int c = 0; c < D; ++c) p[c] = (i * (7 + 2 * c)) % (side + 1);
    (void)reader->Field(p);
  }
  (void)store.Verify();
}

}  // namespace
}  // namespace simplexdb

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const simplexdb::fuzz::MemoryFile file(data, size);
  if (!file.ok()) return 0;
  auto store = simplexdb::SparseStore::Open(file.path());
  if (!store.ok()) return 0;
  if ((*store)->header().domain_bits > 12) return 0;  // bounded work: the loops above
  if ((*store)->dimension() == 3) {
    simplexdb::Exercise<3>(**store);
  } else {
    simplexdb::Exercise<4>(**store);
  }
  return 0;
}
