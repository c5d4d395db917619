// The volume readers (storage/volume/volume.h): the real volumes of ../shared/data
// read through VolumeReader against the bytes read directly with fread, and
// files written here byte by byte (NRRD headers by hand, NIfTI-1 headers
// field by field, big-endian data, gzip via zlib) for every format feature
// and every error a user can meet.
#include "storage/volume/volume.h"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tests/storage/store_test_util.h"
#include "tests/storage/volume/gzip_test_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Helpers, independent of the code under test.

using testing::Gzip;
using testing::TempDir;
using testing::ReadFile;
using testing::WriteFile;

const std::string kSharedData = SIMPLEXDB_SHARED_DATA;

#define SKIP_WITHOUT_SHARED_DATA()                                                 \
  if (!fs::exists(kSharedData + "/README.md")) {                                   \
    GTEST_SKIP() << "no shared data at " << kSharedData                            \
                 << " (the real volumes live beside the repository in ../shared/data)"; \
  }

size_t SizeOf(VoxelType t) {
  switch (t) {
    case VoxelType::kU8: case VoxelType::kI8: return 1;
    case VoxelType::kU16: case VoxelType::kI16: return 2;
    case VoxelType::kF32: return 4;
    case VoxelType::kF64: return 8;
  }
  return 0;
}

// One voxel's bytes to a double, by shifts (not the library's decoder).
double DecodeOne(const unsigned char* b, VoxelType type, ByteOrder order) {
  const size_t n = SizeOf(type);
  uint64_t u = 0;
  for (size_t i = 0; i < n; ++i) {
    const size_t k = order == ByteOrder::kLittle ? n - 1 - i : i;  // most significant first
    u = u << 8 | b[k];
  }
  switch (type) {
    case VoxelType::kU8: return static_cast<double>(u);
    case VoxelType::kI8: return static_cast<double>(static_cast<int8_t>(u));
    case VoxelType::kU16: return static_cast<double>(u);
    case VoxelType::kI16: return static_cast<double>(static_cast<int16_t>(u));
    case VoxelType::kF32: return std::bit_cast<float>(static_cast<uint32_t>(u));
    case VoxelType::kF64: return std::bit_cast<double>(u);
  }
  return 0;
}

// Values to bytes in `order`, by shifts.
std::string Encode(VoxelType type, ByteOrder order, const std::vector<double>& values) {
  std::string out;
  const size_t n = SizeOf(type);
  for (double v : values) {
    uint64_t u = 0;
    switch (type) {
      case VoxelType::kU8: u = static_cast<uint8_t>(v); break;
      case VoxelType::kI8: u = static_cast<uint8_t>(static_cast<int8_t>(v)); break;
      case VoxelType::kU16: u = static_cast<uint16_t>(v); break;
      case VoxelType::kI16: u = static_cast<uint16_t>(static_cast<int16_t>(v)); break;
      case VoxelType::kF32: u = std::bit_cast<uint32_t>(static_cast<float>(v)); break;
      case VoxelType::kF64: u = std::bit_cast<uint64_t>(v); break;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t shift = 8 * (order == ByteOrder::kLittle ? i : n - 1 - i);
      out.push_back(static_cast<char>((u >> shift) & 0xFF));
    }
  }
  return out;
}

// The voxel at linear `index` read with fread at offset + index * size.
double FreadVoxel(const std::string& path, uint64_t offset, uint64_t index,
                  VoxelType type, ByteOrder order) {
  FILE* f = std::fopen(path.c_str(), "rb");
  EXPECT_NE(f, nullptr) << path;
  if (f == nullptr) return -1e300;
  unsigned char b[8] = {};
  EXPECT_EQ(std::fseek(f, static_cast<long>(offset + index * SizeOf(type)), SEEK_SET), 0);
  EXPECT_EQ(std::fread(b, 1, SizeOf(type), f), SizeOf(type)) << path << " voxel " << index;
  std::fclose(f);
  return DecodeOne(b, type, order);
}

std::vector<double> ReadAll(const VolumeInfo& info) {
  auto reader = VolumeReader::Open(info);
  EXPECT_TRUE(reader.ok()) << reader.status().ToString();
  if (!reader.ok()) return {};
  std::vector<double> v(info.voxel_count());
  const Status s = (*reader)->Read(0, v.size(), v.data());
  EXPECT_TRUE(s.ok()) << s.ToString();
  return v;
}

// A 348-byte NIfTI-1 header, the 4-byte extension flag, then `data`.
struct NiftiSpec {
  ByteOrder order = ByteOrder::kLittle;
  int32_t sizeof_hdr = 348;
  std::array<int16_t, 8> dim = {3, 2, 2, 2, 1, 1, 1, 1};
  int16_t datatype = 4;  // int16
  int16_t bitpix = 16;
  float vox_offset = 352;
  std::array<float, 8> pixdim = {1, 1, 1, 1, 1, 1, 1, 1};
  std::string magic = std::string("n+1\0", 4);
  float scl_slope = 0;  // 0: no scaling
  float scl_inter = 0;
  uint8_t xyzt_units = 0;
  float toffset = 0;
  int16_t qform_code = 0, sform_code = 0;
  std::array<float, 6> quatern = {};  // b, c, d, qoffset_x, y, z
  std::array<float, 12> srow = {};    // srow_x, srow_y, srow_z
};

std::string MakeNifti(const NiftiSpec& s, const std::string& data) {
  std::string h(352, '\0');
  const auto put = [&](size_t at, uint64_t u, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      const size_t shift = 8 * (s.order == ByteOrder::kLittle ? i : n - 1 - i);
      h[at + i] = static_cast<char>((u >> shift) & 0xFF);
    }
  };
  put(0, static_cast<uint32_t>(s.sizeof_hdr), 4);
  for (size_t i = 0; i < 8; ++i) put(40 + 2 * i, static_cast<uint16_t>(s.dim[i]), 2);
  put(70, static_cast<uint16_t>(s.datatype), 2);
  put(72, static_cast<uint16_t>(s.bitpix), 2);
  for (size_t i = 0; i < 8; ++i) put(76 + 4 * i, std::bit_cast<uint32_t>(s.pixdim[i]), 4);
  put(108, std::bit_cast<uint32_t>(s.vox_offset), 4);
  put(112, std::bit_cast<uint32_t>(s.scl_slope), 4);
  put(116, std::bit_cast<uint32_t>(s.scl_inter), 4);
  put(123, s.xyzt_units, 1);
  put(136, std::bit_cast<uint32_t>(s.toffset), 4);
  put(252, static_cast<uint16_t>(s.qform_code), 2);
  put(254, static_cast<uint16_t>(s.sform_code), 2);
  for (size_t i = 0; i < 6; ++i) put(256 + 4 * i, std::bit_cast<uint32_t>(s.quatern[i]), 4);
  for (size_t i = 0; i < 12; ++i) put(280 + 4 * i, std::bit_cast<uint32_t>(s.srow[i]), 4);
  std::memcpy(h.data() + 344, s.magic.data(), 4);
  h.resize(static_cast<size_t>(s.vox_offset), '\0');
  return h + data;
}

std::vector<double> Iota(size_t n, double start = 0, double step = 1) {
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = start + step * static_cast<double>(i);
  return v;
}

// ---------------------------------------------------------------------------
// The real volumes.

struct RawCase {
  const char* file;
  std::array<uint32_t, 4> dims;
  VoxelType type;
};

// From ../shared/data/README.md.
constexpr RawCase kRawCases[] = {
    {"bucky/bucky_32x32x32_uint8.raw", {32, 32, 32, 1}, VoxelType::kU8},
    {"neghip/neghip_64x64x64_uint8.raw", {64, 64, 64, 1}, VoxelType::kU8},
    {"tooth/tooth_103x94x161_uint8.raw", {103, 94, 161, 1}, VoxelType::kU8},
    {"headsq/headsq_64x64x93_int16le.raw", {64, 64, 93, 1}, VoxelType::kI16},
    {"lidc2/LIDC2_256x256x133_uint8.raw", {256, 256, 133, 1}, VoxelType::kU8},
};

// Voxels at the ends, the middle, fixed-seed random ones and short runs,
// read through VolumeReader in an order that jumps back and forth, each
// equal to the bytes at offset + index * size.
void CheckAgainstFread(const VolumeInfo& info, uint64_t seed) {
  auto reader = VolumeReader::Open(info);
  ASSERT_TRUE(reader.ok()) << reader.status().ToString();
  const uint64_t n = info.voxel_count();
  std::vector<uint64_t> indices = {0, 1, n / 2, n - 1, info.dims[0] - 1, info.dims[0]};
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 40; ++i) indices.push_back(rng() % n);
  for (uint64_t i : indices) {
    SCOPED_TRACE("voxel " + std::to_string(i));
    const size_t run = static_cast<size_t>(std::min<uint64_t>(5, n - i));
    std::vector<double> got(run);
    ASSERT_TRUE((*reader)->Read(i, run, got.data()).ok());
    for (size_t k = 0; k < run; ++k) {
      const size_t file = static_cast<size_t>((i + k) / info.voxels_per_file());
      const uint64_t in_file = (i + k) % info.voxels_per_file();
      ASSERT_EQ(got[k], FreadVoxel(info.files[file], info.offset_of(file), in_file,
                                   info.type, info.order));
    }
  }
}

TEST(SharedData, RawVolumesOpenWithTheirDimsAndReadLikeFread) {
  SKIP_WITHOUT_SHARED_DATA();
  for (const RawCase& c : kRawCases) {
    SCOPED_TRACE(c.file);
    const std::string path = kSharedData + "/" + c.file;
    auto info = OpenRawVolume(path, 3, c.dims, c.type, ByteOrder::kLittle, 0);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->dimension, 3);
    EXPECT_EQ(info->dims, c.dims);
    EXPECT_EQ(info->type, c.type);
    EXPECT_EQ(info->order, ByteOrder::kLittle);
    EXPECT_EQ(info->encoding, VolumeInfo::Encoding::kRaw);
    EXPECT_EQ(info->offset, 0u);
    EXPECT_EQ(info->files, std::vector<std::string>{path});
    EXPECT_EQ(info->voxel_count() * SizeOf(c.type), fs::file_size(path));
    CheckAgainstFread(*info, 7);
  }
}

// README: headsq's range is 0..3926. Reading every x-row in order (the
// importer's pattern) must find exactly that.
TEST(SharedData, HeadsqRowByRowHasTheReadmeRange) {
  SKIP_WITHOUT_SHARED_DATA();
  auto info = OpenRawVolume(kSharedData + "/headsq/headsq_64x64x93_int16le.raw", 3,
                            {64, 64, 93, 1}, VoxelType::kI16, ByteOrder::kLittle, 0);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  auto reader = VolumeReader::Open(*info);
  ASSERT_TRUE(reader.ok());
  double lo = 1e9, hi = -1e9;
  std::vector<double> row(64);
  for (uint64_t r = 0; r < 64 * 93; ++r) {
    ASSERT_TRUE((*reader)->Read(r * 64, 64, row.data()).ok());
    lo = std::min(lo, *std::min_element(row.begin(), row.end()));
    hi = std::max(hi, *std::max_element(row.begin(), row.end()));
  }
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 3926);
}

TEST(SharedData, NiftiFilesOpenWithReadmeLayout) {
  SKIP_WITHOUT_SHARED_DATA();
  struct Case {
    const char* file;
    std::array<uint32_t, 4> dims;
    VoxelType type;
    uint64_t offset;
  };
  const Case cases[] = {
      {"fmri_example4d/example4d.nii", {128, 96, 24, 2}, VoxelType::kI16, 416},
      {"dwi_small_101D/small_101D.nii", {6, 10, 10, 102}, VoxelType::kU16, 352},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    const std::string path = kSharedData + "/" + c.file;
    auto info = OpenVolume(path);  // dispatches to OpenNifti
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->dimension, 4);
    EXPECT_EQ(info->dims, c.dims);
    EXPECT_EQ(info->type, c.type);
    EXPECT_EQ(info->order, ByteOrder::kLittle);
    EXPECT_EQ(info->offset, c.offset);
    EXPECT_EQ(info->files, std::vector<std::string>{path});
    EXPECT_NE(info->description.find("NIfTI-1"), std::string::npos);
    // The voxels end exactly at the end of the file.
    EXPECT_EQ(c.offset + info->voxel_count() * SizeOf(c.type), fs::file_size(path));
    CheckAgainstFread(*info, 11);
  }
}

TEST(SharedData, FourDimensionalFileIsNotATimeStep) {
  SKIP_WITHOUT_SHARED_DATA();
  const std::string nii = kSharedData + "/fmri_example4d/example4d.nii";
  auto series = OpenTimeSeries({nii, nii});
  ASSERT_FALSE(series.ok());
  EXPECT_TRUE(series.status().IsInvalidArgument());
  EXPECT_NE(series.status().message().find(nii), std::string::npos);
  EXPECT_NE(series.status().message().find("dimension 4"), std::string::npos)
      << series.status().ToString();
}

// ---------------------------------------------------------------------------
// Raw input.

TEST(RawVolume, BigEndianInt16AndFloat32ReadBack) {
  TempDir dir;
  const std::vector<double> i16 = {0, 1, -1, 300, -300, 32767, -32768, 258, -2, 7, 8, 9};
  // Exactly representable as float, so the round trip is exact.
  const std::vector<double> f32 = {0.5, -1.25, 0x1.fffffep127, -0x1p-149, 1024, 0, -0.0, 7.75,
                                   1, 2, 3, 4};
  for (const auto& [type, values] : {std::pair{VoxelType::kI16, i16},
                                     std::pair{VoxelType::kF32, f32}}) {
    SCOPED_TRACE(std::string(VoxelTypeName(type)));
    // A 5-byte "header" before the voxels, skipped with the offset.
    const std::string path = dir / ("be_" + std::string(VoxelTypeName(type)) + ".raw");
    WriteFile(path, "HEAD!" + Encode(type, ByteOrder::kBig, values));
    auto info = OpenRawVolume(path, 3, {3, 2, 2, 1}, type, ByteOrder::kBig, 5);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(ReadAll(*info), values);
    // The same bytes read little-endian are different numbers: the order
    // is really applied.
    auto wrong = OpenRawVolume(path, 3, {3, 2, 2, 1}, type, ByteOrder::kLittle, 5);
    ASSERT_TRUE(wrong.ok());
    EXPECT_NE(ReadAll(*wrong), values);
  }
}

TEST(RawVolume, TrailingBytesAreRefused) {
  TempDir dir;
  const std::string path = dir / "trailing.raw";
  WriteFile(path, Encode(VoxelType::kU8, ByteOrder::kLittle, Iota(8)) + "extra");
  auto info = OpenRawVolume(path, 3, {2, 2, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsInvalidArgument());
  EXPECT_NE(info.status().message().find(path + ": has 13 bytes, expected 8 (2x2x2 uint8 = 8 bytes after offset 0)"),
            std::string::npos)
      << info.status().ToString();
  // The same voxels behind a 5-byte header that --offset skips are fine.
  WriteFile(path, "head:" + Encode(VoxelType::kU8, ByteOrder::kLittle, Iota(8)));
  info = OpenRawVolume(path, 3, {2, 2, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, 5);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(ReadAll(*info), Iota(8));
}

TEST(RawVolume, FourDWithOneTimeStepIsThreeD) {
  TempDir dir;
  const std::string path = dir / "t1.raw";
  WriteFile(path, Encode(VoxelType::kU8, ByteOrder::kLittle, Iota(8)));
  auto info = OpenRawVolume(path, 4, {2, 2, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, 0);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->dimension, 3);
}

TEST(RawVolume, TruncatedFileNamesFileAndSizes) {
  TempDir dir;
  const std::string path = dir / "short.raw";
  // 4x4x4 int16 needs 128 bytes; write 127.
  WriteFile(path, Encode(VoxelType::kI16, ByteOrder::kLittle, Iota(64)).substr(0, 127));
  auto info = OpenRawVolume(path, 3, {4, 4, 4, 1}, VoxelType::kI16, ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsInvalidArgument()) << info.status().ToString();
  const std::string msg(info.status().message());
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("127"), std::string::npos) << msg;
  EXPECT_NE(msg.find("128"), std::string::npos) << msg;
  // And with the offset counted: 120 bytes after 8 of header is also short.
  auto off = OpenRawVolume(path, 3, {4, 4, 4, 1}, VoxelType::kI16, ByteOrder::kLittle, 8);
  ASSERT_FALSE(off.ok());
  EXPECT_NE(off.status().message().find("136"), std::string::npos) << off.status().ToString();
}

TEST(RawVolume, TruncatedCopyOfARealVolume) {
  SKIP_WITHOUT_SHARED_DATA();
  TempDir dir;
  const std::string copy = dir / "bucky_short.raw";
  WriteFile(copy, ReadFile(kSharedData + "/bucky/bucky_32x32x32_uint8.raw").substr(0, 32767));
  auto info = OpenRawVolume(copy, 3, {32, 32, 32, 1}, VoxelType::kU8, ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_NE(info.status().message().find(copy), std::string::npos);
  EXPECT_NE(info.status().message().find("32768"), std::string::npos)
      << info.status().ToString();
}

TEST(RawVolume, WrongDimsForARealVolume) {
  SKIP_WITHOUT_SHARED_DATA();
  const std::string path = kSharedData + "/headsq/headsq_64x64x93_int16le.raw";
  // One slice too many: 64*64*94*2 = 770048 bytes, the file has 761856.
  auto info = OpenRawVolume(path, 3, {64, 64, 94, 1}, VoxelType::kI16, ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsInvalidArgument());
  const std::string msg(info.status().message());
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("761856"), std::string::npos) << msg;
  EXPECT_NE(msg.find("770048"), std::string::npos) << msg;
}

TEST(RawVolume, NonexistentFileIsNotFound) {
  TempDir dir;
  const std::string path = dir / "missing.raw";
  auto info = OpenRawVolume(path, 3, {2, 2, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsNotFound()) << info.status().ToString();
  EXPECT_NE(info.status().message().find(path), std::string::npos);
  for (const std::string& other : {dir / "missing.nrrd", dir / "missing.nii"}) {
    auto v = OpenVolume(other);
    ASSERT_FALSE(v.ok());
    EXPECT_TRUE(v.status().IsNotFound()) << v.status().ToString();
    EXPECT_NE(v.status().message().find(other), std::string::npos);
  }
}

TEST(RawVolume, DimsOfZeroOrOneAreRejected) {
  TempDir dir;
  const std::string path = dir / "small.raw";
  WriteFile(path, std::string(64, '\0'));
  const std::array<uint32_t, 4> bad[] = {{1, 4, 4, 1}, {4, 0, 4, 1}, {4, 4, 1, 1}};
  for (const auto& dims : bad) {
    auto info = OpenRawVolume(path, 3, dims, VoxelType::kU8, ByteOrder::kLittle, 0);
    ASSERT_FALSE(info.ok());
    EXPECT_TRUE(info.status().IsInvalidArgument());
    EXPECT_NE(info.status().message().find(path), std::string::npos);
    EXPECT_NE(info.status().message().find("at least 2"), std::string::npos)
        << info.status().ToString();
  }
  // A 3D volume with a time extent, and a dimension of 5.
  EXPECT_TRUE(OpenRawVolume(path, 3, {2, 2, 2, 2}, VoxelType::kU8, ByteOrder::kLittle, 0)
                  .status()
                  .IsInvalidArgument());
  EXPECT_TRUE(OpenRawVolume(path, 5, {2, 2, 2, 2}, VoxelType::kU8, ByteOrder::kLittle, 0)
                  .status()
                  .IsInvalidArgument());
}

TEST(RawVolume, InvalidVoxelTypeIsNotSupported) {
  TempDir dir;
  const std::string path = dir / "x.raw";
  WriteFile(path, std::string(64, '\0'));
  auto info = OpenRawVolume(path, 3, {4, 4, 4, 1}, static_cast<VoxelType>(9),
                            ByteOrder::kLittle, 0);
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsNotSupported());
  EXPECT_NE(info.status().message().find(path), std::string::npos);
}

TEST(OpenVolume, UnknownExtensionAsksForDimsAndType) {
  auto info = OpenVolume("/data/volume.raw");
  ASSERT_FALSE(info.ok());
  EXPECT_TRUE(info.status().IsInvalidArgument());
  EXPECT_NE(info.status().message().find("/data/volume.raw"), std::string::npos);
  EXPECT_NE(info.status().message().find("--dims"), std::string::npos);
  EXPECT_NE(info.status().message().find("--type"), std::string::npos);
  EXPECT_TRUE(OpenVolume("/data/brain.nii.gz").status().IsNotSupported());
  EXPECT_TRUE(OpenVolume("/data/brain.hdr").status().IsNotSupported());
}

// ---------------------------------------------------------------------------
// Reader.

TEST(VolumeReader, RandomAccessEqualsSequentialAndBoundsAreChecked) {
  TempDir dir;
  const std::string path = dir / "ramp.raw";
  const std::vector<double> values = Iota(5 * 6 * 7, -100, 1);
  WriteFile(path, Encode(VoxelType::kI16, ByteOrder::kLittle, values));
  auto info = OpenRawVolume(path, 3, {5, 6, 7, 1}, VoxelType::kI16, ByteOrder::kLittle, 0);
  ASSERT_TRUE(info.ok());
  auto reader = VolumeReader::Open(*info);
  ASSERT_TRUE(reader.ok());
  std::mt19937_64 rng(3);
  for (int i = 0; i < 200; ++i) {
    const uint64_t first = rng() % values.size();
    const size_t count = 1 + rng() % (values.size() - first);
    std::vector<double> got(count);
    ASSERT_TRUE((*reader)->Read(first, count, got.data()).ok());
    ASSERT_TRUE(std::equal(got.begin(), got.end(), values.begin() + static_cast<long>(first)));
  }
  double v;
  const Status past = (*reader)->Read(values.size(), 1, &v);
  EXPECT_TRUE(past.IsInvalidArgument()) << past.ToString();
  std::vector<double> two(2);
  EXPECT_TRUE((*reader)->Read(values.size() - 1, 2, two.data()).IsInvalidArgument());
  EXPECT_TRUE((*reader)->Read(values.size(), 0, two.data()).ok());
}

TEST(VolumeReader, FileShrunkAfterOpenIsCorruptionNamingTheFile) {
  TempDir dir;
  const std::string path = dir / "shrinks.raw";
  WriteFile(path, std::string(4 * 4 * 4, '\1'));
  auto info = OpenRawVolume(path, 3, {4, 4, 4, 1}, VoxelType::kU8, ByteOrder::kLittle, 0);
  ASSERT_TRUE(info.ok());
  auto reader = VolumeReader::Open(*info);
  ASSERT_TRUE(reader.ok());
  fs::resize_file(path, 10);
  std::vector<double> out(64);
  const Status s = (*reader)->Read(0, 64, out.data());
  ASSERT_TRUE(s.IsCorruption()) << s.ToString();
  EXPECT_NE(s.message().find(path), std::string::npos);
}

TEST(VolumeReader, RejectsInconsistentInfo) {
  VolumeInfo info;
  info.dims = {2, 2, 2, 1};
  EXPECT_TRUE(VolumeReader::Open(info).status().IsInvalidArgument());  // no files
  info.files = {"a", "b", "c"};                                         // 8 % 3 != 0
  EXPECT_TRUE(VolumeReader::Open(info).status().IsInvalidArgument());
  info.files = {"/nonexistent/a"};
  EXPECT_TRUE(VolumeReader::Open(info).status().IsNotFound());
}

// ---------------------------------------------------------------------------
// NRRD, written by hand.

std::string NrrdHeader(const std::string& fields) { return "NRRD0004\n" + fields; }

TEST(Nrrd, AttachedBigEndianWithCommentsKeyValuesAndSpacings) {
  TempDir dir;
  const std::string path = dir / "a.nrrd";
  const std::vector<double> values = Iota(3 * 2 * 2, -6, 1.5);
  WriteFile(path, NrrdHeader("# a comment\n"
                             "type: float\n"
                             "dimension: 3\n"
                             "sizes: 3 2 2\n"
                             "spacings: 0.5 2 NaN\n"
                             "modality:=CT\n"
                             "content: test\n"
                             "endian: big\n"
                             "encoding: raw\n"
                             "\n") +
                      Encode(VoxelType::kF32, ByteOrder::kBig, values));
  auto info = OpenNrrd(path);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->dims, (std::array<uint32_t, 4>{3, 2, 2, 1}));
  EXPECT_EQ(info->type, VoxelType::kF32);
  EXPECT_EQ(info->order, ByteOrder::kBig);
  EXPECT_EQ(info->offset, ReadFile(path).size() - values.size() * 4);
  EXPECT_EQ(info->spacing, (std::array<double, 4>{0.5, 2, 1, 1}));  // NaN -> 1
  EXPECT_EQ(ReadAll(*info), values);
}

TEST(Nrrd, TypeSpellingsOfTheSpecification) {
  TempDir dir;
  const std::pair<const char*, VoxelType> spellings[] = {
      {"unsigned char", VoxelType::kU8}, {"uchar", VoxelType::kU8},
      {"signed char", VoxelType::kI8},   {"int8_t", VoxelType::kI8},
      {"ushort", VoxelType::kU16},       {"unsigned short int", VoxelType::kU16},
      {"short", VoxelType::kI16},        {"signed short int", VoxelType::kI16},
      {"float", VoxelType::kF32},        {"double", VoxelType::kF64},
  };
  for (const auto& [name, type] : spellings) {
    SCOPED_TRACE(name);
    const std::string path = dir / "t.nrrd";
    const std::vector<double> values = {1, 2, 3, 4, 5, 6, 7, 100};
    WriteFile(path, NrrdHeader(std::string("type: ") + name +
                               "\ndimension: 3\nsizes: 2 2 2\nendian: little\n"
                               "encoding: raw\n\n") +
                        Encode(type, ByteOrder::kLittle, values));
    auto info = OpenNrrd(path);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->type, type);
    EXPECT_EQ(ReadAll(*info), values);
  }
}

TEST(Nrrd, DetachedHeaderWithRelativeDataFileLineAndByteSkip) {
  TempDir dir;
  fs::create_directories(dir / "sub");
  const std::vector<double> values = Iota(2 * 3 * 2 * 2, 1000, 7);
  // Two text lines and 3 more bytes before the voxels.
  WriteFile(dir / "sub/data.bin",
            "line one\nline two\nxyz" + Encode(VoxelType::kU16, ByteOrder::kLittle, values));
  WriteFile(dir / "h.nhdr", NrrdHeader("type: uint16\ndimension: 4\nsizes: 2 3 2 2\n"
                                       "endian: little\nencoding: raw\n"
                                       "data file: sub/data.bin\nline skip: 2\n"
                                       "byte skip: 3\n"));
  auto info = OpenVolume(dir / "h.nhdr");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->dimension, 4);
  EXPECT_EQ(info->dims, (std::array<uint32_t, 4>{2, 3, 2, 2}));
  EXPECT_EQ(info->files, std::vector<std::string>{dir / "sub/data.bin"});
  EXPECT_EQ(info->offset, 21u);
  EXPECT_EQ(ReadAll(*info), values);
}

TEST(Nrrd, ByteSkipMinusOneReadsTheLastBytes) {
  TempDir dir;
  const std::vector<double> values = Iota(8, -4);
  WriteFile(dir / "d.raw", "some preamble of any length" +
                               Encode(VoxelType::kI8, ByteOrder::kLittle, values));
  WriteFile(dir / "h.nhdr", NrrdHeader("type: int8\ndimension: 3\nsizes: 2 2 2\n"
                                       "encoding: raw\ndata file: d.raw\nbyte skip: -1\n"));
  auto info = OpenNrrd(dir / "h.nhdr");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(ReadAll(*info), values);
}

TEST(Nrrd, ListAndFormatDataFilesOnePerTimeStep) {
  TempDir dir;
  std::vector<double> all;
  for (int t = 0; t < 3; ++t) {
    const std::vector<double> step = Iota(8, 100.0 * t);
    all.insert(all.end(), step.begin(), step.end());
    char name[32];
    std::snprintf(name, sizeof(name), "step%03d.raw", t + 1);
    WriteFile(dir / name, Encode(VoxelType::kI16, ByteOrder::kBig, step));
  }
  const std::string fields = "type: int16\ndimension: 4\nsizes: 2 2 2 3\nendian: big\n"
                             "encoding: raw\n";
  WriteFile(dir / "list.nhdr",
            NrrdHeader(fields + "data file: LIST\nstep001.raw\nstep002.raw\nstep003.raw\n"));
  WriteFile(dir / "fmt.nhdr", NrrdHeader(fields + "data file: step%03d.raw 1 3 1 3\n"));
  for (const char* header : {"list.nhdr", "fmt.nhdr"}) {
    SCOPED_TRACE(header);
    auto info = OpenNrrd(dir / header);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    ASSERT_EQ(info->files.size(), 3u);
    EXPECT_EQ(info->files[2], dir / "step003.raw");
    EXPECT_EQ(ReadAll(*info), all);
    CheckAgainstFread(*info, 5);
  }
  // Two files for three time steps.
  WriteFile(dir / "short_list.nhdr",
            NrrdHeader(fields + "data file: LIST\nstep001.raw\nstep002.raw\n"));
  auto bad = OpenNrrd(dir / "short_list.nhdr");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(bad.status().IsInvalidArgument());
  EXPECT_NE(bad.status().message().find("2 data files, expected 3"), std::string::npos)
      << bad.status().ToString();
}

TEST(Nrrd, SpaceDirectionsGiveTheSpacing) {
  TempDir dir;
  WriteFile(dir / "s.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "space: right-anterior-superior\n"
                       "space directions: (0,3,0) (0.6,0,0.8) (0,0,2.5)\n\n") +
                std::string(8, 'a'));
  auto info = OpenNrrd(dir / "s.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_DOUBLE_EQ(info->spacing[0], 3);
  EXPECT_DOUBLE_EQ(info->spacing[1], 1);
  EXPECT_DOUBLE_EQ(info->spacing[2], 2.5);
  // Not the positive axes in order: said, for the store's source.
  EXPECT_NE(info->dropped.find("orientation dropped"), std::string::npos) << info->dropped;
  EXPECT_NE(DescribeSource(*info).find("orientation dropped"), std::string::npos);
}

TEST(Nrrd, SpaceOriginAndDiagonalDirectionsPlaceTheGrid) {
  TempDir dir;
  WriteFile(dir / "o.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "space: left-posterior-superior\n"
                       "space directions: (0.5,0,0) (0,0.75,0) (0,0,2.5)\n"
                       "space origin: (-10.25,20,3.5)\n\n") +
                std::string(8, 'a'));
  auto info = OpenNrrd(dir / "o.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{0.5, 0.75, 2.5, 1}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{-10.25, 20, 3.5, 0}));
  EXPECT_EQ(info->dropped, "");
}

TEST(Nrrd, TimeAxisTakesSpacingsAndAxisMinsBesideSpaceDirections) {
  TempDir dir;
  WriteFile(dir / "t.nrrd",
            NrrdHeader("type: uint8\ndimension: 4\nsizes: 2 2 2 3\nencoding: raw\n"
                       "kinds: space space space time\nspace: 3D-right-handed\n"
                       "space directions: (2,0,0) (0,2,0) (0,0,2.2) none\n"
                       "spacings: nan nan nan 0.5\naxis mins: nan nan nan 7\n"
                       "space origin: (1,2,3)\n\n") +
                std::string(24, 'a'));
  auto info = OpenNrrd(dir / "t.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{2, 2, 2.2, 0.5}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{1, 2, 3, 7}));
}

TEST(Nrrd, SpacingsAndAxisMinsWithoutSpace) {
  TempDir dir;
  WriteFile(dir / "m.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "spacings: 1.5 2 3\naxis mins: -1 0.25 100\n\n") +
                std::string(8, 'a'));
  auto info = OpenNrrd(dir / "m.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{1.5, 2, 3, 1}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{-1, 0.25, 100, 0}));
  // A flipped axis is kept: a negative spacing, nothing dropped.
  WriteFile(dir / "f.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "space directions: (-1,0,0) (0,1.5,0) (0,0,-2)\n"
                       "space origin: (5,6,7)\n\n") +
                std::string(8, 'a'));
  info = OpenNrrd(dir / "f.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{-1, 1.5, -2, 1}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{5, 6, 7, 0}));
  EXPECT_EQ(info->dropped, "");
  // Turned 30 degrees about z (and y flipped): the nearest axis-aligned
  // orientation is kept, the turn is said.
  WriteFile(dir / "o.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "space directions: (0.8660254037844387,0.5,0) (0.5,-0.8660254037844387,0) "
                       "(0,0,3)\n\n") +
                std::string(8, 'a'));
  info = OpenNrrd(dir / "o.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_DOUBLE_EQ(info->spacing[0], 1);
  EXPECT_DOUBLE_EQ(info->spacing[1], -1);
  EXPECT_DOUBLE_EQ(info->spacing[2], 3);
  EXPECT_NE(info->dropped.find("oblique orientation dropped"), std::string::npos) << info->dropped;
  EXPECT_NE(info->dropped.find(" 30 degrees"), std::string::npos) << info->dropped;
  EXPECT_NE(info->dropped.find("flipped y)"), std::string::npos) << info->dropped;
  // Bad values name the field.
  WriteFile(dir / "b.nrrd",
            NrrdHeader("type: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
                       "space origin: 1,2,3\n\n") +
                std::string(8, 'a'));
  info = OpenNrrd(dir / "b.nrrd");
  ASSERT_FALSE(info.ok());
  EXPECT_NE(info.status().message().find("space origin"), std::string::npos)
      << info.status().ToString();
}

TEST(Nrrd, GzipAttachedAndDetachedReadBackInAnyOrder) {
  TempDir dir;
  // Large enough that the stream spans many zlib buffers.
  const std::array<uint32_t, 4> dims = {40, 30, 20, 1};
  std::vector<double> values(40 * 30 * 20);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>((i * 7919) % 65536) - 32768;
  const std::string gz = Gzip(Encode(VoxelType::kI16, ByteOrder::kLittle, values));
  const std::string fields = "type: short\ndimension: 3\nsizes: 40 30 20\n"
                             "endian: little\nencoding: gzip\n";
  WriteFile(dir / "g.nrrd", NrrdHeader(fields + "\n") + gz);
  WriteFile(dir / "g.raw.gz", gz);
  WriteFile(dir / "g.nhdr", NrrdHeader(fields + "data file: g.raw.gz\n"));
  for (const char* name : {"g.nrrd", "g.nhdr"}) {
    SCOPED_TRACE(name);
    auto info = OpenNrrd(dir / name);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->encoding, VolumeInfo::Encoding::kGzip);
    EXPECT_EQ(info->dims, dims);
    EXPECT_EQ(ReadAll(*info), values);
    // Backwards and forwards jumps rewind and skip in the stream.
    auto reader = VolumeReader::Open(*info);
    ASSERT_TRUE(reader.ok());
    std::mt19937_64 rng(9);
    for (int i = 0; i < 30; ++i) {
      const uint64_t first = rng() % values.size();
      const size_t count = static_cast<size_t>(1 + rng() % std::min<uint64_t>(5000, values.size() - first));
      std::vector<double> got(count);
      ASSERT_TRUE((*reader)->Read(first, count, got.data()).ok());
      ASSERT_TRUE(std::equal(got.begin(), got.end(), values.begin() + static_cast<long>(first)));
    }
  }
}

TEST(Nrrd, TruncatedOrDamagedGzipIsCorruption) {
  TempDir dir;
  const std::vector<double> values = Iota(16 * 16 * 16, 0, 0.25);
  const std::string gz = Gzip(Encode(VoxelType::kF64, ByteOrder::kLittle, values));
  const std::string header = NrrdHeader("type: double\ndimension: 3\nsizes: 16 16 16\n"
                                        "endian: little\nencoding: gz\n\n");
  // Cut: the trailer no longer holds the size; found at open.
  WriteFile(dir / "cut.nrrd", header + gz.substr(0, gz.size() / 2));
  auto cut = OpenNrrd(dir / "cut.nrrd");
  ASSERT_FALSE(cut.ok());
  EXPECT_TRUE(cut.status().IsCorruption()) << cut.status().ToString();
  EXPECT_NE(cut.status().message().find(dir / "cut.nrrd"), std::string::npos);
  // Damaged in the middle, trailer intact: found when read.
  std::string damaged = gz;
  for (size_t i = gz.size() / 3; i < gz.size() / 3 + 40; ++i) damaged[i] = static_cast<char>(~damaged[i]);
  WriteFile(dir / "damaged.nrrd", header + damaged);
  auto info = OpenNrrd(dir / "damaged.nrrd");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  auto reader = VolumeReader::Open(*info);
  ASSERT_TRUE(reader.ok());
  std::vector<double> out(values.size());
  const Status s = (*reader)->Read(0, out.size(), out.data());
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(s.IsCorruption()) << s.ToString();
  EXPECT_NE(s.message().find(dir / "damaged.nrrd"), std::string::npos);
  // Not gzip at all.
  WriteFile(dir / "plain.nrrd", header + std::string(16 * 16 * 16 * 8, '\0'));
  auto plain = OpenNrrd(dir / "plain.nrrd");
  EXPECT_TRUE(plain.status().IsCorruption()) << plain.status().ToString();
}

// Each malformed or unsupported header fails with the expected code, the
// file name and the offending text in the message.
TEST(Nrrd, BadHeadersGiveClearErrors) {
  TempDir dir;
  struct Case {
    const char* name;
    std::string text;
    Status::Code code;
    const char* mentions;
  };
  const std::string ok_fields = "dimension: 3\nsizes: 2 2 2\nencoding: raw\n";
  const std::string data(64, '\0');
  const Case cases[] = {
      {"block", NrrdHeader("type: block\nblock size: 4\n" + ok_fields + "\n") + data,
       Status::Code::kNotSupported, "block"},
      {"int32", NrrdHeader("type: int\nendian: little\n" + ok_fields + "\n") + data,
       Status::Code::kNotSupported, "int"},
      {"badtype", NrrdHeader("type: quaternion\n" + ok_fields + "\n") + data,
       Status::Code::kInvalidArgument, "quaternion"},
      {"unknown_encoding",
       NrrdHeader("type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: lzma\n\n") + data,
       Status::Code::kInvalidArgument, "lzma"},
      {"bzip2", NrrdHeader("type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: bzip2\n\n") + data,
       Status::Code::kNotSupported, "bzip2"},
      {"text", NrrdHeader("type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: text\n\n") +
                   "1 2 3 4 5 6 7 8\n",
       Status::Code::kNotSupported, "text"},
      {"no_endian", NrrdHeader("type: int16\n" + ok_fields + "\n") + data,
       Status::Code::kInvalidArgument, "endian"},
      {"no_type", NrrdHeader(ok_fields + "\n") + data, Status::Code::kInvalidArgument, "type"},
      {"bad_magic", "NRRX0004\ntype: uchar\n" + ok_fields + "\n" + data,
       Status::Code::kInvalidArgument, "NRRX0004"},
      {"future_magic", "NRRD0009\ntype: uchar\n" + ok_fields + "\n" + data,
       Status::Code::kNotSupported, "NRRD0009"},
      {"2d", NrrdHeader("type: uchar\ndimension: 2\nsizes: 8 8\nencoding: raw\n\n") + data,
       Status::Code::kNotSupported, "dimension 2"},
      {"sizes_count", NrrdHeader("type: uchar\ndimension: 3\nsizes: 4 4\nencoding: raw\n\n") + data,
       Status::Code::kInvalidArgument, "sizes"},
      {"size_one", NrrdHeader("type: uchar\ndimension: 3\nsizes: 1 8 8\nencoding: raw\n\n") + data,
       Status::Code::kInvalidArgument, "at least 2"},
      {"vector", NrrdHeader("type: uchar\ndimension: 4\nsizes: 3 2 2 2\nkinds: 3-vector "
                            "domain domain domain\nencoding: raw\n\n") + data,
       Status::Code::kNotSupported, "3-vector"},
      {"duplicate", NrrdHeader("type: uchar\ntype: uchar\n" + ok_fields + "\n") + data,
       Status::Code::kInvalidArgument, "twice"},
      {"no_colon", NrrdHeader("type uchar\n" + ok_fields + "\n") + data,
       Status::Code::kInvalidArgument, "field: value"},
      {"no_data", NrrdHeader("type: uchar\n" + ok_fields), Status::Code::kInvalidArgument,
       "data file"},
      {"truncated", NrrdHeader("type: uchar\n" + ok_fields + "\n") + data.substr(0, 7),
       Status::Code::kCorruption, "truncated"},
      {"missing_data_file", NrrdHeader("type: uchar\n" + ok_fields + "data file: nope.raw\n"),
       Status::Code::kNotFound, "nope.raw"},
      {"gzip_byte_skip", NrrdHeader("type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n"
                                    "byte skip: 4\n\n") + Gzip(data.substr(0, 8)),
       Status::Code::kNotSupported, "byte skip"},
      {"bad_format", NrrdHeader("type: uchar\n" + ok_fields + "data file: f%s.raw 1 2 1\n"),
       Status::Code::kNotSupported, "%s"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir / (std::string(c.name) + ".nrrd");
    WriteFile(path, c.text);
    auto info = OpenNrrd(path);
    ASSERT_FALSE(info.ok());
    EXPECT_EQ(info.status().code(), c.code) << info.status().ToString();
    EXPECT_NE(info.status().message().find(path), std::string::npos) << info.status().ToString();
    EXPECT_NE(info.status().message().find(c.mentions), std::string::npos)
        << info.status().ToString();
  }
}

// ---------------------------------------------------------------------------
// NIfTI-1, written field by field.

TEST(Nifti, BothByteOrdersAndUnscaledValues) {
  TempDir dir;
  const std::vector<double> values = {-1.5, 2.25, 1e10, -3, 0, 5, 6, 7,
                                      8,    9,    10,   11, 12, 13, 14, 15};
  for (ByteOrder order : {ByteOrder::kLittle, ByteOrder::kBig}) {
    SCOPED_TRACE(std::string(ByteOrderName(order)));
    NiftiSpec spec;
    spec.order = order;
    spec.dim = {4, 2, 2, 2, 2, 1, 1, 1};
    spec.datatype = 16;  // float32
    spec.bitpix = 32;
    spec.vox_offset = 368;
    spec.pixdim = {1, 0.5, -0.75, 2, 3, 0, 0, 0};
    const std::string path = dir / ("f_" + std::string(ByteOrderName(order)) + ".nii");
    WriteFile(path, MakeNifti(spec, Encode(VoxelType::kF32, order, values)));
    auto info = OpenNifti(path);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->order, order);
    EXPECT_EQ(info->dimension, 4);
    EXPECT_EQ(info->dims, (std::array<uint32_t, 4>{2, 2, 2, 2}));
    EXPECT_EQ(info->type, VoxelType::kF32);
    EXPECT_EQ(info->offset, 368u);
    EXPECT_EQ(info->spacing, (std::array<double, 4>{0.5, 0.75, 2, 3}));
    // scl_slope 0 means no scaling, whatever scl_inter says.
    EXPECT_FALSE(info->scaled());
    EXPECT_EQ(ReadAll(*info), values);
  }
}

TEST(Nifti, SclSlopeAndSclInterScaleTheValues) {
  TempDir dir;
  // int16 stored values and, worked out by hand, 0.5 * stored + 10.
  const std::vector<double> stored = {-32768, -21, -1, 0, 1, 3, 100, 32767};
  const std::vector<double> scaled = {-16374, -0.5, 9.5, 10, 10.5, 11.5, 60, 16393.5};
  for (ByteOrder order : {ByteOrder::kLittle, ByteOrder::kBig}) {
    SCOPED_TRACE(std::string(ByteOrderName(order)));
    NiftiSpec spec;
    spec.order = order;
    spec.scl_slope = 0.5f;
    spec.scl_inter = 10.0f;
    const std::string path = dir / ("s_" + std::string(ByteOrderName(order)) + ".nii");
    WriteFile(path, MakeNifti(spec, Encode(VoxelType::kI16, order, stored)));
    auto info = OpenNifti(path);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->type, VoxelType::kI16);  // as stored; the values are doubles
    EXPECT_TRUE(info->scaled());
    EXPECT_EQ(info->scale, 0.5);
    EXPECT_EQ(info->shift, 10.0);
    EXPECT_EQ(FormatScaling(*info), "slope 0.5, intercept 10");
    EXPECT_EQ(ReadAll(*info), scaled);
    // A read from the middle scales too.
    auto reader = VolumeReader::Open(*info);
    ASSERT_TRUE(reader.ok()) << reader.status().ToString();
    double v = 0;
    ASSERT_TRUE((*reader)->Read(5, 1, &v).ok());
    EXPECT_EQ(v, 11.5);
  }
}

TEST(Nifti, SlopeOneInterceptZeroAndBadSlopesAreNoScaling) {
  TempDir dir;
  const std::vector<double> stored = {0, 1, 2, 3, 4, 5, 6, 7};
  const std::pair<float, float> cases[] = {
      {1.0f, 0.0f},  // the identity
      {0.0f, 5.0f},  // slope 0: no scaling, the intercept is not applied
      {std::numeric_limits<float>::quiet_NaN(), 5.0f},
      {std::numeric_limits<float>::infinity(), 5.0f},
  };
  for (const auto& [slope, inter] : cases) {
    SCOPED_TRACE(std::to_string(slope) + " " + std::to_string(inter));
    NiftiSpec spec;
    spec.scl_slope = slope;
    spec.scl_inter = inter;
    const std::string path = dir / "n.nii";
    WriteFile(path, MakeNifti(spec, Encode(VoxelType::kI16, ByteOrder::kLittle, stored)));
    auto info = OpenNifti(path);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_FALSE(info->scaled());
    EXPECT_EQ(ReadAll(*info), stored);
  }
  // A slope with an intercept that is not finite: the intercept is 0.
  NiftiSpec spec;
  spec.scl_slope = -2.0f;
  spec.scl_inter = std::numeric_limits<float>::quiet_NaN();
  const std::string path = dir / "m.nii";
  WriteFile(path, MakeNifti(spec, Encode(VoxelType::kI16, ByteOrder::kLittle, stored)));
  auto info = OpenNifti(path);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(ReadAll(*info), (std::vector<double>{0, -2, -4, -6, -8, -10, -12, -14}));
}

TEST(Nifti, TimeSeriesStepsMustScaleAlike) {
  TempDir dir;
  const std::vector<double> stored = {0, 1, 2, 3, 4, 5, 6, 7};
  const auto write = [&](const std::string& name, float slope, float inter) {
    NiftiSpec spec;
    spec.scl_slope = slope;
    spec.scl_inter = inter;
    const std::string path = dir / name;
    WriteFile(path, MakeNifti(spec, Encode(VoxelType::kI16, ByteOrder::kLittle, stored)));
    return path;
  };
  const std::string a = write("a.nii", 2, 1), b = write("b.nii", 2, 1), c = write("c.nii", 3, 1);
  auto same = OpenTimeSeries({a, b});
  ASSERT_TRUE(same.ok()) << same.status().ToString();
  std::vector<double> expected;
  for (int step = 0; step < 2; ++step) {
    for (double v : stored) expected.push_back(2 * v + 1);
  }
  EXPECT_EQ(ReadAll(*same), expected);
  auto mixed = OpenTimeSeries({a, c});
  ASSERT_FALSE(mixed.ok());
  EXPECT_TRUE(mixed.status().IsInvalidArgument()) << mixed.status().ToString();
  EXPECT_NE(mixed.status().message().find(c + ": time step 1 has scaling slope 3, intercept 1, "
                                          "expected slope 2, intercept 1"),
            std::string::npos)
      << mixed.status().ToString();
}

TEST(Nifti, EverySupportedDatatypeCode) {
  TempDir dir;
  const std::tuple<int16_t, int16_t, VoxelType> codes[] = {
      {2, 8, VoxelType::kU8},     {256, 8, VoxelType::kI8},   {512, 16, VoxelType::kU16},
      {4, 16, VoxelType::kI16},   {16, 32, VoxelType::kF32},  {64, 64, VoxelType::kF64},
  };
  const std::vector<double> values = {0, 1, 2, 3, 4, 5, 6, 127};
  for (const auto& [code, bitpix, type] : codes) {
    SCOPED_TRACE(code);
    NiftiSpec spec;
    spec.datatype = code;
    spec.bitpix = bitpix;
    const std::string path = dir / "t.nii";
    WriteFile(path, MakeNifti(spec, Encode(type, ByteOrder::kLittle, values)));
    auto info = OpenVolume(path);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    EXPECT_EQ(info->type, type);
    EXPECT_EQ(ReadAll(*info), values);
  }
}

TEST(Nifti, SformPlacesTheGridInMillimetresAndSeconds) {
  TempDir dir;
  NiftiSpec spec;
  spec.dim = {4, 2, 2, 2, 2, 1, 1, 1};
  spec.pixdim = {1, 2, 2, 2.2f, 2000, 1, 1, 1};
  spec.xyzt_units = 2 | 16;  // mm, ms
  spec.toffset = 500;        // ms
  spec.sform_code = 1;
  spec.srow = {2, 0, 0, -90, 0, 2, 0, 126, 0, 0, 2.2f, -72};
  spec.qform_code = 1;  // the sform wins
  spec.quatern = {0, 0, 0, 1, 2, 3};
  WriteFile(dir / "s.nii", MakeNifti(spec, std::string(32, '\0')));
  auto info = OpenNifti(dir / "s.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{2, 2, 2.2f, 2}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{-90, 126, -72, 0.5}));
  EXPECT_EQ(info->dropped, "");
}

TEST(Nifti, QformOffsetAndWhatIsDroppedOtherwise) {
  TempDir dir;
  NiftiSpec spec;
  spec.pixdim = {1, 0.001f, 0.002f, 0.003f, 1, 1, 1, 1};
  spec.xyzt_units = 1;  // metres
  spec.qform_code = 1;
  spec.quatern = {0, 0, 0, 0.5f, -0.25f, 1};  // identity rotation
  WriteFile(dir / "q.nii", MakeNifti(spec, std::string(16, '\0')));
  auto info = OpenNifti(dir / "q.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_DOUBLE_EQ(info->spacing[0], 1000 * double{0.001f});
  EXPECT_DOUBLE_EQ(info->origin[0], 500);
  EXPECT_DOUBLE_EQ(info->origin[1], -250);
  EXPECT_DOUBLE_EQ(info->origin[2], 1000);
  EXPECT_EQ(info->dropped, "");
  // qfac -1 flips z: kept as a negative spacing, the origin stays.
  spec.pixdim[0] = -1;
  WriteFile(dir / "flip.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "flip.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_DOUBLE_EQ(info->origin[0], 500);
  EXPECT_DOUBLE_EQ(info->spacing[0], 1000 * double{0.001f});
  EXPECT_DOUBLE_EQ(info->spacing[2], -1000 * double{0.003f});
  EXPECT_EQ(info->dropped, "");
  // A quaternion of 180 degrees about z (b, c, d = 0, 0, 1) flips x and y.
  spec.pixdim[0] = 1;
  spec.quatern = {0, 0, 1, 0, 0, 0};
  WriteFile(dir / "turn.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "turn.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_LT(info->spacing[0], 0);
  EXPECT_LT(info->spacing[1], 0);
  EXPECT_GT(info->spacing[2], 0);
  EXPECT_EQ(info->dropped, "");
  // A 90-degree turn about z permutes x and y: nothing of it is kept.
  spec.quatern = {0, 0, 0.70710678f, 0, 0, 0};
  WriteFile(dir / "perm.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "perm.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_GT(info->spacing[0], 0);
  EXPECT_GT(info->spacing[1], 0);
  EXPECT_NE(info->dropped.find("qform permutes the axes"), std::string::npos) << info->dropped;
  // The sform comes first: x flipped, z scaled, no turn.
  spec.sform_code = 1;
  spec.srow = {-0.002f, 0, 0, 1, 0, 0.002f, 0, 2, 0, 0, 0.003f, 3};
  WriteFile(dir / "s.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "s.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_LT(info->spacing[0], 0);
  EXPECT_GT(info->spacing[1], 0);
  EXPECT_DOUBLE_EQ(info->origin[0], 1000);
  EXPECT_EQ(info->dropped, "");
  spec.sform_code = 0;
  // No qform or sform: method 1, origin 0.
  spec.qform_code = 0;
  WriteFile(dir / "none.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "none.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->origin, (std::array<double, 4>{0, 0, 0, 0}));
  EXPECT_EQ(info->dropped, "");
}

// Issue 46: NIfTI-1's method 3 takes each axis's spacing from the sform's
// column (pixdim 1 here, ignored); codes it does not define are not used,
// with a note; a quaternion that is no rotation is refused.
TEST(Nifti, PlacementFollowsTheStandardsMethods) {
  TempDir dir;
  NiftiSpec spec;
  spec.xyzt_units = 2;  // mm
  spec.sform_code = 2;
  spec.srow = {2, 0, 0, 5, 0, 3, 0, 6, 0, 0, 4, 7};
  WriteFile(dir / "s.nii", MakeNifti(spec, std::string(16, '\0')));
  auto info = OpenNifti(dir / "s.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{2, 3, 4, 1}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{5, 6, 7, 0}));
  EXPECT_EQ(info->dropped, "");
  // A column that is not along its axis: its length is still the spacing.
  spec.srow = {0.8660254f, -0.5f, 0, 0, 0.5f, 0.8660254f, 0, 0, 0, 0, 1, 0};  // 30 degrees about z
  WriteFile(dir / "turned.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "turned.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_NEAR(std::fabs(info->spacing[0]), 1, 1e-6);
  EXPECT_NE(info->dropped.find("turns the grid"), std::string::npos) << info->dropped;
  // sform_code 99: not a NIfTI-1 code, so method 2 (the qform) places it.
  spec.sform_code = 99;
  spec.qform_code = 1;
  spec.pixdim = {1, 1.5f, 1.5f, 1.5f, 1, 1, 1, 1};
  spec.quatern = {0, 0, 0, 1, 2, 3};
  WriteFile(dir / "odd.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "odd.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->spacing, (std::array<double, 4>{1.5, 1.5, 1.5, 1}));
  EXPECT_EQ(info->origin, (std::array<double, 4>{1, 2, 3, 0}));
  EXPECT_NE(info->dropped.find("sform_code 99 is not a NIfTI-1 transform code (0-4): not used"),
            std::string::npos)
      << info->dropped;
  // qform_code 99 alone: method 1, with the note.
  spec.sform_code = 0;
  spec.qform_code = 99;
  WriteFile(dir / "odd_q.nii", MakeNifti(spec, std::string(16, '\0')));
  info = OpenNifti(dir / "odd_q.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->origin, (std::array<double, 4>{0, 0, 0, 0}));
  EXPECT_NE(info->dropped.find("qform_code 99"), std::string::npos) << info->dropped;
  // A quaternion longer than 1, or not finite: refused, naming it.
  spec.qform_code = 1;
  for (const float b : {0.9f, std::numeric_limits<float>::quiet_NaN()}) {
    spec.quatern = {b, 0.9f, 0, 0, 0, 0};
    WriteFile(dir / "bad.nii", MakeNifti(spec, std::string(16, '\0')));
    const auto bad = OpenNifti(dir / "bad.nii");
    ASSERT_FALSE(bad.ok()) << b;
    EXPECT_TRUE(bad.status().IsInvalidArgument()) << bad.status().ToString();
    EXPECT_NE(bad.status().message().find("qform's quaternion"), std::string_view::npos) << bad.status().message();
    EXPECT_NE(bad.status().message().find(dir / "bad.nii"), std::string_view::npos) << bad.status().message();
  }
}

TEST(SharedData, FmriSpacingIsTheReadmeVoxelSizeAndTr) {
  SKIP_WITHOUT_SHARED_DATA();
  auto info = OpenNifti(kSharedData + "/fmri_example4d/example4d.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  // Method 3: the sform's columns' lengths (float32 entries: within 1e-6).
  EXPECT_NEAR(info->spacing[0], -2, 1e-6);  // the sform flips x
  EXPECT_NEAR(info->spacing[1], 2, 1e-6);
  EXPECT_NEAR(info->spacing[2], 2.2, 1e-5);
  // The TR is 2000 ms, but the header's xyzt_units is 10 (mm, seconds) with
  // pixdim[4] 2000: kept as the header says, not guessed at.
  EXPECT_DOUBLE_EQ(info->spacing[3], 2000);
  // The sform's translation (nibabel's affine[:3, 3]); its x is flipped.
  EXPECT_NEAR(info->origin[0], 117.855, 1e-3);
  EXPECT_NEAR(info->origin[1], -35.7229, 1e-3);
  EXPECT_NEAR(info->origin[2], -7.2488, 1e-3);
  // Its y and z axes are turned 9.3 degrees about x (atan(0.3232 / 1.9737)).
  EXPECT_NE(info->dropped.find("the NIfTI sform turns the grid up to 9.3 degrees"),
            std::string::npos)
      << info->dropped;
}

TEST(Nifti, SingleTimeStepIsThreeD) {
  TempDir dir;
  NiftiSpec spec;
  spec.dim = {5, 2, 2, 2, 1, 1, 1, 1};  // trailing axes of 1
  WriteFile(dir / "t1.nii", MakeNifti(spec, std::string(16, '\0')));
  auto info = OpenNifti(dir / "t1.nii");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->dimension, 3);
  EXPECT_EQ(info->dims, (std::array<uint32_t, 4>{2, 2, 2, 1}));
}

TEST(Nifti, BadHeadersGiveClearErrors) {
  TempDir dir;
  struct Case {
    const char* name;
    NiftiSpec spec;
    size_t data_bytes;
    Status::Code code;
    const char* mentions;
  };
  std::vector<Case> cases;
  const auto add = [&](const char* name, auto edit, size_t bytes, Status::Code code,
                       const char* mentions) {
    NiftiSpec s;
    edit(s);
    cases.push_back({name, s, bytes, code, mentions});
  };
  using C = Status::Code;
  add("bad_magic", [](NiftiSpec& s) { s.magic = std::string("abc\0", 4); }, 16,
      C::kInvalidArgument, "magic");
  add("pair_magic", [](NiftiSpec& s) { s.magic = std::string("ni1\0", 4); }, 16,
      C::kNotSupported, "ni1");
  add("sizeof_hdr", [](NiftiSpec& s) { s.sizeof_hdr = 350; }, 16, C::kInvalidArgument,
      "sizeof_hdr is 350");
  add("nifti2", [](NiftiSpec& s) { s.sizeof_hdr = 540; }, 16, C::kNotSupported, "NIfTI-2");
  add("int32", [](NiftiSpec& s) { s.datatype = 8; s.bitpix = 32; }, 32, C::kNotSupported,
      "int32");
  add("rgb", [](NiftiSpec& s) { s.datatype = 128; s.bitpix = 24; }, 24, C::kNotSupported,
      "rgb24");
  add("unknown_type", [](NiftiSpec& s) { s.datatype = 3; }, 16, C::kInvalidArgument,
      "datatype code 3");
  add("bitpix", [](NiftiSpec& s) { s.bitpix = 8; }, 16, C::kInvalidArgument, "bitpix");
  add("2d", [](NiftiSpec& s) { s.dim = {2, 4, 4, 1, 1, 1, 1, 1}; }, 32, C::kNotSupported,
      "dim[0] is 2");
  add("dim_one", [](NiftiSpec& s) { s.dim = {3, 1, 8, 8, 1, 1, 1, 1}; }, 128,
      C::kInvalidArgument, "at least 2");
  add("negative_dim", [](NiftiSpec& s) { s.dim = {3, 2, -2, 2, 1, 1, 1, 1}; }, 16,
      C::kInvalidArgument, "dim[2]");
  add("vox_offset", [](NiftiSpec& s) { s.vox_offset = 352.5f; }, 16, C::kInvalidArgument,
      "vox_offset");
  add("truncated", [](NiftiSpec&) {}, 15, C::kCorruption, "truncated");
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir / (std::string(c.name) + ".nii");
    NiftiSpec spec = c.spec;
    if (spec.vox_offset != std::floor(spec.vox_offset)) {
      // MakeNifti pads to vox_offset: write the header at 352 then patch.
      const float bad = spec.vox_offset;
      spec.vox_offset = 352;
      std::string bytes = MakeNifti(spec, std::string(c.data_bytes, '\0'));
      const uint32_t u = std::bit_cast<uint32_t>(bad);
      for (size_t i = 0; i < 4; ++i) bytes[108 + i] = static_cast<char>((u >> (8 * i)) & 0xFF);
      WriteFile(path, bytes);
    } else {
      WriteFile(path, MakeNifti(spec, std::string(c.data_bytes, '\0')));
    }
    auto info = OpenNifti(path);
    ASSERT_FALSE(info.ok());
    EXPECT_EQ(info.status().code(), c.code) << info.status().ToString();
    EXPECT_NE(info.status().message().find(path), std::string::npos) << info.status().ToString();
    EXPECT_NE(info.status().message().find(c.mentions), std::string::npos)
        << info.status().ToString();
  }
  // Shorter than a header.
  WriteFile(dir / "tiny.nii", "n+1");
  auto tiny = OpenNifti(dir / "tiny.nii");
  EXPECT_TRUE(tiny.status().IsInvalidArgument()) << tiny.status().ToString();
}

// ---------------------------------------------------------------------------
// Time series.

TEST(TimeSeries, MixedFormatsBecomeOneFourDVolume) {
  TempDir dir;
  const size_t n = 3 * 4 * 5;
  const std::vector<double> a = Iota(n, 0), b = Iota(n, 1000), c = Iota(n, -500, -1);
  // An attached NRRD, a NIfTI-1 and a detached NRRD: three header lengths.
  WriteFile(dir / "a.nrrd", NrrdHeader("type: int16\ndimension: 3\nsizes: 3 4 5\n"
                                       "endian: little\nencoding: raw\n\n") +
                                Encode(VoxelType::kI16, ByteOrder::kLittle, a));
  NiftiSpec spec;
  spec.dim = {3, 3, 4, 5, 1, 1, 1, 1};
  WriteFile(dir / "b.nii", MakeNifti(spec, Encode(VoxelType::kI16, ByteOrder::kLittle, b)));
  WriteFile(dir / "c.raw", Encode(VoxelType::kI16, ByteOrder::kLittle, c));
  WriteFile(dir / "c.nhdr", NrrdHeader("type: int16\ndimension: 3\nsizes: 3 4 5\n"
                                       "endian: little\nencoding: raw\ndata file: c.raw\n"));
  auto info = OpenTimeSeries({dir / "a.nrrd", dir / "b.nii", dir / "c.nhdr"});
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->dimension, 4);
  EXPECT_EQ(info->dims, (std::array<uint32_t, 4>{3, 4, 5, 3}));
  EXPECT_EQ(info->files, (std::vector<std::string>{dir / "a.nrrd", dir / "b.nii", dir / "c.raw"}));
  ASSERT_EQ(info->file_offsets.size(), 3u);
  EXPECT_EQ(info->offset_of(1), 352u);
  EXPECT_EQ(info->offset_of(2), 0u);
  std::vector<double> all = a;
  all.insert(all.end(), b.begin(), b.end());
  all.insert(all.end(), c.begin(), c.end());
  EXPECT_EQ(ReadAll(*info), all);
  CheckAgainstFread(*info, 13);
}

TEST(TimeSeries, MismatchesNameTheFileAndBothValues) {
  TempDir dir;
  const auto nrrd = [&](const std::string& name, const std::string& type,
                        const std::string& sizes, const std::string& endian, size_t bytes) {
    WriteFile(dir / name, NrrdHeader("type: " + type + "\ndimension: 3\nsizes: " + sizes +
                                     "\nendian: " + endian + "\nencoding: raw\n\n") +
                              std::string(bytes, '\0'));
    return dir / name;
  };
  const std::string base = nrrd("base.nrrd", "int16", "2 3 4", "little", 48);
  const std::string dims = nrrd("dims.nrrd", "int16", "2 3 5", "little", 60);
  const std::string type = nrrd("type.nrrd", "uint16", "2 3 4", "little", 48);
  const std::string order = nrrd("order.nrrd", "int16", "2 3 4", "big", 48);
  struct Case {
    std::string path;
    const char* found;
    const char* expected;
  };
  for (const Case& c : {Case{dims, "2x3x5", "2x3x4"}, Case{type, "uint16", "int16"},
                        Case{order, "big", "little"}}) {
    SCOPED_TRACE(c.path);
    auto info = OpenTimeSeries({base, base, c.path});
    ASSERT_FALSE(info.ok());
    EXPECT_TRUE(info.status().IsInvalidArgument());
    const std::string msg(info.status().message());
    EXPECT_EQ(msg.rfind(c.path, 0), 0u) << msg;  // starts with the file
    EXPECT_NE(msg.find(c.found), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.expected), std::string::npos) << msg;
    EXPECT_NE(msg.find("time step 2"), std::string::npos) << msg;
  }
  EXPECT_TRUE(OpenTimeSeries({base}).status().IsInvalidArgument());
  EXPECT_TRUE(OpenTimeSeries({base, dir / "absent.nrrd"}).status().IsNotFound());
}

}  // namespace
}  // namespace simplexdb
