// ReadOnlyFile (storage/io/read_only_file.h): open, size, reads that stop
// only at the end of the file, seek and hand-over of the descriptor, and the
// errors a reader meets (a missing file, a directory).
#include "storage/io/read_only_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstddef>
#include <fstream>
#include <string>
#include <utility>

#include "storage/io/file.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

std::string AsText(const std::byte* bytes, size_t n) {
  return std::string(reinterpret_cast<const char*>(bytes), n);
}

TEST(ReadOnlyFile, SizeAndReadsThatStopOnlyAtTheEnd) {
  TempDir dir;
  const std::string path = dir.path() + "/ten.bin";
  WriteFile(path, "0123456789");
  auto file = ReadOnlyFile::Open(path);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  EXPECT_EQ(file->path(), path);
  auto size = file->Size();
  ASSERT_TRUE(size.ok()) << size.status().ToString();
  EXPECT_EQ(*size, 10u);

  std::array<std::byte, 16> buf{};
  auto got = file->ReadUpTo(2, 4, buf.data());
  ASSERT_TRUE(got.ok()) << got.status().ToString();
  EXPECT_EQ(*got, 4u);
  EXPECT_EQ(AsText(buf.data(), 4), "2345");
  got = file->ReadUpTo(6, 16, buf.data());  // past the end: fewer bytes
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(*got, 4u);
  EXPECT_EQ(AsText(buf.data(), 4), "6789");
  got = file->ReadUpTo(10, 16, buf.data());  // at the end: none
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(*got, 0u);
  got = file->ReadUpTo(1000, 16, buf.data());  // beyond it: none
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(*got, 0u);
}

TEST(ReadOnlyFile, MissingFileIsNotFoundNamingIt) {
  TempDir dir;
  const std::string path = dir.path() + "/absent.bin";
  auto file = ReadOnlyFile::Open(path);
  ASSERT_FALSE(file.ok());
  EXPECT_TRUE(file.status().IsNotFound()) << file.status().ToString();
  const std::string msg(file.status().message());
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  EXPECT_NE(msg.find("open"), std::string::npos) << msg;
}

TEST(ReadOnlyFile, DirectoryIsRefusedAsReadWouldRefuseIt) {
  TempDir dir;
  auto file = ReadOnlyFile::Open(dir.path());
  ASSERT_FALSE(file.ok());
  // Whatever code the one errno table gives EISDIR.
  EXPECT_EQ(file.status().code(), StatusFromErrno(EISDIR, dir.path(), "read").code())
      << file.status().ToString();
  const std::string msg(file.status().message());
  EXPECT_NE(msg.find(dir.path()), std::string::npos) << msg;
  EXPECT_NE(msg.find("directory"), std::string::npos) << msg;
}

TEST(ReadOnlyFile, SeekThenReleaseHandsOverThePositionedDescriptor) {
  TempDir dir;
  const std::string path = dir.path() + "/ten.bin";
  WriteFile(path, "0123456789");
  auto opened = ReadOnlyFile::Open(path);
  ASSERT_TRUE(opened.ok());
  ReadOnlyFile file = std::move(opened).value();
  ASSERT_TRUE(file.Seek(7).ok());
  const int fd = file.Release();
  ASSERT_GE(fd, 0);
  EXPECT_EQ(file.fd(), -1);
  EXPECT_EQ(file.path(), path);  // still there after the hand-over
  char buf[4] = {};
  EXPECT_EQ(::read(fd, buf, sizeof(buf)), 3);  // from byte 7 on
  EXPECT_EQ(std::string(buf, 3), "789");
  EXPECT_EQ(::close(fd), 0);  // ours to close, and still open
}

TEST(ReadOnlyFile, MoveTransfersTheDescriptor) {
  TempDir dir;
  const std::string path = dir.path() + "/ten.bin";
  WriteFile(path, "0123456789");
  auto opened = ReadOnlyFile::Open(path);
  ASSERT_TRUE(opened.ok());
  ReadOnlyFile a = std::move(opened).value();
  const int fd = a.fd();
  ReadOnlyFile b = std::move(a);
  EXPECT_EQ(a.fd(), -1);  // NOLINT(bugprone-use-after-move): moved-from state
  EXPECT_EQ(b.fd(), fd);
  std::array<std::byte, 2> buf{};
  auto got = b.ReadUpTo(0, 2, buf.data());
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(AsText(buf.data(), 2), "01");
}

}  // namespace
}  // namespace simplexdb
