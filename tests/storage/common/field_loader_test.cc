// The field every builder reads (storage/common/field_loader.h) against the
// volume's own values: as the store keeps them (float32 rounding), a mask's
// points missing, the range over the values present, the same on one worker
// and on several; and the pass a plane at a time (ScanPlanes) against it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "storage/common/field_loader.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

TEST(FieldLoader, ReadsTheVolumeOnAnyNumberOfWorkers) {
  TempDir dir;
  // More than one chunk of 2^20 voxels.
  const TestVolume v = TestVolume::Random(3, {128, 96, 100, 1}, VoxelType::kI16, 1);
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  const VolumeInfo in = *OpenVolume(dir / "v.nrrd");
  for (const int threads : {1, 3}) {
    SCOPED_TRACE(threads);
    LoadFieldOptions o;
    o.stored = VoxelType::kI16;
    o.threads = threads;
    const auto f = LoadField<int16_t>(in, std::nullopt, o);
    ASSERT_TRUE(f.ok()) << f.status().message();
    ASSERT_EQ(f->values.size(), v.values.size());
    double lo = v.values[0], hi = v.values[0];
    for (size_t i = 0; i < v.values.size(); ++i) {
      ASSERT_EQ(f->values[i], v.values[i]) << i;
      lo = std::min(lo, v.values[i]);
      hi = std::max(hi, v.values[i]);
    }
    EXPECT_EQ(f->min, lo);
    EXPECT_EQ(f->max, hi);
    EXPECT_FALSE(f->missing);
  }
}

// A float64 volume kept as float32: every value rounded to the nearest
// float, the range of the rounded values.
TEST(FieldLoader, KeepsTheStoredTypesValues) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {9, 8, 7, 1}, VoxelType::kF64, 2);
  for (double& x : v.values) x = x / 3 + 1e-9;  // not floats
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  LoadFieldOptions o;
  o.stored = VoxelType::kF32;
  const auto f = LoadField<float>(*OpenVolume(dir / "v.nrrd"), std::nullopt, o);
  ASSERT_TRUE(f.ok()) << f.status().message();
  float lo = static_cast<float>(v.values[0]);
  for (size_t i = 0; i < v.values.size(); ++i) {
    ASSERT_EQ(f->values[i], static_cast<float>(v.values[i])) << i;
    lo = std::min(lo, static_cast<float>(v.values[i]));
  }
  EXPECT_EQ(f->min, static_cast<double>(lo));
}

// A mask's zeros (and NaN) are missing values; the range skips them; a
// field with every point masked has the range 0 to 0; an integer field
// cannot hold a missing value.
TEST(FieldLoader, MaskedPointsAreMissing) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {11, 7, 5, 1}, VoxelType::kU8, 3);
  TestVolume mask = v;
  mask.type = VoxelType::kF32;
  for (size_t i = 0; i < mask.values.size(); ++i) {
    mask.values[i] = i % 5 == 0 ? 0 : (i % 7 == 0 ? std::nan("") : 0.5);
  }
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  ASSERT_TRUE(mask.WriteNrrd(dir / "m.nrrd").ok());
  const VolumeInfo in = *OpenVolume(dir / "v.nrrd");
  LoadFieldOptions o;
  o.stored = VoxelType::kF32;
  o.threads = 2;
  const auto f = LoadField<float>(in, *OpenVolume(dir / "m.nrrd"), o);
  ASSERT_TRUE(f.ok()) << f.status().message();
  EXPECT_TRUE(f->missing);
  double lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < v.values.size(); ++i) {
    if (i % 5 == 0 || i % 7 == 0) {
      ASSERT_TRUE(std::isnan(f->values[i])) << i;
      continue;
    }
    ASSERT_EQ(f->values[i], v.values[i]) << i;
    lo = std::min(lo, v.values[i]);
    hi = std::max(hi, v.values[i]);
  }
  EXPECT_EQ(f->min, lo);
  EXPECT_EQ(f->max, hi);

  for (double& x : mask.values) x = 0;
  ASSERT_TRUE(mask.WriteNrrd(dir / "none.nrrd").ok());
  const auto none = LoadField<float>(in, *OpenVolume(dir / "none.nrrd"), o);
  ASSERT_TRUE(none.ok()) << none.status().message();
  EXPECT_TRUE(none->missing);
  EXPECT_EQ(none->min, 0);
  EXPECT_EQ(none->max, 0);

  o.stored = VoxelType::kU8;
  const auto integers = LoadField<uint8_t>(in, *OpenVolume(dir / "m.nrrd"), o);
  ASSERT_FALSE(integers.ok());
  EXPECT_TRUE(integers.status().IsInvalidArgument()) << integers.status().ToString();
}

// MaskedReader: any run of voxels, masked points NaN, the same as LoadField.
TEST(FieldLoader, MaskedReaderReadsRuns) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {6, 5, 4, 1}, VoxelType::kF32, 4);
  TestVolume mask = v;
  for (size_t i = 0; i < mask.values.size(); ++i) mask.values[i] = i % 3 == 1 ? 0 : 1;
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  ASSERT_TRUE(mask.WriteNrrd(dir / "m.nrrd").ok());
  MaskedReader reader(*OpenVolume(dir / "v.nrrd"), *OpenVolume(dir / "m.nrrd"));
  std::vector<double> run(17);
  ASSERT_TRUE(reader.Read(40, run.size(), run.data()).ok());
  for (size_t i = 0; i < run.size(); ++i) {
    if ((40 + i) % 3 == 1) {
      EXPECT_TRUE(std::isnan(run[i])) << i;
    } else {
      EXPECT_EQ(run[i], v.values[40 + i]) << i;
    }
  }
}

// ScanPlanes: every plane once, to the sink, with the values the store
// keeps (float32 rounding, masked points NaN); the same range and
// missingness as LoadField, on one worker and on several; the first value
// in file order a store cannot hold.
TEST(FieldLoader, ScanPlanesSeesEveryPlaneOnceAsLoadFieldReadsIt) {
  TempDir dir;
  TestVolume v = TestVolume::Random(4, {7, 6, 5, 9}, VoxelType::kF64, 5);
  for (double& x : v.values) x = x / 3 + 1e-9;  // not floats
  TestVolume mask = v;
  for (size_t i = 0; i < mask.values.size(); ++i) mask.values[i] = i % 4 == 2 ? 0 : 1;
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  ASSERT_TRUE(mask.WriteNrrd(dir / "m.nrrd").ok());
  const VolumeInfo in = *OpenVolume(dir / "v.nrrd");
  const uint64_t plane = 7 * 6 * 5;
  for (const auto& masked : {std::optional<VolumeInfo>{}, std::optional<VolumeInfo>{*OpenVolume(dir / "m.nrrd")}}) {
    for (const int threads : {1, 3}) {
      SCOPED_TRACE(std::to_string(threads) + (masked ? " masked" : ""));
      LoadFieldOptions o;
      o.stored = VoxelType::kF32;
      o.threads = threads;
      std::vector<int> seen(9, 0);
      std::vector<double> got(v.values.size(), -1);
      std::mutex mu;
      const auto range = ScanPlanes(in, masked, o, [&](int64_t z, const double* values) {
        std::lock_guard<std::mutex> lock(mu);
        ++seen[static_cast<size_t>(z)];
        std::copy(values, values + plane, got.begin() + static_cast<ptrdiff_t>(z * plane));
      });
      ASSERT_TRUE(range.ok()) << range.status().message();
      EXPECT_EQ(seen, std::vector<int>(9, 1));
      for (size_t i = 0; i < v.values.size(); ++i) {
        if (masked && i % 4 == 2) {
          ASSERT_TRUE(std::isnan(got[i])) << i;
        } else {
          ASSERT_EQ(got[i], static_cast<double>(static_cast<float>(v.values[i]))) << i;
        }
      }
      const auto loaded = LoadField<float>(in, masked, o);
      ASSERT_TRUE(loaded.ok());
      EXPECT_EQ(range->min, loaded->min);
      EXPECT_EQ(range->max, loaded->max);
      EXPECT_EQ(range->missing, loaded->missing);
      EXPECT_EQ(range->missing, masked.has_value());
    }
  }
  v.values[3 * plane + 11] = 1e39;  // plane 3
  v.values[2 * plane + 40] = std::numeric_limits<double>::infinity();  // plane 2: first in file order
  ASSERT_TRUE(v.WriteNrrd(dir / "bad.nrrd").ok());
  LoadFieldOptions o;
  o.stored = VoxelType::kF32;
  o.threads = 2;
  const auto bad = ScanPlanes(*OpenVolume(dir / "bad.nrrd"), std::nullopt, o, [](int64_t, const double*) {});
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(bad.status().IsInvalidArgument()) << bad.status().ToString();
  EXPECT_NE(bad.status().message().find("voxel (" + std::to_string(40 % 7) + ", " + std::to_string(40 / 7 % 6) +
                                        ", " + std::to_string(40 / 42) + ", 2)"),
            std::string::npos)
      << bad.status().message();
}

// Values each storable whose range is not (3e38 and -3e38): refused by both
// passes before a store is written, saying what to do.
TEST(FieldLoader, ARangeBeyondFloat32IsRefused) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {6, 5, 4, 1}, VoxelType::kF32, 6);
  v.values[3] = 3e38;
  v.values[70] = -3e38;
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  const VolumeInfo in = *OpenVolume(dir / "v.nrrd");
  LoadFieldOptions o;
  o.stored = VoxelType::kF32;
  const auto loaded = LoadField<float>(in, std::nullopt, o);
  const auto scanned = ScanPlanes(in, std::nullopt, o, [](int64_t, const double*) {});
  for (const Status& s : {loaded.status(), scanned.status()}) {
    EXPECT_TRUE(s.IsInvalidArgument()) << s.ToString();
    EXPECT_NE(s.message().find("a range of 6e+38, beyond float32's"), std::string_view::npos) << s.message();
    EXPECT_NE(s.message().find("scale the values down"), std::string_view::npos) << s.message();
  }
  v.values[70] = -4e37;  // a range of 3.4e38: within float32's
  ASSERT_TRUE(v.WriteNrrd(dir / "w.nrrd").ok());
  EXPECT_TRUE(LoadField<float>(*OpenVolume(dir / "w.nrrd"), std::nullopt, o).ok());
}

}  // namespace
}  // namespace simplexdb
