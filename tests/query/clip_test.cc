// Meshes clipped to the real grid, checked from geometry: every cell
// positive, volumes adding up to the grid's box, every interior face shared
// by exactly two tetrahedra and every other face on the box's walls; and the
// field at every grid point within the error bound of the input volume
// (points located by brute force).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <numeric>
#include <random>

#include "query/clip.h"
#include "query/mesh_io.h"
#include "query/slice.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

double Det3(const std::array<std::array<double, 3>, 3>& e) {
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
         e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

// The edge vectors of cell c, from its first point to the other three.
std::array<std::array<double, 3>, 3> CellEdges(const TetMeshData& m, uint64_t c) {
  const int64_t* t = &m.connectivity[4 * c];
  std::array<std::array<double, 3>, 3> e{};
  for (int i = 0; i < 3; ++i) {
    for (int a = 0; a < 3; ++a) e[i][a] = m.points[3 * t[i + 1] + a] - m.points[3 * t[0] + a];
  }
  return e;
}

// The box [0, hi] meshed: see the file comment.
void CheckMeshOfBox(const TetMeshData& m, const std::array<double, 3>& hi) {
  ASSERT_GT(m.cells(), 0u);
  ASSERT_EQ(m.points.size(), 3 * m.field.size());
  ASSERT_EQ(m.error.size(), m.cells());
  for (size_t p = 0; p < m.field.size(); ++p) {
    for (int a = 0; a < 3; ++a) {
      ASSERT_GE(m.points[3 * p + a], 0.0);
      ASSERT_LE(m.points[3 * p + a], hi[a]) << "point " << p << " axis " << a;
    }
  }
  std::vector<bool> used(m.field.size());
  double volume = 0;
  std::map<std::array<int64_t, 3>, int> faces;
  for (uint64_t c = 0; c < m.cells(); ++c) {
    const int64_t* t = &m.connectivity[4 * c];
    const std::array<std::array<double, 3>, 3> e = CellEdges(m, c);
    const double det = Det3(e);
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
    for (int i = 0; i < 4; ++i) used[t[i]] = true;
  }
  EXPECT_EQ(std::count(used.begin(), used.end(), false), 0) << "points no cell uses";
  const double box = hi[0] * hi[1] * hi[2];
  EXPECT_NEAR(volume, box, 1e-9 * box);
  for (const auto& [f, uses] : faces) {
    bool wall = false;
    for (int a = 0; a < 3; ++a) {
      for (double x : {0.0, hi[a]}) {
        bool all = true;
        for (int64_t p : f) all = all && m.points[3 * p + a] == x;
        wall = wall || all;
      }
    }
    ASSERT_EQ(uses, wall ? 1 : 2) << "face " << f[0] << "," << f[1] << "," << f[2];
  }
}

// The mesh's linear interpolant at x, from the first cell holding it.
std::optional<double> Interpolate(const TetMeshData& m, const std::array<double, 3>& x) {
  for (uint64_t c = 0; c < m.cells(); ++c) {
    const int64_t* t = &m.connectivity[4 * c];
    const std::array<std::array<double, 3>, 3> e = CellEdges(m, c);
    const double det = Det3(e);
    std::array<double, 4> w{};
    double sum = 0;
    for (int i = 0; i < 3; ++i) {
      auto ei = e;
      for (int a = 0; a < 3; ++a) ei[i][a] = x[a] - m.points[3 * t[0] + a];
      w[i + 1] = Det3(ei) / det;
      sum += w[i + 1];
    }
    w[0] = 1 - sum;
    if (*std::min_element(w.begin(), w.end()) < -1e-9) continue;
    double f = 0;
    for (int i = 0; i < 4; ++i) f += w[i] * m.field[t[i]];
    return f;
  }
  return std::nullopt;
}

// The mesh with its points renumbered at random: conformity must not hang
// on the order the walk met them in.
TetMeshData Shuffled(const TetMeshData& m, uint64_t seed) {
  std::vector<int64_t> to(m.field.size());
  std::iota(to.begin(), to.end(), 0);
  std::shuffle(to.begin(), to.end(), std::mt19937_64(seed));
  TetMeshData out = m;
  for (size_t p = 0; p < to.size(); ++p) {
    out.field[to[p]] = m.field[p];
    for (int a = 0; a < 3; ++a) out.points[3 * to[p] + a] = m.points[3 * p + a];
  }
  for (int64_t& p : out.connectivity) p = to[p];
  return out;
}

template <class Source>
void CheckHtMeshesCoverTheRealGrid(Source& source, const TestVolume& volume) {
  const double range = source.info().field_range();
  for (double pct : {0.0, 10.0, 40.0, 100.0}) {
    SCOPED_TRACE(std::to_string(pct) + "%");
    Criteria<3> criteria;
    criteria.threshold = range * pct / 100;
    Refiner<3, Source> refiner(source, criteria);
    Mesh<3> mesh;
    QueryStats stats;
    ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
    auto full = CollectTetMesh(mesh, source);
    ASSERT_TRUE(full.ok());
    const TetMeshData clipped = ClipToGrid(*full, volume.dims);
    ASSERT_NO_FATAL_FAILURE(CheckMeshOfBox(clipped, {10, 6, 12}));
    ASSERT_LE(clipped.cells(), 12 * full->cells());
    for (uint64_t seed : {1, 2, 3}) {
      SCOPED_TRACE("points renumbered, seed " + std::to_string(seed));
      ASSERT_NO_FATAL_FAILURE(CheckMeshOfBox(ClipToGrid(Shuffled(*full, seed), volume.dims), {10, 6, 12}));
    }
    for (int64_t z = 0; z < 13; ++z) {
      for (int64_t y = 0; y < 7; ++y) {
        for (int64_t x = 0; x < 11; ++x) {
          const std::array<double, 3> at = {double(x), double(y), double(z)};
          const std::optional<double> f = Interpolate(clipped, at);
          ASSERT_TRUE(f.has_value()) << x << "," << y << "," << z;
          EXPECT_LE(std::abs(*f - volume.At({x, y, z, 0})), criteria.threshold + 1e-9)
              << x << "," << y << "," << z;
        }
      }
    }
  }
}

// Over the dense store as import makes it (u16 errors) and the lossless
// sparse store.
TEST(ClipToGrid, HtMeshesCoverTheRealGridWithinTheErrorBound) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {11, 7, 13, 1}, VoxelType::kU8, 5);
  testing::OverDenseAndSparse<3>(volume, dir.path(), "ht",
                                 [&](auto& source) { CheckHtMeshesCoverTheRealGrid(source, volume); });
}

TEST(ClipToGrid, AMeshInsideTheGridIsUnchanged) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 6);
  const auto store = testing::BuildDense(volume, dir.path(), "ht", DenseBuildOptions{});
  DenseSource<3> source(*store);
  Criteria<3> criteria;
  criteria.threshold = source.info().field_range() / 5;
  Refiner<3, DenseSource<3>> refiner(source, criteria);
  Mesh<3> mesh;
  QueryStats stats;
  ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
  auto full = CollectTetMesh(mesh, source);
  ASSERT_TRUE(full.ok());
  const TetMeshData clipped = ClipToGrid(*full, volume.dims);
  EXPECT_EQ(clipped.points, full->points);
  EXPECT_EQ(clipped.connectivity, full->connectivity);
  EXPECT_EQ(clipped.code, full->code);
}

TEST(ClipToGrid, HpSlicesCoverTheRealGrid) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(4, {7, 9, 5, 6}, VoxelType::kU8, 7);
  const auto store = testing::BuildDense(volume, dir.path(), "hp", DenseBuildOptions{});
  DenseSource<4> source(*store);
  const double scale = std::ldexp(1.0, kCoordBits<4> - source.info().domain_bits);
  for (double pct : {0.0, 30.0}) {
    Criteria<4> criteria;
    criteria.threshold = source.info().field_range() * pct / 100;
    Refiner<4, DenseSource<4>> refiner(source, criteria);
    Mesh<4> mesh;
    QueryStats stats;
    ASSERT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
    for (double t : {0.0, 2.5, 5.0}) {
      SCOPED_TRACE(std::to_string(pct) + "% at t = " + std::to_string(t));
      auto slice = SliceHpMesh(mesh, source, t * scale);
      ASSERT_TRUE(slice.ok());
      ASSERT_NO_FATAL_FAILURE(CheckMeshOfBox(ClipToGrid(*slice, volume.dims), {6, 8, 4}));
    }
  }
}

TEST(PlacePhysically, MovesPointsByOriginAndSpacing) {
  TetMeshData m;
  m.points = {0, 0, 0, 2, 3, 4};
  m.field = {1, 2};
  SourceInfo info;
  info.spacing = {0.5, 2, 2.2, 1};
  info.origin = {-10, 0, 3, 0};
  PlacePhysically(m, info);
  const std::vector<double> want = {-10, 0, 3, -9, 6, 3 + 4 * 2.2};
  EXPECT_EQ(m.points, want);
}

// Flipped axes mirror the mesh once per flip: every cell stays positive
// and keeps its volume, whatever the number of flips.
TEST(PlacePhysically, FlippedAxesKeepCellsPositive) {
  const std::vector<double> points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  const std::vector<int64_t> cells = {0, 1, 2, 3, 1, 2, 3, 4};  // both positive
  for (const std::array<double, 4>& spacing :
       {std::array<double, 4>{2, 3, 4, 1}, {-2, 3, 4, 1}, {2, -3, 4, 1}, {-2, 3, -4, 1}, {-2, -3, -4, 1}}) {
    SCOPED_TRACE(spacing[0] * spacing[1] * spacing[2]);
    TetMeshData m;
    m.points = points;
    m.field = {0, 1, 2, 3, 4};
    m.connectivity = cells;
    SourceInfo info;
    info.spacing = spacing;
    PlacePhysically(m, info);
    for (size_t c = 0; c < m.connectivity.size(); c += 4) {
      const double in_grid_units = c == 0 ? 1 : 2;  // the two cells' determinants before
      EXPECT_NEAR(Det3(CellEdges(m, c / 4)), in_grid_units * 2 * 3 * 4, 1e-12) << "cell " << c / 4;
    }
    // Points stay where the spacing puts them; only cells are reordered.
    for (size_t p = 0; p < points.size(); ++p) EXPECT_EQ(m.points[p], points[p] * spacing[p % 3]);
  }
}

}  // namespace
}  // namespace simplexdb
