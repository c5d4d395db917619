// The finest octave's errors computed box by box from a window of the field
// (what format 2's next reader does) against the builder's table
// (DiamondErrors): bit for bit, for every finest vertex whose diamond
// reaches the real grid, on cubic, padded and short-axis grids, HT and HP,
// integer and float, with boxes that do and do not divide the grid.
#include "storage/error/finest_box_errors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/error/diamond_errors.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TestVolume;

float RoundUp(double e) {
  float f = static_cast<float>(e);
  if (static_cast<double>(f) < e) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

template <int D>
void ExpectBuildersErrors(const TestVolume& volume, bool exact, int64_t box) {
  SCOPED_TRACE("box " + std::to_string(box));
  int k = 1;
  std::array<int64_t, D> dims{}, strides{};
  int64_t n = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = volume.dims[a];
    while ((int64_t{1} << k) + 1 < dims[a]) ++k;
    strides[a] = n;
    n *= dims[a];
  }
  const auto [lo, hi] = std::minmax_element(volume.values.begin(), volume.values.end());
  DiamondErrors<D> table(volume.values.data(), dims, k, exact, *hi - *lo, 1);
  table.Allocate();
  for (uint64_t i = 0; i < table.item_count(); ++i) table.ComputeItem(0, i);
  table.Finish();
  const HzOrder<D> order(k);

  const FinestBoxErrors<D> boxes(box);
  const int64_t side = int64_t{1} << k, w = boxes.window_side();
  std::vector<double> window(boxes.window_points()), out;
  // Boxes tiling the vertices whose diamonds can reach the real grid.
  std::array<int64_t, D> reach{}, first{};
  for (int a = 0; a < D; ++a) reach[a] = std::min(side, dims[a] + 1) + 1;
  uint64_t compared = 0;
  while (true) {
    std::array<int64_t, D> extent{};
    uint64_t count = 1;
    for (int a = 0; a < D; ++a) {
      extent[a] = std::min(box, reach[a] - first[a]);
      count *= static_cast<uint64_t>(extent[a]);
    }
    // The window: real points from the volume, the rest NaN (never read).
    for (uint64_t i = 0; i < window.size(); ++i) {
      bool real = true;
      int64_t index = 0;
      uint64_t rest = i;
      for (int a = 0; a < D; ++a) {
        const int64_t p = first[a] - 2 + static_cast<int64_t>(rest % static_cast<uint64_t>(w));
        rest /= static_cast<uint64_t>(w);
        real = real && p >= 0 && p < dims[a];
        index += p * strides[a];
      }
      window[i] = real ? volume.values[static_cast<size_t>(index)]
                       : std::numeric_limits<double>::quiet_NaN();
    }
    out.assign(count, -1);
    boxes.Compute(first, extent, k, dims, window.data(), out.data());
    std::array<int64_t, D> local{};
    for (uint64_t slot = 0; slot < count; ++slot) {
      std::array<int64_t, D> g{};
      bool finest = false;
      for (int a = 0; a < D; ++a) {
        g[a] = first[a] + local[a];
        finest = finest || (g[a] & 1) != 0;
      }
      if (finest) {
        const float want = static_cast<float>(table.At(g, order.PositionAtLevel(g, order.Level(g))));
        ASSERT_EQ(RoundUp(out[slot]), want) << ::testing::PrintToString(g);
        ++compared;
      } else {
        ASSERT_EQ(out[slot], 0.0) << ::testing::PrintToString(g);
      }
      for (int a = 0; a < D; ++a) {
        if (++local[a] < extent[a]) break;
        local[a] = 0;
      }
    }
    int a = 0;
    for (; a < D; ++a) {
      first[a] += box;
      if (first[a] < reach[a]) break;
      first[a] = 0;
    }
    if (a == D) break;
  }
  EXPECT_GT(compared, 0u);
}

TEST(FinestBoxErrors, HtEqualsTheBuildersTable) {
  ExpectBuildersErrors<3>(TestVolume::Random(3, {33, 33, 33, 1}, VoxelType::kU8, 31), true, 16);
  ExpectBuildersErrors<3>(TestVolume::Random(3, {21, 9, 14, 1}, VoxelType::kF32, 32), false, 8);
  ExpectBuildersErrors<3>(TestVolume::Random(3, {17, 3, 30, 1}, VoxelType::kI16, 33), true, 5);
}

TEST(FinestBoxErrors, HpEqualsTheBuildersTable) {
  ExpectBuildersErrors<4>(TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 34), true, 8);
  ExpectBuildersErrors<4>(TestVolume::Random(4, {11, 5, 7, 4}, VoxelType::kF32, 35), false, 4);
}

}  // namespace
}  // namespace simplexdb
