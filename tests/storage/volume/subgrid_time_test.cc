// The 4D volume made of 3D subgrids (storage/volume/subgrid_time.h), against the
// input's own points: each input value names its grid point, so every output
// value says where it came from.
#include "storage/volume/subgrid_time.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <tuple>

#include "storage/volume/nrrd_writer.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

// A 3D volume whose value at (x, y, z) is x + 100 y + 10000 z.
VolumeInfo CoordinateVolume(const std::string& path, std::array<uint32_t, 4> dims) {
  std::vector<double> values;
  for (uint32_t z = 0; z < dims[2]; ++z) {
    for (uint32_t y = 0; y < dims[1]; ++y) {
      for (uint32_t x = 0; x < dims[0]; ++x) values.push_back(x + 100.0 * y + 10000.0 * z);
    }
  }
  EXPECT_TRUE(WriteNrrd(path, 3, dims, VoxelType::kF32, values).ok());
  return *OpenVolume(path);
}

TEST(SubgridsToTime, EveryPointOfASubgridOnceAlongTime) {
  const testing::TempDir dir;
  // 13 = 3 * 4 + 1 points: three whole subgrids of side 4 and a last point.
  const VolumeInfo in = CoordinateVolume(dir.path() + "/c.nrrd", {13, 9, 13, 1});
  Result<SubgridTimeVolume> out = SubgridsToTime(in, 4, 64);
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  EXPECT_EQ(out->dims, (std::array<uint32_t, 4>{4, 3, 4, 64}));
  const auto& d = out->dims;
  for (uint32_t k = 0; k < d[2]; ++k) {
    for (uint32_t j = 0; j < d[1]; ++j) {
      for (uint32_t i = 0; i < d[0]; ++i) {
        SCOPED_TRACE(::testing::Message() << i << "," << j << "," << k);
        std::set<std::tuple<int, int, int>> seen;
        for (uint32_t t = 0; t < d[3]; ++t) {
          const double v = out->values[((uint64_t{t} * d[2] + k) * d[1] + j) * d[0] + i];
          const int x = static_cast<int>(v) % 100, y = static_cast<int>(v) / 100 % 100,
                    z = static_cast<int>(v) / 10000;
          // Inside the subgrid of (i, j, k), clamped to the grid.
          EXPECT_GE(x, static_cast<int>(4 * i));
          EXPECT_LE(x, std::min<int>(4 * i + 3, 12));
          EXPECT_GE(y, static_cast<int>(4 * j));
          EXPECT_LE(y, std::min<int>(4 * j + 3, 8));
          EXPECT_GE(z, static_cast<int>(4 * k));
          EXPECT_LE(z, std::min<int>(4 * k + 3, 12));
          seen.insert({x, y, z});
        }
        // A whole subgrid shows each of its 64 points once; one cut by the
        // far faces shows each point it has.
        const auto extent = [](uint32_t first, int last) { return std::min<int>(4, last - 4 * static_cast<int>(first) + 1); };
        EXPECT_EQ(seen.size(), static_cast<size_t>(extent(i, 12) * extent(j, 8) * extent(k, 12)));
      }
    }
  }
  // Time step 0 is the subgrid's first corner: the input at step 4.
  EXPECT_EQ(out->values[1 + 4 * (2 + 3 * 3)], 4 + 100 * 8 + 10000 * 12);
}

TEST(SubgridsToTime, TheSeedsSizesAndClearErrors) {
  const testing::TempDir dir;
  const VolumeInfo in = CoordinateVolume(dir.path() + "/c.nrrd", {129, 5, 9, 1});
  Result<SubgridTimeVolume> out = SubgridsToTime(in, 4, 33);
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->dims, (std::array<uint32_t, 4>{33, 2, 3, 33}));
  EXPECT_TRUE(SubgridsToTime(in, 4, 65).status().IsInvalidArgument());
  EXPECT_TRUE(SubgridsToTime(in, 1, 2).status().IsInvalidArgument());
  std::vector<double> four(2 * 2 * 2 * 2, 1.0);
  ASSERT_TRUE(WriteNrrd(dir.path() + "/f.nrrd", 4, {2, 2, 2, 2}, VoxelType::kU8, four).ok());
  const Status s = SubgridsToTime(*OpenVolume(dir.path() + "/f.nrrd"), 4, 8).status();
  EXPECT_TRUE(s.IsInvalidArgument());
  EXPECT_NE(s.message().find("f.nrrd"), std::string::npos) << s.ToString();
}

}  // namespace
}  // namespace simplexdb
