// A thin layer over LMDB (liblmdb, the C library): owning handles for the
// environment, transactions and cursors, a batch writer that grows the map,
// and LMDB's return codes as a Status that names the file. Nothing here
// knows about SimplexDB's data. It includes <lmdb.h>, so it is meant for
// the stores' own code, not for embedders (today sparse_store.h and
// tri_leaf_store.h still include it).
//
// Environments are single files (MDB_NOSUBDIR: STORE and STORE-lock) opened
// with MDB_NOTLS, so one thread may hold several read transactions (one per
// Reader) and a read transaction is not tied to the thread that began it.
// A builder writes its environment under a TemporaryFile's name
// (storage/io/file.h) and renames it into place when it is complete.
//
// Map size: LMDB fails a write with MDB_MAP_FULL when the map is too small.
// Writers here never show that to a user: BatchWriter keeps each batch until
// it commits, and on MDB_MAP_FULL aborts it, doubles the map and replays it.
// Readers follow a map grown by another process (MDB_MAP_RESIZED) by
// adopting the new size and retrying.
//
// Errors: every function returning a Status or Result turns LMDB's code into
// one through FromCode (errno-valued codes through the one errno table of
// storage/io/file.h, so a full disk reads the same here as anywhere), with
// the message "<file>: cannot <action>: <reason>".
//
// Lifetimes: a Txn must end before its Env is destroyed, a Cursor before its
// Txn; bytes returned by Txn::Get live until the transaction ends.
//
// Thread safety: an Env may be shared by threads; a Txn belongs to one
// thread at a time; a BatchWriter to one thread.
#pragma once

#include <lmdb.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "util/status.h"

namespace simplexdb {
class MappingGuard;
}  // namespace simplexdb

namespace simplexdb::lmdb {

// True when `path` begins like an LMDB data file: a meta page whose magic
// is LMDB's (a sparse store, or another program's LMDB file). A FIFO or a
// device is refused at once, not waited on.
bool LooksLikeLmdb(const std::string& path);

// The Status for LMDB return code `rc` (not MDB_SUCCESS) from `action` (a
// verb phrase: "open", "read the field") on the environment at `path`:
// "<path>: cannot <action>: <reason>". Codes that are errno values go
// through StatusFromErrno (storage/io/file.h): a missing file is NotFound,
// a full disk ResourceExhausted (also LMDB's EIO for a short write when the
// disk is full: it is then reported as ENOSPC), a refused write IOError.
// LMDB's own codes: a damaged file (MDB_CORRUPTED, MDB_PAGE_NOTFOUND,
// MDB_BAD_VALSIZE) is Corruption, a file that is not LMDB or of another
// LMDB version (MDB_INVALID, MDB_VERSION_MISMATCH) InvalidArgument, a full
// map, reader table, transaction or database table ResourceExhausted, any
// other IOError.
Status FromCode(int rc, const std::string& path, std::string_view action);

// Keys: a 64-bit integer stored big-endian, so LMDB's byte order (memcmp)
// is the integer's order.
inline std::array<uint8_t, 8> KeyBytes(uint64_t key) {
  std::array<uint8_t, 8> out;
  for (int i = 0; i < 8; ++i) out[i] = static_cast<uint8_t>(key >> (56 - 8 * i));
  return out;
}
inline uint64_t KeyValue(const MDB_val& v) {
  const auto* b = static_cast<const uint8_t*>(v.mv_data);
  uint64_t key = 0;
  for (int i = 0; i < 8; ++i) key = key << 8 | b[i];
  return key;
}
inline MDB_val Val(const void* data, size_t size) {
  return MDB_val{size, const_cast<void*>(data)};
}

class Env {
 public:
  struct Options {
    bool read_only = true;
    uint64_t map_bytes = 0;  // 0: the size recorded in the file (readers)
    // Writers: make every commit durable. Off for builders, which write a
    // temporary file and call Sync() once before renaming it.
    bool sync_commits = false;
    unsigned max_dbs = 4;
    unsigned max_readers = 510;
    // The file errors name (empty: `path`): a builder writing a temporary
    // names its output, which is what the user asked for.
    std::string name;
    // Walk every page of an existing file's current snapshot before using
    // it (lmdb::CheckPages, storage/io/lmdb_check.h): reads every branch and
    // leaf page once. Its meta pages are checked whatever this says.
    bool check_pages = true;
  };
  // Opens (a writer creates) the single-file environment at `path`. An
  // existing file is checked first (storage/io/lmdb_check.h: its meta pages,
  // that it holds every page they count, and with Options::check_pages every
  // page of its current snapshot), so LMDB never reads a damaged page:
  // Corruption names the damage. The lock file's reader table is allocated
  // before LMDB maps it (a full file system would fault at the first read
  // otherwise); a reader that cannot allocate it reads without one
  // (MDB_NOLOCK), a writer fails. Then clears the reader slots of processes
  // that died (mdb_reader_check). Errors: FromCode's; NotFound for a missing
  // file (a reader) or folder; ResourceExhausted when a writer's lock file
  // cannot be allocated on a full disk.
  static Result<std::unique_ptr<Env>> Open(const std::string& path, const Options& options);
  ~Env();  // closes the environment

  MDB_env* get() const { return env_; }
  const std::string& path() const { return path_; }
  // The file errors name: Options::name, or path().
  const std::string& name() const { return name_; }
  uint64_t map_bytes() const;
  // The size of its pages (the system's page size when it was created).
  size_t page_bytes() const;
  // Sets the map size (no transaction of this process may be open).
  Status SetMapBytes(uint64_t bytes);
  // Flushes to disk (a no-op unless the environment was opened without
  // syncing: here it is, for writers that sync once at the end).
  Status Sync();
  // lmdb::FromCode for this environment's name().
  Status FromCode(int rc, std::string_view action) const {
    return lmdb::FromCode(rc, name_, action);
  }

  // For a reader of a file that other programs may change: OK while the
  // file is as LMDB left it. A read of the map that faulted (the file
  // shrank under it: storage/io/mapping_guard.h) or a file shorter than its
  // pages is IOError "<name>: the file changed after it was opened (...):
  // open it again". A file written since the last check (LMDB's own
  // writers do that, in place) is checked again as at open (its meta pages
  // and every page of its current snapshot): Corruption names the damage
  // of a file written by anything else. Cost: one fstat, and a walk of the
  // pages after a write.
  Status CheckUnchanged();

 private:
  friend class Txn;  // adopts a map grown elsewhere, then GuardMap
  Env(MDB_env* env, std::string path, std::string name)
      : env_(env), path_(std::move(path)), name_(std::move(name)) {}
  // Guards the map as it is now (after the open, and after it moved).
  void GuardMap();
  MDB_env* env_;
  std::string path_;
  std::string name_;
  MappingGuard* guard_ = nullptr;
  uint64_t guarded_bytes_ = 0;    // the map's size when guarded
  bool check_pages_ = true;
  std::mutex check_mu_;
  int64_t checked_mtime_ns_ = 0;   // the file's modification time when last checked
  uint64_t checked_bytes_ = 0;     // and its size
};

class Txn {
 public:
  // A read-only snapshot, or the (single) write transaction. A read-only
  // one first checks that the file still holds every page (Corruption if it
  // was cut short since the open).
  static Result<Txn> Begin(Env& env, bool read_only);
  Txn(Txn&& other) noexcept : env_(other.env_), txn_(other.txn_) { other.txn_ = nullptr; }
  Txn& operator=(Txn&& other) noexcept;
  ~Txn() { Abort(); }

  MDB_txn* get() const { return txn_; }
  const Env& env() const { return *env_; }
  Status Commit();
  int CommitCode();  // Commit's LMDB return code, for callers that retry
  void Abort();

  // The named database `name` (nullptr: the unnamed one, which always
  // exists); `create` in a write transaction. InvalidArgument when it does
  // not exist and `create` is false.
  Result<MDB_dbi> OpenDb(const char* name, bool create);

  // The value of `key` in `dbi`: the bytes (valid until the transaction
  // ends), or an empty span with found = false (not an error).
  Result<std::span<const uint8_t>> Get(MDB_dbi dbi, std::span<const uint8_t> key, bool* found);
  Status Put(MDB_dbi dbi, std::span<const uint8_t> key, std::span<const uint8_t> value,
             unsigned flags = 0);

 private:
  Txn(Env* env, MDB_txn* txn) : env_(env), txn_(txn) {}
  Env* env_;
  MDB_txn* txn_;
};

// A cursor that closes itself (before its transaction ends).
class Cursor {
 public:
  static Result<Cursor> Open(Txn& txn, MDB_dbi dbi);
  Cursor(Cursor&& other) noexcept : cursor_(other.cursor_) { other.cursor_ = nullptr; }
  ~Cursor() {
    if (cursor_ != nullptr) mdb_cursor_close(cursor_);
  }
  MDB_cursor* get() const { return cursor_; }

 private:
  explicit Cursor(MDB_cursor* c) : cursor_(c) {}
  MDB_cursor* cursor_;
};

// Writes many entries in batches of transactions. Each batch is kept in
// memory until its transaction commits; if the map is full, the batch is
// aborted, the map doubled and the batch replayed, so callers never see
// MDB_MAP_FULL. Entries added in key order to a database (per database) can
// use `append` (MDB_APPEND: no B-tree search, pages filled completely).
class BatchWriter {
 public:
  BatchWriter(Env& env, size_t batch_bytes = size_t{64} << 20)
      : env_(env), batch_bytes_(batch_bytes) {}

  Status Put(MDB_dbi dbi, std::span<const uint8_t> key, std::span<const uint8_t> value,
             bool append);
  // Commits what is pending. Errors: FromCode's (never MDB_MAP_FULL); a
  // failed batch is not kept.
  Status Flush();
  uint64_t map_growths() const { return growths_; }

 private:
  struct Entry {
    MDB_dbi dbi;
    uint32_t key_size, value_size;
    bool append;
  };
  Status TryCommit(int* rc);

  Env& env_;
  size_t batch_bytes_;
  std::vector<Entry> entries_;
  std::vector<uint8_t> bytes_;
  uint64_t growths_ = 0;
};

}  // namespace simplexdb::lmdb
