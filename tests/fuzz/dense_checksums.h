// Recomputes every checksum of a (possibly damaged) format-2 store in place
// (docs/format/dense-store.md): each block's and brick's, the bitmap's,
// the two indexes' and the header's, wherever the offsets the damaged
// header and indexes give stay inside the bytes. Damage then gets past the checksums and reaches the
// structural checks behind them: the fuzz target and the damage tests use it.
#ifndef SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_
#define SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_

#include <cstdint>
#include <span>
#include <vector>

#include "storage/dense/dense_format.h"
#include "storage/io/checksum.h"
#include "util/little_endian.h"

namespace simplexdb::fuzz {

inline void RepairDenseChecksums(std::vector<uint8_t>& f) {
  if (f.size() < kDenseHeaderSize) return;
  uint8_t* h = f.data();
  const auto inside = [&](uint64_t offset, uint64_t bytes) {
    return offset <= f.size() && bytes <= f.size() - offset;
  };
  const uint64_t virtual_blocks = LoadLittle<uint64_t>(h + 152);
  const uint64_t stored_blocks = LoadLittle<uint64_t>(h + 160);
  const uint64_t bitmap_offset = LoadLittle<uint64_t>(h + 168);
  const uint64_t index_offset = LoadLittle<uint64_t>(h + 176);
  const uint64_t words = virtual_blocks / 64 + (virtual_blocks % 64 != 0 ? 1 : 0);
  if (words <= f.size() / 8 && inside(bitmap_offset, 8 * words)) {
    StoreLittle(h + 192, Checksum(std::span<const uint8_t>(h + bitmap_offset, 8 * words)));
  }
  // Each entry's data, then the index itself.
  const auto repair_index = [&](uint64_t offset, uint64_t count, size_t checksum_at) {
    if (count > f.size() / kDenseIndexEntrySize || !inside(offset, count * kDenseIndexEntrySize)) return;
    for (uint64_t i = 0; i < count; ++i) {
      uint8_t* e = h + offset + i * kDenseIndexEntrySize;
      const uint64_t at = LoadLittle<uint64_t>(e);
      const uint64_t stored = LoadLittle<uint32_t>(e + 8);
      if (inside(at, stored)) StoreLittle(e + 16, Checksum(std::span<const uint8_t>(h + at, stored)));
    }
    StoreLittle(h + checksum_at,
                Checksum(std::span<const uint8_t>(h + offset, count * kDenseIndexEntrySize)));
  };
  repair_index(index_offset, stored_blocks, 200);
  repair_index(LoadLittle<uint64_t>(h + 216), LoadLittle<uint64_t>(h + 208), 224);
  StoreLittle(h + kDenseHeaderSize - 8, Checksum(std::span<const uint8_t>(h, kDenseHeaderSize - 8)));
}

}  // namespace simplexdb::fuzz

#endif  // SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_
