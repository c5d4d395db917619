// ReadOnlyFile (storage/io/read_only_file.h): open, size, reads that stop
// only at the end of the file, seek and hand-over of the descriptor, and the
// errors a reader meets (a missing file, a directory, a FIFO or a device).
#include "storage/io/read_only_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <thread>
#include <cerrno>
#include <cstddef>
#include <fstream>
#include <functional>
#include <string>
#include <utility>

#include "storage/io/file.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::WriteFile;

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

// Runs `open` in a child process and returns its exit status, or -1 when
// it is still running after 20 s (then it is killed): a reader that waits
// on a FIFO for a writer fails the test instead of hanging it.
int ExitStatusWithin20s(const std::function<int()>& open) {
  const pid_t child = fork();
  if (child == 0) _exit(open());
  for (int i = 0; i < 2000; ++i) {
    int status = 0;
    if (waitpid(child, &status, WNOHANG) == child) {
      return WIFEXITED(status) ? WEXITSTATUS(status) : 100;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  return -1;
}

// The readers read at positions and check sizes: a FIFO (no writer), a
// character device and a socket are refused at once, by their kind.
TEST(ReadOnlyFile, RefusesAFifoAndADeviceWithoutWaiting) {
  TempDir dir;
  const std::string fifo = dir.path() + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto refused = [](const std::string& path, const std::string& kind) {
    auto file = ReadOnlyFile::Open(path);
    if (file.ok()) return 1;
    if (!file.status().IsInvalidArgument()) return 2;
    if (file.status().message() !=
        path + ": cannot read: is " + kind + " (expected a regular file)") {
      return 3;
    }
    return 0;
  };
  EXPECT_EQ(ExitStatusWithin20s([&] { return refused(fifo, "a FIFO"); }), 0);
  EXPECT_EQ(ExitStatusWithin20s([&] { return refused("/dev/null", "a character device"); }), 0);
  // A regular file still opens, and reads as before.
  const std::string plain = dir.path() + "/plain";
  WriteFile(plain, "abc");
  auto file = ReadOnlyFile::Open(plain);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  std::array<std::byte, 3> bytes{};
  auto got = file->ReadUpTo(0, 3, bytes.data());
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(AsText(bytes.data(), *got), "abc");
}

}  // namespace
}  // namespace simplexdb
