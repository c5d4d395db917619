// storage/io/file.h: the atomic writer, the temporaries' one naming pattern
// and the removal of stale ones, TemporaryFile; and the XXH3 checksum.
#include "storage/io/file.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "storage/io/checksum.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

std::vector<std::string> Names(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void Touch(const std::string& path) { std::ofstream(path) << "x"; }

// The id of a process that has run and is gone (reaped).
pid_t DeadPid() {
  const pid_t child = fork();
  if (child == 0) _exit(0);
  int status = 0;
  waitpid(child, &status, 0);
  return child;
}

TEST(Temporaries, OnePattern) {
  const std::string pid = std::to_string(getpid());
  EXPECT_EQ(TemporaryPathFor("/a/out.sdb"), "/a/out.sdb.tmp." + pid);
  for (const char* name : {"out.sdb.tmp.17", "out.sdb.tmp.17-lock", "out.sdb.tmp.17.2",
                           "out.sdb.tmp.17.dense", "out.sdb.tmp.17.dense.tmp.17",
                           "out.sdb.tmp.17.field"}) {
    SCOPED_TRACE(name);
    EXPECT_TRUE(IsTemporaryOf(name, "out.sdb"));
  }
  for (const char* name : {"out.sdb", "out.sdb.tmp.", "out.sdb.tmp.x", "out.sdb.tmp.17x",
                           "out.sdb.tmp.0", "out.sdb.tmp-123456", "xout.sdb.tmp.17",
                           "out.sdbx.tmp.17", "other.sdb.tmp.17"}) {
    SCOPED_TRACE(name);
    EXPECT_FALSE(IsTemporaryOf(name, "out.sdb"));
  }
}

TEST(Temporaries, StaleOnesOfDeadProcessesAreRemoved) {
  TempDir dir;
  const std::string out = dir.path() + "/out.sdb";
  const std::string dead = std::to_string(DeadPid());
  const std::string live = std::to_string(getppid());  // runs as long as we do
  for (const std::string& suffix : {dead, dead + "-lock", dead + ".dense",
                                    dead + ".dense.tmp." + dead, dead + ".field", live,
                                    live + "-lock"}) {
    Touch(out + ".tmp." + suffix);
  }
  Touch(dir.path() + "/other.sdb.tmp." + dead);  // another output's
  Touch(out + ".tmp.notapid");                    // not a temporary
  RemoveStaleTemporaries(out);
  EXPECT_EQ(Names(dir.path()),
            (std::vector<std::string>{"other.sdb.tmp." + dead, "out.sdb.tmp." + live,
                                      "out.sdb.tmp." + live + "-lock", "out.sdb.tmp.notapid"}));
}

TEST(AtomicFileWriter, WritesUnderATemporaryAndCommitsIntoPlace) {
  TempDir dir;
  const std::string out = dir.path() + "/out.bin";
  Touch(out + ".tmp." + std::to_string(DeadPid()));  // a killed run's
  auto writer = AtomicFileWriter::Create(out);
  ASSERT_TRUE(writer.ok()) << writer.status().ToString();
  EXPECT_EQ((*writer)->temp_path(), TemporaryPathFor(out));
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"out.bin.tmp." + std::to_string(getpid())});
  ASSERT_TRUE((*writer)->Append(std::string_view("world")).ok());
  const uint64_t at = (*writer)->Reserve(2);
  ASSERT_TRUE((*writer)->WriteAt(at, std::vector<uint8_t>{'!', '\n'}).ok());
  ASSERT_TRUE((*writer)->Commit().ok());
  EXPECT_EQ(ReadAll(out), "world!\n");
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"out.bin"});
}

TEST(AtomicFileWriter, AnAbandonedWriteLeavesTheEarlierFile) {
  TempDir dir;
  const std::string out = dir.path() + "/out.txt";
  ASSERT_TRUE(WriteFileAtomically(out, "old\n").ok());
  {
    auto writer = AtomicFileWriter::Create(out);
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE((*writer)->Append(std::string_view("new, half")).ok());
  }
  EXPECT_EQ(ReadAll(out), "old\n");
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFileWriter, WritersOfOneOutputInOneProcessGetDistinctTemporaries) {
  TempDir dir;
  const std::string out = dir.path() + "/out.txt";
  auto a = AtomicFileWriter::Create(out);
  auto b = AtomicFileWriter::Create(out);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE((*a)->temp_path(), (*b)->temp_path());
  EXPECT_TRUE(IsTemporaryOf(fs::path((*b)->temp_path()).filename().string(), "out.txt"));
  ASSERT_TRUE((*a)->Append(std::string_view("a")).ok());
  ASSERT_TRUE((*b)->Append(std::string_view("b")).ok());
  ASSERT_TRUE((*a)->Commit().ok());
  ASSERT_TRUE((*b)->Commit().ok());
  EXPECT_EQ(ReadAll(out), "b");
  // Threads writing the same output: each file whole, one of them wins.
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      EXPECT_TRUE(WriteFileAtomically(out, std::string(1000, static_cast<char>('0' + t))).ok());
    });
  }
  for (auto& t : threads) t.join();
  const std::string text = ReadAll(out);
  ASSERT_EQ(text.size(), 1000u);
  EXPECT_EQ(text, std::string(1000, text[0]));
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFileWriter, AMissingFolderIsReportedByTheOutputsName) {
  TempDir dir;
  const std::string out = dir.path() + "/no/such/folder/out.sdb";
  const auto writer = AtomicFileWriter::Create(out);
  ASSERT_TRUE(writer.status().IsNotFound()) << writer.status().ToString();
  EXPECT_EQ(writer.status().message(), out + ": cannot create: No such file or directory");
  Touch(dir.path() + "/file");
  const std::string under_file = dir.path() + "/file/out.sdb";
  const Status s = WriteFileAtomically(under_file, "x");
  ASSERT_TRUE(s.IsNotFound()) << s.ToString();
  EXPECT_EQ(s.message(), under_file + ": cannot create: Not a directory");
  EXPECT_TRUE(PrepareOutput(out).IsNotFound());
  EXPECT_TRUE(PrepareOutput(dir.path() + "/fine.sdb").ok());
}

TEST(TemporaryFile, CommitsOrRemovesItselfAndLmdbsLock) {
  TempDir dir;
  const std::string out = dir.path() + "/s.lmdb";
  {
    TemporaryFile temp(out);
    EXPECT_EQ(temp.path(), TemporaryPathFor(out));
    Touch(temp.path());
    Touch(temp.path() + "-lock");
    ASSERT_TRUE(temp.Commit().ok());
  }
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"s.lmdb"});
  {
    TemporaryFile scratch(out, "dense");
    EXPECT_EQ(scratch.path(), TemporaryPathFor(out) + ".dense");
    Touch(scratch.path());
    TemporaryFile temp(out);
    Touch(temp.path());
    Touch(temp.path() + "-lock");
  }  // neither committed
  EXPECT_EQ(Names(dir.path()), std::vector<std::string>{"s.lmdb"});
}

TEST(WritableScratchMapping, HoldsWhatIsWrittenUntilItGoesAway) {
  TempDir dir;
  const std::string path = dir.path() + "/scratch";
  {
    auto scratch = WritableScratchMapping::Create(path, 3000);
    ASSERT_TRUE(scratch.ok()) << scratch.status().ToString();
    std::byte* data = (*scratch)->data();
    for (int i = 0; i < 3000; ++i) data[i] = static_cast<std::byte>(i % 251);
    ASSERT_TRUE((*scratch)->Flush().ok());
    std::ifstream in(path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_EQ(bytes.size(), 3000u);
    for (int i = 0; i < 3000; ++i) ASSERT_EQ(static_cast<unsigned char>(bytes[i]), i % 251) << i;
  }
  EXPECT_FALSE(fs::exists(path));
  const auto missing = WritableScratchMapping::Create(dir.path() + "/no/scratch", 10);
  ASSERT_FALSE(missing.ok());
  EXPECT_TRUE(missing.status().IsNotFound()) << missing.status().ToString();
  EXPECT_NE(missing.status().message().find(dir.path() + "/no/scratch"), std::string::npos);
}

TEST(Checksum, IsXxh3) {
  // XXH3-64 of nothing, and of "a" (xxHash's own test values).
  EXPECT_EQ(Checksum({}), 0x2D06800538D394C2ull);
  const uint8_t a[] = {'a'};
  EXPECT_EQ(Checksum(a), Checksum(a, 0));
  EXPECT_NE(Checksum(a), Checksum(a, 1));
  EXPECT_NE(Checksum(a, 1), Checksum(a, 2));
}

}  // namespace
}  // namespace simplexdb
