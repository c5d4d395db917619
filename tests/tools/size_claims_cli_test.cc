// simplexdb import of inputs that claim more than their files hold or than
// --memory-mb allows (issue 20): exit 1 at once with the numbers, never an
// internal error (70) from an attempted allocation. The commands run under
// a 1 GiB address-space limit, so an allocation for the claim fails there.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/storage/address_space_limit.h"
#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

using testing::CommandResult;
using testing::kOneGiB;
using testing::RunCli;
using testing::ScopedAddressSpaceLimit;
using testing::TempDir;
namespace fs = std::filesystem;

CommandResult RunLimited(const std::string& args) {
  const ScopedAddressSpaceLimit limit(kOneGiB);
  return RunCli(args);
}

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

// A gzip member (RFC 1952) around an empty fixed-Huffman deflate block,
// whose trailer claims `claimed` bytes (mod 2^32): 20 bytes that pass a
// check of the magic and the trailer alone.
std::string TinyGzipClaiming(uint64_t claimed) {
  std::string gz("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03", 10);
  gz += std::string("\x03\x00", 2);          // final block, fixed codes, end of block
  gz += std::string(4, '\0');                // CRC-32 of nothing
  for (int i = 0; i < 4; ++i) gz.push_back(static_cast<char>(claimed >> (8 * i) & 0xff));
  return gz;
}

TEST(SizeClaimsCli, TinyGzipNrrdClaimingAHugeGridExitsOneWithTheNumbers) {
  const TempDir dir;
  for (const uint64_t side : {uint64_t{5000}, uint64_t{20000}}) {
    SCOPED_TRACE(side);
    const std::string s = std::to_string(side);
    const std::string in = dir.path() + "/claim" + s + ".nrrd", store = dir.path() + "/c.sdb";
    WriteFile(in, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " + s + " " + s + " " + s +
                      "\nencoding: gzip\n\n" + TinyGzipClaiming(side * side * side));
    const CommandResult r = RunLimited("import " + in + " -o " + store);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(in), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(s + "x" + s + "x" + s), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(std::to_string(side * side * side)), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("holds 20 bytes"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(store));
  }
}

TEST(SizeClaimsCli, DetachedNrrdNamingMillionsOfFilesExitsOneAtTheFirstMissing) {
  const TempDir dir;
  WriteFile(dir.path() + "/s0.raw", std::string(4, '\x01'));
  const std::string header = dir.path() + "/many.nhdr";
  WriteFile(header,
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 16777217\nencoding: raw\n"
            "data file: s%d.raw 0 16777216 1 2\n");
  const CommandResult r = RunLimited("import " + header + " -o " + dir.path() + "/m.sdb");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find(dir.path() + "/s1.raw"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("many.nhdr"), std::string::npos) << r.err;
}

TEST(SizeClaimsCli, MemoryBoundCoversTheBlockIndex) {
  const TempDir dir;
  const std::string in = dir.path() + "/wide.nrrd";
  ASSERT_EQ(RunCli("generate --field ramp --dims 600,2,2 --type uint8 -o " + in).exit_code, 0);
  // 600 along x: a domain of side 2^10 (1025^3 points), of which the dense
  // store indexes only the blocks that hold the grid's errors: it builds
  // within 1 MiB and stores tens of kilobytes, not the padded domain.
  CommandResult r = RunLimited("import " + in + " --memory-mb 1 --threads 1 --json -o " +
                               dir.path() + "/w.sdb");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(fs::file_size(dir.path() + "/w.sdb"), 100000u);
  // convert takes the same bound, both ways. The sparse store's work arrays
  // cover the real grid and a margin, not the padded domain: megabytes.
  r = RunLimited("convert " + dir.path() + "/w.sdb --to sparse --memory-mb 1 -o " + dir.path() +
                 "/c.lmdb");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("built in memory and needs"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(--memory-mb) is 1 MiB"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() + "/c.lmdb"));
  r = RunLimited("convert " + dir.path() + "/w.sdb --to sparse --memory-mb 16 -o " + dir.path() +
                 "/c.lmdb");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(fs::file_size(dir.path() + "/c.lmdb"), 100000u);
  r = RunLimited("convert " + dir.path() + "/c.lmdb --to dense --memory-mb 1 -o " + dir.path() +
                 "/c.sdb");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LT(fs::file_size(dir.path() + "/c.sdb"), 100000u);

  // A 1 MB raw file 200000 voxels wide: a domain of side 2^18, whose block
  // index no bound can hold (61426dc: bad_alloc, exit 70).
  const std::string raw = dir.path() + "/wide.raw";
  WriteFile(raw, std::string(200000 * 2 * 2, '\x02'));
  r = RunLimited("import " + raw + " --dims 200000,2,2 --type uint8 -o " + dir.path() + "/r.sdb");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("200000x2x2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("block index of"), std::string::npos) << r.err;

  // import --sparse is held to the bound too, with the same need.
  r = RunLimited("import " + in + " --sparse --memory-mb 1 --threads 1 -o " + dir.path() +
                 "/w.lmdb");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("built in memory and needs"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() + "/w.lmdb"));
  r = RunLimited("import " + in + " --sparse --memory-mb 16 --threads 1 -o " + dir.path() +
                 "/w.lmdb");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

// A bound whose bytes do not fit size_t would wrap into a small one.
TEST(SizeClaimsCli, MemoryBoundBeyondTheAddressSpaceIsAUsageError) {
  const TempDir dir;
  const std::string in = dir.path() + "/v.nrrd";
  ASSERT_EQ(RunCli("generate --dims 5,5,5 -o " + in).exit_code, 0);
  const CommandResult r =
      RunCli("import " + in + " --memory-mb 99999999999999 -o " + dir.path() + "/v.sdb");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--memory-mb 99999999999999"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() + "/v.sdb"));
}

}  // namespace
}  // namespace simplexdb
