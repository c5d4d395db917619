// The operations' own checks and values (ops/): amounts, values brought
// into their voxel type, export boxes, convert both ways and extract over
// both kinds, against truths computed here (the voxels put in, the
// arithmetic written out), not against the code under test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ops/amount.h"
#include "ops/convert.h"
#include "ops/export.h"
#include "ops/extract.h"
#include "ops/import.h"
#include "ops/read_grid.h"
#include "query/open_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;

// `values` as a volume in memory of `type` (each value must be one `type`
// holds), and the values it holds.
struct Voxels {
  std::shared_ptr<std::vector<std::byte>> bytes;
  std::vector<double> values;
  VolumeInfo volume;
};

Voxels MakeVoxels(int dimension, std::array<uint32_t, 4> dims, VoxelType type, std::vector<double> values) {
  Voxels v;
  v.values = std::move(values);
  v.bytes = std::make_shared<std::vector<std::byte>>(v.values.size() * VoxelSize(type));
  EncodeVoxels(type, NativeByteOrder(), v.values.data(), v.values.size(), v.bytes->data());
  std::shared_ptr<const std::byte> view(v.bytes, v.bytes->data());
  Result<VolumeInfo> info = MemoryVolume(dimension, dims, type, NativeByteOrder(), view, "test voxels");
  EXPECT_TRUE(info.ok()) << info.status().ToString();
  v.volume = *info;
  return v;
}

// Integer voxels of `dims` in 0..255 with a seeded noise.
Voxels NoisyU8(int dimension, std::array<uint32_t, 4> dims, unsigned seed) {
  uint64_t n = 1;
  for (const uint32_t d : dims) n *= d;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(0, 255);
  std::vector<double> values(n);
  for (double& x : values) x = u(rng);
  return MakeVoxels(dimension, dims, VoxelType::kU8, std::move(values));
}

AnyStore Open(const std::string& path) {
  Result<AnyStore> store = AnyStore::Open(path);
  EXPECT_TRUE(store.ok()) << store.status().ToString();
  return std::move(store).value();
}

TEST(Amount, ParsesTextAndResolvesAsTheCommandAlwaysDid) {
  Result<Amount> a = ParseAmount("7.5", "--error");
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(a->value, 7.5);
  EXPECT_FALSE(a->percent);
  a = ParseAmount("3%", "--error");
  ASSERT_TRUE(a.ok());
  EXPECT_TRUE(a->percent);
  EXPECT_EQ(ResolveAmount(*a, 255), 3.0 / 100 * 255);
  for (const char* bad : {"", "%", "lots", "-1", "inf", "1%%", "nan"}) {
    SCOPED_TRACE(bad);
    const Status s = ParseAmount(bad, "--error").status();
    EXPECT_TRUE(s.IsInvalidArgument());
    EXPECT_EQ(std::string(s.message()).rfind("--error: expected a number >= 0", 0), 0u) << s.message();
  }
  EXPECT_TRUE(CheckAmount(Amount{-0.5, false}, "--tolerance").IsInvalidArgument());
  EXPECT_TRUE(CheckAmount(Amount{std::nan(""), false}, "--tolerance").IsInvalidArgument());
  EXPECT_TRUE(CheckAmount(Amount{0, false}, "--tolerance").ok());
}

TEST(RoundToVoxelType, RoundsHalfAwayAndClampsIntegerTypesOnly) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> u8 = {-0.6, -0.4, 0.5, 2.5, 254.5, 255.4, 300, nan};
  RoundToVoxelType(VoxelType::kU8, u8);
  const std::vector<double> want_u8 = {0, 0, 1, 3, 255, 255, 255};
  for (size_t i = 0; i < want_u8.size(); ++i) EXPECT_EQ(u8[i], want_u8[i]) << i;
  EXPECT_TRUE(std::isnan(u8.back()));
  std::vector<double> i16 = {-32768.7, -2.5, 32767.6, 12.49};
  RoundToVoxelType(VoxelType::kI16, i16);
  EXPECT_EQ(i16, (std::vector<double>{-32768, -3, 32767, 12}));
  std::vector<double> f32 = {-0.6, 1e6 + 0.25};
  RoundToVoxelType(VoxelType::kF32, f32);
  EXPECT_EQ(f32, (std::vector<double>{-0.6, 1e6 + 0.25}));
}

TEST(CheckImport, PlacementNamesTheOption) {
  const Voxels v = NoisyU8(3, {4, 3, 3, 1}, 1);
  ImportOptions o;
  o.spacing = std::vector<double>{1, 2};
  EXPECT_EQ(CheckImport(v.volume, o).message(), "--spacing: 2 numbers for a 3D volume (4x3x3); give 3, x first");
  o.spacing = std::vector<double>{1, 0, 2};
  EXPECT_EQ(CheckImport(v.volume, o).message(),
            "--spacing: 0 on axis 1 is not a finite non-zero number (negative: a flipped axis)");
  o.spacing = std::vector<double>{1, -2, 2};  // a flipped y
  EXPECT_TRUE(CheckImport(v.volume, o).ok());
  o.origin = std::vector<double>{0, std::numeric_limits<double>::infinity(), 0};
  EXPECT_EQ(CheckImport(v.volume, o).message(), "--origin: inf on axis 1 is not a finite number");
  o.origin.reset();
  o.threads = -1;
  EXPECT_EQ(CheckImport(v.volume, o).message(), "--threads: expected a count >= 0 (0: one per core), not -1");
  o.threads = 0;
  const VolumeInfo placed = PlacedInput(v.volume, o);
  EXPECT_EQ(placed.spacing, (std::array<double, 4>{1, -2, 2, 1}));
  EXPECT_EQ(placed.origin, v.volume.origin);
}

TEST(ExportRequest, ResolvesToTheBoxAndNamesTheOption) {
  SourceInfo info;
  info.dimension = 4;
  info.dims = {5, 4, 3, 6};
  info.path = "s.sdb";
  ExportRequest r;
  r.time = 2;
  r.roi = std::vector<double>{1, 0, 0, 4, 3, 1};
  r.step = 2;
  Result<ExportBox> box = ResolveExportBox(info, r);
  ASSERT_TRUE(box.ok()) << box.status().ToString();
  EXPECT_EQ(box->lo, (std::array<int64_t, 4>{1, 0, 0, 2}));
  EXPECT_EQ(box->hi, (std::array<int64_t, 4>{4, 3, 1, 2}));
  EXPECT_EQ(box->step, 2);
  const auto expect = [&](std::vector<double> roi, std::optional<double> time, int64_t step,
                          const std::string& message) {
    SCOPED_TRACE(message);
    ExportRequest request;
    if (!roi.empty()) request.roi = std::move(roi);
    request.time = time;
    request.step = step;
    const Status s = ResolveExportBox(info, request).status();
    EXPECT_TRUE(s.IsInvalidArgument());
    EXPECT_EQ(std::string(s.message()).rfind(message, 0), 0u) << s.message();
  };
  expect({}, 6, 1, "--time 6: not a time step of s.sdb: expected a whole number in 0..5");
  expect({}, 1.5, 1, "--time 1.5: not a time step");
  expect({}, std::nullopt, 0, "--step: expected a whole number >= 1, not 0");
  expect({0, 0, 0, 0, 1, 1, 1, 1}, 1, 1, "--roi with --time is x0,y0,z0,x1,y1,z1");
  expect({0, 0, 0, 1}, std::nullopt, 1, "--roi: expected 8 grid indices");
  expect({0, 0, 0, 0, 5, 1, 1, 1}, std::nullopt, 1, "--roi: axis 0 range 0..5 is not within 0..4");
  info.dimension = 3;
  info.dims[3] = 1;
  ExportRequest at_time;
  at_time.time = 0;
  EXPECT_EQ(std::string(ResolveExportBox(info, at_time).status().message()),
            "--time: s.sdb is a 3D (HT) store; it has no time axis (leave --time out)");
}

// Dense -> sparse (lossless) -> dense gives the voxels put in; a lossy
// sparse store of an integer field converts to values of its type within
// the tolerance (the rebuilt ones rounded), read back through export.
TEST(Convert, BothWaysKeepTheVoxelsAndTheirType) {
  TempDir dir;
  for (const int dimension : {3, 4}) {
    SCOPED_TRACE(dimension);
    const std::array<uint32_t, 4> dims = dimension == 3 ? std::array<uint32_t, 4>{9, 7, 6, 1}
                                                        : std::array<uint32_t, 4>{5, 4, 3, 4};
    const Voxels v = NoisyU8(dimension, dims, 3);
    const std::string dense = dir / "d.sdb", sparse = dir / "s.lmdb", back = dir / "b.sdb";
    ASSERT_TRUE(ImportVolume(v.volume, dense, {}).ok());
    ConvertOptions to_sparse;
    to_sparse.to = StoreKind::kSparse;
    Result<ConvertReport> r = Convert(dense, sparse, to_sparse);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_TRUE(r->sparse.has_value());
    ConvertOptions to_dense;
    to_dense.to = StoreKind::kDense;
    r = Convert(sparse, back, to_dense);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_TRUE(r->dense.has_value());
    const AnyStore store = Open(back);
    EXPECT_EQ(StoreVoxelType(store), VoxelType::kU8);
    EXPECT_EQ(store.dense()->header().source, "test voxels");
    Result<FieldImage> image = ReadExport(store, {});
    ASSERT_TRUE(image.ok()) << image.status().ToString();
    EXPECT_EQ(image->values, v.values);
    // Converting again, in the wrong direction, or from a missing store.
    EXPECT_TRUE(CheckConvert(sparse, StoreKind::kSparse, to_sparse).IsInvalidArgument());
    EXPECT_TRUE(CheckConvert(dense, StoreKind::kDense, to_dense).IsInvalidArgument());
    to_dense.tolerance = Amount{1, false};
    EXPECT_EQ(CheckConvert(sparse, StoreKind::kSparse, to_dense).message(), "--tolerance applies to --to sparse");
  }
  const Voxels v = NoisyU8(3, {17, 12, 9, 1}, 5);
  const std::string dense = dir / "n.sdb", lossy = dir / "n.lmdb", back = dir / "nb.sdb";
  ASSERT_TRUE(ImportVolume(v.volume, dense, {}).ok());
  ConvertOptions to_sparse;
  to_sparse.tolerance = Amount{20, false};
  ASSERT_TRUE(Convert(dense, lossy, to_sparse).ok());
  ConvertOptions to_dense;
  to_dense.to = StoreKind::kDense;
  to_dense.threads = 1;
  ASSERT_TRUE(Convert(lossy, back, to_dense).ok());
  const AnyStore sparse_store = Open(lossy), dense_store = Open(back);
  Result<FieldImage> from_sparse = ReadExport(sparse_store, {});
  Result<FieldImage> from_dense = ReadExport(dense_store, {});
  ASSERT_TRUE(from_sparse.ok() && from_dense.ok());
  EXPECT_EQ(from_sparse->values, from_dense->values);  // the values the dense store was built from
  size_t changed = 0;
  for (size_t i = 0; i < v.values.size(); ++i) {
    const double x = from_dense->values[i];
    ASSERT_EQ(x, std::round(x)) << i;
    ASSERT_GE(x, 0) << i;
    ASSERT_LE(x, 255) << i;
    ASSERT_LE(std::abs(x - v.values[i]), 20.5) << i;
    changed += x != v.values[i];
  }
  EXPECT_GT(changed, 0u);  // the tolerance dropped something, or the test checks nothing
}

// A box in physical units is the grid box it stands for: the same leaves.
TEST(Extract, PhysicalUnitsAreTheGridBoxTheyNameOnBothKinds) {
  TempDir dir;
  const Voxels v = NoisyU8(3, {13, 11, 9, 1}, 9);
  for (const bool sparse : {false, true}) {
    SCOPED_TRACE(sparse);
    ImportOptions o;
    o.sparse = sparse;
    o.spacing = std::vector<double>{0.5, -2, 1.5};
    o.origin = std::vector<double>{10, 4, -3};
    const std::string path = dir / (sparse ? "p.lmdb" : "p.sdb");
    ASSERT_TRUE(ImportVolume(v.volume, path, o).ok());
    const AnyStore store = Open(path);
    ExtractRequest grid;
    grid.error = Amount{2, true};
    grid.box = std::vector<double>{2, 3, 1, 8, 7, 5};
    ExtractRequest physical = grid;
    physical.units = "physical";
    // x: 10 + 0.5 i; y: 4 - 2 j (flipped: the larger j is the smaller y); z: -3 + 1.5 k.
    physical.box = std::vector<double>{11, 4 - 2 * 7, -1.5, 14, 4 - 2 * 3, 4.5};
    Result<ExtractResult> a = Extract(store, grid), b = Extract(store, physical);
    ASSERT_TRUE(a.ok()) << a.status().ToString();
    ASSERT_TRUE(b.ok()) << b.status().ToString();
    EXPECT_EQ(a->leaves, b->leaves);
    EXPECT_EQ(a->threshold, 2.0 / 100 * (store.info().field_max - store.info().field_min));
    ExtractRequest outside = grid;
    outside.box = std::vector<double>{20, 0, 0, 30, 5, 5};
    const Status s = CheckExtract(store.info(), outside);
    EXPECT_EQ(std::string(s.message()).rfind("--box 20,0,0,30,5,5: x from 20 to 30 misses the grid", 0), 0u)
        << s.message();
  }
}

}  // namespace
}  // namespace simplexdb
