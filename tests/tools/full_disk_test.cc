// A full disk, for real: every command that writes a file is run against a
// small tmpfs (mounted for the test; skipped where mounting is not allowed).
// Each must fail with a clear reason naming the file, leave nothing under
// the real name or as a temporary, and leave an earlier file of the same
// name as it was.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

using testing::RunCli;
using testing::TempDir;
namespace fs = std::filesystem;

class FullDisk : public ::testing::Test {
 protected:
  void SetUp() override {
    disk_ = dir_.path() + "/disk";
    fs::create_directory(disk_);
    if (mount("tmpfs", disk_.c_str(), "tmpfs", 0, "size=128k") != 0) {
      GTEST_SKIP() << "cannot mount a small tmpfs here (needs root): " << std::strerror(errno);
    }
    mounted_ = true;
    in_ = dir_.path() + "/p65.nrrd";
    ASSERT_EQ(RunCli("generate --field perlin --dims 65,65,65 --type uint8 -o " + in_).exit_code, 0);
    store_ = dir_.path() + "/p65.sdb";
    ASSERT_EQ(RunCli("import " + in_ + " -o " + store_ + " -q").exit_code, 0);
  }
  void TearDown() override {
    if (mounted_) umount(disk_.c_str());
  }
  // Nothing but `keep` in the small disk.
  void ExpectOnly(const std::vector<std::string>& keep) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(disk_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, keep);
  }
  void ExpectDiskFull(const testing::CommandResult& r, const std::string& file) {
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
    EXPECT_TRUE(r.err.find("No space left") != std::string::npos || r.err.find("disk is full") != std::string::npos)
        << r.err;
  }

  TempDir dir_;
  std::string disk_, in_, store_;
  bool mounted_ = false;
};

TEST_F(FullDisk, EveryWriterFailsCleanly) {
  ExpectDiskFull(RunCli("import " + in_ + " -o " + disk_ + "/d.sdb -q"), disk_ + "/d.sdb");
  ExpectDiskFull(RunCli("import " + in_ + " --sparse -o " + disk_ + "/s.lmdb -q"), disk_ + "/s.");
  ExpectDiskFull(RunCli("convert " + store_ + " --to sparse -o " + disk_ + "/c.lmdb"), disk_ + "/c.lmdb");
  ExpectDiskFull(RunCli("extract " + store_ + " --error 1% --format vtu -o " + disk_ + "/m.vtu"),
                 disk_ + "/m.vtu");
  ExpectDiskFull(RunCli("extract " + store_ + " --error 0 --format codes -o " + disk_ + "/m.codes"),
                 disk_ + "/m.codes");
  ExpectOnly({});
}

TEST_F(FullDisk, AnEarlierFileSurvivesAFailedRewrite) {
  const std::string small = dir_.path() + "/small.nrrd";
  ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9 --type uint8 -o " + small).exit_code, 0);
  const std::string target = disk_ + "/s.sdb";
  ASSERT_EQ(RunCli("import " + small + " -o " + target + " -q").exit_code, 0);
  ExpectDiskFull(RunCli("import " + in_ + " -o " + target + " -q"), target);
  ExpectOnly({"s.sdb"});
  auto r = RunCli("verify " + target);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("info " + target + " --json");
  // The dims, not any "65": the temporary folder's random name may hold one.
  EXPECT_NE(r.out.find("\"dims\":[9,9,9]"), std::string::npos) << r.out;
}

// Reading needs no space, but LMDB's lock file does: before it was
// allocated ahead of LMDB's mapping, every read of a sparse store on a full
// file system died of SIGBUS at the first transaction.
TEST_F(FullDisk, ASparseStoreOnAFullDiskIsRead) {
  const std::string small = dir_.path() + "/small.nrrd";
  ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9 --type uint8 -o " + small).exit_code, 0);
  const std::string built = dir_.path() + "/s.lmdb";
  ASSERT_EQ(RunCli("import " + small + " --sparse -o " + built + " -q").exit_code, 0);
  const std::string store = disk_ + "/s.lmdb";
  fs::copy_file(built, store);
  {  // fill the disk
    std::FILE* fill = std::fopen((disk_ + "/fill").c_str(), "wb");
    ASSERT_NE(fill, nullptr);
    const std::vector<char> chunk(4096, 'x');
    while (std::fwrite(chunk.data(), 1, chunk.size(), fill) == chunk.size() && std::fflush(fill) == 0) {
    }
    std::fclose(fill);
  }
  const std::string expected = RunCli("info " + built + " --json").out;
  auto r = RunCli("info " + store + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The same report but for the path.
  ASSERT_NE(r.out.find("\"kind\""), std::string::npos) << r.out;
  EXPECT_EQ(r.out.substr(r.out.find("\"kind\"")), expected.substr(expected.find("\"kind\"")));
  r = RunCli("verify " + store);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("extract " + store + " --error 1% --format codes -o -");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, RunCli("extract " + built + " --error 1% --format codes -o -").out);
  EXPECT_FALSE(r.out.empty());
}

}  // namespace
}  // namespace simplexdb
