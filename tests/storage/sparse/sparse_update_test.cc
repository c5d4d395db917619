// Updating a box of a sparse store of format 2 while another process reads
// it: every snapshot a reader takes is the whole old store or the whole new
// one (every entry, the header included, compared with the store before and
// with a copy updated alone), never a mix, and a snapshot held from before
// keeps reading the old store. (Updates against a fresh import:
// tests/tools/sparse_cli_test.cc.)
#include <gtest/gtest.h>
#include <lmdb.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_update.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// Every entry (blocks' parts and the header), by key.
using Snapshot = std::map<std::vector<uint8_t>, std::vector<uint8_t>>;

Snapshot Read(lmdb::Txn& txn) {
  Snapshot out;
  const MDB_dbi dbi = *txn.OpenDb(nullptr, false);
  auto cursor = *lmdb::Cursor::Open(txn, dbi);
  MDB_val k, v;
  for (int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST); rc == MDB_SUCCESS;
       rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    const auto* kb = static_cast<const uint8_t*>(k.mv_data);
    const auto* vb = static_cast<const uint8_t*>(v.mv_data);
    out[std::vector<uint8_t>(kb, kb + k.mv_size)] = std::vector<uint8_t>(vb, vb + v.mv_size);
  }
  return out;
}

Snapshot ReadPath(const std::string& path) {
  auto env = *lmdb::Env::Open(path, {});
  auto txn = *lmdb::Txn::Begin(*env, /*read_only=*/true);
  return Read(txn);
}

TEST(SparseUpdate, ReadersSeeTheOldStoreOrTheNewOneNeverAMix) {
  const TempDir dir;
  // Noise whose middle becomes flat: blocks change, some vanish.
  TestVolume before = TestVolume::Random(3, {20, 18, 22, 1}, VoxelType::kU8, 31);
  before.values.front() = 0;  // the range, and with it the quantum, stays
  before.values.back() = 255;
  TestVolume after = before;
  GridBox box;
  box.lo = {4, 3, 5, 0};
  box.hi = {15, 14, 16, 0};
  for (int64_t z = box.lo[2]; z <= box.hi[2]; ++z) {
    for (int64_t y = box.lo[1]; y <= box.hi[1]; ++y) {
      for (int64_t x = box.lo[0]; x <= box.hi[0]; ++x) after.values[static_cast<size_t>((z * 18 + y) * 20 + x)] = 90;
    }
  }
  ASSERT_TRUE(before.WriteNrrd(dir / "before.nrrd").ok());
  ASSERT_TRUE(after.WriteNrrd(dir / "after.nrrd").ok());
  SparseBuildOptions o;
  o.block_bits = 8;  // many blocks
  const std::string store = dir / "store.sdb";
  ASSERT_TRUE(BuildSparseStore(*OpenVolume(dir / "before.nrrd"), store, o).ok());
  // The outcome, from an update of a copy.
  const std::string copy = dir / "copy.sdb";
  std::filesystem::copy_file(store, copy);
  const auto alone = UpdateSparseStore(copy, *OpenVolume(dir / "after.nrrd"), box);
  ASSERT_TRUE(alone.ok()) << alone.status().ToString();
  ASSERT_GT(alone->blocks_written + alone->blocks_deleted, 0u);
  const Snapshot old_store = ReadPath(store), new_store = ReadPath(copy);
  ASSERT_NE(old_store, new_store);

  auto env = *lmdb::Env::Open(store, {});
  auto held = *lmdb::Txn::Begin(*env, /*read_only=*/true);  // a snapshot kept throughout
  // Another process updates the store while this one reads snapshots.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const auto r = UpdateSparseStore(store, *OpenVolume(dir / "after.nrrd"), box);
    _exit(r.ok() ? 0 : 1);
  }
  int snapshots = 0, old_seen = 0, new_seen = 0, status = 0;
  while (true) {
    const bool done = waitpid(child, &status, WNOHANG) == child;
    auto txn = *lmdb::Txn::Begin(*env, /*read_only=*/true);
    const Snapshot s = Read(txn);
    txn.Abort();
    const bool is_old = s == old_store, is_new = s == new_store;
    ASSERT_TRUE(is_old || is_new) << "snapshot " << snapshots << " mixes the old store and the new one";
    ++snapshots;
    (is_old ? old_seen : new_seen)++;
    if (done) break;
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_GT(new_seen, 0) << "the last snapshot, after the update, must be the new store";
  EXPECT_EQ(Read(held), old_store) << "a snapshot held from before must keep the old store";
  RecordProperty("snapshots", snapshots);
  RecordProperty("old_seen", old_seen);
}

}  // namespace
}  // namespace simplexdb
