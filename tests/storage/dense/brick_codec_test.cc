// The brick codec against independent truth: every voxel comes back bit for
// bit (all six types, NaN payloads, -0, infinities, denormals; full and
// partial bricks, 3D and 4D), and each coded voxel is the Lorenzo residual
// its header promises, computed here directly by inclusion-exclusion over
// the unit cell's corners, zigzagged and byte-shuffled.
#include "storage/dense/brick_codec.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace simplexdb {
namespace {

constexpr VoxelType kTypes[] = {VoxelType::kU8,  VoxelType::kI8,  VoxelType::kU16,
                                VoxelType::kI16, VoxelType::kF32, VoxelType::kF64};

// Random voxel bytes: for floats, a mix of smooth values and the special
// bit patterns.
std::vector<uint8_t> RandomVoxels(VoxelType type, size_t n, std::mt19937_64& rng) {
  const size_t w = VoxelSize(type);
  std::vector<uint8_t> bytes(n * w);
  for (size_t i = 0; i < n; ++i) {
    uint64_t bits = rng();
    if (type == VoxelType::kF32) {
      const float specials[] = {0.0f, -0.0f, std::numeric_limits<float>::infinity(),
                                -std::numeric_limits<float>::infinity(),
                                std::numeric_limits<float>::denorm_min(), 1.5f, -2.25f};
      const uint32_t r = static_cast<uint32_t>(bits);
      bits = r % 4 == 0 ? std::bit_cast<uint32_t>(specials[(r >> 8) % 7])
             : r % 4 == 1 ? (0x7fc00000u | (r >> 12))  // NaN with a payload
                          : std::bit_cast<uint32_t>(static_cast<float>(i) * 0.25f - 7.0f);
    } else if (type == VoxelType::kF64) {
      bits = bits % 3 == 0 ? std::bit_cast<uint64_t>(-0.0)
             : bits % 3 == 1 ? (0xfff8000000000000ull | (bits >> 20))
                             : std::bit_cast<uint64_t>(static_cast<double>(i) * 1e-3 - 1.0);
    }
    for (size_t b = 0; b < w; ++b) bytes[i * w + b] = static_cast<uint8_t>(bits >> (8 * b));
  }
  return bytes;
}

// The voxel's integer in the predictor's domain, from its header: the bits,
// or for floats the order-preserving map.
uint64_t Ordered(VoxelType type, const uint8_t* p) {
  const size_t w = VoxelSize(type);
  uint64_t bits = 0;
  for (size_t b = 0; b < w; ++b) bits |= uint64_t{p[b]} << (8 * b);
  if (!IsFloatType(type)) return bits;
  const uint64_t sign = uint64_t{1} << (8 * w - 1);
  const uint64_t mask = w == 8 ? ~uint64_t{0} : (uint64_t{1} << (8 * w)) - 1;
  return (bits & sign) != 0 ? ~bits & mask : bits | sign;
}

void ExpectRoundTrip(VoxelType type, int dimension, std::array<uint32_t, 4> extent, uint64_t seed) {
  SCOPED_TRACE(std::string(VoxelTypeName(type)) + " " + std::to_string(extent[0]) + "x" +
               std::to_string(extent[1]) + "x" + std::to_string(extent[2]) + "x" +
               std::to_string(extent[3]));
  std::mt19937_64 rng(seed);
  const size_t n = BrickVoxels(dimension, extent), w = VoxelSize(type);
  const std::vector<uint8_t> voxels = RandomVoxels(type, n, rng);
  std::vector<uint8_t> coded(voxels.size()), back(voxels.size());
  PredictBrick(type, dimension, extent, voxels, coded);
  UnpredictBrick(type, dimension, extent, coded, back);
  ASSERT_EQ(back, voxels);

  // Each coded voxel against the residual computed directly.
  const uint64_t mask = w == 8 ? ~uint64_t{0} : (uint64_t{1} << (8 * w)) - 1;
  std::array<size_t, 4> stride{1, 1, 1, 1};
  for (int a = 1; a < 4; ++a) stride[a] = stride[a - 1] * (a - 1 < dimension ? extent[a - 1] : 1);
  for (size_t i = 0; i < n; ++i) {
    std::array<uint32_t, 4> c{};
    for (int a = 0; a < dimension; ++a) c[a] = static_cast<uint32_t>(i / stride[a] % extent[a]);
    uint64_t residual = 0;
    for (uint32_t corner = 0; corner < (1u << dimension); ++corner) {
      size_t j = i;
      bool inside = true;
      for (int a = 0; a < dimension; ++a) {
        if ((corner >> a) & 1) {
          inside = inside && c[a] > 0;
          j -= stride[a];
        }
      }
      if (!inside) continue;
      const uint64_t v = Ordered(type, &voxels[j * w]);
      residual += std::popcount(corner) % 2 == 0 ? v : ~v + 1;  // +- by inclusion-exclusion
    }
    residual &= mask;
    const int64_t s = static_cast<int64_t>(residual << (64 - 8 * w)) >> (64 - 8 * w);
    const uint64_t zig = (s >= 0 ? 2 * static_cast<uint64_t>(s) : 2 * (~static_cast<uint64_t>(s)) + 1) & mask;
    uint64_t got = 0;
    for (size_t b = 0; b < w; ++b) got |= uint64_t{coded[b * n + i]} << (8 * b);
    ASSERT_EQ(got, zig) << "voxel " << i;
  }
}

TEST(BrickCodec, RoundTripsEveryTypeAndMatchesTheLorenzoResiduals) {
  uint64_t seed = 1;
  for (const VoxelType t : kTypes) {
    ExpectRoundTrip(t, 3, {16, 16, 16, 1}, seed++);
    ExpectRoundTrip(t, 3, {5, 1, 3, 1}, seed++);  // a partial brick, a flat axis
    ExpectRoundTrip(t, 3, {1, 1, 1, 1}, seed++);
    ExpectRoundTrip(t, 4, {8, 8, 8, 8}, seed++);
    ExpectRoundTrip(t, 4, {3, 7, 2, 5}, seed++);
  }
}

// A field linear in the coordinates leaves residuals only on the brick's
// lower faces (there the predictor has fewer corners): the interior codes
// to zero.
TEST(BrickCodec, LinearFieldsCodeToZeroInside) {
  const std::array<uint32_t, 4> extent{6, 5, 4, 1};
  std::vector<uint8_t> voxels;
  for (uint32_t z = 0; z < 4; ++z)
    for (uint32_t y = 0; y < 5; ++y)
      for (uint32_t x = 0; x < 6; ++x) {
        const uint16_t v = static_cast<uint16_t>(1000 + 3 * x - 7 * y + 11 * z);
        voxels.push_back(static_cast<uint8_t>(v));
        voxels.push_back(static_cast<uint8_t>(v >> 8));
      }
  std::vector<uint8_t> coded(voxels.size());
  PredictBrick(VoxelType::kU16, 3, extent, voxels, coded);
  const size_t n = 6 * 5 * 4;
  for (uint32_t z = 1; z < 4; ++z)
    for (uint32_t y = 1; y < 5; ++y)
      for (uint32_t x = 1; x < 6; ++x) {
        const size_t i = x + 6 * (y + 5 * z);
        EXPECT_EQ(coded[i], 0) << i;
        EXPECT_EQ(coded[n + i], 0) << i;
      }
}

}  // namespace
}  // namespace simplexdb
