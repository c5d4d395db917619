// Checksums of stored bytes: XXH3-64 (xxHash), the one hash of every
// on-disk format here (the dense store's header, index and blocks; the
// sparse store's content sum). A checksum is part of a format: changing the
// function or the seed changes the format (docs/format/).
//
// Thread safety: pure functions, reentrant. No errors: any span is hashed.
#pragma once

#include <cstdint>
#include <span>

namespace simplexdb {

// XXH3-64 of `bytes` with `seed`; seed 0 is XXH3-64 without a seed.
// O(bytes.size()), several GB/s.
uint64_t Checksum(std::span<const uint8_t> bytes, uint64_t seed = 0);

}  // namespace simplexdb
