// The lookups the store reader fuzz targets make on a store that opened
// (tests/fuzz/dense_store_reader_fuzz.cc, sparse_store_reader_fuzz.cc):
// nodes and domain points sampled across the whole hierarchy, in bounded
// work per input.
#ifndef SIMPLEXDB_TESTS_FUZZ_STORE_PROBE_H_
#define SIMPLEXDB_TESTS_FUZZ_STORE_PROBE_H_

#include <array>
#include <cstdint>

#include "hierarchy/simplex_code.h"

namespace simplexdb::fuzz {

// Calls f(code) for fewer than `budget` nodes above `leaf`, by root and
// level, skipping along each level's paths (every level reached while the
// budget lasts).
template <int D, class F>
void ForSampledNodes(int leaf, int budget, F&& f) {
  for (int top = 0; top < SimplexCode<D>::kRoots && budget > 0; ++top) {
    for (int l = 0; l < leaf && budget > 0; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l) && --budget > 0; p += 1 + (p * 5) % 7) {
        f(SimplexCode<D>::FromPath(top, p, l));
      }
    }
  }
}

// Calls f(p) for `count` points of the domain [0, 2^domain_bits]^D, spread
// along a different stride per axis.
template <int D, class F>
void ForSampledPoints(int domain_bits, int count, F&& f) {
  const int64_t side = int64_t{1} << domain_bits;
  for (int64_t i = 0; i < count; ++i) {
    std::array<int64_t, D> p{};
    for (int c = 0; c < D; ++c) p[c] = (i * (7 + 2 * c)) % (side + 1);
    f(p);
  }
}

}  // namespace simplexdb::fuzz

#endif  // SIMPLEXDB_TESTS_FUZZ_STORE_PROBE_H_
