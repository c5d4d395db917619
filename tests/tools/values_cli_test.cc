// Values that were silently wrong: a NIfTI's scl_slope/scl_inter must scale
// what import stores, and a value no store can hold (+-Inf, a float64
// beyond float32's range) must fail every build or update with exit 1,
// naming the file, the value and the voxel, and leave no output.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/tools/cli_test_util.h"

namespace simplexdb {
namespace {

static_assert(std::endian::native == std::endian::little, "the files below are written as is");

template <class T>
void Put(std::string& bytes, size_t at, T v) {
  std::memcpy(bytes.data() + at, &v, sizeof v);
}

// A little-endian NIfTI-1 .nii of int16 voxels, dims x*y*z, with
// scl_slope/scl_inter.
void WriteScaledNifti(const std::string& path, std::array<int16_t, 3> dims,
                      const std::vector<int16_t>& stored, float slope, float inter) {
  std::string b(352, '\0');
  Put<int32_t>(b, 0, 348);
  const int16_t dim[8] = {3, dims[0], dims[1], dims[2], 1, 1, 1, 1};
  for (size_t i = 0; i < 8; ++i) Put<int16_t>(b, 40 + 2 * i, dim[i]);
  Put<int16_t>(b, 70, 4);   // int16
  Put<int16_t>(b, 72, 16);  // bitpix
  for (size_t i = 0; i < 8; ++i) Put<float>(b, 76 + 4 * i, 1.0f);
  Put<float>(b, 108, 352.0f);  // vox_offset
  Put<float>(b, 112, slope);
  Put<float>(b, 116, inter);
  std::memcpy(b.data() + 344, "n+1\0", 4);
  for (int16_t v : stored) {
    b.resize(b.size() + 2);
    Put<int16_t>(b, b.size() - 2, v);
  }
  std::ofstream(path, std::ios::binary) << b;
}

void WriteRawF64(const std::string& path, const std::vector<double>& values) {
  std::string b(values.size() * sizeof(double), '\0');
  for (size_t i = 0; i < values.size(); ++i) Put<double>(b, i * sizeof(double), values[i]);
  std::ofstream(path, std::ios::binary) << b;
}

// The dense store holds a scaled volume as float32, built by the direct
// builder: at a uniform threshold, the mesh of the lossless sparse store's
// per-node errors (made through the per-node engine).
TEST(ValuesCli, ScaledNiftiDenseStoreHasThePerNodeMesh) {
  const TempDir dir;
  const std::string nii = dir.path() + "/s.nii";
  std::vector<int16_t> stored;
  for (int i = 0; i < 9 * 8 * 7; ++i) stored.push_back(static_cast<int16_t>((i * i) % 97 - 40));
  WriteScaledNifti(nii, {9, 8, 7}, stored, 0.1f, 0.3f);
  const std::string f1 = dir.path() + "/a.lmdb", f2 = dir.path() + "/b.sdb";
  ASSERT_EQ(RunCli("import " + nii + " --sparse --quantization f32 -q -o " + f1).exit_code, 0);
  auto r = RunCli("import " + nii + " --quantization f32 --json -o " + f2);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["error_method"], "diamonds");
  r = RunCli("info " + f2 + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["voxel_type"], "float32");
  EXPECT_NE(info["source"].get<std::string>().find("(scaled: slope 0.1"), std::string::npos)
      << info["source"];
  for (const std::string& s : {f1, f2}) {
    r = RunCli("extract " + s + " --error 2% --format codes -o " + s + ".codes");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  std::ifstream a(f1 + ".codes"), b(f2 + ".codes");
  std::set<std::string> la, lb;
  for (std::string line; std::getline(a, line);) la.insert(line);
  for (std::string line; std::getline(b, line);) lb.insert(line);
  EXPECT_GT(la.size(), 6u);
  EXPECT_EQ(la, lb);
}

// Imports `nii` (stored with slope 0.25, intercept -3) into `store` with
// `flags` and checks what import and info report: the scaling, float32
// values, the field's range [lo, hi].
void ExpectScaledImport(const std::string& nii, const std::string& store, const std::string& flags,
                        double lo, double hi) {
  SCOPED_TRACE(store);
  const auto r = RunCli("import " + nii + flags + " -o " + store);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("scaled: slope 0.25, intercept -3 -> float32"), std::string::npos)
      << r.out;
  nlohmann::json info = RunJson("info " + store + " --json");
  EXPECT_EQ(info["voxel_type"], "float32");
  EXPECT_NE(info.value("source", "").find("(scaled: slope 0.25, intercept -3)"),
            std::string::npos)
      << info["source"];
  EXPECT_EQ(info.value("field_min", 0.0), lo);
  EXPECT_EQ(info.value("field_max", 0.0), hi);
}

TEST(ValuesCli, ScaledNiftiImportsTheScaledValues) {
  const TempDir dir;
  const std::string nii = dir.path() + "/s.nii";
  // Not linear, so the errors are not all 0: stored (i * i) % 23 - 11.
  std::vector<int16_t> stored;
  std::vector<double> expected;  // 0.25 * stored - 3, worked out apart from the reader
  for (int i = 0; i < 5 * 4 * 3; ++i) {
    stored.push_back(static_cast<int16_t>((i * i) % 23 - 11));
    expected.push_back(((i * i) % 23 - 11) / 4.0 - 3.0);
  }
  WriteScaledNifti(nii, {5, 4, 3}, stored, 0.25f, -3.0f);
  const auto [lo, hi] = std::minmax_element(expected.begin(), expected.end());

  const std::string store = dir.path() + "/s.sdb";
  ASSERT_NO_FATAL_FAILURE(ExpectScaledImport(nii, store, "", *lo, *hi));
  const auto r = RunCli("info " + store);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("(scaled: slope 0.25, intercept -3)"), std::string::npos) << r.out;
  ASSERT_EQ(RunCli("export " + store + " -o " + dir.path() + "/back.nrrd").exit_code, 0);
  EXPECT_EQ(ReadVolumeValues(dir.path() + "/back.nrrd"), expected);
  EXPECT_EQ(RunCli("verify " + store).exit_code, 0);

  nlohmann::json report = RunJson("import " + nii + " --json -o " + dir.path() + "/j.sdb");
  EXPECT_EQ(report["scaling"]["slope"], 0.25);
  EXPECT_EQ(report["scaling"]["intercept"], -3.0);

  // The sparse store holds the same values.
  ExpectScaledImport(nii, dir.path() + "/s.lmdb", " --sparse", *lo, *hi);
}

// Exit 1 (not 0, not 70) with `mentions` on stderr, and `output` absent.
void ExpectRejected(const std::string& args, const std::string& output,
                    const std::vector<std::string>& mentions) {
  SCOPED_TRACE(args);
  const auto r = RunCli(args);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  for (const std::string& m : mentions) EXPECT_NE(r.err.find(m), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(output));
  for (const auto& e : fs::directory_iterator(fs::path(output).parent_path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

TEST(ValuesCli, ValuesBeyondFloat32AreRejectedWithTheirPosition) {
  const TempDir dir;
  const std::string& d = dir.path();
  std::vector<double> values(4 * 3 * 2);
  for (size_t i = 0; i < values.size(); ++i) values[i] = 0.5 * static_cast<double>(i % 7);
  values[1 + 4 * (2 + 3 * 1)] = 1e39;  // (1, 2, 1)

  const std::string raw = d + "/big.raw";
  WriteRawF64(raw, values);
  for (const char* sparse : {"", " --sparse"}) {
    ExpectRejected("import " + raw + " --dims 4,3,2 --type float64 -o " + d + "/o.sdb" + sparse,
                   d + "/o.sdb",
                   {raw + ": value 1e+39 at voxel (1, 2, 1) is beyond float32's range"});
  }
  const std::string nrrd = d + "/big.nrrd";
  ASSERT_TRUE(WriteNrrd(nrrd, 3, {4, 3, 2, 1}, VoxelType::kF64, values).ok());
  ExpectRejected("import " + nrrd + " -o " + d + "/n.sdb", d + "/n.sdb",
                 {nrrd + ": value 1e+39 at voxel (1, 2, 1) is beyond float32's range"});

  // A time series (HP): the position has t, the message the step's file.
  values[1 + 4 * (2 + 3 * 1)] = 1;
  std::vector<double> step = values;
  step[3] = -std::numeric_limits<double>::infinity();  // (3, 0, 0)
  const std::string t0 = d + "/t0.raw", t1 = d + "/t1.raw";
  WriteRawF64(t0, values);
  WriteRawF64(t1, step);
  ExpectRejected("import " + t0 + " " + t1 + " --dims 4,3,2 --type float64 -o " + d + "/t.sdb",
                 d + "/t.sdb", {"value -inf at voxel (3, 0, 0, 1) is infinite", t1});

  // A scaled NIfTI whose scaled values overflow float32: 1000 * 1e36.
  const std::string nii = d + "/over.nii";
  std::vector<int16_t> stored(4 * 3 * 2, 1);
  stored[2 + 4 * 1] = 1000;  // (2, 1, 0)
  WriteScaledNifti(nii, {4, 3, 2}, stored, 1e36f, 0.0f);
  ExpectRejected("import " + nii + " -o " + d + "/s.sdb", d + "/s.sdb",
                 {nii, "at voxel (2, 1, 0)", "beyond float32's range"});
}

TEST(ValuesCli, UpdateRejectsValuesBeyondFloat32) {
  const TempDir dir;
  const std::string& d = dir.path();
  std::vector<double> values(4 * 3 * 2);
  for (size_t i = 0; i < values.size(); ++i) values[i] = 0.5 * static_cast<double>(i % 7);
  const std::string good = d + "/good.nrrd", bad = d + "/bad.nrrd", store = d + "/s.lmdb";
  ASSERT_TRUE(WriteNrrd(good, 3, {4, 3, 2, 1}, VoxelType::kF64, values).ok());
  auto r = RunCli("import " + good + " --sparse -o " + store);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  values[2 + 4 * (1 + 3 * 1)] = std::numeric_limits<double>::infinity();  // (2, 1, 1)
  ASSERT_TRUE(WriteNrrd(bad, 3, {4, 3, 2, 1}, VoxelType::kF64, values).ok());
  r = RunCli("update " + store + " " + bad + " --box 0,0,0,3,2,1");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(bad + ": value inf at voxel (2, 1, 1) is infinite"), std::string::npos)
      << r.err;
  values[2 + 4 * (1 + 3 * 1)] = -1e39;
  ASSERT_TRUE(WriteNrrd(bad, 3, {4, 3, 2, 1}, VoxelType::kF64, values).ok());
  r = RunCli("update " + store + " " + bad + " --box 0,0,0,3,2,1");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(bad + ": value -1e+39 at voxel (2, 1, 1) is beyond float32's range"),
            std::string::npos)
      << r.err;
  // The store is as imported.
  EXPECT_EQ(RunCli("verify " + store).exit_code, 0);
}

}  // namespace
}  // namespace simplexdb
