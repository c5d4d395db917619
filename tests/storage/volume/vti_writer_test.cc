// PrepareVti (storage/volume/vti_writer.h): the bytes of a small file
// pinned, nothing under the name before Commit, bad input refused before
// anything is created. VTK's own reader reads these files in
// tests/tools/export_cli_test.cc.
#include "storage/volume/vti_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;
using testing::ReadFile;

// The exact bytes: a change of format is a decision.
TEST(PrepareVti, FileIsPinnedAndAppearsOnCommit) {
  const TempDir dir;
  const std::string path = dir / "p.vti";
  auto file = PrepareVti(path, {2, 1, 2}, VoxelType::kI16, std::vector<double>{1, -2, 256, -32768},
                         {0.5, 1, 2.5}, {-1, 0, 3.25});
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  EXPECT_FALSE(fs::exists(path));
  ASSERT_TRUE((*file)->Commit().ok());
  const std::string expected =
      "<?xml version=\"1.0\"?>\n"
      "<!-- Written by SimplexDB. -->\n"
      "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n"
      "<ImageData WholeExtent=\"0 1 0 0 0 1\" Origin=\"-1 0 3.25\" Spacing=\"0.5 1 2.5\">\n"
      "<Piece Extent=\"0 1 0 0 0 1\">\n"
      "<PointData Scalars=\"field\">\n"
      "<DataArray type=\"Int16\" Name=\"field\" format=\"appended\" offset=\"0\"/>\n"
      "</PointData>\n<CellData/>\n</Piece>\n</ImageData>\n"
      "<AppendedData encoding=\"raw\">\n_" +
      std::string("\x08\0\0\0\0\0\0\0", 8) + std::string("\x01\x00\xfe\xff\x00\x01\x00\x80", 8) +
      "\n</AppendedData>\n</VTKFile>\n";
  EXPECT_EQ(ReadFile(path), expected);
}

TEST(PrepareVti, BadInputCreatesNothing) {
  const TempDir dir;
  const std::string path = dir / "bad.vti";
  struct Case {
    std::array<uint32_t, 3> dims;
    std::vector<double> values;
    std::array<double, 3> spacing, origin;
    const char* message;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {{2, 1, 1}, {1}, {1, 1, 1}, {0, 0, 0}, "1 values for 2 voxels"},
      {{1, 1, 1}, {300}, {1, 1, 1}, {0, 0, 0}, "value 300 at voxel 0 is not representable"},
      {{1, 1, 1}, {1}, {1, 0, 1}, {0, 0, 0}, "spacing 0 along y"},
      {{1, 1, 1}, {1}, {1, 1, 1}, {0, nan, 0}, "the origin must be finite"},
      {{0, 1, 1}, {}, {1, 1, 1}, {0, 0, 0}, "axis x has 0 samples"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.message);
    auto file = PrepareVti(path, c.dims, VoxelType::kU8, c.values, c.spacing, c.origin);
    ASSERT_FALSE(file.ok());
    EXPECT_TRUE(file.status().IsInvalidArgument());
    EXPECT_NE(file.status().ToString().find(c.message), std::string::npos) << file.status().ToString();
    EXPECT_TRUE(fs::is_empty(dir.path()));
  }
}

}  // namespace
}  // namespace simplexdb
