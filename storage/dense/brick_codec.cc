#include "storage/dense/brick_codec.h"

#include <cassert>
#include <vector>

namespace simplexdb {
namespace {

// The w-bit integer a voxel codes as: integers as they are (two's
// complement bits for the signed ones; the predictor works modulo 2^w, so
// the sign needs no care), floats by the order-preserving map.
struct Width {
  int bytes = 1;
  bool is_float = false;
  uint64_t mask() const { return bytes == 8 ? ~uint64_t{0} : (uint64_t{1} << (8 * bytes)) - 1; }
  uint64_t sign() const { return uint64_t{1} << (8 * bytes - 1); }
};

uint64_t ToOrdered(uint64_t bits, const Width& w) {
  if (!w.is_float) return bits;
  return (bits & w.sign()) != 0 ? ~bits & w.mask() : bits | w.sign();
}

uint64_t FromOrdered(uint64_t u, const Width& w) {
  if (!w.is_float) return u;
  return (u & w.sign()) != 0 ? u & ~w.sign() : ~u & w.mask();
}

uint64_t ZigZag(uint64_t r, const Width& w) {
  const int shift = 64 - 8 * w.bytes;
  const int64_t s = static_cast<int64_t>(r << shift) >> shift;  // sign-extended
  return ((static_cast<uint64_t>(s) << 1) ^ static_cast<uint64_t>(s >> 63)) & w.mask();
}

uint64_t UnZigZag(uint64_t z, const Width& w) {
  return ((z >> 1) ^ (~(z & 1) + 1)) & w.mask();
}

// Calls f(base, inner, len) for each line along `axis`: the line's voxels
// are base + j * inner for j in [0, len).
template <class F>
void ForEachLine(const std::array<uint32_t, 4>& extent, int axis, size_t n, F&& f) {
  size_t inner = 1;
  for (int a = 0; a < axis; ++a) inner *= extent[a];
  const size_t len = extent[axis];
  for (size_t outer = 0; outer < n; outer += inner * len) {
    for (size_t i = 0; i < inner; ++i) f(outer + i, inner, len);
  }
}

std::vector<uint64_t>& Scratch(size_t n) {
  thread_local std::vector<uint64_t> values;
  values.resize(n);
  return values;
}

}  // namespace

size_t BrickVoxels(int dimension, const std::array<uint32_t, 4>& extent) {
  size_t n = 1;
  for (int a = 0; a < dimension; ++a) n *= extent[a];
  return n;
}

void PredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                  std::span<const uint8_t> voxels, std::span<uint8_t> coded) {
  const Width w{static_cast<int>(VoxelSize(type)), IsFloatType(type)};
  const size_t n = BrickVoxels(dimension, extent);
  assert(voxels.size() == n * w.bytes && coded.size() == voxels.size());
  std::vector<uint64_t>& v = Scratch(n);
  for (size_t i = 0; i < n; ++i) {
    uint64_t bits = 0;
    for (int b = 0; b < w.bytes; ++b) bits |= uint64_t{voxels[i * w.bytes + b]} << (8 * b);
    v[i] = ToOrdered(bits, w);
  }
  // Differences along each axis, last point first so that each subtracts
  // its neighbor's value before that neighbor changes.
  for (int axis = 0; axis < dimension; ++axis) {
    ForEachLine(extent, axis, n, [&](size_t base, size_t inner, size_t len) {
      for (size_t j = len; j-- > 1;) v[base + j * inner] -= v[base + (j - 1) * inner];
    });
  }
  for (size_t i = 0; i < n; ++i) {
    const uint64_t z = ZigZag(v[i] & w.mask(), w);
    for (int b = 0; b < w.bytes; ++b) coded[b * n + i] = static_cast<uint8_t>(z >> (8 * b));
  }
}

void UnpredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                    std::span<const uint8_t> coded, std::span<uint8_t> voxels) {
  const Width w{static_cast<int>(VoxelSize(type)), IsFloatType(type)};
  const size_t n = BrickVoxels(dimension, extent);
  assert(voxels.size() == n * w.bytes && coded.size() == voxels.size());
  std::vector<uint64_t>& v = Scratch(n);
  for (size_t i = 0; i < n; ++i) {
    uint64_t z = 0;
    for (int b = 0; b < w.bytes; ++b) z |= uint64_t{coded[b * n + i]} << (8 * b);
    v[i] = UnZigZag(z, w);
  }
  // Prefix sums undo the differences (they commute, so any axis order).
  for (int axis = 0; axis < dimension; ++axis) {
    ForEachLine(extent, axis, n, [&](size_t base, size_t inner, size_t len) {
      for (size_t j = 1; j < len; ++j) v[base + j * inner] += v[base + (j - 1) * inner];
    });
  }
  for (size_t i = 0; i < n; ++i) {
    const uint64_t bits = FromOrdered(v[i] & w.mask(), w);
    for (int b = 0; b < w.bytes; ++b) voxels[i * w.bytes + b] = static_cast<uint8_t>(bits >> (8 * b));
  }
}

}  // namespace simplexdb
