#include "storage/dense/brick_codec.h"

#include <bit>
#include <cassert>
#include <cstring>
#include <type_traits>
#include <vector>

#include "util/little_endian.h"

namespace simplexdb {
namespace {

// The predictor's arithmetic on U, the unsigned integer of the voxel's
// width (modulo 2^w comes with the type): integers as they are (two's
// complement bits for the signed ones, so the sign needs no care), floats
// by the order-preserving map. Each step is a loop over the brick that the
// compiler vectorizes.
template <class U>
constexpr U kSign = static_cast<U>(U{1} << (8 * sizeof(U) - 1));

template <class U>
U ToOrdered(U bits) {
  return (bits & kSign<U>) != 0 ? static_cast<U>(~bits) : static_cast<U>(bits | kSign<U>);
}

template <class U>
U FromOrdered(U u) {
  return (u & kSign<U>) != 0 ? static_cast<U>(u & ~kSign<U>) : static_cast<U>(~u);
}

template <class U>
U ZigZag(U r) {
  using S = std::make_signed_t<U>;
  const U sign = static_cast<U>(static_cast<S>(r) >> (8 * sizeof(U) - 1));  // all ones when negative
  return static_cast<U>(static_cast<U>(r << 1) ^ sign);
}

template <class U>
U UnZigZag(U z) {
  return static_cast<U>((z >> 1) ^ static_cast<U>(U{0} - (z & 1)));
}

template <class U>
std::vector<U>& Scratch(size_t n) {
  thread_local std::vector<U> values;
  values.resize(n);
  return values;
}

// Calls f(outer, inner, len) for each slab of lines along `axis`: the slab's
// lines start at outer + i for i in [0, inner), their voxels are inner
// apart, len of them.
template <class F>
void ForEachSlab(const std::array<uint32_t, 4>& extent, int axis, size_t n, F&& f) {
  size_t inner = 1;
  for (int a = 0; a < axis; ++a) inner *= extent[a];
  const size_t len = extent[axis];
  for (size_t outer = 0; outer < n; outer += inner * len) f(outer, inner, len);
}

// The loops below take __restrict pointers: the voxels are bytes, which may
// alias anything, and the compiler vectorizes only what it knows apart.
template <class U>
void GatherPlane(const uint8_t* __restrict plane, int b, size_t n, U* __restrict v) {
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<U>(v[i] | static_cast<U>(plane[i]) << (8 * b));
}

template <class U>
void ScatterPlane(const U* __restrict v, int b, size_t n, uint8_t* __restrict plane) {
  for (size_t i = 0; i < n; ++i) plane[i] = static_cast<uint8_t>(ZigZag(v[i]) >> (8 * b));
}

template <class U>
void AddLine(const U* __restrict below, size_t n, U* __restrict line) {
  for (size_t i = 0; i < n; ++i) line[i] = static_cast<U>(line[i] + below[i]);
}

template <class U>
void SubtractLine(const U* __restrict below, size_t n, U* __restrict line) {
  for (size_t i = 0; i < n; ++i) line[i] = static_cast<U>(line[i] - below[i]);
}

template <class U>
void PredictTyped(bool is_float, int dimension, const std::array<uint32_t, 4>& extent, size_t n,
                  const uint8_t* voxels, uint8_t* coded) {
  std::vector<U>& values = Scratch<U>(n);
  U* v = values.data();
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(v, voxels, n * sizeof(U));
  } else {
    for (size_t i = 0; i < n; ++i) v[i] = LoadLittle<U>(voxels + i * sizeof(U));
  }
  if (is_float) {
    for (size_t i = 0; i < n; ++i) v[i] = ToOrdered(v[i]);
  }
  // Differences along each axis, last line first so that each subtracts
  // its neighbor's value before that neighbor changes.
  for (int axis = 0; axis < dimension; ++axis) {
    ForEachSlab(extent, axis, n, [v](size_t outer, size_t inner, size_t len) {
      for (size_t j = len; j-- > 1;) SubtractLine(v + outer + (j - 1) * inner, inner, v + outer + j * inner);
    });
  }
  for (size_t b = 0; b < sizeof(U); ++b) ScatterPlane(v, static_cast<int>(b), n, coded + b * n);
}

template <class U>
void UnpredictTyped(bool is_float, int dimension, const std::array<uint32_t, 4>& extent, size_t n,
                    const uint8_t* coded, uint8_t* voxels) {
  std::vector<U>& values = Scratch<U>(n);
  U* v = values.data();
  std::fill(v, v + n, U{0});
  for (size_t b = 0; b < sizeof(U); ++b) GatherPlane(coded + b * n, static_cast<int>(b), n, v);
  for (size_t i = 0; i < n; ++i) v[i] = UnZigZag(v[i]);
  // Prefix sums undo the differences (they commute, so any axis order).
  // Along x, one running sum per row.
  for (size_t row = 0; row < n; row += extent[0]) {
    U sum = 0;
    for (size_t i = row; i < row + extent[0]; ++i) v[i] = sum = static_cast<U>(sum + v[i]);
  }
  for (int axis = 1; axis < dimension; ++axis) {
    ForEachSlab(extent, axis, n, [v](size_t outer, size_t inner, size_t len) {
      for (size_t j = 1; j < len; ++j) AddLine(v + outer + (j - 1) * inner, inner, v + outer + j * inner);
    });
  }
  if (is_float) {
    for (size_t i = 0; i < n; ++i) v[i] = FromOrdered(v[i]);
  }
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(voxels, v, n * sizeof(U));
  } else {
    for (size_t i = 0; i < n; ++i) StoreLittle<U>(voxels + i * sizeof(U), v[i]);
  }
}

// Returns f(W{}) for W the unsigned word of `width` bytes (1, 2, 4 or 8).
template <class F>
void WithWord(size_t width, F&& f) {
  switch (width) {
    case 1: return f(uint8_t{});
    case 2: return f(uint16_t{});
    case 4: return f(uint32_t{});
    default: return f(uint64_t{});
  }
}

}  // namespace

size_t BrickVoxels(int dimension, const std::array<uint32_t, 4>& extent) {
  size_t n = 1;
  for (int a = 0; a < dimension; ++a) n *= extent[a];
  return n;
}

void PredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                  std::span<const uint8_t> voxels, std::span<uint8_t> coded) {
  const size_t n = BrickVoxels(dimension, extent), w = VoxelSize(type);
  assert(voxels.size() == n * w && coded.size() == voxels.size());
  WithWord(w, [&](auto word) {
    PredictTyped<decltype(word)>(IsFloatType(type), dimension, extent, n, voxels.data(), coded.data());
  });
}

void UnpredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                    std::span<const uint8_t> coded, std::span<uint8_t> voxels) {
  const size_t n = BrickVoxels(dimension, extent), w = VoxelSize(type);
  assert(voxels.size() == n * w && coded.size() == voxels.size());
  WithWord(w, [&](auto word) {
    UnpredictTyped<decltype(word)>(IsFloatType(type), dimension, extent, n, coded.data(), voxels.data());
  });
}

}  // namespace simplexdb
