// The one errno -> Status table (storage/io/file.h): each errno gives the
// documented code and the same words, through StatusFromErrno, through
// LMDB's codes, and through every writer of an output (a dense store, a
// sparse store, a volume, a mesh, a small file written whole) under the real
// condition where a test can make it: ENOENT (a missing output folder),
// ENOTDIR (an output under a regular file) always; ENOSPC (a tiny tmpfs) and
// EROFS (a read-only tmpfs) where mounting is allowed (root). EACCES cannot
// be made as root and EIO not at all: those rows go through the table only.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "query/mesh_io.h"
#include "storage/dense/dense_builder.h"
#include "storage/io/file.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;
using Code = Status::Code;
using testing::TempDir;

struct Row {
  int err;
  Code code;
  const char* words;  // strerror's text
};

// The documented table, for the errnos the issue names.
constexpr Row kTable[] = {
    {EACCES, Code::kIOError, "Permission denied"},
    {ENOENT, Code::kNotFound, "No such file or directory"},
    {ENOTDIR, Code::kNotFound, "Not a directory"},
    {ENOSPC, Code::kResourceExhausted, "No space left on device"},
    {EROFS, Code::kIOError, "Read-only file system"},
    {EIO, Code::kIOError, "Input/output error"},
};

const Row& RowOf(int err) {
  return *std::find_if(std::begin(kTable), std::end(kTable),
                       [&](const Row& r) { return r.err == err; });
}

TEST(ErrnoTable, EachErrnoGivesItsCodeAndWords) {
  for (const Row& row : kTable) {
    SCOPED_TRACE(row.words);
    const Status s = StatusFromErrno(row.err, "/no/such/dir/out.sdb", "write");
    EXPECT_EQ(s.code(), row.code) << s.ToString();
    EXPECT_EQ(s.message(), std::string("/no/such/dir/out.sdb: cannot write: ") + row.words);
    // LMDB reports errno values as its codes: the same table, the same words.
    const Status l = lmdb::FromCode(row.err, "/no/such/dir/out.sdb", "write");
    EXPECT_EQ(l.code(), s.code());
    EXPECT_EQ(l.message(), s.message());
  }
  // LMDB's own codes keep the same shape.
  const Status c = lmdb::FromCode(MDB_CORRUPTED, "/d/s.lmdb", "read");
  EXPECT_TRUE(c.IsCorruption());
  EXPECT_EQ(c.message().substr(0, 22), "/d/s.lmdb: cannot read");
}

// Every kind of output, written to `path` by its real writer.
struct Writer {
  const char* kind;
  std::function<Status(const std::string& path)> write;
};

class ErrnoFromWriters : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string nrrd = dir_.path() + "/in.nrrd";
    std::vector<double> values(17 * 17 * 17);
    for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>((i * 7919) % 251);
    ASSERT_TRUE(WriteNrrd(nrrd, 3, {17, 17, 17, 1}, VoxelType::kU8, values).ok());
    auto volume = OpenVolume(nrrd);
    ASSERT_TRUE(volume.ok()) << volume.status().ToString();
    volume_ = *volume;
    // One tetrahedron 2,000 times with random errors: more than 4 KiB of
    // arrays even zlib-compressed (.vtu compresses them).
    mesh_.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    mesh_.field = {0, 1, 2, 3};
    std::mt19937_64 rng(1);
    for (int i = 0; i < 2000; ++i) {
      mesh_.connectivity.insert(mesh_.connectivity.end(), {0, 1, 2, 3});
      mesh_.error.push_back(std::uniform_real_distribution<double>(0, 1)(rng));
      mesh_.level.push_back(0);
      mesh_.code.push_back(SimplexCode<3>::Root(0).key());
    }
    codes_.assign(2000, SimplexCode<3>::Root(0));
    writers_ = {
        {"dense store",
         [&](const std::string& p) { return BuildDenseStore(volume_, p, {}).status(); }},
        {"sparse store",
         [&](const std::string& p) { return BuildSparseStore(volume_, p, {}).status(); }},
        {"volume (NRRD)",
         [&](const std::string& p) {
           return WriteNrrd(p, 3, {17, 17, 17, 1}, VoxelType::kU8, values_());
         }},
        {"mesh (.vtu)", [&](const std::string& p) { return WriteVtu(mesh_, p); }},
        {"mesh (codes)",
         [&](const std::string& p) {
           return WriteCodes<3>(std::span<const SimplexCode<3>>(codes_), p);
         }},
        {"report (JSON, .pvd)",
         [&](const std::string& p) { return WriteFileAtomically(p, std::string(64 << 10, ' ')); }},
    };
  }
  void TearDown() override {
    if (mounted_) umount(mount_.c_str());
  }
  std::vector<double> values_() const { return std::vector<double>(17 * 17 * 17, 3.0); }

  // A tmpfs at dir/name with `flags` and `options`; false where mounting is
  // not allowed.
  bool Mount(const std::string& name, unsigned long flags, const char* options) {
    mount_ = dir_.path() + "/" + name;
    fs::create_directory(mount_);
    mounted_ = mount("tmpfs", mount_.c_str(), "tmpfs", flags, options) == 0;
    return mounted_;
  }

  // Each writer fails to write `out` with the row of `err`: its code, and
  // the words "<out>: cannot <action>: <strerror>" naming the output, never
  // a temporary; and leaves nothing in `folder` (when given).
  void ExpectEveryWriterFails(const std::string& folder, int err) {
    const Row& row = RowOf(err);
    for (const Writer& w : writers_) {
      SCOPED_TRACE(std::string(w.kind) + ", " + row.words);
      const std::string out = (folder.empty() ? dir_.path() + "/nowhere" : folder) + "/out";
      const Status s = w.write(out);
      EXPECT_EQ(s.code(), row.code) << s.ToString();
      const std::string_view m = s.message();
      EXPECT_EQ(m.substr(0, out.size() + 9), out + ": cannot ") << m;
      EXPECT_TRUE(m.ends_with(std::string(": ") + row.words)) << m;
      EXPECT_EQ(m.find(".tmp."), std::string::npos) << m;
      if (!folder.empty() && fs::is_directory(folder)) {
        EXPECT_TRUE(fs::is_empty(folder)) << folder;
      }
    }
  }

  TempDir dir_;
  VolumeInfo volume_;
  TetMeshData mesh_;
  std::vector<SimplexCode<3>> codes_;
  std::vector<Writer> writers_;
  std::string mount_;
  bool mounted_ = false;
};

TEST_F(ErrnoFromWriters, MissingFolderIsENOENT) {
  ExpectEveryWriterFails(dir_.path() + "/no/such/folder", ENOENT);
}

TEST_F(ErrnoFromWriters, FolderThatIsARegularFileIsENOTDIR) {
  std::ofstream(dir_.path() + "/file") << "x";
  ExpectEveryWriterFails(dir_.path() + "/file", ENOTDIR);
}

TEST_F(ErrnoFromWriters, ReadOnlyFileSystemIsEROFS) {
  if (!Mount("ro", MS_RDONLY, "size=64k")) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  ExpectEveryWriterFails(mount_, EROFS);
}

TEST_F(ErrnoFromWriters, FullDiskIsENOSPC) {
  // Room for the files, not for their contents (every output here is more
  // than 4 KiB).
  if (!Mount("full", 0, "size=4k")) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  ExpectEveryWriterFails(mount_, ENOSPC);
}

}  // namespace
}  // namespace simplexdb
