// VertexSet: a set of vertices of the (2^k + 1)^D domain grid, as one bit
// per grid point, keyed like the sparse store's field (the point's index, x
// fastest). Memory: (2^k + 1)^D / 8 bytes (17 MiB for a 513^3 domain).
//
// Thread safety: none; one owner.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <vector>

namespace simplexdb {

class VertexSet {
 public:
  VertexSet(int dimension, int domain_bits) {
    uint64_t points = 1;
    for (int c = 0; c < dimension; ++c) points *= (uint64_t{1} << domain_bits) + 1;
    points_ = points;
    words_.assign((points + 63) / 64, 0);
  }

  uint64_t points() const { return points_; }
  uint64_t size() const { return size_; }

  // REQUIRES: key < points().
  void Insert(uint64_t key) {
    uint64_t& w = words_[key >> 6];
    const uint64_t bit = uint64_t{1} << (key & 63);
    size_ += (w & bit) == 0;
    w |= bit;
  }
  bool Contains(uint64_t key) const {
    return key < points_ && (words_[key >> 6] >> (key & 63) & 1) != 0;
  }

  // Calls f(key) for every member, in increasing order.
  template <class F>
  void ForEach(F&& f) const {
    for (uint64_t i = 0; i < words_.size(); ++i) {
      for (uint64_t w = words_[i]; w != 0; w &= w - 1) f(i * 64 + std::countr_zero(w));
    }
  }

 private:
  uint64_t points_ = 0;
  uint64_t size_ = 0;
  std::vector<uint64_t> words_;
};

// The 2^D corners of the domain [0, 2^k]^D: the vertices of the roots.
template <int D>
std::array<std::array<int64_t, D>, (1 << D)> DomainCorners(int domain_bits) {
  std::array<std::array<int64_t, D>, (1 << D)> out{};
  for (int m = 0; m < (1 << D); ++m) {
    for (int c = 0; c < D; ++c) out[m][c] = (m >> c & 1) ? int64_t{1} << domain_bits : 0;
  }
  return out;
}

}  // namespace simplexdb
