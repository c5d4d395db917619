// MemoryVolume (storage/volume/volume.h): voxels in memory read through
// VolumeReader give what the same bytes in a raw file give, for every voxel
// type and both byte orders, and the grid rules and errors hold as for files.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"

namespace simplexdb {
namespace {

// Random bytes for `count` voxels of `type` (any bit pattern; float NaNs
// included, compared by bits below).
std::shared_ptr<std::vector<std::byte>> RandomBytes(size_t bytes, unsigned seed) {
  std::mt19937 rng(seed);
  auto v = std::make_shared<std::vector<std::byte>>(bytes);
  for (std::byte& b : *v) b = static_cast<std::byte>(rng() & 0xFF);
  return v;
}

std::shared_ptr<const std::byte> Share(const std::shared_ptr<std::vector<std::byte>>& v) {
  return std::shared_ptr<const std::byte>(v, v->data());  // keeps the vector alive
}

TEST(MemoryVolume, ReadsLikeTheSameBytesInARawFile) {
  const std::array<uint32_t, 4> dims = {5, 3, 4, 2};
  const uint64_t count = 5 * 3 * 4 * 2;
  const std::string dir = ::testing::TempDir();
  for (const VoxelType type : {VoxelType::kU8, VoxelType::kI8, VoxelType::kU16, VoxelType::kI16,
                               VoxelType::kF32, VoxelType::kF64}) {
    for (const ByteOrder order : {ByteOrder::kLittle, ByteOrder::kBig}) {
      SCOPED_TRACE(std::string(VoxelTypeName(type)) + " " + std::string(ByteOrderName(order)));
      const auto bytes = RandomBytes(count * VoxelSize(type), static_cast<unsigned>(type) * 2 + 1);
      const std::string path = dir + "/memory_volume_test_" + std::to_string(getpid()) + ".raw";
      FILE* f = std::fopen(path.c_str(), "wb");
      ASSERT_NE(f, nullptr);
      ASSERT_EQ(std::fwrite(bytes->data(), 1, bytes->size(), f), bytes->size());
      std::fclose(f);
      Result<VolumeInfo> file = OpenRawVolume(path, 4, dims, type, order, 0);
      Result<VolumeInfo> memory = MemoryVolume(4, dims, type, order, Share(bytes), "test array");
      ASSERT_TRUE(file.ok()) << file.status().ToString();
      ASSERT_TRUE(memory.ok()) << memory.status().ToString();
      EXPECT_TRUE(memory->files.empty());
      auto a = VolumeReader::Open(*file);
      auto b = VolumeReader::Open(*memory);
      ASSERT_TRUE(a.ok() && b.ok());
      std::vector<double> x(count), y(count);
      ASSERT_TRUE((*a)->Read(0, count, x.data()).ok());
      ASSERT_TRUE((*b)->Read(0, count, y.data()).ok());
      EXPECT_EQ(std::memcmp(x.data(), y.data(), count * sizeof(double)), 0);
      // Random access inside: a window from the middle.
      std::vector<double> z(7);
      ASSERT_TRUE((*b)->Read(50, 7, z.data()).ok());
      EXPECT_EQ(std::memcmp(z.data(), x.data() + 50, 7 * sizeof(double)), 0);
      std::remove(path.c_str());
    }
  }
}

TEST(MemoryVolume, OneTimeStepIsThreeDimensional) {
  const auto bytes = RandomBytes(4 * 3 * 2, 9);
  Result<VolumeInfo> v = MemoryVolume(4, {4, 3, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, Share(bytes), "a");
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  EXPECT_EQ(v->dimension, 3);
}

TEST(MemoryVolume, ErrorsNameTheVolumeAndTheReason) {
  const auto bytes = RandomBytes(64, 1);
  Result<VolumeInfo> flat = MemoryVolume(3, {4, 1, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, Share(bytes), "array x");
  ASSERT_FALSE(flat.ok());
  EXPECT_TRUE(flat.status().IsInvalidArgument());
  EXPECT_NE(flat.status().ToString().find("array x"), std::string::npos) << flat.status().ToString();
  Result<VolumeInfo> null = MemoryVolume(3, {2, 2, 2, 1}, VoxelType::kU8, ByteOrder::kLittle, nullptr, "array y");
  ASSERT_FALSE(null.ok());
  EXPECT_NE(null.status().ToString().find("array y: no voxels"), std::string::npos) << null.status().ToString();
  Result<VolumeInfo> v = MemoryVolume(3, {4, 4, 4, 1}, VoxelType::kU8, ByteOrder::kLittle, Share(bytes), "array z");
  ASSERT_TRUE(v.ok());
  auto reader = VolumeReader::Open(*v);
  ASSERT_TRUE(reader.ok());
  double out[2];
  const Status past = (*reader)->Read(63, 2, out);
  EXPECT_TRUE(past.IsInvalidArgument()) << past.ToString();
  VolumeInfo with_files = *v;
  with_files.files = {"/tmp/x.raw"};
  EXPECT_TRUE(VolumeReader::Open(with_files).status().IsInvalidArgument());
}

}  // namespace
}  // namespace simplexdb
