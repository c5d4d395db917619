// Octave bricks against brute force: every point of every lattice (the grid
// points at multiples of 2^s) lies in exactly one brick, the one BrickOf
// names, at the slot its place gives; bricks run coarsest lattice first;
// and every brick, in every coding, decodes to the field's values at its
// points, HT and HP, full and partial bricks, integer and float voxels.
#include "storage/dense/field_bricks.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <vector>

namespace simplexdb {
namespace {

std::vector<double> RandomField(const std::array<uint32_t, 4>& dims, VoxelType type, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<double> f(size_t{dims[0]} * dims[1] * dims[2] * dims[3]);
  for (size_t i = 0; i < f.size(); ++i) {
    // Smooth with noise, so that every coding wins somewhere.
    const double smooth = static_cast<double>(i % 97) * 0.5;
    f[i] = type == VoxelType::kF32 ? static_cast<float>(smooth + static_cast<double>(rng() % 1000) * 1e-3)
                                   : static_cast<double>((static_cast<int64_t>(smooth) + rng() % 3) % 200);
  }
  return f;
}

void Check(int dimension, std::array<uint32_t, 4> dims, int k, int side_bits, VoxelType type) {
  SCOPED_TRACE(std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]) +
               "x" + std::to_string(dims[3]) + " side 2^" + std::to_string(side_bits));
  const BrickGrid grid(dimension, dims, k, side_bits);
  const std::vector<double> field = RandomField(dims, type, 5);
  const std::array<int64_t, 4> stride{1, dims[0], int64_t{dims[0]} * dims[1],
                                      int64_t{dims[0]} * dims[1] * dims[2]};
  ASSERT_EQ(grid.lattices(), k + 1);
  // Coarsest first, contiguous.
  uint64_t next = 0;
  for (int s = k; s >= 0; --s) {
    ASSERT_EQ(grid.FirstBrick(s), next);
    next += grid.Count(s);
  }
  ASSERT_EQ(grid.bricks(), next);

  // Each brick's decoded voxels, in every coding.
  ZstdCompressor zstd(3);
  ZstdDecompressor unzstd;
  std::vector<std::vector<double>> decoded(grid.bricks());
  for (uint64_t b = 0; b < grid.bricks(); ++b) {
    const BrickPlace place = grid.Place(b);
    const size_t n = size_t{place.extent[0]} * place.extent[1] * place.extent[2] * place.extent[3];
    ASSERT_LE(n, grid.brick_voxels());
    for (const auto only : {std::optional<BrickCoding>{}, std::optional{BrickCoding::kRaw},
                            std::optional{BrickCoding::kZstd},
                            std::optional{BrickCoding::kZstdPredicted}}) {
      const Result<EncodedBrick> e = EncodeBrick(grid, b, field.data(), type, &zstd, only);
      ASSERT_TRUE(e.ok()) << e.status().message();
      if (only) {
        ASSERT_EQ(e->coding, *only);
      }
      std::vector<uint8_t> voxels(n * VoxelSize(type));
      ASSERT_TRUE(DecodeBrick(e->bytes, e->coding, type, dimension, place.extent, unzstd, voxels, "b").ok());
      std::vector<double> values(n);
      DecodeVoxels(type, ByteOrder::kLittle, reinterpret_cast<const std::byte*>(voxels.data()), n,
                   values.data());
      if (decoded[b].empty()) decoded[b] = values;
      ASSERT_EQ(values, decoded[b]) << "brick " << b;
    }
  }

  // Every lattice point: in the brick and slot BrickOf names, inside that
  // brick's place, holding the field's value; every slot used once.
  std::map<std::pair<uint64_t, size_t>, int> used;
  for (int s = 0; s <= k; ++s) {
    const int64_t step = int64_t{1} << s;
    std::array<int64_t, 4> p{};
    while (true) {
      size_t slot = 0;
      const uint64_t b = grid.BrickOf(s, p, &slot);
      ASSERT_GE(b, grid.FirstBrick(s));
      ASSERT_LT(b, grid.FirstBrick(s) + grid.Count(s));
      const BrickPlace place = grid.Place(b);
      ASSERT_EQ(place.lattice, s);
      size_t expect = 0, scale = 1;
      for (int a = 0; a < 4; ++a) {
        const int64_t local = (p[a] - place.first[a]) / step;
        ASSERT_EQ((p[a] - place.first[a]) % step, 0);
        ASSERT_GE(local, 0);
        ASSERT_LT(local, int64_t{place.extent[a]});
        expect += static_cast<size_t>(local) * scale;
        scale *= place.extent[a];
      }
      ASSERT_EQ(slot, expect);
      ASSERT_EQ(++used[std::make_pair(b, slot)], 1);
      int64_t index = 0;
      for (int a = 0; a < 4; ++a) index += p[a] * stride[a];
      ASSERT_EQ(decoded[b][slot], field[static_cast<size_t>(index)]);
      int a = 0;
      for (; a < dimension; ++a) {
        p[a] += step;
        if (p[a] < int64_t{dims[a]}) break;
        p[a] = 0;
      }
      if (a == dimension) break;
    }
  }
  size_t slots = 0;
  for (const auto& d : decoded) slots += d.size();
  EXPECT_EQ(used.size(), slots);  // no slot holds a point outside its lattice
}

TEST(FieldBricks, HtLatticesBricksAndValues) {
  Check(3, {17, 17, 17, 1}, 4, 2, VoxelType::kU8);
  Check(3, {13, 6, 9, 1}, 4, 2, VoxelType::kF32);  // padded, partial bricks
  Check(3, {33, 20, 5, 1}, 5, 4, VoxelType::kI16);
}

TEST(FieldBricks, HpLatticesBricksAndValues) {
  Check(4, {9, 9, 9, 9}, 3, 2, VoxelType::kU16);
  Check(4, {5, 7, 3, 6}, 3, 1, VoxelType::kF32);
}

TEST(FieldBricks, DamagedFramesAreCorruption) {
  const BrickGrid grid(3, {17, 17, 17, 1}, 4, 3);
  const std::vector<double> field = RandomField({17, 17, 17, 1}, VoxelType::kU8, 9);
  ZstdCompressor zstd(3);
  ZstdDecompressor unzstd;
  const uint64_t b = grid.FirstBrick(0);
  const BrickPlace place = grid.Place(b);
  std::vector<uint8_t> out(512);
  for (const BrickCoding c : {BrickCoding::kZstd, BrickCoding::kZstdPredicted}) {
    EncodedBrick e = *EncodeBrick(grid, b, field.data(), VoxelType::kU8, &zstd, c);
    e.bytes.resize(e.bytes.size() / 2);
    const Status s = DecodeBrick(e.bytes, c, VoxelType::kU8, 3, place.extent, unzstd, out, "s.sdb: brick 9");
    EXPECT_TRUE(s.IsCorruption()) << s.ToString();
    EXPECT_NE(s.message().find("s.sdb: brick 9"), std::string_view::npos);
  }
  const std::vector<uint8_t> short_raw(100);
  EXPECT_TRUE(DecodeBrick(short_raw, BrickCoding::kRaw, VoxelType::kU8, 3, place.extent, unzstd, out, "x")
                  .IsCorruption());
  EXPECT_TRUE(DecodeBrick(short_raw, static_cast<BrickCoding>(7), VoxelType::kU8, 3, place.extent, unzstd,
                          out, "x")
                  .IsCorruption());
}

}  // namespace
}  // namespace simplexdb
