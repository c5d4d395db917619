// The LMDB file check (storage/io/lmdb_check.h) through lmdb::Env::Open:
// damage that LMDB would crash on is reported as Corruption, and no damage
// at all crashes a reader.
//
// The test file is written by LMDB itself (three named databases, keys as
// the stores write them, small values, values on overflow pages, entries
// deleted so the free database holds pages, two meta pages in use). Pages
// are classified by reading their headers here, from LMDB's documented
// layout, not by the code under test.
//
// DamageNeverCrashesAReader: random bit flips, byte and word overwrites
// and truncations, spread over meta, branch, leaf and overflow pages; each
// case opens the damaged copy in a child process that reads every entry
// of every database. Passes when no child dies of a signal, hangs or fails
// a sanitizer check. The count is SIMPLEXDB_DAMAGE_CASES (default 400; the
// `long`-labelled LmdbDamageLong runs 4000).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "storage/io/lmdb.h"
#include "storage/io/lmdb_check.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;

constexpr const char* kDbs[] = {"errors", "field", "meta"};

std::vector<uint8_t> ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}
void WriteAll(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}
template <class T>
T Load(const std::vector<uint8_t>& b, size_t at) {
  T v;
  std::memcpy(&v, b.data() + at, sizeof v);
  return v;
}
template <class T>
void Store(std::vector<uint8_t>& b, size_t at, T v) {
  std::memcpy(b.data() + at, &v, sizeof v);
}

// Writes the test file: database 0 holds 6000 8-byte keys with 2-byte
// values (a tree of depth 2 or more), database 1 200 keys with values of
// 5 to 40 KiB (overflow runs), database 2 one small entry; then a second
// transaction deletes every third key of database 0 and a quarter of
// database 1 (pages to the free database) and rewrites one value.
void WriteTestFile(const std::string& path) {
  lmdb::Env::Options o;
  o.read_only = false;
  o.map_bytes = uint64_t{64} << 20;
  auto env = *lmdb::Env::Open(path, o);
  std::mt19937_64 rng(7);
  {
    auto txn = *lmdb::Txn::Begin(*env, false);
    MDB_dbi db[3];
    for (int i = 0; i < 3; ++i) db[i] = *txn.OpenDb(kDbs[i], true);
    for (uint64_t k = 0; k < 6000; ++k) {
      const uint16_t v = static_cast<uint16_t>(rng());
      ASSERT_TRUE(txn.Put(db[0], lmdb::KeyBytes(k * 977), {reinterpret_cast<const uint8_t*>(&v), 2}).ok());
    }
    for (uint64_t k = 0; k < 200; ++k) {
      std::vector<uint8_t> v(5000 + rng() % 36000);
      for (auto& b : v) b = static_cast<uint8_t>(rng());
      ASSERT_TRUE(txn.Put(db[1], lmdb::KeyBytes(k), v).ok());
    }
    const std::string header = "{\"format\":\"test\"}";
    ASSERT_TRUE(txn.Put(db[2], {reinterpret_cast<const uint8_t*>("header"), 6},
                        {reinterpret_cast<const uint8_t*>(header.data()), header.size()})
                    .ok());
    ASSERT_TRUE(txn.Commit().ok());
  }
  {
    auto txn = *lmdb::Txn::Begin(*env, false);
    MDB_dbi db0 = *txn.OpenDb(kDbs[0], false), db1 = *txn.OpenDb(kDbs[1], false);
    for (uint64_t k = 0; k < 6000; k += 3) {
      auto key = lmdb::KeyBytes(k * 977);
      MDB_val kv = lmdb::Val(key.data(), key.size());
      ASSERT_EQ(mdb_del(txn.get(), db0, &kv, nullptr), MDB_SUCCESS);
    }
    for (uint64_t k = 0; k < 200; k += 4) {
      auto key = lmdb::KeyBytes(k);
      MDB_val kv = lmdb::Val(key.data(), key.size());
      ASSERT_EQ(mdb_del(txn.get(), db1, &kv, nullptr), MDB_SUCCESS);
    }
    std::vector<uint8_t> v(9000, 0x5a);
    ASSERT_TRUE(txn.Put(db1, lmdb::KeyBytes(1), v).ok());
    ASSERT_TRUE(txn.Commit().ok());
  }
  ASSERT_TRUE(env->Sync().ok());
}

// Every entry of every database, read through LMDB: what a reader sees.
std::map<std::string, std::string> ReadEverything(const std::string& path, Status* status) {
  std::map<std::string, std::string> out;
  auto env = lmdb::Env::Open(path, lmdb::Env::Options{});
  if (!env.ok()) {
    *status = env.status();
    return out;
  }
  auto txn = lmdb::Txn::Begin(**env, true);
  if (!txn.ok()) {
    *status = txn.status();
    return out;
  }
  for (int i = 0; i < 3; ++i) {
    auto db = txn->OpenDb(kDbs[i], false);
    if (!db.ok()) {
      *status = db.status();
      return out;
    }
    auto cursor = lmdb::Cursor::Open(*txn, *db);
    if (!cursor.ok()) {
      *status = cursor.status();
      return out;
    }
    MDB_val k, v;
    int rc = mdb_cursor_get(cursor->get(), &k, &v, MDB_FIRST);
    while (rc == MDB_SUCCESS) {
      std::string key(static_cast<const char*>(k.mv_data), k.mv_size);
      out[std::string(kDbs[i]) + "/" + key] = std::string(static_cast<const char*>(v.mv_data), v.mv_size);
      bool found = false;
      auto again = txn->Get(*db, {static_cast<const uint8_t*>(k.mv_data), k.mv_size}, &found);
      if (!again.ok()) {
        *status = again.status();
        return out;
      }
      rc = mdb_cursor_get(cursor->get(), &k, &v, MDB_NEXT);
    }
    if (rc != MDB_NOTFOUND) {
      *status = (*env)->FromCode(rc, "read");
      return out;
    }
  }
  *status = Status::OK();
  return out;
}

// The pages of the file by kind, from their headers.
struct Pages {
  uint32_t size = 0;
  std::vector<uint64_t> meta, branch, leaf, overflow;
};
Pages Classify(const std::vector<uint8_t>& file) {
  Pages p;
  p.size = Load<uint32_t>(file, 40);
  for (uint64_t pg = 0; (pg + 1) * p.size <= file.size();) {
    const size_t at = pg * p.size;
    const uint16_t flags = Load<uint16_t>(file, at + 10) & ~0x10;
    uint64_t step = 1;
    if (Load<uint64_t>(file, at) == pg) {
      if (flags == 0x08) p.meta.push_back(pg);
      if (flags == 0x01) p.branch.push_back(pg);
      if (flags == 0x02) p.leaf.push_back(pg);
      if (flags == 0x04) {
        p.overflow.push_back(pg);
        step = std::max<uint64_t>(1, Load<uint32_t>(file, at + 12));
      }
    }
    pg += step;
  }
  return p;
}

class LmdbCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = dir_.path() + "/good.lmdb";
    WriteTestFile(path_);
    good_ = ReadAll(path_);
    pages_ = Classify(good_);
    Status s;
    everything_ = ReadEverything(path_, &s);
    ASSERT_TRUE(s.ok()) << s.ToString();
  }
  // Writes `bytes` as a fresh file (no lock file) and opens it.
  Status OpenDamaged(const std::vector<uint8_t>& bytes) {
    const std::string p = dir_.path() + "/damaged" + std::to_string(++cases_) + ".lmdb";
    WriteAll(p, bytes);
    Status s;
    ReadEverything(p, &s);
    return s;
  }
  void ExpectCorruption(const std::vector<uint8_t>& bytes, const std::string& says) {
    SCOPED_TRACE(says);
    const Status s = OpenDamaged(bytes);
    EXPECT_EQ(s.code(), Status::Code::kCorruption) << s.ToString();
    const std::string file = "damaged" + std::to_string(cases_) + ".lmdb";
    EXPECT_NE(s.ToString().find(file), std::string::npos) << s.ToString();
    EXPECT_NE(s.ToString().find(says), std::string::npos) << s.ToString();
  }
  size_t At(uint64_t pg, size_t offset = 0) const { return pg * pages_.size + offset; }
  // Live pages, found by descending from the live meta (a file holds stale
  // copies of pages too): the root of named database `name` (a record in
  // the main database's root, a leaf here) and a branch's first child.
  uint64_t LiveRoot(const std::string& name) const {
    const uint64_t main = Load<uint64_t>(good_, LiveMeta() + 88 + 40);
    const uint32_t n = (Load<uint16_t>(good_, At(main, 12)) - 16) / 2;
    for (uint32_t i = 0; i < n; ++i) {
      const uint16_t node = Load<uint16_t>(good_, At(main, 16 + 2 * i));
      const uint16_t ksize = Load<uint16_t>(good_, At(main, node + 6));
      if (std::string(reinterpret_cast<const char*>(good_.data() + At(main, node + 8)), ksize) == name) {
        return Load<uint64_t>(good_, At(main, node + 8 + ksize + 40));
      }
    }
    ADD_FAILURE() << "no database " << name;
    return 0;
  }
  uint64_t FirstChild(uint64_t branch) const {
    const uint16_t node = Load<uint16_t>(good_, At(branch, 16));
    return Load<uint16_t>(good_, At(branch, node)) |
           uint64_t{Load<uint16_t>(good_, At(branch, node + 2))} << 16;
  }
  // The meta LMDB reads: the one with the larger transaction id.
  size_t LiveMeta() const {
    return Load<uint64_t>(good_, At(1, 144)) > Load<uint64_t>(good_, At(0, 144)) ? At(1) : At(0);
  }

  testing::TempDir dir_;
  std::string path_;
  std::vector<uint8_t> good_;
  Pages pages_;
  std::map<std::string, std::string> everything_;
  int cases_ = 0;
};

TEST_F(LmdbCheck, TheTestFileHasEveryKindOfPage) {
  EXPECT_EQ(pages_.size, 4096u);
  EXPECT_EQ(pages_.meta.size(), 2u);
  EXPECT_GE(pages_.branch.size(), 2u);
  EXPECT_GE(pages_.leaf.size(), 20u);
  EXPECT_GE(pages_.overflow.size(), 100u);
  EXPECT_EQ(everything_.size(), 4000u + 150u + 1u);
  EXPECT_NE(Load<uint64_t>(good_, At(0, 144)), Load<uint64_t>(good_, At(1, 144)));
  // The free database holds pages (its root is a page).
  EXPECT_NE(Load<uint64_t>(good_, LiveMeta() + 40 + 40), ~uint64_t{0});
}

TEST_F(LmdbCheck, MetaDamageIsReported) {
  auto b = good_;
  Store<uint32_t>(b, 40, 0);  // meta 0's page size: LMDB divides by it
  ExpectCorruption(b, "page size 0");
  b = good_;
  Store<uint32_t>(b, LiveMeta() + 40, 4096 + 512);
  ExpectCorruption(b, "page size");
  for (const uint64_t root : {uint64_t{0}, uint64_t{1}, uint64_t{1} << 40}) {
    b = good_;
    Store<uint64_t>(b, LiveMeta() + 88 + 40, root);  // main database root: LMDB asserts on 0 and 1
    ExpectCorruption(b, "root page " + std::to_string(root));
  }
  b = good_;
  Store<uint64_t>(b, LiveMeta() + 136, uint64_t{1} << 50);  // last page
  ExpectCorruption(b, "truncated");
  b = good_;
  Store<uint16_t>(b, LiveMeta() + 88 + 6, 40);  // main depth
  ExpectCorruption(b, "depth 40");
  b = good_;
  Store<uint16_t>(b, LiveMeta() + 10, 0x02);  // not a meta page
  ExpectCorruption(b, "meta page");
  // Not LMDB at all, or another data version.
  b = good_;
  Store<uint32_t>(b, 16, 0x12345678);
  EXPECT_EQ(OpenDamaged(b).code(), Status::Code::kInvalidArgument);
  b = good_;
  Store<uint32_t>(b, 20, 2);
  EXPECT_EQ(OpenDamaged(b).code(), Status::Code::kNotSupported);
}

TEST_F(LmdbCheck, TruncationIsReported) {
  auto b = good_;
  b.resize(b.size() - pages_.size);
  ExpectCorruption(b, "truncated");
  b = good_;
  b.resize(pages_.size + 100);
  ExpectCorruption(b, "meta page 1");
  b.resize(100);
  EXPECT_EQ(OpenDamaged(b).code(), Status::Code::kInvalidArgument);
}

TEST_F(LmdbCheck, PageDamageIsReported) {
  const uint64_t branch = LiveRoot("errors"), leaf = FirstChild(branch);
  ASSERT_EQ(Load<uint16_t>(good_, At(branch, 10)), 0x01);
  ASSERT_EQ(Load<uint16_t>(good_, At(leaf, 10)), 0x02);
  ASSERT_GE((Load<uint16_t>(good_, At(leaf, 12)) - 16) / 2, 10);
  auto b = good_;
  Store<uint64_t>(b, At(leaf), leaf + 1);  // the header's page number
  ExpectCorruption(b, "its header says page");
  b = good_;
  Store<uint16_t>(b, At(leaf, 12), static_cast<uint16_t>(pages_.size + 2));  // lower bound past the page
  ExpectCorruption(b, "bounds");
  b = good_;
  Store<uint16_t>(b, At(leaf, 16), static_cast<uint16_t>(pages_.size - 4));  // node 0 at the page's end
  ExpectCorruption(b, "node 0 at offset");
  b = good_;
  const uint16_t node = Load<uint16_t>(b, At(leaf, 16));
  Store<uint16_t>(b, At(leaf, node + 6), 60000);  // key size
  ExpectCorruption(b, "its key runs past the page");
  b = good_;
  Store<uint16_t>(b, At(branch, 10), 0x02);  // a branch marked as a leaf
  ExpectCorruption(b, "flags 2");
  b = good_;
  // A branch's second child pointing at its first: a page reached twice.
  const uint16_t n0 = Load<uint16_t>(b, At(branch, 16)), n1 = Load<uint16_t>(b, At(branch, 18));
  std::memcpy(b.data() + At(branch, n1), b.data() + At(branch, n0), 4);
  Store<uint16_t>(b, At(branch, n1 + 4), Load<uint16_t>(b, At(branch, n0 + 4)));
  ExpectCorruption(b, "which something else points to too");
  b = good_;
  // Two keys of a leaf swapped: out of order.
  const uint16_t k0 = Load<uint16_t>(b, At(leaf, 16)), k1 = Load<uint16_t>(b, At(leaf, 18));
  Store<uint16_t>(b, At(leaf, 16), k1);
  Store<uint16_t>(b, At(leaf, 18), k0);
  ExpectCorruption(b, "keys out of order");
}

TEST_F(LmdbCheck, OverflowAndCountDamageIsReported) {
  const auto key = lmdb::KeyBytes(2);
  const std::string& value = everything_.at("field/" + std::string(key.begin(), key.end()));
  const std::vector<uint8_t> start(value.begin(), value.begin() + 64);
  const auto found = std::search(good_.begin(), good_.end(), start.begin(), start.end());
  ASSERT_NE(found, good_.end());
  const uint64_t run = static_cast<uint64_t>(found - good_.begin()) / pages_.size;
  ASSERT_EQ(Load<uint64_t>(good_, At(run)), run);
  auto b = good_;
  Store<uint32_t>(b, At(run, 12), 1);  // a run too short for its value
  ExpectCorruption(b, "overflow run");
  b = good_;
  Store<uint16_t>(b, At(run, 10), 0x02);
  ExpectCorruption(b, "overflow run");
  b = good_;
  Store<uint64_t>(b, LiveMeta() + 88 + 32, 12345);  // the main database's entry count
  ExpectCorruption(b, "entries");
}

TEST_F(LmdbCheck, TheUndamagedFileReadsTheSame) {
  Status s;
  EXPECT_EQ(ReadEverything(path_, &s), everything_);
  EXPECT_TRUE(s.ok()) << s.ToString();
  const int fd = open(path_.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  auto meta = lmdb::CheckMetas(fd, path_);
  ASSERT_TRUE(meta.ok()) << meta.status().ToString();
  EXPECT_TRUE(lmdb::CheckPages(fd, path_, meta->txnid).ok());
  EXPECT_EQ(lmdb::CheckPages(fd, path_, meta->txnid + 5).code(), Status::Code::kNotFound);
  close(fd);
}

TEST_F(LmdbCheck, DamageNeverCrashesAReader) {
  const char* env_cases = std::getenv("SIMPLEXDB_DAMAGE_CASES");
  const int cases = env_cases ? std::atoi(env_cases) : 400;
  std::mt19937_64 rng(20261126);
  const std::vector<const std::vector<uint64_t>*> kinds = {&pages_.meta, &pages_.branch, &pages_.leaf,
                                                           &pages_.overflow};
  int reported = 0, same = 0, different = 0;
  for (int c = 0; c < cases; ++c) {
    auto b = good_;
    const int kind = static_cast<int>(rng() % 5);
    std::string what;
    if (kind == 4) {  // truncation: at a page boundary or anywhere
      const size_t cut = rng() % 2 ? (rng() % (b.size() / pages_.size)) * pages_.size : rng() % b.size();
      b.resize(cut);
      what = "truncated to " + std::to_string(cut);
    } else {
      const auto& list = *kinds[static_cast<size_t>(kind)];
      const uint64_t pg = list[rng() % list.size()];
      // Most of a page's meaning is in its first bytes (header, node
      // offsets, the first nodes): aim half of the damage there.
      const size_t span = rng() % 2 ? 256 : pages_.size;
      const size_t at = At(pg, rng() % span);
      switch (rng() % 3) {
        case 0: b[at] ^= static_cast<uint8_t>(1u << (rng() % 8)); what = "bit flip"; break;
        case 1: b[at] = static_cast<uint8_t>(rng()); what = "byte"; break;
        default:
          for (size_t i = 0; i < 8 && at + i < b.size(); ++i) b[at + i] = static_cast<uint8_t>(rng());
          what = "8 bytes";
      }
      what += " at " + std::to_string(at) + " (page " + std::to_string(pg) + ")";
    }
    const std::string p = dir_.path() + "/case.lmdb";
    fs::remove(p);
    fs::remove(p + "-lock");
    WriteAll(p, b);
    // The reader in a child: a signal, a hang or a sanitizer report ends it
    // abnormally (a sanitizer exits 1). Exit code 10: reported, 11: read
    // the undamaged content, 12: read something else (damage to keys or
    // values, which only the stores' checksums can see).
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      alarm(30);
      Status s;
      const auto read = ReadEverything(p, &s);
      _exit(!s.ok() ? 10 : read == everything_ ? 11 : 12);
    }
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status)) << "case " << c << " (" << what << "): the reader died of signal "
                                   << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    const int code = WEXITSTATUS(status);
    ASSERT_TRUE(code >= 10 && code <= 12) << "case " << c << " (" << what << "): the reader failed (exit "
                                          << code << ")";
    (code == 10 ? reported : code == 11 ? same : different)++;
  }
  std::printf("%d cases: %d reported, %d read the undamaged content, %d read other keys or values\n",
              cases, reported, same, different);
  EXPECT_EQ(reported + same + different, cases);
}

}  // namespace
}  // namespace simplexdb
