// WriteNrrd and WriteRawWithNhdr (storage/volume/nrrd_writer.h): exact round trips
// through our reader for every voxel type, the header text pinned, atomic
// replacement, input checks, and an independent reader (VTK's
// vtkNrrdReader, through tests/storage/volume/vtk_read_nrrd.py).
#include "storage/volume/nrrd_writer.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <algorithm>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/python_vtk.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;

using testing::TempDir;
using testing::ReadFile;

constexpr VoxelType kAllTypes[] = {VoxelType::kU8,  VoxelType::kI8,  VoxelType::kU16,
                                   VoxelType::kI16, VoxelType::kF32, VoxelType::kF64};

// `n` values of `type` including its extremes, zero and (for floats)
// fractions and signed zero.
std::vector<double> TestValues(VoxelType type, size_t n) {
  std::vector<double> special;
  switch (type) {
    case VoxelType::kU8: special = {0, 255, 1, 128}; break;
    case VoxelType::kI8: special = {-128, 127, 0, -1}; break;
    case VoxelType::kU16: special = {0, 65535, 256, 1}; break;
    case VoxelType::kI16: special = {-32768, 32767, 0, -1}; break;
    case VoxelType::kF32:
      special = {std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest(),
                 std::numeric_limits<float>::denorm_min(), -0.0, 0.1f};
      break;
    case VoxelType::kF64:
      special = {std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(),
                 std::numeric_limits<double>::denorm_min(), -0.0, 0.1, 1.0 / 3};
      break;
  }
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) {
    if (i < special.size()) {
      v[i] = special[i];
    } else if (type == VoxelType::kF32) {
      v[i] = static_cast<float>(0.37 * static_cast<double>(i) - 9);
    } else if (type == VoxelType::kF64) {
      v[i] = 0.37 * static_cast<double>(i) - 9;
    } else {
      v[i] = static_cast<double>((i * 37) % 100) - (type == VoxelType::kU8 || type == VoxelType::kU16 ? 0 : 50);
    }
  }
  return v;
}

std::vector<double> ReadBack(const std::string& path) {
  auto info = OpenNrrd(path);
  EXPECT_TRUE(info.ok()) << info.status().ToString();
  if (!info.ok()) return {};
  auto reader = VolumeReader::Open(*info);
  EXPECT_TRUE(reader.ok()) << reader.status().ToString();
  std::vector<double> v(info->voxel_count());
  EXPECT_TRUE((*reader)->Read(0, v.size(), v.data()).ok());
  return v;
}

// Bitwise equality, so -0.0 and 0.0 differ.
void ExpectSameBits(const std::vector<double>& got, const std::vector<double>& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(std::bit_cast<uint64_t>(got[i]), std::bit_cast<uint64_t>(want[i]))
        << "voxel " << i << ": " << got[i] << " vs " << want[i];
  }
}

TEST(WriteNrrd, RoundTripsEveryTypeExactly3DAnd4D) {
  TempDir dir;
  const std::array<double, 4> spacing = {0.5, 1.25, 3.2, 7};
  for (VoxelType type : kAllTypes) {
    for (int dimension : {3, 4}) {
      SCOPED_TRACE(std::string(VoxelTypeName(type)) + " " + std::to_string(dimension) + "D");
      const std::array<uint32_t, 4> dims =
          dimension == 3 ? std::array<uint32_t, 4>{5, 4, 3, 1} : std::array<uint32_t, 4>{3, 3, 2, 2};
      const std::vector<double> values = TestValues(type, dims[0] * dims[1] * dims[2] * dims[3]);
      const std::string path = dir / "v.nrrd";
      ASSERT_TRUE(WriteNrrd(path, dimension, dims, type, values, spacing).ok());
      auto info = OpenNrrd(path);
      ASSERT_TRUE(info.ok()) << info.status().ToString();
      EXPECT_EQ(info->dimension, dimension);
      EXPECT_EQ(info->dims, dims);
      EXPECT_EQ(info->type, type);
      EXPECT_EQ(info->order, ByteOrder::kLittle);
      EXPECT_EQ(info->encoding, VolumeInfo::Encoding::kRaw);
      for (int i = 0; i < dimension; ++i) EXPECT_EQ(info->spacing[i], spacing[i]);
      ExpectSameBits(ReadBack(path), values);
      // Header + voxels, nothing else.
      EXPECT_EQ(fs::file_size(path), info->offset + values.size() * VoxelSize(type));
    }
  }
}

// The exact bytes of a small file: a change of format is a decision.
TEST(WriteNrrd, HeaderTextIsPinned) {
  TempDir dir;
  const std::string path = dir / "pinned.nrrd";
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 1 + 1, 2, 1}, VoxelType::kI16,
                        std::vector<double>{0, 1, -1, 256, 2, 3, 4, -32768},
                        {0.5, 1, 2.5, 1})
                  .ok());
  const std::string expected_header =
      "NRRD0004\n"
      "# Written by SimplexDB.\n"
      "type: int16\n"
      "dimension: 3\n"
      "sizes: 2 2 2\n"
      "spacings: 0.5 1 2.5\n"
      "kinds: domain domain domain\n"
      "endian: little\n"
      "encoding: raw\n"
      "\n";
  const std::string expected_data("\x00\x00\x01\x00\xff\xff\x00\x01\x02\x00\x03\x00\x04\x00\x00\x80",
                                  16);
  EXPECT_EQ(ReadFile(path), expected_header + expected_data);
  // One-byte types carry no endian line; floats use NRRD's names.
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 1)).ok());
  EXPECT_EQ(ReadFile(path).find("endian"), std::string::npos);
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kF32, std::vector<double>(8, 1)).ok());
  EXPECT_NE(ReadFile(path).find("type: float\n"), std::string::npos);
}

// With an origin: the space fields instead of "spacings:", pinned too; our
// reader takes the spacing from the directions.
TEST(WriteNrrd, OriginWritesSpaceDirectionsAndOrigin) {
  TempDir dir;
  const std::string path = dir / "placed.nrrd";
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 7),
                        {0.5, 1, 2.5, 1}, std::array<double, 3>{-1.5, 0, 10})
                  .ok());
  const std::string expected_header =
      "NRRD0004\n"
      "# Written by SimplexDB.\n"
      "type: uint8\n"
      "dimension: 3\n"
      "space dimension: 3\n"
      "sizes: 2 2 2\n"
      "space directions: (0.5,0,0) (0,1,0) (0,0,2.5)\n"
      "space origin: (-1.5,0,10)\n"
      "kinds: domain domain domain\n"
      "encoding: raw\n"
      "\n";
  EXPECT_EQ(ReadFile(path), expected_header + std::string(8, '\x07'));
  const Result<VolumeInfo> info = OpenVolume(path);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{0.5, 1, 2.5, 1}));
  // 4D: the space fields for x, y, z, time in "spacings:".
  const std::string path4 = dir / "t.nrrd";
  ASSERT_TRUE(WriteNrrd(path4, 4, {2, 2, 2, 2}, VoxelType::kU8, std::vector<double>(16, 1),
                        {0.5, 1, 2.5, 3}, std::array<double, 3>{1, 2, 3})
                  .ok());
  const std::string text = ReadFile(path4);
  EXPECT_NE(text.find("space directions: (0.5,0,0) (0,1,0) (0,0,2.5) none\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("spacings: nan nan nan 3\n"), std::string::npos) << text;
  const Result<VolumeInfo> info4 = OpenVolume(path4);
  ASSERT_TRUE(info4.ok()) << info4.status().ToString();
  EXPECT_EQ(info4->spacing, (std::array<double, 4>{0.5, 1, 2.5, 3}));
  EXPECT_EQ(info4->origin, (std::array<double, 4>{1, 2, 3, 0}));
  EXPECT_EQ(info4->dropped, "");
  // A negative spacing is refused: VTK's reader would drop its sign.
  const Status s = WriteNrrd(dir / "f.nrrd", 3, {2, 2, 2, 1}, VoxelType::kU8,
                             std::vector<double>(8, 1), {1, -1, 1, 1}, std::array<double, 3>{0, 0, 0});
  EXPECT_TRUE(s.IsInvalidArgument()) << s.ToString();
  EXPECT_FALSE(fs::exists(dir / "f.nrrd"));
}

// PrepareNrrd: nothing under the name until Commit; dropped, nothing at all.
TEST(PrepareNrrd, NothingAppearsUntilCommit) {
  TempDir dir;
  const std::string path = dir / "p.nrrd";
  {
    auto file = PrepareNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 1),
                            {1, 1, 1, 1}, std::nullopt);
    ASSERT_TRUE(file.ok()) << file.status().ToString();
    EXPECT_FALSE(fs::exists(path));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
  auto file = PrepareNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 1),
                          {1, 1, 1, 1}, std::nullopt);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  ASSERT_TRUE((*file)->Commit().ok());
  EXPECT_EQ(ReadBack(path), std::vector<double>(8, 1));
}

TEST(WriteRawWithNhdr, RoundTripsAndSurvivesMovingBothFiles) {
  TempDir dir;
  for (VoxelType type : kAllTypes) {
    SCOPED_TRACE(std::string(VoxelTypeName(type)));
    const std::vector<double> values = TestValues(type, 4 * 3 * 2 * 2);
    const std::string raw = dir / "x.raw", nhdr = dir / "x.nhdr";
    ASSERT_TRUE(WriteRawWithNhdr(raw, nhdr, 4, {4, 3, 2, 2}, type, values).ok());
    EXPECT_EQ(fs::file_size(raw), values.size() * VoxelSize(type));  // headerless
    EXPECT_NE(ReadFile(nhdr).find("\ndata file: x.raw\n"), std::string::npos) << ReadFile(nhdr);
    ExpectSameBits(ReadBack(nhdr), values);
  }
  // The name is relative to the header's directory: move both and reread.
  fs::create_directories(dir / "moved");
  fs::rename(dir / "x.raw", dir / "moved/x.raw");
  fs::rename(dir / "x.nhdr", dir / "moved/x.nhdr");
  EXPECT_EQ(ReadBack(dir / "moved/x.nhdr").size(), 4u * 3 * 2 * 2);
  // A raw file outside the header's directory is named absolutely.
  fs::create_directories(dir / "headers");
  ASSERT_TRUE(WriteRawWithNhdr(dir / "outside.raw", dir / "headers/o.nhdr", 3, {2, 2, 2, 1},
                               VoxelType::kU8, std::vector<double>(8, 3))
                  .ok());
  EXPECT_NE(ReadFile(dir / "headers/o.nhdr").find("data file: " + (dir / "outside.raw") + "\n"),
            std::string::npos)
      << ReadFile(dir / "headers/o.nhdr");
  EXPECT_EQ(ReadBack(dir / "headers/o.nhdr"), std::vector<double>(8, 3));
}

TEST(WriteNrrd, ReplacesAtomicallyAndLeavesNoTemporaryFiles) {
  TempDir dir;
  const std::string path = dir / "v.nrrd";
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 1)).ok());
  ASSERT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 2)).ok());
  EXPECT_EQ(ReadBack(path), std::vector<double>(8, 2));
  EXPECT_EQ(testing::SortedNames(dir.path()), std::vector<std::string>{"v.nrrd"});
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                fs::perms::others_read);
  // A rejected write leaves the old file as it was and no temporary file.
  const Status s = WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 300));
  EXPECT_TRUE(s.IsInvalidArgument());
  EXPECT_EQ(ReadBack(path), std::vector<double>(8, 2));
  EXPECT_EQ(testing::SortedNames(dir.path()), std::vector<std::string>{"v.nrrd"});
}

TEST(WriteNrrd, RejectsBadInputNamingFileAndValue) {
  TempDir dir;
  const std::string path = dir / "bad.nrrd";
  struct Case {
    VoxelType type;
    double value;
    const char* mentions;
  };
  for (const Case& c : {Case{VoxelType::kU8, 256, "256"}, Case{VoxelType::kU8, -1, "-1"},
                        Case{VoxelType::kI16, 1.5, "1.5"}, Case{VoxelType::kI8, 128, "128"},
                        Case{VoxelType::kU16, std::nan(""), "nan"},
                        Case{VoxelType::kF32, 1e39, "1e+39"}}) {
    SCOPED_TRACE(c.mentions);
    std::vector<double> values(8, 0);
    values[5] = c.value;
    const Status s = WriteNrrd(path, 3, {2, 2, 2, 1}, c.type, values);
    ASSERT_TRUE(s.IsInvalidArgument()) << s.ToString();
    EXPECT_NE(s.message().find(path), std::string::npos) << s.ToString();
    EXPECT_NE(s.message().find(c.mentions), std::string::npos) << s.ToString();
    EXPECT_NE(s.message().find("voxel 5"), std::string::npos) << s.ToString();
  }
  // Floats take anything in range, including NaN and infinities.
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kF32,
                        std::vector<double>{inf, -inf, std::nan(""), 0, 0, 0, 0, 0})
                  .ok());
  EXPECT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(7, 0))
                  .IsInvalidArgument());
  EXPECT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 2}, VoxelType::kU8, std::vector<double>(16, 0))
                  .IsInvalidArgument());
  EXPECT_TRUE(WriteNrrd(path, 2, {2, 2, 1, 1}, VoxelType::kU8, std::vector<double>(4, 0))
                  .IsInvalidArgument());
  EXPECT_TRUE(WriteNrrd(path, 3, {2, 2, 2, 1}, VoxelType::kU8, std::vector<double>(8, 0),
                        {1, 0, 1, 1})
                  .IsInvalidArgument());
  const Status no_dir = WriteNrrd(dir / "no/such/dir/v.nrrd", 3, {2, 2, 2, 1}, VoxelType::kU8,
                                  std::vector<double>(8, 0));
  ASSERT_FALSE(no_dir.ok());
  EXPECT_NE(no_dir.message().find(dir / "no/such/dir/v.nrrd"), std::string::npos);
}

// ---------------------------------------------------------------------------
// VTK reads what we write.

struct VtkView {
  std::array<int, 3> dims{};
  std::array<double, 3> spacing{};
  std::vector<double> values;
};

TEST(WriteNrrd, VtkNrrdReaderReadsOurFiles) {
  const std::string python = testing::FindPythonWithVtk("vtkmodules.vtkIOImage");
  if (python.empty()) {
    GTEST_SKIP() << "no python3 that can import VTK (Debian: apt-get install python3-vtk9)";
  }
  TempDir dir;
  // x >= 10: vtkNrrdReader takes a first axis of 9 or fewer samples for
  // vector components (its guess, whatever the header says).
  const std::array<uint32_t, 4> dims = {10, 4, 3, 1};
  const std::array<double, 4> spacing = {0.5, 1.25, 3.2, 1};
  std::vector<std::string> files;
  std::vector<std::vector<double>> written;
  for (VoxelType type : kAllTypes) {
    const std::vector<double> values = TestValues(type, 120);
    files.push_back(dir / (std::string(VoxelTypeName(type)) + ".nrrd"));
    ASSERT_TRUE(WriteNrrd(files.back(), 3, dims, type, values, spacing).ok());
    written.push_back(values);
  }
  files.push_back(dir / "detached.nhdr");
  written.push_back(TestValues(VoxelType::kI16, 120));
  ASSERT_TRUE(WriteRawWithNhdr(dir / "detached.raw", files.back(), 3, dims, VoxelType::kI16,
                               written.back(), spacing)
                  .ok());

  std::string cmd = python + " '" + SIMPLEXDB_STORAGE_TEST_DIR "/vtk_read_nrrd.py'";
  for (const std::string& f : files) cmd += " '" + f + "'";
  cmd += " > '" + (dir / "vtk.out") + "' 2> '" + (dir / "vtk.err") + "'";
  const int rc = std::system(cmd.c_str());
  ASSERT_EQ(rc, 0) << cmd << "\n" << std::ifstream(dir / "vtk.err").rdbuf();

  std::ifstream out(dir / "vtk.out");
  for (size_t f = 0; f < files.size(); ++f) {
    SCOPED_TRACE(files[f]);
    std::string line;
    ASSERT_TRUE(std::getline(out, line));
    std::istringstream in(line);
    VtkView v;
    size_t count = 0;
    in >> v.dims[0] >> v.dims[1] >> v.dims[2] >> v.spacing[0] >> v.spacing[1] >>
        v.spacing[2] >> count;
    EXPECT_EQ(v.dims, (std::array<int, 3>{10, 4, 3}));
    EXPECT_EQ(v.spacing, (std::array<double, 3>{0.5, 1.25, 3.2}));
    ASSERT_EQ(count, 120u);
    for (size_t i = 0; i < count; ++i) {
      std::string text;
      in >> text;
      // strtod, not >>: streams reject denormals on some libraries.
      const double value = std::strtod(text.c_str(), nullptr);
      if (written[f][i] == 0) {
        EXPECT_EQ(value, 0) << "voxel " << i;  // VTK may print -0.0 as 0.0
      } else {
        EXPECT_EQ(value, written[f][i]) << "voxel " << i;
      }
    }
  }
}

}  // namespace
}  // namespace simplexdb
