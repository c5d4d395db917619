// simplexdb import / info / verify / export / generate end to end: what a
// user sees for good and bad input, a killed build, round trips.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>

#include <nlohmann/json.hpp>

#include "storage/dense/dense_format.h"
#include "storage/volume/volume.h"
#include "tests/tools/cli_test_util.h"

namespace simplexdb {
namespace {

TEST(StoreCli, GenerateImportInfoVerifyExport) {
  const TempDir dir;
  const std::string in = dir.path() + "/p.nrrd", store = dir.path() + "/p.sdb";
  auto r = RunCli("generate --field perlin --dims 17,13,9 --type int16 --seed 3 -o " + in);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("import " + in + " -o " + store + " --quantization u8 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out);
  EXPECT_EQ(report["hierarchy"], "ht");
  EXPECT_EQ(report["leaf_level"], 12);  // 17 -> domain 2^4 + 1, 3 levels per halving
  r = RunCli("info " + store + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["kind"], "ht-dense");
  EXPECT_EQ(info["quantization"], "u8");
  EXPECT_EQ(info["dims"], (std::vector<int>{17, 13, 9}));
  EXPECT_EQ(info["voxel_type"], "int16");
  EXPECT_GT(info["compression_ratio"].get<double>(), 1.0);
  EXPECT_EQ(info["file_bytes"].get<uint64_t>(), fs::file_size(store));
  EXPECT_EQ(RunCli("verify " + store).exit_code, 0);
  // The field comes back losslessly, whole or as a box at a coarser step.
  ASSERT_EQ(RunCli("export " + store + " -o " + dir.path() + "/back.nrrd").exit_code, 0);
  EXPECT_EQ(ReadVolumeValues(dir.path() + "/back.nrrd"), ReadVolumeValues(in));
  r = RunCli("export " + store + " --roi 2,1,0,10,12,8 --step 2 -o " + dir.path() + "/box.raw");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<double> all = ReadVolumeValues(in), box = ReadVolumeValues(dir.path() + "/box.nhdr");
  ASSERT_EQ(box.size(), 5u * 6 * 5);
  size_t i = 0;
  for (int z = 0; z <= 8; z += 2) {
    for (int y = 1; y <= 12; y += 2) {
      for (int x = 2; x <= 10; x += 2) ASSERT_EQ(box[i++], all[(z * 13 + y) * 17 + x]);
    }
  }
}

std::vector<std::string> SortedLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::sort(lines.begin(), lines.end());
  return lines;
}

// import end to end (the dense store, format 2): info and verify read it,
// extract at a uniform threshold gives exactly the mesh of the lossless
// sparse store's per-node errors (both float32: diamond errors change no
// uniform mesh of these volumes), HT and HP, reporting the blocks it
// decoded and needed, and export gives the field back, whole and at every
// other point.
TEST(StoreCli, ImportInfoVerifyExtractExport) {
  const TempDir dir;
  for (const std::string dims : {"17,13,9", "9,7,9,5"}) {
    SCOPED_TRACE(dims);
    const std::string in = dir.path() + "/p.nrrd", sparse = dir.path() + "/p.lmdb",
                      f2 = dir.path() + "/p2.sdb";
    auto r = RunCli("generate --field perlin --dims " + dims + " --type int16 --seed 5 -o " + in +
                    " --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = RunCli("import " + in + " -o " + f2 + " --quantization f32 --json --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto report = nlohmann::json::parse(r.out);
    EXPECT_EQ(report["format_version"], 3);
    EXPECT_EQ(report["file_bytes"].get<uint64_t>(), fs::file_size(f2));
    ASSERT_EQ(RunCli("import " + in + " --sparse -o " + sparse + " --quantization f32 -q --force")
                  .exit_code,
              0);
    r = RunCli("info " + f2 + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto info = nlohmann::json::parse(r.out);
    EXPECT_EQ(info["format_version"], 3);
    EXPECT_EQ(info["voxel_type"], "int16");
    EXPECT_EQ(info["grid_points"], report["grid_points"]);
    EXPECT_GT(info["stored_blocks"].get<uint64_t>(), 0u);
    EXPECT_EQ(RunCli("verify " + f2 + " -q").exit_code, 0);
    for (const std::string& s : {sparse, f2}) {
      r = RunCli("extract " + s + " --error 3% --format codes -o " + s + ".codes --force");
      ASSERT_EQ(r.exit_code, 0) << r.err;
    }
    const auto leaves = SortedLines(f2 + ".codes");
    EXPECT_GT(leaves.size(), 100u);
    EXPECT_EQ(leaves, SortedLines(sparse + ".codes"));
    r = RunCli("extract " + f2 + " --error 3% --format json -o -");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto stats = nlohmann::json::parse(r.out);
    EXPECT_EQ(stats["simplices"].get<size_t>(), leaves.size());
    EXPECT_GT(stats["distinct_blocks"].get<uint64_t>(), 0u);
    EXPECT_GE(stats["blocks_decoded"].get<uint64_t>(), stats["distinct_blocks"].get<uint64_t>());
    // export: the field back, losslessly, whole and every other point (one
    // lattice's bricks against the input read by this test). As raw + .nhdr:
    // one file with every axis, where a 4D .nrrd export is a file per time
    // step (tests/tools/export_cli_test.cc).
    r = RunCli("export " + f2 + " -o " + dir.path() + "/back.raw --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const std::vector<double> whole = ReadVolumeValues(in);
    EXPECT_EQ(ReadVolumeValues(dir.path() + "/back.nhdr"), whole);
    r = RunCli("export " + f2 + " --step 2 -o " + dir.path() + "/half.raw --force");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::vector<int64_t> n;
    for (size_t start = 0; start < dims.size();) {
      const size_t comma = dims.find(',', start);
      n.push_back(std::stoll(dims.substr(start, comma - start)));
      start = comma == std::string::npos ? dims.size() : comma + 1;
    }
    std::vector<double> every_other;
    const int64_t nt = n.size() == 4 ? n[3] : 1;
    for (int64_t t = 0; t < nt; t += 2) {
      for (int64_t z = 0; z < n[2]; z += 2) {
        for (int64_t y = 0; y < n[1]; y += 2) {
          for (int64_t x = 0; x < n[0]; x += 2) {
            every_other.push_back(whole[static_cast<size_t>(((t * n[2] + z) * n[1] + y) * n[0] + x)]);
          }
        }
      }
    }
    EXPECT_EQ(ReadVolumeValues(dir.path() + "/half.nhdr"), every_other);
  }
}

// A dense store of format 1 (the layout before 2026-11-26; the stored
// reference file of storage's golden tests) is refused by every command
// that reads a store, naming the file and saying to import again.
TEST(StoreCli, FormatOneStoresAreRefusedSayingToImportAgain) {
  const TempDir dir;
  const std::string f1 = dir.path() + "/old.sdb";
  fs::copy_file(std::string(SIMPLEXDB_GOLDEN_DIR) + "/format1_ht_7x6x5_u8_u16.sdb", f1);
  for (const std::string& command :
       {"info " + f1, "verify " + f1, "extract " + f1 + " --error 1%",
        "export " + f1 + " -o " + dir.path() + "/x.nrrd",
        "convert " + f1 + " --to sparse -o " + dir.path() + "/x.lmdb"}) {
    SCOPED_TRACE(command);
    const auto r = RunCli(command);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(f1 + ": a format-1 dense store"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("import the volume again"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir.path() + "/x.nrrd"));
  EXPECT_FALSE(fs::exists(dir.path() + "/x.lmdb"));
}

// to4d end to end: the seed's construction of a 4D set (section 4.7) as a
// NRRD the importer reads as an HP; values checked against the 3D input.
TEST(StoreCli, To4dLaysSubgridsAlongTime) {
  const TempDir dir;
  const std::string in = dir.path() + "/b.nrrd", out = dir.path() + "/b4.nrrd";
  ASSERT_EQ(RunCli("generate --field perlin --dims 17,17,13 --type uint8 -q -o " + in).exit_code, 0);
  auto r = RunCli("to4d " + in + " -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const VolumeInfo v = *OpenVolume(out);
  EXPECT_EQ(v.dimension, 4);
  EXPECT_EQ(v.dims, (std::array<uint32_t, 4>{5, 5, 4, 5}));  // (n - 1) / 4 + 1; steps: the longest axis
  EXPECT_EQ(v.type, VoxelType::kU8);
  const std::vector<double> a = ReadVolumeValues(in), b = ReadVolumeValues(out);
  // Time step 4 of point (1, 2, 3) is input point (4 + 0, 8 + 1, 12 + 0),
  // time step 3 of point (4, 2, 3) input point (16 + 3, 8, 12) clamped to x = 16.
  ASSERT_EQ(b.size(), 5u * 5 * 4 * 5);
  EXPECT_EQ(b.at(((4 * 4 + 3) * 5 + 2) * 5 + 1), a.at((12 * 17 + 9) * 17 + 4));
  EXPECT_EQ(b.at(((3 * 4 + 3) * 5 + 2) * 5 + 4), a.at((12 * 17 + 8) * 17 + 16));
  ASSERT_EQ(RunCli("import " + out + " -o " + dir.path() + "/b4.sdb -q").exit_code, 0);
  r = RunCli("info " + dir.path() + "/b4.sdb --json");
  EXPECT_EQ(nlohmann::json::parse(r.out)["hierarchy"], "hp");
  r = RunCli("to4d " + out + " -o " + dir.path() + "/x.nrrd");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("b4.nrrd"), std::string::npos) << r.err;
  r = RunCli("to4d " + in + " --steps 65 -o " + dir.path() + "/x.nrrd");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("65"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() + "/x.nrrd"));
}

TEST(StoreCli, RealVolumesAndTimeSeries) {
  const std::string data = SIMPLEXDB_SHARED_DATA;
  if (!fs::exists(data)) GTEST_SKIP() << "no " << data;
  const TempDir dir;
  auto r = RunCli("import " + data + "/bucky/bucky_32x32x32_uint8.raw --dims 32,32,32 --type uint8 -o " +
                  dir.path() + "/b.sdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["domain_bits"], 5);  // 32 needs 2^5 + 1
  EXPECT_EQ(RunCli("verify " + dir.path() + "/b.sdb").exit_code, 0);
  // A 4D NIfTI file builds an HP.
  r = RunCli("import " + data + "/dwi_small_101D/small_101D.nii -o " + dir.path() + "/d.sdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["hierarchy"], "hp");
  // Several 3D volumes: a time series, an HP.
  for (int t = 0; t < 3; ++t) {
    ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9 --seed " + std::to_string(t) + " -o " +
                     dir.path() + "/t" + std::to_string(t) + ".nrrd")
                  .exit_code,
              0);
  }
  r = RunCli("import " + dir.path() + "/t0.nrrd " + dir.path() + "/t1.nrrd " + dir.path() +
             "/t2.nrrd -o " + dir.path() + "/ts.sdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("info " + dir.path() + "/ts.sdb --json");
  EXPECT_EQ(nlohmann::json::parse(r.out)["dims"], (std::vector<int>{9, 9, 9, 3}));
}

// An import is reproducible: every shared volume, imported with one thread
// and with the default (one per core), gives the same bytes; the small ones
// also as sparse stores (whose build takes seconds on the larger ones).
TEST(StoreCli, ImportGivesTheSameBytesAtAnyThreadCount) {
  const std::string data = SIMPLEXDB_SHARED_DATA;
  if (!fs::exists(data)) GTEST_SKIP() << "no " << data;
  const TempDir dir;
  const std::vector<std::pair<std::string, bool>> volumes = {  // and whether sparse too
      {"bucky/bucky_32x32x32_uint8.raw --dims 32,32,32 --type uint8", true},
      {"neghip/neghip_64x64x64_uint8.raw --dims 64,64,64 --type uint8", true},
      {"tooth/tooth_103x94x161_uint8.raw --dims 103,94,161 --type uint8", true},
      {"headsq/headsq_64x64x93_int16le.raw --dims 64,64,93 --type int16 --spacing 3.2,3.2,1.5", true},
      {"lidc2/LIDC2_256x256x133_uint8.raw --dims 256,256,133 --type uint8", false},
      {"fmri_example4d/example4d.nii", false},
      {"dwi_small_101D/small_101D.nii", false},
  };
  for (const auto& [volume, sparse_too] : volumes) {
    for (const std::string kind : {"", " --sparse"}) {
      if (!kind.empty() && !sparse_too) continue;
      SCOPED_TRACE(volume + kind);
      const std::string one = dir.path() + "/one.sdb", all = dir.path() + "/all.sdb";
      auto r = RunCli("import " + data + "/" + volume + kind + " --threads 1 --quiet -o " + one);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      r = RunCli("import " + data + "/" + volume + kind + " --quiet -o " + all);
      ASSERT_EQ(r.exit_code, 0) << r.err;
      // (A sparse store's lock file, beside it, holds no data.)
      EXPECT_TRUE(testing::ReadFileBytes(one) == testing::ReadFileBytes(all));
      EXPECT_FALSE(testing::ReadFileBytes(one).empty());
    }
  }
}

TEST(StoreCli, BadInputSaysWhatAndWhere) {
  const TempDir dir;
  const std::string raw = dir.path() + "/v.raw";
  std::ofstream(raw, std::ios::binary) << std::string(1000, 'x');
  // Wrong dims for the file size.
  auto r = RunCli("import " + raw + " --dims 10,10,11 --type uint8 -o " + dir.path() + "/s.sdb");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("v.raw"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("1100"), std::string::npos) << r.err;  // bytes expected
  EXPECT_FALSE(fs::exists(dir.path() + "/s.sdb"));
  // Unsupported voxel type, missing type, unknown quantization: usage errors.
  EXPECT_EQ(RunCli("import " + raw + " --dims 10,10,10 --type int32 -o x.sdb").exit_code, 2);
  EXPECT_EQ(RunCli("import " + raw + " --dims 10,10,10 -o x.sdb").exit_code, 2);
  EXPECT_EQ(RunCli("import " + raw + " --dims 10,10,10 --type uint8 --quantization u4 -o x.sdb")
                .exit_code,
            2);
  // A 3D volume asked to build an HP.
  r = RunCli("import " + raw + " --dims 10,10,10 --type uint8 --hierarchy hp -o " + dir.path() +
             "/s.sdb");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("4D"), std::string::npos) << r.err;
  // Infinity in float input (NaN is a missing value, and builds).
  testing::TestVolume inf = testing::TestVolume::Random(3, {4, 4, 4, 1}, VoxelType::kF32, 1);
  inf.values[7] = std::numeric_limits<double>::infinity();
  ASSERT_TRUE(inf.WriteNrrd(dir.path() + "/inf.nrrd").ok());
  r = RunCli("import " + dir.path() + "/inf.nrrd -o " + dir.path() + "/n.sdb");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("infinite"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(3, 1, 0)"), std::string::npos) << r.err;  // voxel 7 of 4x4x4
  // A mask of another grid.
  r = RunCli("import " + dir.path() + "/inf.nrrd --mask " + dir.path() + "/g0.nrrd -o " +
             dir.path() + "/n.sdb");
  EXPECT_EQ(r.exit_code, 2);  // no such file
  ASSERT_EQ(RunCli("generate --dims 4,4,5 -o " + dir.path() + "/g0.nrrd").exit_code, 0);
  r = RunCli("import " + dir.path() + "/inf.nrrd --mask " + dir.path() + "/g0.nrrd -o " +
             dir.path() + "/n.sdb");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("4x4x5"), std::string::npos) << r.err;
  // Not a store; a damaged store.
  r = RunCli("info " + raw);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("not a SimplexDB"), std::string::npos) << r.err;
  ASSERT_EQ(RunCli("generate --dims 9,9,9 -o " + dir.path() + "/g.nrrd").exit_code, 0);
  ASSERT_EQ(RunCli("import " + dir.path() + "/g.nrrd -o " + dir.path() + "/g.sdb").exit_code, 0);
  {
    std::fstream f(dir.path() + "/g.sdb", std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(kDenseHeaderSize + 10);  // in the first block or brick
    f.put('\x5a');
  }
  r = RunCli("verify " + dir.path() + "/g.sdb");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("block"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("checksum"), std::string::npos) << r.err;
}

// A build killed part-way leaves nothing under the store's name, and the
// next build succeeds (and removes the dead build's temporary file).
TEST(StoreCli, KilledBuildLeavesNoStore) {
  const TempDir dir;
  const std::string in = dir.path() + "/big.nrrd", store = dir.path() + "/big.sdb";
  // Big enough that writing takes a while after the temporary appears (the
  // errors are computed in memory first).
  ASSERT_EQ(RunCli("generate --field perlin --dims 193,193,193 -o " + in).exit_code, 0);
  for (int attempt = 0; attempt < 3; ++attempt) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      execl(SIMPLEXDB_CLI, SIMPLEXDB_CLI, "import", in.c_str(), "-o", store.c_str(), "-q",
            "--threads", "1", static_cast<char*>(nullptr));
      _exit(127);
    }
    // Wait until the build is writing, then kill it without warning.
    const auto temporary_exists = [&] {
      for (const auto& e : fs::directory_iterator(dir.path())) {
        if (e.path().filename().string().find("big.sdb.tmp.") == 0) return true;
      }
      return false;
    };
    const auto start = std::chrono::steady_clock::now();
    while (!temporary_exists() && std::chrono::steady_clock::now() - start < std::chrono::seconds(20)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20 * attempt));
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "the build finished before it was killed";
    EXPECT_FALSE(fs::exists(store)) << "a partial store under the final name";
  }
  const auto r = RunCli("import " + in + " -o " + store + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(RunCli("verify " + store + " -q").exit_code, 0);
  for (const auto& e : fs::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

// Raw input placed with --spacing and --origin: info shows them (text and
// JSON) for the dense and the sparse store, convert carries them both ways,
// and bad values are refused before anything is written.
TEST(StoreCli, RawSpacingAndOriginReachTheHeaderAndInfo) {
  const TempDir dir;
  const std::string raw = dir.path() + "/v.raw";
  {
    std::ofstream out(raw, std::ios::binary);
    for (int i = 0; i < 9 * 7 * 5 * 3; ++i) out.put(static_cast<char>(i * 37 % 251));
  }
  const std::string placed = " --dims 9,7,5,3 --type uint8 --spacing 2,2,2.2,0.5 --origin -90.5,126,-72,7";
  const std::vector<double> spacing = {2, 2, 2.2, 0.5}, origin = {-90.5, 126, -72, 7};
  const std::string dense = dir.path() + "/v.sdb", sparse = dir.path() + "/v.lmdb";
  auto r = RunCli("import " + raw + placed + " -q -o " + dense);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("import " + raw + placed + " --sparse -q -o " + sparse);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string back_dense = dir.path() + "/back.sdb", back_sparse = dir.path() + "/back.lmdb";
  r = RunCli("convert " + sparse + " --to dense -q -o " + back_dense);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("convert " + dense + " --to sparse -q -o " + back_sparse);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const std::string& store : {dense, sparse, back_dense, back_sparse}) {
    SCOPED_TRACE(store);
    r = RunCli("info " + store + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto info = nlohmann::json::parse(r.out);
    EXPECT_EQ(info["spacing"].get<std::vector<double>>(), spacing);
    EXPECT_EQ(info["origin"].get<std::vector<double>>(), origin);
    r = RunCli("info " + store);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("placement   spacing 2 x 2 x 2.2 x 0.5, origin (-90.5, 126, -72, 7)"),
              std::string::npos)
        << r.out;
  }
  // Refused, exit 2, naming the option; nothing written.
  const struct {
    std::string options, message;
  } bad[] = {
      {" --spacing 1,0,1,1", "--spacing: 0 on axis 1 is not a finite non-zero number"},
      {" --spacing=1,2,1,-1", "--spacing: -1 on axis 3 is not a finite number > 0 (time runs forwards)"},
      {" --spacing 1,inf,1,1", "--spacing"},
      {" --spacing 1,nan,1,1", "--spacing"},
      {" --spacing 1,1,1", "--spacing: 3 numbers for a 4D volume"},
      {" --origin 1,2,3", "--origin: 3 numbers for a 4D volume"},
      {" --origin 1,x,3,4", "--origin"},
  };
  for (const auto& b : bad) {
    SCOPED_TRACE(b.options);
    const std::string out = dir.path() + "/bad.sdb";
    r = RunCli("import " + raw + " --dims 9,7,5,3 --type uint8" + b.options + " -q -o " + out);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(b.message), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

}  // namespace
}  // namespace simplexdb
