// The layer `simplexdb import`/`export`/`codes` and the Python package share
// (ops/import.h, read_grid.h, code_json.h; query/field_at.h): stores
// built from voxels in memory read back as those voxels, dense and sparse;
// FieldAt against the grid (brute force) and its interpolation's bounds;
// the options' errors; the codes contract's lines.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ops/code_json.h"
#include "ops/import.h"
#include "ops/read_grid.h"
#include "query/field_at.h"
#include "query/open_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;

// Random float32 voxels (little-endian bytes) of `dims`, and their values.
struct Voxels {
  std::shared_ptr<std::vector<float>> values;
  VolumeInfo volume;
};

Voxels MakeVoxels(int dimension, std::array<uint32_t, 4> dims, unsigned seed) {
  uint64_t n = 1;
  for (const uint32_t d : dims) n *= d;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-50, 200);
  Voxels v;
  v.values = std::make_shared<std::vector<float>>(n);
  for (float& x : *v.values) x = u(rng);
  std::shared_ptr<const std::byte> bytes(v.values, reinterpret_cast<const std::byte*>(v.values->data()));
  Result<VolumeInfo> info = MemoryVolume(dimension, dims, VoxelType::kF32, NativeByteOrder(), bytes, "test");
  EXPECT_TRUE(info.ok()) << info.status().ToString();
  v.volume = *info;
  return v;
}

AnyStore Build(const Voxels& v, const std::string& path, bool sparse) {
  ImportOptions options;
  options.sparse = sparse;
  options.threads = 2;
  Result<ImportReport> r = ImportVolume(v.volume, path, options);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->sparse.has_value(), sparse);
  EXPECT_EQ(r->dense.has_value(), !sparse);
  Result<AnyStore> store = AnyStore::Open(path);
  EXPECT_TRUE(store.ok()) << store.status().ToString();
  return std::move(store).value();
}

TEST(ImportVolume, MemoryVoxelsReadBackWholeAndByBox) {
  TempDir dir;
  for (const bool sparse : {false, true}) {
    SCOPED_TRACE(sparse ? "sparse" : "dense");
    const Voxels v = MakeVoxels(3, {7, 6, 5, 1}, 4);
    const AnyStore store = Build(v, dir / (sparse ? "s.lmdb" : "d.sdb"), sparse);
    Result<std::vector<double>> all = ReadGridBox(store, WholeGrid(store.info()));
    ASSERT_TRUE(all.ok()) << all.status().ToString();
    ASSERT_EQ(all->size(), v.values->size());
    for (size_t i = 0; i < all->size(); ++i) ASSERT_EQ((*all)[i], (*v.values)[i]) << i;
    ExportBox box;
    box.lo = {1, 0, 2, 0};
    box.hi = {6, 5, 4, 0};
    box.step = 2;  // x 1,3,5; y 0,2,4; z 2,4
    EXPECT_EQ(ExportDims(box, 3), (std::array<uint32_t, 4>{3, 3, 2, 1}));
    Result<std::vector<double>> part = ReadGridBox(store, box);
    ASSERT_TRUE(part.ok()) << part.status().ToString();
    size_t i = 0;
    for (int z = 2; z <= 4; z += 2) {
      for (int y = 0; y <= 5; y += 2) {
        for (int x = 1; x <= 6; x += 2) EXPECT_EQ((*part)[i++], (*v.values)[(z * 6 + y) * 7 + x]);
      }
    }
    box.hi[2] = 5;
    const Status outside = ReadGridBox(store, box).status();
    EXPECT_TRUE(outside.IsInvalidArgument());
    EXPECT_NE(outside.ToString().find("axis 2 range 2..5 is not within 0..4"), std::string::npos)
        << outside.ToString();
    box.hi[2] = 4;
    box.step = 0;
    EXPECT_TRUE(ReadGridBox(store, box).status().IsInvalidArgument());
  }
}

TEST(FieldAt, GridPointsEdgesAndCellsHP) {
  TempDir dir;
  const std::array<uint32_t, 4> dims = {4, 3, 3, 3};
  const Voxels v = MakeVoxels(4, dims, 8);
  const AnyStore store = Build(v, dir / "hp.sdb", false);
  const auto at = [&](std::array<int, 4> g) {
    return static_cast<double>((*v.values)[((g[3] * dims[2] + g[2]) * dims[1] + g[1]) * dims[0] + g[0]]);
  };
  std::mt19937 rng(2);
  const Status s = store.Visit([&]<int D, class Source>(Source& source) {
    if constexpr (D == 4) {
      for (int i = 0; i < 200; ++i) {
        std::array<int, 4> g{};
        std::array<double, 4> p{};
        for (int a = 0; a < 4; ++a) {
          g[a] = static_cast<int>(rng() % (dims[a] - 1));
          p[a] = g[a];
        }
        EXPECT_EQ(*FieldAt<4>(source, p), at(g));  // a grid point: its value
        p[0] += 0.25;                               // along the x edge: linear
        std::array<int, 4> h = g;
        ++h[0];
        EXPECT_NEAR(*FieldAt<4>(source, p), 0.75 * at(g) + 0.25 * at(h), 1e-9);
        double lo = 1e300, hi = -1e300;  // inside the cell: within its corners
        for (int c = 0; c < 16; ++c) {
          std::array<int, 4> q = g;
          for (int a = 0; a < 4; ++a) q[a] += (c >> a) & 1;
          lo = std::min(lo, at(q));
          hi = std::max(hi, at(q));
        }
        for (int a = 1; a < 4; ++a) p[a] += std::uniform_real_distribution<double>(0, 1)(rng);
        const double f = *FieldAt<4>(source, p);
        EXPECT_GE(f, lo - 1e-9);
        EXPECT_LE(f, hi + 1e-9);
      }
      const Result<double> outside = FieldAt<4>(source, {0, 0, 3.5, 0});
      EXPECT_TRUE(outside.status().IsInvalidArgument());
      EXPECT_NE(outside.status().ToString().find("point (0, 0, 3.5, 0) is outside the grid (0..3, 0..2, "
                                                 "0..2, 0..2"),
                std::string::npos)
          << outside.status().ToString();
    } else {
      ADD_FAILURE() << "an HP store visited as D = " << D;
    }
  });
  EXPECT_TRUE(s.ok()) << s.ToString();
}

TEST(CheckImport, NamesTheOptionAndTheVolume) {
  const Voxels v = MakeVoxels(3, {3, 3, 3, 1}, 1);
  ImportOptions o;
  o.hierarchy = "hp";
  EXPECT_NE(CheckImport(v.volume, o).ToString().find("hierarchy hp needs a 4D volume; test is 3D (3x3x3)"),
            std::string::npos)
      << CheckImport(v.volume, o).ToString();
  o.hierarchy = "ht";
  EXPECT_TRUE(CheckImport(v.volume, o).ok());
  o.hierarchy = "quad";
  EXPECT_TRUE(CheckImport(v.volume, o).IsInvalidArgument());
  o.hierarchy = "";
  o.tolerance = Amount{1, false};
  EXPECT_TRUE(CheckImport(v.volume, o).IsInvalidArgument());  // tolerance needs sparse
  o.sparse = true;
  EXPECT_TRUE(CheckImport(v.volume, o).ok());
  o.mask = v.volume;
  EXPECT_TRUE(CheckImport(v.volume, o).IsInvalidArgument());  // no missing values in sparse
}

TEST(CodeJson, DescribeCodeIsTheContractLine) {
  Result<std::string> root = DescribeCode("ht", "0:");
  ASSERT_TRUE(root.ok());
  EXPECT_EQ(*root,
            "{\"code\":\"0:\",\"level\":0,\"vertices\":[[1.0,0.0,0.0],[1.0,1.0,0.0],[1.0,1.0,1.0],"
            "[0.0,0.0,0.0]],\"neighbors\":[null,null,\"1:\",\"2:\"],\"parent\":null,\"children\":"
            "[\"0:0\",\"0:1\"],\"cluster\":[\"0:\",\"1:\",\"4:\",\"5:\",\"3:\",\"2:\"]}");
  EXPECT_EQ(*DescribeCode("hp", "3:"), CodeJson(PentaCode::Root(3)));
  EXPECT_TRUE(DescribeCode("ht", "9:").status().IsInvalidArgument());
  const Status unknown = DescribeCode("quad", "0:").status();
  EXPECT_NE(unknown.ToString().find("expected ht, hp, tri-icosahedron"), std::string::npos);
}

}  // namespace
}  // namespace simplexdb
