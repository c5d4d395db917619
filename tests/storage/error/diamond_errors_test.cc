// Diamond errors computed octave by octave against brute force: for every
// vertex of small grids (cubic, non-cubic with padding, HT and HP, integer
// and float), the largest brute-force seed error over the nodes whose split
// creates it; whichever order and threads the work items run in, with the
// field as doubles or as its own voxel type; and the finest octave's largest error
// over boxes of vertices.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <thread>
#include <type_traits>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/error/diamond_errors.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TestVolume;

template <int D>
int DomainBits(const TestVolume& volume) {
  int k = 1;
  for (int a = 0; a < D; ++a) {
    while ((int64_t{1} << k) + 1 < volume.dims[a]) ++k;
  }
  return k;
}

// Every node's brute-force error, the largest per split vertex.
template <int D>
std::map<std::array<int64_t, D>, long double> BruteForceDiamonds(const TestVolume& volume, int k) {
  std::map<std::array<int64_t, D>, long double> out;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < D * k; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) {
        const SimplexCode<D> c = SimplexCode<D>::FromPath(top, p, l);
        long double& e = out[LatticeToGrid<D>(SplitVertex(c), k)];
        e = std::max(e, testing::BruteForceError<D>(c, k, volume));
      }
    }
  }
  return out;
}

// `brute`: BruteForceDiamonds(volume, k), computed once per volume (it is
// most of the test's time).
template <int D, class V>
void ExpectBruteForce(const TestVolume& volume, const std::map<std::array<int64_t, D>, long double>& brute,
                      bool exact, int threads, bool reverse) {
  SCOPED_TRACE("threads " + std::to_string(threads) + (reverse ? ", reversed" : "") +
               ", field of " + std::to_string(sizeof(V)) + "-byte " +
               (std::is_floating_point_v<V> ? "floats" : "integers"));
  const int k = DomainBits<D>(volume);
  std::array<int64_t, D> dims{};
  double lo = volume.values[0], hi = volume.values[0];
  for (double v : volume.values) lo = std::min(lo, v), hi = std::max(hi, v);
  for (int a = 0; a < D; ++a) dims[a] = volume.dims[a];
  std::vector<V> field(volume.values.size());
  for (size_t i = 0; i < field.size(); ++i) {
    field[i] = static_cast<V>(volume.values[i]);
    ASSERT_EQ(static_cast<double>(field[i]), volume.values[i]);  // the field as given
  }
  DiamondErrors<D, V> diamonds(field.data(), dims, k, exact, hi - lo, threads);
  diamonds.Allocate();
  std::vector<std::thread> workers;
  const uint64_t n = diamonds.item_count();
  for (int w = 0; w < threads; ++w) {
    workers.emplace_back([&, w] {
      for (uint64_t i = static_cast<uint64_t>(w); i < n; i += static_cast<uint64_t>(threads)) {
        diamonds.ComputeItem(w, reverse ? n - 1 - i : i);
      }
    });
  }
  for (auto& t : workers) t.join();
  diamonds.Finish();

  const HzOrder<D> order(k);
  int nonzero = 0;
  for (const auto& [g, exact_error] : brute) {
    const double e = diamonds.At(g, order.PositionAtLevel(g, order.Level(g)));
    const double want = static_cast<double>(exact_error);
    // The table keeps floats rounded up.
    ASSERT_NEAR(want, e, 1e-6 * std::max(1.0, want)) << ::testing::PrintToString(g);
    ASSERT_GE(e, want * (1 - 1e-12)) << ::testing::PrintToString(g);
    nonzero += e > 0;
  }
  EXPECT_GT(nonzero, 0);

  // FinestBoxMax over boxes of 3 points per axis (odd and even starts)
  // tiling the domain and reaching past it: the brute-force maximum over
  // the finest vertices (some coordinate odd) inside.
  const int64_t side = int64_t{1} << k;
  std::array<int64_t, D> first{}, extent{};
  extent.fill(3);
  int nonzero_boxes = 0;
  while (true) {
    long double want = 0;
    for (int i = 0; i < (1 << (2 * D)); ++i) {  // 3^D <= 4^D offsets, two bits per axis
      std::array<int64_t, D> g{};
      bool finest = false, valid = true;
      for (int a = 0; a < D; ++a) {
        const int64_t offset = (i >> (2 * a)) & 3;
        valid = valid && offset < extent[a];
        g[a] = first[a] + offset;
        finest = finest || (g[a] & 1) != 0;
      }
      const auto it = brute.find(g);
      if (valid && finest && it != brute.end()) want = std::max(want, it->second);
    }
    const double got = diamonds.FinestBoxMax(first, extent);
    ASSERT_NEAR(static_cast<double>(want), got, 1e-9 * std::max(1.0, static_cast<double>(want)))
        << "box at " << ::testing::PrintToString(first);
    nonzero_boxes += want > 0;
    int a = 0;
    for (; a < D; ++a) {
      first[a] += 3;
      if (first[a] <= side) break;
      first[a] = 0;
    }
    if (a == D) break;
  }
  EXPECT_GT(nonzero_boxes, 0);
}

// Once with the field as doubles, once as its own voxels (as the builder
// holds it).
template <int D>
void ExpectBruteForce(const TestVolume& volume, bool exact) {
  const auto brute = BruteForceDiamonds<D>(volume, DomainBits<D>(volume));
  ExpectBruteForce<D, double>(volume, brute, exact, 1, false);
  WithVoxelCppType(volume.type, [&](auto voxel) {
    ExpectBruteForce<D, decltype(voxel)>(volume, brute, exact, 2, true);
  });
}

TEST(DiamondErrors, HtCubic) {
  ExpectBruteForce<3>(TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kU8, 11), true);
  ExpectBruteForce<3>(TestVolume::Random(3, {33, 33, 33, 1}, VoxelType::kF32, 12), false);
}

TEST(DiamondErrors, HtPaddedAndShortAxes) {
  ExpectBruteForce<3>(TestVolume::Random(3, {11, 6, 17, 1}, VoxelType::kI16, 13), true);
  ExpectBruteForce<3>(TestVolume::Random(3, {20, 3, 9, 1}, VoxelType::kF64, 14), false);
  ExpectBruteForce<3>(TestVolume::Random(3, {2, 2, 2, 1}, VoxelType::kU16, 15), true);
}

TEST(DiamondErrors, HpCubic) {
  ExpectBruteForce<4>(TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 16), true);
}

TEST(DiamondErrors, HpPaddedAndShortAxes) {
  ExpectBruteForce<4>(TestVolume::Random(4, {7, 5, 6, 3}, VoxelType::kF32, 17), false);
  ExpectBruteForce<4>(TestVolume::Random(4, {12, 4, 3, 2}, VoxelType::kU8, 18), true);
}

// The stencils (point stencils of the finest octaves, row stencils of the
// middle ones) against scanning every diamond's simplices, at every vertex
// of grids large enough for each kind to serve interior diamonds.
template <int D>
void ExpectStencilsMatchScans(const TestVolume& volume, bool exact) {
  const int k = DomainBits<D>(volume);
  std::array<int64_t, D> dims{};
  double lo = volume.values[0], hi = volume.values[0];
  for (double v : volume.values) lo = std::min(lo, v), hi = std::max(hi, v);
  for (int a = 0; a < D; ++a) dims[a] = volume.dims[a];
  DiamondErrors<D> fast(volume.values.data(), dims, k, exact, hi - lo, 1, true);
  DiamondErrors<D> scanned(volume.values.data(), dims, k, exact, hi - lo, 1, false);
  fast.Allocate();
  scanned.Allocate();
  for (uint64_t i = 0; i < fast.item_count(); ++i) {
    fast.ComputeItem(0, i);
    scanned.ComputeItem(0, i);
  }
  fast.Finish();
  scanned.Finish();
  const HzOrder<D> order(k);
  const int64_t side = int64_t{1} << k;
  std::array<int64_t, D> g{};
  uint64_t compared = 0;
  while (true) {
    if (order.Level(g) >= 0) {
      const uint64_t position = order.PositionAtLevel(g, order.Level(g));
      ASSERT_NEAR(scanned.At(g, position), fast.At(g, position), 1e-9 * (hi - lo))
          << ::testing::PrintToString(g);
      ++compared;
    }
    int a = 0;
    for (; a < D && g[a] == side; ++a) g[a] = 0;
    if (a == D) break;
    ++g[a];
  }
  EXPECT_GT(compared, 0u);
}

TEST(DiamondErrors, HtStencilsMatchScans) {
  ExpectStencilsMatchScans<3>(TestVolume::Random(3, {65, 65, 65, 1}, VoxelType::kF32, 21), false);
  ExpectStencilsMatchScans<3>(TestVolume::Random(3, {70, 40, 35, 1}, VoxelType::kU16, 22), true);
}

TEST(DiamondErrors, HpStencilsMatchScans) {
  ExpectStencilsMatchScans<4>(TestVolume::Random(4, {17, 17, 17, 17}, VoxelType::kF32, 23), false);
  ExpectStencilsMatchScans<4>(TestVolume::Random(4, {20, 9, 18, 12}, VoxelType::kI16, 24), true);
}

}  // namespace
}  // namespace simplexdb
