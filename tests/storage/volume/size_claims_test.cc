// Headers that claim more than their files hold (issue 20): the readers
// must refuse them when they open, with the numbers, before allocating or
// decompressing anything in proportion to the claim. Each claim is opened
// in a child process under a 1 GiB address-space limit, so an attempt to
// allocate for it ends in bad_alloc there and fails the test.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <zlib.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "storage/volume/volume.h"
#include "tests/storage/address_space_limit.h"
#include "tests/storage/store_test_util.h"
#include "tests/storage/volume/gzip_test_util.h"

namespace simplexdb {
namespace {

using testing::kOneGiB;
using testing::LimitedRun;
using testing::RunUnderAddressSpaceLimit;
using testing::TempDir;
using testing::WriteFile;

// gzip at zlib's best compression: the largest claims per byte.
std::string Gzip(const std::string& data) { return testing::Gzip(data, 9, 9); }

// Sets the gzip trailer's ISIZE (the decompressed size mod 2^32) to that of
// `claimed` bytes, as a crafted file would to pass a trailer check.
std::string WithIsize(std::string gz, uint64_t claimed) {
  for (int i = 0; i < 4; ++i) {
    gz[gz.size() - 4 + static_cast<size_t>(i)] = static_cast<char>(claimed >> (8 * i) & 0xff);
  }
  return gz;
}

// Opens `path` under the limit: "OK" or the error's code and message.
LimitedRun OpenLimited(const std::string& path) {
  return RunUnderAddressSpaceLimit(kOneGiB, [&] {
    const Result<VolumeInfo> info = OpenVolume(path);
    return info.status().ToString();
  });
}

TEST(SizeClaims, GzipNrrdClaimingMoreThanDeflateCanHoldFailsAtOpen) {
  const TempDir dir;
  // Deflate reaches about 1030:1 on zeros: such a file is real and opens.
  const std::string zeros(uint64_t{256} * 256 * 256, '\0');
  const std::string dense_gz = Gzip(zeros);
  ASSERT_GT(zeros.size() / dense_gz.size(), 1000u);
  const std::string header_256 =
      "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 256 256 256\nencoding: gzip\n\n";
  WriteFile(dir / "zeros.nrrd", header_256 + dense_gz);
  const LimitedRun ok = OpenLimited(dir / "zeros.nrrd");
  ASSERT_TRUE(ok.finished) << ok.wait_status;
  EXPECT_EQ(ok.text, "OK");

  // A 1 KB file claiming 5000^3 or 20000^3 voxels, with a trailer that
  // agrees mod 2^32: refused with the claim and what the file holds.
  const std::string small_gz = Gzip(std::string(1000, '\x07'));
  for (const uint64_t side : {uint64_t{5000}, uint64_t{20000}}) {
    SCOPED_TRACE(side);
    const uint64_t claimed = side * side * side;
    const std::string s = std::to_string(side);
    const std::string header = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " + s + " " + s +
                               " " + s + "\nencoding: gzip\n\n";
    const std::string path = dir / ("claim" + s + ".nrrd");
    WriteFile(path, header + WithIsize(small_gz, claimed));
    const LimitedRun run = OpenLimited(path);
    ASSERT_TRUE(run.finished) << "bad_alloc: " << run.bad_alloc << ", status " << run.wait_status;
    EXPECT_EQ(run.text.rfind("corruption: " + path + ": ", 0), 0u) << run.text;
    EXPECT_NE(run.text.find(s + "x" + s + "x" + s), std::string::npos) << run.text;
    EXPECT_NE(run.text.find("claims " + std::to_string(claimed) + " decompressed bytes"),
              std::string::npos) << run.text;
    EXPECT_NE(run.text.find("holds " + std::to_string(small_gz.size()) + " bytes of gzip data"),
              std::string::npos) << run.text;
    EXPECT_NE(run.text.find(std::to_string(small_gz.size() * 1032)), std::string::npos)
        << run.text;
  }
}

TEST(SizeClaims, DetachedNrrdFormatNamingMillionsOfFilesFailsAtOnce) {
  const TempDir dir;
  WriteFile(dir / "s0.raw", std::string(4, '\x01'));
  // 16777217 names for 4 slabs: the count is wrong, said before any name
  // is made.
  WriteFile(dir / "count.nhdr",
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 4\nencoding: raw\n"
            "data file: s%d.raw 0 16777216 1 2\n");
  LimitedRun run = OpenLimited(dir / "count.nhdr");
  ASSERT_TRUE(run.finished) << "bad_alloc: " << run.bad_alloc << ", status " << run.wait_status;
  EXPECT_NE(run.text.find("invalid argument: " + (dir / "count.nhdr") +
                          ": 16777217 data files, expected 4"),
            std::string::npos)
      << run.text;

  // 16777217 names for as many slabs: the first missing file ends it.
  WriteFile(dir / "many.nhdr",
            "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 16777217\nencoding: raw\n"
            "data file: s%d.raw 0 16777216 1 2\n");
  run = OpenLimited(dir / "many.nhdr");
  ASSERT_TRUE(run.finished) << "bad_alloc: " << run.bad_alloc << ", status " << run.wait_status;
  EXPECT_EQ(run.text.rfind("not found: " + (dir / "s1.raw"), 0), 0u) << run.text;
  EXPECT_NE(run.text.find("data file of NRRD header " + (dir / "many.nhdr")), std::string::npos)
      << run.text;

  // A short file among them is named with its size and the one expected.
  WriteFile(dir / "s1.raw", std::string(4, '\x01'));
  WriteFile(dir / "s2.raw", std::string(3, '\x01'));
  run = OpenLimited(dir / "many.nhdr");
  ASSERT_TRUE(run.finished) << "bad_alloc: " << run.bad_alloc << ", status " << run.wait_status;
  EXPECT_EQ(run.text.rfind("corruption: " + (dir / "s2.raw") + ": has 3 bytes, expected at least 4", 0),
            0u)
      << run.text;
}

// A raw offset near 2^64: the bytes it needs are said without wrapping.
TEST(SizeClaims, RawOffsetNearTwoToTheSixtyFourSaysTheNeedUnwrapped) {
  const TempDir dir;
  WriteFile(dir / "v.raw", std::string(100, '\0'));
  const uint64_t offset = ~uint64_t{0} - 5;
  const Result<VolumeInfo> info = OpenRawVolume(dir / "v.raw", 3, {2, 2, 2, 1}, VoxelType::kU8,
                                                ByteOrder::kLittle, offset);
  ASSERT_FALSE(info.ok());
  const std::string msg(info.status().message());
  EXPECT_NE(msg.find("has 100 bytes, expected more than 2^64 - 1"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("8 bytes after offset " + std::to_string(offset)), std::string::npos) << msg;
}

}  // namespace
}  // namespace simplexdb
