// The HP's time slices: a conforming tetrahedral mesh of the whole cube,
// checked from geometry (volumes add up to the cube, every interior face
// shared by exactly two tetrahedra, boundary faces on the cube's faces).
#include <gtest/gtest.h>

#include <map>

#include "query/slice.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

void CheckSlice(const TetMeshData& m, double side) {
  ASSERT_GT(m.cells(), 0u);
  double volume = 0;
  std::map<std::array<int64_t, 3>, int> faces;
  for (uint64_t c = 0; c < m.cells(); ++c) {
    const int64_t* t = &m.connectivity[4 * c];
    const auto P = [&](int i, int a) { return m.points[3 * t[i] + a]; };
    double e[3][3];
    for (int i = 0; i < 3; ++i) {
      for (int a = 0; a < 3; ++a) e[i][a] = P(i + 1, a) - P(0, a);
    }
    const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                       e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                       e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    ASSERT_GT(det, 0) << "cell " << c << " is not positively oriented";
    volume += det / 6;
    for (int skip = 0; skip < 4; ++skip) {
      std::array<int64_t, 3> f{};
      for (int i = 0, n = 0; i < 4; ++i) {
        if (i != skip) f[n++] = t[i];
      }
      std::sort(f.begin(), f.end());
      ++faces[f];
    }
  }
  EXPECT_NEAR(volume, side * side * side, 1e-9 * side * side * side);
  for (const auto& [f, uses] : faces) {
    bool boundary = false;
    for (int a = 0; a < 3; ++a) {
      for (double wall : {0.0, side}) {
        bool all = true;
        for (int64_t p : f) all = all && m.points[3 * p + a] == wall;
        boundary = boundary || all;
      }
    }
    ASSERT_EQ(uses, boundary ? 1 : 2) << "face " << f[0] << "," << f[1] << "," << f[2];
  }
}

template <class Source>
void CheckSlices(Source& source, const TestVolume& volume) {
  const double range = source.info().field_range();
  const double scale = std::ldexp(1.0, kCoordBits<4> - 3);
  for (double pct : {0.0, 20.0, 45.0, 100.0}) {
    Criteria<4> c;
    c.threshold = range * pct / 100;
    Refiner<4, Source> refiner(source, c);
    Mesh<4> mesh;
    QueryStats stats;
    ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
    for (double t : {0.0, 1.0, 1.5, 3.25, 4.0, 7.9, 8.0}) {
      SCOPED_TRACE(std::to_string(pct) + "% at t = " + std::to_string(t));
      auto slice = SliceHpMesh(mesh, source, t * scale);
      ASSERT_TRUE(slice.ok());
      CheckSlice(*slice, 8);
      // At a grid time, full resolution cuts through grid points: their values
      // are the volume's.
      if (pct == 0.0 && t == 4.0) {
        for (size_t p = 0; p < slice->field.size(); ++p) {
          const double* x = &slice->points[3 * p];
          if (x[0] != std::floor(x[0]) || x[1] != std::floor(x[1]) || x[2] != std::floor(x[2])) continue;
          const double want = volume.At({int64_t(x[0]), int64_t(x[1]), int64_t(x[2]), 4});
          ASSERT_EQ(slice->field[p], want);
        }
      }
    }
  }
}

// Over the dense store as import makes it and the lossless sparse store.
TEST(Slice, HpSlicesAreConformingMeshesOfTheCube) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kU8, 31);
  testing::OverDenseAndSparse<4>(volume, dir.path(), "hp", [&](auto& source) { CheckSlices(source, volume); });
}

}  // namespace
}  // namespace simplexdb
