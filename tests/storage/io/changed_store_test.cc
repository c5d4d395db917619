// A store changed under an open reader (issue 46): truncated to a part, cut
// to nothing, written in place, or truncated while a query runs. Dense and
// sparse, out of core and in memory: the operation fails with IOError (or
// Corruption for a sparse store written by something other than LMDB)
// naming the file, and the process lives. A store replaced by renaming a
// new file over it is read whole from the file that was opened.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "query/open_store.h"
#include "query/refine.h"
#include "storage/dense/dense_builder.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// A depth-first query at `fraction` of the range over every source.
Status Query(const AnyStore& store, double fraction, uint64_t* leaves = nullptr) {
  return store.Visit([&]<int D, class Source>(Source& source) -> Status {
    Criteria<D> c;
    c.threshold = (source.info().field_max - source.info().field_min) * fraction;
    Refiner<D, Source> refiner(source, c);
    Mesh<D> mesh;
    QueryStats stats;
    SDB_RETURN_IF_ERROR(refiner.Run({Algorithm::kDepthFirst}, mesh, stats));
    if (leaves != nullptr) *leaves = stats.simplices;
    return Status::OK();
  });
}

struct Stores {
  std::string dense, sparse;
};

Stores Build(const TempDir& dir, const std::string& name, std::array<uint32_t, 4> dims) {
  const TestVolume v = TestVolume::Random(3, dims, VoxelType::kU8, 7);
  const std::string nrrd = dir / (name + ".nrrd");
  EXPECT_TRUE(v.WriteNrrd(nrrd).ok());
  Stores s{dir / (name + ".sdb"), dir / (name + ".lmdb")};
  EXPECT_TRUE(BuildDenseStore(*OpenVolume(nrrd), s.dense, DenseBuildOptions{}).ok());
  EXPECT_TRUE(BuildSparseStore(*OpenVolume(nrrd), s.sparse, SparseBuildOptions{}).ok());
  return s;
}

void LetTheClockMove() { std::this_thread::sleep_for(std::chrono::milliseconds(20)); }

void ExpectChangedError(const Status& s, const std::string& path) {
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(s.IsIOError() || s.IsCorruption()) << s.ToString();
  EXPECT_NE(s.message().find(path), std::string_view::npos) << s.message();
}

TEST(ChangedStore, ATruncatedStoreIsRefusedNotASignal) {
  const TempDir dir;
  const Stores s = Build(dir, "v", {40, 37, 33, 1});
  for (const std::string& path : {s.dense, s.sparse}) {
    for (const uint64_t keep_part : {2, 0}) {  // half, nothing
      for (const bool in_memory : {false, true}) {
        if (in_memory && path == s.sparse) continue;
        SCOPED_TRACE(path + (keep_part ? " half" : " empty") + (in_memory ? " in memory" : ""));
        const std::string copy = dir / "copy";
        std::filesystem::copy_file(path, copy, std::filesystem::copy_options::overwrite_existing);
        StoreOptions o;
        o.in_memory = in_memory;
        o.cache_bytes = size_t{1} << 20;
        auto store = AnyStore::Open(copy, o);
        ASSERT_TRUE(store.ok()) << store.status().ToString();
        ASSERT_TRUE(Query(*store, 0.05).ok());
        const uint64_t size = std::filesystem::file_size(copy);
        ASSERT_EQ(truncate(copy.c_str(), keep_part ? static_cast<off_t>(size / keep_part) : 0), 0);
        const Status after = Query(*store, 0.01);
        ExpectChangedError(after, copy);
        EXPECT_TRUE(after.IsIOError()) << after.ToString();
        EXPECT_NE(after.message().find("open it again"), std::string_view::npos) << after.message();
      }
    }
  }
}

TEST(ChangedStore, AStoreWrittenInPlaceIsRefused) {
  const TempDir dir;
  const Stores s = Build(dir, "v", {40, 37, 33, 1});
  for (const std::string& path : {s.dense, s.sparse}) {
    SCOPED_TRACE(path);
    auto store = AnyStore::Open(path);
    ASSERT_TRUE(store.ok());
    ASSERT_TRUE(Query(*store, 0.05).ok());
    LetTheClockMove();
    // Bytes in the middle overwritten at the same size (for the sparse
    // store: not by LMDB, so its pages are checked again and found damaged).
    const int fd = open(path.c_str(), O_WRONLY);
    ASSERT_GE(fd, 0);
    const std::vector<char> junk(8192, '\x5a');
    const off_t middle = static_cast<off_t>(std::filesystem::file_size(path) / 2) & ~off_t{4095};
    ASSERT_EQ(pwrite(fd, junk.data(), junk.size(), middle), static_cast<ssize_t>(junk.size()));
    close(fd);
    ExpectChangedError(Query(*store, 0.01), path);
  }
}

TEST(ChangedStore, AStoreReplacedByRenameIsReadFromTheFileOpened) {
  const TempDir dir;
  const Stores a = Build(dir, "a", {40, 37, 33, 1});
  const Stores b = Build(dir, "b", {20, 21, 22, 1});
  for (const auto& [path, other] : {std::pair{a.dense, b.dense}, std::pair{a.sparse, b.sparse}}) {
    SCOPED_TRACE(path);
    auto store = AnyStore::Open(path);
    ASSERT_TRUE(store.ok());
    uint64_t before = 0, after = 0;
    ASSERT_TRUE(Query(*store, 0.01, &before).ok());
    const std::string fresh = path + ".new";
    std::filesystem::copy_file(other, fresh);
    ASSERT_EQ(rename(fresh.c_str(), path.c_str()), 0);
    const Status s = Query(*store, 0.01, &after);
    ASSERT_TRUE(s.ok()) << s.ToString();
    EXPECT_EQ(after, before);
  }
}

// Truncated while a query runs, at several moments: the query fails (the
// guard turns the faults into zeros, the checks after it refuse the
// answer) and the process lives.
TEST(ChangedStore, ATruncationDuringAQueryIsRefused) {
  const TempDir dir;
  const Stores s = Build(dir, "v", {97, 90, 95, 1});
  for (const std::string& path : {s.dense, s.sparse}) {
    for (const int delay_ms : {0, 5, 20}) {
      SCOPED_TRACE(path + " after " + std::to_string(delay_ms) + " ms");
      const std::string copy = dir / "copy";
      std::filesystem::copy_file(path, copy, std::filesystem::copy_options::overwrite_existing);
      StoreOptions o;
      o.cache_bytes = size_t{1} << 20;
      auto store = AnyStore::Open(copy, o);
      ASSERT_TRUE(store.ok());
      std::thread cut([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
        EXPECT_EQ(truncate(copy.c_str(), 4096), 0);
      });
      const Status q = Query(*store, 0.002);
      cut.join();
      ExpectChangedError(q.ok() ? store->CheckUnchanged() : q, copy);
    }
  }
}

}  // namespace
}  // namespace simplexdb
