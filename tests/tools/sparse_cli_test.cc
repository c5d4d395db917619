// simplexdb import --sparse / convert / info / verify on sparse stores, end
// to end: the contract's forms, round trips through the dense store, and
// what a user sees for wrong input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include <nlohmann/json.hpp>

#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/tools/cli_test_util.h"
#include "tests/util/python_vtk.h"

namespace simplexdb {
namespace {

TEST(SparseCli, ImportConvertInfoVerifyRoundTrip) {
  const TempDir dir;
  const std::string in = dir.path() + "/p.nrrd";
  ASSERT_EQ(RunCli("generate --field perlin --dims 17,13,9 --type uint8 --seed 2 -o " + in).exit_code, 0);
  // Built directly from the volume, and converted from a dense store.
  auto r = RunCli("import " + in + " --sparse -o " + dir.path() + "/a.lmdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["kind"], "ht-sparse");
  ASSERT_EQ(RunCli("import " + in + " -o " + dir.path() + "/d.sdb --threads 1 -q").exit_code, 0);
  r = RunCli("convert " + dir.path() + "/d.sdb --to sparse -o " + dir.path() + "/b.lmdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("info " + dir.path() + "/b.lmdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = Json(r);
  EXPECT_EQ(info["kind"], "ht-sparse");
  EXPECT_EQ(info["dims"], (std::vector<int>{17, 13, 9}));
  EXPECT_EQ(info["tolerance"], 0.0);
  EXPECT_EQ(info["format_version"], 4);
  // Built from the volume or through the dense store: the same store.
  const auto direct = Json(RunCli("info " + dir.path() + "/a.lmdb --json"));
  for (const char* key : {"kept", "blocks", "field_min", "field_max", "error_max", "quantum"}) {
    EXPECT_EQ(info[key], direct[key]) << key;
  }
  EXPECT_GT(info["kept"].get<uint64_t>(), 8u);
  EXPECT_EQ(RunCli("verify " + dir.path() + "/b.lmdb").exit_code, 0);
  // Back to dense: the same field.
  ASSERT_EQ(RunCli("convert " + dir.path() + "/b.lmdb --to dense -o " + dir.path() + "/back.sdb -q").exit_code, 0);
  ASSERT_EQ(RunCli("export " + dir.path() + "/back.sdb -o " + dir.path() + "/back.nrrd").exit_code, 0);
  EXPECT_EQ(ReadVolumeValues(dir.path() + "/back.nrrd"), ReadVolumeValues(in));
  // A tolerance as a share of the field range keeps fewer vertices.
  r = RunCli("convert " + dir.path() + "/d.sdb --to sparse --tolerance 10% -o " + dir.path() + "/c.lmdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(Json(r)["kept"].get<uint64_t>(), info["kept"].get<uint64_t>());
  EXPECT_NEAR(Json(r)["tolerance"].get<double>(), 0.1 * (info["field_max"].get<double>() - info["field_min"].get<double>()), 1e-9);
}

// A lossy store of an integer field converts back to its type: values
// rebuilt beyond the type's range (a 0 rebuilt as -1) are clamped, and
// every voxel stays within the tolerance (+ 0.5 for rounding) of the input.
TEST(SparseCli, LossyIntegerStoreConvertsToDense) {
  const TempDir dir;
  const std::string in = dir.path() + "/v.nrrd";
  // Values pinned at 0 and 255 over wide regions, with noise: rebuilt
  // vertices there overshoot the type's range.
  const std::array<uint32_t, 3> n = {24, 20, 18};
  std::vector<double> v(n[0] * n[1] * n[2]);
  uint32_t state = 12345;
  for (size_t i = 0; i < v.size(); ++i) {
    state = state * 1664525u + 1013904223u;
    const size_t x = i % n[0];
    const double base = x < 8 ? 0 : x < 16 ? 128 : 255;
    v[i] = std::clamp(base + static_cast<double>(state >> 28) - 7, 0.0, 255.0);
  }
  {
    std::ofstream out(in, std::ios::binary);
    out << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 24 20 18\nencoding: raw\n\n";
    for (double x : v) out.put(static_cast<char>(static_cast<uint8_t>(x)));
  }
  for (const char* tolerance : {"4", "20"}) {
    SCOPED_TRACE(tolerance);
    const std::string sparse = dir.path() + "/s" + tolerance + ".lmdb", dense = dir.path() + "/d" + tolerance + ".sdb",
                      back = dir.path() + "/b" + tolerance + ".nrrd";
    ASSERT_EQ(RunCli("import " + in + " --sparse --tolerance " + tolerance + " -o " + sparse + " -q").exit_code, 0);
    auto r = RunCli("convert " + sparse + " --to dense -o " + dense + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(RunCli("export " + dense + " -o " + back).exit_code, 0);
    const std::vector<double> got = ReadVolumeValues(back);
    ASSERT_EQ(got.size(), v.size());
    double worst = 0;
    for (size_t i = 0; i < v.size(); ++i) worst = std::max(worst, std::fabs(got[i] - v[i]));
    EXPECT_LE(worst, std::stod(tolerance) + 0.5);
    // Exported from the sparse store itself: the same uint8 values, in range.
    const std::string direct = dir.path() + "/e" + tolerance + ".nrrd";
    r = RunCli("export " + sparse + " -o " + direct);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(OpenVolume(direct)->type, VoxelType::kU8);
    EXPECT_EQ(ReadVolumeValues(direct), got);
  }
}

TEST(SparseCli, WrongInputSaysWhat) {
  const TempDir dir;
  const std::string in = dir.path() + "/p.nrrd", dense = dir.path() + "/d.sdb", sparse = dir.path() + "/s.lmdb";
  ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9 --type uint8 -o " + in).exit_code, 0);
  ASSERT_EQ(RunCli("import " + in + " -o " + dense + " -q").exit_code, 0);
  ASSERT_EQ(RunCli("convert " + dense + " --to sparse -o " + sparse + " -q").exit_code, 0);
  const auto expect = [](const std::string& args, int code, const std::string& needle) {
    SCOPED_TRACE(args);
    const auto r = RunCli(args);
    EXPECT_EQ(r.exit_code, code) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
  };
  expect("convert " + sparse + " --to sparse -o " + dir.path() + "/x.lmdb", 2, "already a sparse store");
  expect("convert " + dense + " --to dense -o " + dir.path() + "/x.sdb", 2, "not a sparse store");
  expect("convert " + dense + " --to sparse --tolerance -3 -o " + dir.path() + "/x.lmdb", 2, "--tolerance");
  expect("convert " + dense + " --to sparse --tolerance lots -o " + dir.path() + "/x.lmdb", 2, "'lots'");
  expect("import " + in + " --tolerance 1 -o " + dir.path() + "/x.sdb", 2, "--tolerance needs --sparse");
  // Not a store, and an LMDB file of another program.
  std::ofstream(dir.path() + "/junk.lmdb") << "junk";
  expect("info " + dir.path() + "/junk.lmdb", 1, "junk.lmdb");
  EXPECT_FALSE(fs::exists(dir.path() + "/x.lmdb"));
  EXPECT_FALSE(fs::exists(dir.path() + "/x.sdb"));
}

TEST(SparseCli, UpdateEqualsAFreshImport) {
  const TempDir dir;
  const std::string a = dir.path() + "/a.nrrd", b = dir.path() + "/b.nrrd", c = dir.path() + "/c.nrrd";
  ASSERT_EQ(RunCli("generate --field perlin --dims 17,13,9 --type uint8 --seed 2 -o " + a).exit_code, 0);
  ASSERT_EQ(RunCli("generate --field perlin --dims 17,13,9 --type uint8 --seed 3 -o " + b).exit_code, 0);
  // c: a, with b's values (within a's range) in the box x 3..9, y 2..12, z 4..6.
  const std::vector<double> va = ReadVolumeValues(a), vb = ReadVolumeValues(b);
  const auto [lo, hi] = std::minmax_element(va.begin(), va.end());
  std::vector<double> vc = va;
  for (int z = 4; z <= 6; ++z) {
    for (int y = 2; y <= 12; ++y) {
      for (int x = 3; x <= 9; ++x) {
        const size_t i = x + 17 * (y + 13 * z);
        vc[i] = std::clamp(vb[i], *lo, *hi);
      }
    }
  }
  ASSERT_TRUE(WriteNrrd(c, 3, {17, 13, 9, 1}, VoxelType::kU8, vc).ok());
  ASSERT_EQ(RunCli("import " + a + " --sparse --tolerance 2% -o " + dir.path() + "/s.lmdb -q").exit_code, 0);
  ASSERT_EQ(RunCli("import " + c + " --sparse --tolerance 2% -o " + dir.path() + "/fresh.lmdb -q").exit_code, 0);
  auto r = RunCli("update " + dir.path() + "/s.lmdb " + c + " --box 3,2,4,9,12,6 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_GT(Json(r)["blocks_written"].get<uint64_t>(), 0u);
  const auto got = Json(RunCli("info " + dir.path() + "/s.lmdb --json"));
  const auto want = Json(RunCli("info " + dir.path() + "/fresh.lmdb --json"));
  for (const char* key : {"kept", "blocks", "field_min", "field_max", "error_max", "tolerance"}) {
    EXPECT_EQ(got[key], want[key]) << key;
  }
  EXPECT_EQ(RunCli("verify " + dir.path() + "/s.lmdb").exit_code, 0);
  // The same meshes and values as the fresh import.
  const auto codes = [&](const std::string& store) {
    return RunCli("extract " + store + " --error 3% --format codes -o -").out;
  };
  EXPECT_EQ(codes(dir.path() + "/s.lmdb"), codes(dir.path() + "/fresh.lmdb"));
  EXPECT_FALSE(codes(dir.path() + "/s.lmdb").empty());
  ASSERT_EQ(RunCli("convert " + dir.path() + "/s.lmdb --to dense -o " + dir.path() + "/u.sdb -q").exit_code, 0);
  ASSERT_EQ(RunCli("convert " + dir.path() + "/fresh.lmdb --to dense -o " + dir.path() + "/f.sdb -q").exit_code, 0);
  ASSERT_EQ(RunCli("export " + dir.path() + "/u.sdb -o " + dir.path() + "/u.nrrd").exit_code, 0);
  ASSERT_EQ(RunCli("export " + dir.path() + "/f.sdb -o " + dir.path() + "/f.nrrd").exit_code, 0);
  EXPECT_EQ(ReadVolumeValues(dir.path() + "/u.nrrd"), ReadVolumeValues(dir.path() + "/f.nrrd"));
  // Updated again with the same volume: nothing to write.
  r = RunCli("update " + dir.path() + "/s.lmdb " + c + " --box 3,2,4,9,12,6 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["blocks_written"], 0);
  EXPECT_EQ(Json(r)["blocks_deleted"], 0);

  // What a user sees for wrong input; nothing changes.
  const auto expect = [](const std::string& args, int code, const std::string& needle) {
    SCOPED_TRACE(args);
    const auto e = RunCli(args);
    EXPECT_EQ(e.exit_code, code) << e.err;
    EXPECT_NE(e.err.find(needle), std::string::npos) << e.err;
  };
  const std::string s = dir.path() + "/s.lmdb ";
  expect("update " + s + c + " --box 3,2,4,9,12", 2, "--box");
  expect("update " + s + c + " --box 3,2.5,4,9,12,6", 2, "2.5");
  expect("update " + s + c + " --box 3,2,4,9,13,6", 1, "axis 1: 2 .. 13");
  // A volume that differs outside the box: the first such point named (a
  // differs from the store, now c, at z = 6).
  expect("update " + s + a + " --box 3,2,4,9,12,5", 1, "differs outside --box");
  expect("update " + s + b + " --box 3,2,4,9,12,6", 1, "grid point (");
  ASSERT_EQ(RunCli("import " + a + " -o " + dir.path() + "/d.sdb -q").exit_code, 0);
  expect("update " + dir.path() + "/d.sdb " + c + " --box 3,2,4,9,12,6", 2, "not a sparse store");
  EXPECT_EQ(codes(dir.path() + "/s.lmdb"), codes(dir.path() + "/fresh.lmdb"));
}

// NaN in a float volume marks missing values: the dense store builds,
// verifies and gives a mesh that conforms; VTK reads the NaN field values.
// The sparse store (format 2) refuses them, naming the file, for now.
TEST(SparseCli, MissingValuesEndToEnd) {
  const TempDir dir;
  const std::string in = dir.path() + "/holes.nrrd";
  testing::TestVolume v = testing::TestVolume::Random(3, {33, 30, 33, 1}, VoxelType::kF32, 5);
  for (size_t i = 0; i < v.values.size(); ++i) {
    const int64_t x = i % 33, y = (i / 33) % 30, z = i / (33 * 30);
    if ((x - 10) * (x - 10) + (y - 12) * (y - 12) + (z - 20) * (z - 20) <= 49) {
      v.values[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  ASSERT_TRUE(v.WriteNrrd(in).ok());
  const std::string dense = dir.path() + "/h.sdb", sparse = dir.path() + "/h.lmdb";
  ASSERT_EQ(RunCli("import " + in + " -o " + dense + " -q").exit_code, 0);
  auto r = RunCli("import " + in + " --sparse -o " + sparse + " -q");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(in + ": missing values (NaN)"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(sparse));
  EXPECT_EQ(RunCli("verify " + dense).exit_code, 0);
  const std::string a = dir.path() + "/a.codes";
  ASSERT_EQ(RunCli("extract " + dense + " --error 20% --format codes -o " + a).exit_code, 0);
  EXPECT_EQ(RunCli("conformity " + a + " --hierarchy ht").exit_code, 0);
  // The same holes as a mask over an integer volume: a float32 store.
  testing::TestVolume u8 = testing::TestVolume::Random(3, {33, 30, 33, 1}, VoxelType::kU8, 5);
  testing::TestVolume mask = u8;
  for (size_t i = 0; i < mask.values.size(); ++i) mask.values[i] = std::isnan(v.values[i]) ? 0 : 1;
  ASSERT_TRUE(u8.WriteNrrd(dir.path() + "/u8.nrrd").ok());
  ASSERT_TRUE(mask.WriteNrrd(dir.path() + "/mask.nrrd").ok());
  r = RunCli("import " + dir.path() + "/u8.nrrd --mask " + dir.path() + "/mask.nrrd -o " +
             dir.path() + "/m.sdb -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(RunCli("info " + dir.path() + "/m.sdb --json"))["voxel_type"], "float32");
  EXPECT_EQ(RunCli("verify " + dir.path() + "/m.sdb").exit_code, 0);
  r = RunCli("import " + dir.path() + "/u8.nrrd --mask " + dir.path() + "/mask.nrrd --sparse -o " +
             dir.path() + "/m.lmdb -q");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--mask with --sparse"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() + "/m.lmdb"));
  const std::string python = testing::FindPythonWithVtk("vtkmodules.vtkIOXML");
  if (python.empty()) GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  const std::string vtu = dir.path() + "/h.vtu";
  ASSERT_EQ(RunCli("extract " + dense + " --error 20% --format vtu -o " + vtu).exit_code, 0);
  FILE* p = popen((python + " " SIMPLEXDB_QUERY_TEST_DIR "/vtk_read_vtu.py " + vtu).c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  ASSERT_EQ(pclose(p), 0) << out;
  const auto vtk = nlohmann::json::parse(out);
  EXPECT_GT(vtk["nan_points"].get<int>(), 0);
  // The mesh is clipped to the real 33 x 30 x 33 grid.
  EXPECT_NEAR(vtk["volume"].get<double>(), 32.0 * 29 * 32, 1e-6);
  EXPECT_NEAR(vtk["signed_volume"].get<double>(), 32.0 * 29 * 32, 1e-6);
  EXPECT_EQ(vtk["negative_cells"], 0);
  EXPECT_EQ(vtk["bounds"], nlohmann::json::parse("[0, 32, 0, 29, 0, 32]"));
}

}  // namespace
}  // namespace simplexdb
