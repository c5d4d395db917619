// Recomputes every checksum of a (possibly damaged) format-2 store in place
// (docs/format/dense-store-2.md): each block's, the bitmap's, the index's
// and the header's, wherever the offsets the damaged header and index give
// stay inside the bytes. Damage then gets past the checksums and reaches the
// structural checks behind them: the fuzz target and the damage tests use it.
#ifndef SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_
#define SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_

#include <cstdint>
#include <span>
#include <vector>

#include "storage/dense/hz_format.h"
#include "storage/io/checksum.h"
#include "util/little_endian.h"

namespace simplexdb::fuzz {

inline void RepairHzChecksums(std::vector<uint8_t>& f) {
  if (f.size() < kHzHeaderSize) return;
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
  if (stored_blocks <= f.size() / kHzIndexEntrySize &&
      inside(index_offset, stored_blocks * kHzIndexEntrySize)) {
    for (uint64_t b = 0; b < stored_blocks; ++b) {
      uint8_t* e = h + index_offset + b * kHzIndexEntrySize;
      const uint64_t offset = LoadLittle<uint64_t>(e);
      const uint64_t stored = LoadLittle<uint32_t>(e + 8);
      if (inside(offset, stored)) {
        StoreLittle(e + 16, Checksum(std::span<const uint8_t>(h + offset, stored)));
      }
    }
    StoreLittle(h + 200, Checksum(std::span<const uint8_t>(h + index_offset,
                                                            stored_blocks * kHzIndexEntrySize)));
  }
  StoreLittle(h + kHzHeaderSize - 8, Checksum(std::span<const uint8_t>(h, kHzHeaderSize - 8)));
}

}  // namespace simplexdb::fuzz

#endif  // SIMPLEXDB_TESTS_FUZZ_HZ_CHECKSUMS_H_
