#include "storage/io/checksum.h"

#include <xxhash.h>

namespace simplexdb {

uint64_t Checksum(std::span<const uint8_t> bytes, uint64_t seed) {
  // XXH3_64bits_withSeed with seed 0 is XXH3_64bits, bit for bit.
  return XXH3_64bits_withSeed(bytes.data(), bytes.size(), static_cast<XXH64_hash_t>(seed));
}

}  // namespace simplexdb
