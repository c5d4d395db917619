// storage/io/mapping_guard.h and MappedFile::CheckUnchanged: a mapped file
// truncated under its reader reads zeros and is reported, not a signal; a
// file written in place is reported; a SIGBUS outside the guarded ranges
// still goes to the handler before ours (the default one ends the process).
#include "storage/io/mapping_guard.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

#include "storage/io/file.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/sanitizer.h"

namespace simplexdb {
namespace {

using testing::TempDir;

constexpr size_t kBytes = size_t{1} << 20;

std::string WriteBytes(const TempDir& dir, const std::string& name, char fill) {
  const std::string path = dir / name;
  testing::WriteFile(path, std::string(kBytes, fill));
  return path;
}

// Linux stamps files with a coarse clock (a few milliseconds): a write
// that follows the open closely could keep its modification time.
void LetTheClockMove() { std::this_thread::sleep_for(std::chrono::milliseconds(20)); }

TEST(MappingGuard, ATruncatedFileReadsZerosAndIsReported) {
  const TempDir dir;
  const std::string path = WriteBytes(dir, "f", 'x');
  auto file = MappedFile::Open(path);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  const std::span<const uint8_t> bytes = (*file)->bytes();
  ASSERT_EQ(bytes.size(), kBytes);
  EXPECT_EQ(bytes[kBytes - 1], 'x');  // the last page resident before the cut
  ASSERT_TRUE((*file)->CheckUnchanged().ok());
  ASSERT_EQ(truncate(path.c_str(), kBytes / 4), 0);
  // Past the new end: zeros, and the process lives.
  uint64_t sum = 0;
  for (size_t i = kBytes / 2; i < kBytes; i += 4096) sum += bytes[i];
  EXPECT_EQ(sum, 0u);
  EXPECT_EQ(bytes[kBytes / 8], 'x');  // before the cut: the file's bytes
  const Status s = (*file)->CheckUnchanged();
  EXPECT_TRUE(s.IsIOError()) << s.ToString();
  EXPECT_NE(s.message().find(path + ": the file changed after it was opened"), std::string_view::npos) << s.message();
  EXPECT_NE(s.message().find("open it again"), std::string_view::npos) << s.message();
}

TEST(MappingGuard, AFileCutToNothingReadsZeros) {
  const TempDir dir;
  const std::string path = WriteBytes(dir, "f", 'y');
  auto file = MappedFile::Open(path);
  ASSERT_TRUE(file.ok());
  ASSERT_EQ(truncate(path.c_str(), 0), 0);
  EXPECT_EQ((*file)->bytes()[12345], 0);
  EXPECT_TRUE((*file)->CheckUnchanged().IsIOError());
}

TEST(MappingGuard, AFileWrittenInPlaceIsReported) {
  const TempDir dir;
  const std::string path = WriteBytes(dir, "f", 'a');
  auto file = MappedFile::Open(path);
  ASSERT_TRUE(file.ok());
  LetTheClockMove();
  const int fd = open(path.c_str(), O_WRONLY);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(pwrite(fd, "b", 1, 100), 1);
  close(fd);
  const Status s = (*file)->CheckUnchanged();
  EXPECT_TRUE(s.IsIOError()) << s.ToString();
  EXPECT_NE(s.message().find("written since"), std::string_view::npos) << s.message();
}

TEST(MappingGuard, AFileReplacedByRenameIsNotAChange) {
  // The atomic writers replace a store by renaming a new file over it: the
  // open one keeps reading the file it mapped, whole.
  const TempDir dir;
  const std::string path = WriteBytes(dir, "f", 'a');
  auto file = MappedFile::Open(path);
  ASSERT_TRUE(file.ok());
  WriteBytes(dir, "g", 'b');
  ASSERT_EQ(rename((dir / "g").c_str(), path.c_str()), 0);
  EXPECT_TRUE((*file)->CheckUnchanged().ok());
  EXPECT_EQ((*file)->bytes()[kBytes - 1], 'a');
}

TEST(MappingGuard, ASignalOutsideTheGuardedRangesStillEndsTheProcess) {
  const TempDir dir;
  const std::string guarded = WriteBytes(dir, "guarded", 'g');
  auto file = MappedFile::Open(guarded);  // the handler is installed
  ASSERT_TRUE(file.ok());
  const std::string path = WriteBytes(dir, "plain", 'p');
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int fd = open(path.c_str(), O_RDONLY);
    void* map = mmap(nullptr, kBytes, PROT_READ, MAP_SHARED, fd, 0);
    if (map == MAP_FAILED || truncate(path.c_str(), 0) != 0) _exit(3);
    volatile uint8_t v = static_cast<const uint8_t*>(map)[kBytes / 2];  // not ours: SIGBUS
    (void)v;
    _exit(0);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  if (testing::UnderAddressSanitizer()) {
    // The handler before ours is the sanitizer's: it reports and exits 1.
    ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
    EXPECT_NE(WEXITSTATUS(status), 0);
    EXPECT_NE(WEXITSTATUS(status), 3) << "the child could not set up the mapping";
    return;
  }
  ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << status;
  EXPECT_EQ(WTERMSIG(status), SIGBUS);
}

TEST(MappingGuard, RangesAreTakenAndGivenBack) {
  static uint8_t a[64], b[64];
  MappingGuard* ga = MappingGuard::Register(a, sizeof a);
  MappingGuard* gb = MappingGuard::Register(b, sizeof b);
  ASSERT_NE(ga, nullptr);
  ASSERT_NE(gb, nullptr);
  EXPECT_NE(ga, gb);
  EXPECT_FALSE(MappingGuard::Faulted(ga));
  EXPECT_FALSE(MappingGuard::Faulted(nullptr));
  MappingGuard::Unregister(ga);
  MappingGuard::Unregister(gb);
  EXPECT_EQ(MappingGuard::Register(a, 0), nullptr);
}

}  // namespace
}  // namespace simplexdb
