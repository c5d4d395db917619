// libFuzzer target for the dense store reader: header, index and block
// decoding (storage/dense/dense_store.cc, storage/dense/format.cc).
//
// Each input is a store file. It is opened as given, and again with every
// checksum repaired (blocks, index, header), so that mutations get past the
// checksums and reach the structural checks behind them. Either way the
// reader must answer or fail cleanly: no crash, no read out of bounds, no
// unbounded allocation.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target store_reader_fuzz
//                  build/fuzz/tests/store_reader_fuzz tests/fuzz/corpus/store_reader
//   Replay (ctest): store_reader_fuzz_replay runs every saved input.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "storage/dense/dense_store.h"
#include "storage/dense/format.h"
#include "storage/io/checksum.h"
#include "tests/fuzz/memory_file.h"
#include "util/little_endian.h"

namespace simplexdb {
namespace {

uint64_t Get64(const uint8_t* p) { return LoadLittle<uint64_t>(p); }
void Put64(uint8_t* p, uint64_t v) { StoreLittle(p, v); }

// Recomputes the checksums the format defines, wherever the offsets the
// (possibly damaged) header and index give stay inside the bytes.
void RepairChecksums(std::vector<uint8_t>& f) {
  if (f.size() < kHeaderSize) return;
  const uint64_t index_offset = Get64(f.data() + 120);
  const uint64_t count = Get64(f.data() + 104) + Get64(f.data() + 112);
  if (index_offset <= f.size() && count <= (f.size() - index_offset) / kIndexEntrySize) {
    for (uint64_t b = 0; b < count; ++b) {
      uint8_t* e = f.data() + index_offset + b * kIndexEntrySize;
      const uint64_t offset = Get64(e);
      const uint64_t stored = LoadLittle<uint32_t>(e + 8);
      if (offset <= f.size() && stored <= f.size() - offset) {
        Put64(e + 16, Checksum(std::span<const uint8_t>(f.data() + offset, stored)));
      }
    }
    Put64(f.data() + 136, Checksum(std::span<const uint8_t>(f.data() + index_offset,
                                                             count * kIndexEntrySize)));
  }
  Put64(f.data() + kHeaderSize - 8,
        Checksum(std::span<const uint8_t>(f.data(), kHeaderSize - 8)));
}

template <int D>
void Exercise(const DenseStore& store) {
  DenseStore::Reader<D> reader(store);
  int budget = 4096;  // bounded work per input
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (--budget < 0 || c.level() > store.header().leaf_level()) return;
    if (!reader.ErrorBound(c).ok()) return;
    if (c.level() < SimplexCode<D>::kMaxLevel) {
      visit(c.child(0));
      visit(c.child(1));
    }
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  const int64_t side = int64_t{1} << store.header().domain_bits;
  for (int64_t i = 0; i < 512; ++i) {
    std::array<int64_t, D> p{};
    for (int c = 0; c < D; ++c) p[c] = (i * (7 + 2 * c)) % (side + 1);
    (void)reader.Field(p);
  }
  (void)store.Verify();
}

void OpenAndRead(const uint8_t* data, size_t size) {
  const fuzz::MemoryFile file(data, size);
  if (!file.ok()) return;
  const std::string& path = file.path();
  for (const bool in_memory : {false, true}) {
    DenseStore::Options options;
    options.cache_bytes = 1 << 20;
    options.in_memory = in_memory;
    Result<std::unique_ptr<DenseStore>> store = DenseStore::Open(path, options);
    if (!store.ok()) continue;
    if ((*store)->dimension() == 3) {
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
  simplexdb::RepairChecksums(repaired);
  simplexdb::OpenAndRead(repaired.data(), repaired.size());
  return 0;
}
