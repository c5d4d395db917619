// storage/io/file.h: the atomic writer, the temporaries' one naming pattern
// and the removal of stale ones, TemporaryFile; and the XXH3 checksum.
#include "storage/io/file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
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
using testing::SortedNames;
using testing::TempDir;

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
  EXPECT_EQ(SortedNames(dir.path()),
            (std::vector<std::string>{"other.sdb.tmp." + dead, "out.sdb.tmp." + live,
                                      "out.sdb.tmp." + live + "-lock", "out.sdb.tmp.notapid"}));
}

// A process that exited and was not reaped (a zombie: an MPI rank whose
// mpirun returned first, under a PID 1 that does not reap) holds no file:
// its temporaries are stale although kill(pid, 0) still finds it.
TEST(Temporaries, ThoseOfAZombieAreStale) {
  TempDir dir;
  const std::string out = dir.path() + "/out.sdb";
  const pid_t zombie = fork();
  if (zombie == 0) _exit(0);
  siginfo_t info{};
  ASSERT_EQ(waitid(P_PID, static_cast<id_t>(zombie), &info, WEXITED | WNOWAIT), 0);  // exited, kept
  ASSERT_EQ(kill(zombie, 0), 0);
  Touch(out + ".tmp." + std::to_string(zombie));
  RemoveStaleTemporaries(out);
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{});
  int status = 0;
  waitpid(zombie, &status, 0);
}

TEST(AtomicFileWriter, WritesUnderATemporaryAndCommitsIntoPlace) {
  TempDir dir;
  const std::string out = dir.path() + "/out.bin";
  Touch(out + ".tmp." + std::to_string(DeadPid()));  // a killed run's
  auto writer = AtomicFileWriter::Create(out);
  ASSERT_TRUE(writer.ok()) << writer.status().ToString();
  EXPECT_EQ((*writer)->temp_path(), TemporaryPathFor(out));
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"out.bin.tmp." + std::to_string(getpid())});
  ASSERT_TRUE((*writer)->Append(std::string_view("world")).ok());
  const uint64_t at = (*writer)->Reserve(2);
  ASSERT_TRUE((*writer)->WriteAt(at, std::vector<uint8_t>{'!', '\n'}).ok());
  ASSERT_TRUE((*writer)->Commit().ok());
  EXPECT_EQ(ReadAll(out), "world!\n");
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"out.bin"});
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
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"out.txt"});
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
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"out.txt"});
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

// Replacing anything but a regular file by the output destroys it: a device
// (`-o /dev/full` as root replaced the device), a FIFO, a socket, a folder,
// a symlink (the link would become a file). PrepareOutput, and so every
// writer, refuses them before it creates or removes anything.
TEST(PrepareOutput, RefusesWhatIsNotARegularFile) {
  TempDir dir;
  const std::string d = dir.path();
  ASSERT_EQ(mkfifo((d + "/fifo").c_str(), 0644), 0);
  Touch(d + "/target");
  fs::create_symlink("target", d + "/link");
  fs::create_symlink("nowhere", d + "/dangling");
  fs::create_directory(d + "/folder");
  const int sock = socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string sock_path = d + "/sock";
  ASSERT_LT(sock_path.size(), sizeof(addr.sun_path));
  std::copy(sock_path.begin(), sock_path.end(), addr.sun_path);
  ASSERT_EQ(bind(sock, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)), 0);
  const std::vector<std::string> before = SortedNames(d);
  const struct {
    std::string path, words;
  } cases[] = {
      {d + "/fifo", "is a FIFO"},
      {d + "/sock", "is a socket"},
      {d + "/folder", "is a directory"},
      {d + "/link", "is a symlink"},
      {d + "/dangling", "is a dangling symlink"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.path);
    const Status s = PrepareOutput(c.path);
    ASSERT_TRUE(s.IsInvalidArgument()) << s.ToString();
    EXPECT_EQ(s.message().substr(0, c.path.size() + 16 + c.words.size()),
              c.path + ": cannot write: " + c.words);
    const auto writer = AtomicFileWriter::Create(c.path);
    EXPECT_TRUE(writer.status().IsInvalidArgument()) << writer.status().ToString();
    EXPECT_TRUE(WriteFileAtomically(c.path, "y").IsInvalidArgument());
  }
  close(sock);
  EXPECT_EQ(SortedNames(d), before);  // no temporary, nothing replaced
  EXPECT_TRUE(fs::is_fifo(d + "/fifo"));
  EXPECT_TRUE(fs::is_symlink(d + "/link"));
  EXPECT_EQ(ReadAll(d + "/target"), "x");
}

// A character device, checked on /dev/null: the refusal comes before any
// temporary, and no writer here is ever committed, so even a broken check
// would leave the device as it is (CI runs as root).
TEST(PrepareOutput, RefusesACharacterDevice) {
  const Status s = PrepareOutput("/dev/null");
  ASSERT_TRUE(s.IsInvalidArgument()) << s.ToString();
  EXPECT_EQ(s.message(), "/dev/null: cannot write: is a character device");
  const auto writer = AtomicFileWriter::Create("/dev/null");
  EXPECT_TRUE(writer.status().IsInvalidArgument()) << writer.status().ToString();
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

TEST(ResolveOutput, RefusesAnInputByAnyName) {
  TempDir dir;
  const std::string d = dir.path();
  Touch(d + "/in");
  ASSERT_EQ(link((d + "/in").c_str(), (d + "/hard").c_str()), 0);
  fs::create_symlink("in", d + "/soft");
  OutputOptions options;
  options.inputs = {d + "/other", d + "/in"};  // a missing input is not compared
  for (const std::string& out : {d + "/in", d + "/./in", d + "/hard", d + "/soft"}) {
    SCOPED_TRACE(out);
    const Result<std::string> r = ResolveOutput(out, options);
    ASSERT_TRUE(r.status().IsInvalidArgument()) << r.status().ToString();
    EXPECT_NE(r.status().message().find(out + ": cannot write: is the input"), std::string::npos)
        << r.status().ToString();
    options.force = true;  // through a symlink too
    EXPECT_TRUE(ResolveOutput(out, options).status().IsInvalidArgument());
    options.force = false;
  }
  // A time series: any of its files.
  options.inputs = {d + "/t0", d + "/t1", d + "/in"};
  Touch(d + "/t0");
  Touch(d + "/t1");
  EXPECT_TRUE(ResolveOutput(d + "/t1", options).status().IsInvalidArgument());
  const Result<std::string> fresh = ResolveOutput(d + "/new", options);
  ASSERT_TRUE(fresh.ok()) << fresh.status().ToString();
  EXPECT_EQ(*fresh, d + "/new");
  EXPECT_EQ(ReadAll(d + "/in"), "x");
}

TEST(ResolveOutput, ForceWritesThroughASymlinkToAFileAndKeepsTheLink) {
  TempDir dir;
  const std::string d = dir.path();
  fs::create_directory(d + "/real");
  Touch(d + "/real/target");
  fs::create_symlink("real/target", d + "/link");
  fs::create_symlink("real/none", d + "/dangling");
  fs::create_symlink("real", d + "/to_folder");
  OutputOptions options;
  EXPECT_TRUE(ResolveOutput(d + "/link", options).status().IsInvalidArgument());
  options.force = true;
  const Result<std::string> target = ResolveOutput(d + "/link", options);
  ASSERT_TRUE(target.ok()) << target.status().ToString();
  EXPECT_TRUE(fs::equivalent(*target, d + "/real/target"));
  ASSERT_TRUE(WriteFileAtomically(*target, "new contents").ok());
  EXPECT_TRUE(fs::is_symlink(d + "/link"));
  EXPECT_EQ(fs::read_symlink(d + "/link"), "real/target");
  EXPECT_EQ(ReadAll(d + "/link"), "new contents");
  EXPECT_EQ(SortedNames(d + "/real"), std::vector<std::string>{"target"});  // no temporary left
  // Never through a dangling symlink or one to something not a file.
  const Result<std::string> dangling = ResolveOutput(d + "/dangling", options);
  ASSERT_TRUE(dangling.status().IsInvalidArgument());
  EXPECT_NE(dangling.status().message().find("dangling symlink"), std::string::npos);
  const Result<std::string> folder = ResolveOutput(d + "/to_folder", options);
  ASSERT_TRUE(folder.status().IsInvalidArgument());
  EXPECT_NE(folder.status().message().find("is a symlink to a directory"), std::string::npos);
  // Without force PrepareOutput still refuses the link itself.
  EXPECT_TRUE(PrepareOutput(d + "/link").IsInvalidArgument());
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
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"s.lmdb"});
  {
    TemporaryFile scratch(out, "dense");
    EXPECT_EQ(scratch.path(), TemporaryPathFor(out) + ".dense");
    Touch(scratch.path());
    TemporaryFile temp(out);
    Touch(temp.path());
    Touch(temp.path() + "-lock");
  }  // neither committed
  EXPECT_EQ(SortedNames(dir.path()), std::vector<std::string>{"s.lmdb"});
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
