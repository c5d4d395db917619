#include "storage/io/lmdb.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <string>

#include "storage/io/file.h"
#include "storage/io/lmdb_check.h"
#include "storage/io/mapping_guard.h"
#include "storage/io/read_only_file.h"
#include "util/little_endian.h"

namespace simplexdb::lmdb {

bool LooksLikeLmdb(const std::string& path) {
  // LMDB's first page is a meta page: a 16-byte page header, then the meta
  // record, whose first field is the magic 0xBEEFC0DE (native order).
  Result<ReadOnlyFile> file = ReadOnlyFile::Open(path);
  if (!file.ok()) return false;
  uint8_t head[20] = {};
  const Result<size_t> got = file->ReadUpTo(0, sizeof head, reinterpret_cast<std::byte*>(head));
  if (!got.ok() || *got != sizeof head) return false;
  return LoadLittle<uint32_t>(head + 16) == 0xBEEFC0DEu;
}

namespace {

// Bytes free to an unprivileged writer on the file system holding `path`'s
// directory; -1 when unknown.
int64_t FreeBytesBeside(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  struct statvfs fs {};
  if (statvfs(dir.c_str(), &fs) != 0) return -1;
  return static_cast<int64_t>(fs.f_bavail) * static_cast<int64_t>(fs.f_frsize);
}

}  // namespace

Status FromCode(int rc, const std::string& path, std::string_view action) {
  if (rc > 0) {  // an errno value
    // LMDB turns a short write into EIO: when the disk is the reason, it is
    // a full disk, reported as one.
    if (rc == EIO) {
      const int64_t free_bytes = FreeBytesBeside(path);
      if (free_bytes >= 0 && free_bytes < (int64_t{1} << 20)) rc = ENOSPC;
    }
    return StatusFromErrno(rc, path, std::string(action));
  }
  const std::string what = path + ": cannot " + std::string(action) + ": " + mdb_strerror(rc);
  switch (rc) {
    case MDB_INVALID:
    case MDB_VERSION_MISMATCH:
      return Status::InvalidArgument(what + " (not an LMDB file this LMDB version reads)");
    case MDB_CORRUPTED:
    case MDB_PAGE_NOTFOUND:
    case MDB_BAD_VALSIZE:
      return Status::Corruption(what);
    case MDB_READERS_FULL:
    case MDB_MAP_FULL:
    case MDB_TXN_FULL:
    case MDB_DBS_FULL:
      return Status::ResourceExhausted(what);
    default:
      return Status::IOError(what);
  }
}

namespace {

// A descriptor that closes itself.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) close(fd);
  }
};

// LMDB's lock file (STORE-lock) holds the reader table, which LMDB writes
// through a shared mapping: on a full file system a page of it with no
// block behind it faults (SIGBUS) at the first read transaction. Allocating
// the table's bytes first turns that into an error here. LMDB sizes the
// table (max_readers - 1) * 64 + 192 bytes (a 64-byte slot per reader after
// two cache lines of header) and adopts a larger existing file.
Status AllocateLockFile(const std::string& path, const std::string& name, unsigned max_readers,
                        bool* allocated) {
  *allocated = false;
  Fd lock;
  lock.fd = open((path + "-lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock.fd < 0) return StatusFromErrno(errno, name, "open its LMDB lock file");
  struct stat st {};
  if (fstat(lock.fd, &st) != 0) {
    return StatusFromErrno(errno, name, "read the size of its LMDB lock file");
  }
  const off_t wanted = std::max<off_t>(st.st_size, off_t{max_readers} * 64 + 128);
  const int rc = posix_fallocate(lock.fd, 0, wanted);
  if (rc != 0) return StatusFromErrno(rc, name, "allocate its LMDB lock file");
  *allocated = true;
  return Status::OK();
}

}  // namespace

Result<std::unique_ptr<Env>> Env::Open(const std::string& path, const Options& options) {
  const std::string& name = options.name.empty() ? path : options.name;
  // An existing file is checked before LMDB maps it (storage/io/lmdb_check.h).
  Fd file;
  file.fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (file.fd < 0 && (errno != ENOENT || options.read_only)) return StatusFromErrno(errno, name, "open");
  const bool existing = file.fd >= 0;
  if (existing) SDB_RETURN_IF_ERROR(CheckMetas(file.fd, name).status());

  MDB_env* raw = nullptr;
  int rc = mdb_env_create(&raw);
  if (rc != MDB_SUCCESS) return lmdb::FromCode(rc, name, "create an LMDB environment");
  std::unique_ptr<Env> env(new Env(raw, path, name));
  rc = mdb_env_set_maxdbs(raw, options.max_dbs);
  if (rc == MDB_SUCCESS) rc = mdb_env_set_maxreaders(raw, options.max_readers);
  if (rc == MDB_SUCCESS && options.map_bytes > 0) {
    rc = mdb_env_set_mapsize(raw, options.map_bytes);
  }
  if (rc != MDB_SUCCESS) return env->FromCode(rc, "configure the environment");
  // Builders sync once, explicitly, when they are done (MDB_NOSYNC): a crash
  // before that leaves a temporary file, never a store under its real name.
  unsigned flags = MDB_NOSUBDIR | MDB_NOTLS;
  bool locked = true;
  if (Status lock = AllocateLockFile(path, name, options.max_readers, &locked); !lock.ok()) {
    // A reader that cannot have a reader table (a full or read-only file
    // system, a folder it may not write) reads without one (MDB_NOLOCK).
    // The price: LMDB cannot then keep a writer in another process (`update`,
    // the only writer of an existing store) from reusing the pages of the
    // reader's snapshot. A writer needs the table.
    if (!options.read_only) return lock;
  }
  if (options.read_only) {
    flags |= MDB_RDONLY;
    if (!locked) flags |= MDB_NOLOCK;
  } else if (!options.sync_commits) {
    flags |= MDB_NOSYNC;
  }
  rc = mdb_env_open(raw, path.c_str(), flags, 0644);
  if (rc != MDB_SUCCESS) return env->FromCode(rc, options.read_only ? "open" : "create");
  if (locked) {
    int dead = 0;
    rc = mdb_reader_check(raw, &dead);
    if (rc != MDB_SUCCESS) return env->FromCode(rc, "clear stale readers");
  }
  if (existing && options.check_pages) {
    // Every page the current snapshot reaches; a read transaction keeps a
    // writer elsewhere from reusing them meanwhile. A commit between reading
    // the meta and walking gives NotFound: walk the newer snapshot.
    Status checked;
    for (int attempt = 0; attempt < 8; ++attempt) {
      SDB_ASSIGN_OR_RETURN(Txn txn, Txn::Begin(*env, /*read_only=*/true));
      checked = CheckPages(file.fd, name, mdb_txn_id(txn.get()));
      if (checked.code() != Status::Code::kNotFound) break;
    }
    SDB_RETURN_IF_ERROR(checked);
  }
  env->check_pages_ = options.check_pages;
  struct stat st {};
  if (existing && fstat(file.fd, &st) == 0) {
    env->checked_mtime_ns_ = ModifiedNs(st);
    env->checked_bytes_ = static_cast<uint64_t>(st.st_size);
  }
  env->GuardMap();
  return env;
}

Env::~Env() {
  MappingGuard::Unregister(guard_);
  mdb_env_close(env_);
}

void Env::GuardMap() {
  // LMDB does not say where its map is (MDB_envinfo's address is the one a
  // fixed map asked for): the guard finds it by the file.
  MDB_envinfo info;
  int fd = -1;
  if (mdb_env_info(env_, &info) != MDB_SUCCESS || mdb_env_get_fd(env_, &fd) != MDB_SUCCESS) return;
  if (guard_ != nullptr && info.me_mapsize == guarded_bytes_) return;
  MappingGuard::Unregister(guard_);
  guard_ = MappingGuard::RegisterMappingOf(fd);
  guarded_bytes_ = info.me_mapsize;
}

Status Env::CheckUnchanged() {
  const auto changed = [&](const std::string& what) {
    return Status::IOError(name_ + ": the file changed after it was opened (" + what + "): open it again");
  };
  int fd = -1;
  struct stat st {};
  if (mdb_env_get_fd(env_, &fd) != MDB_SUCCESS || fstat(fd, &st) != 0) {
    return StatusFromErrno(errno, name_, "stat");
  }
  std::lock_guard<std::mutex> lock(check_mu_);
  // LMDB's writers only grow the file.
  if (static_cast<uint64_t>(st.st_size) < checked_bytes_) {
    return changed(std::to_string(st.st_size) + " bytes now, " + std::to_string(checked_bytes_) + " then");
  }
  MDB_envinfo info;
  MDB_stat stat_info;
  mdb_env_info(env_, &info);  // reads the meta pages from the map
  mdb_env_stat(env_, &stat_info);
  if (MappingGuard::Faulted(guard_)) return changed("a read went past its end");
  const uint64_t needed = (static_cast<uint64_t>(info.me_last_pgno) + 1) * stat_info.ms_psize;
  if (static_cast<uint64_t>(st.st_size) < needed) {
    return changed(std::to_string(st.st_size) + " bytes, its pages need " + std::to_string(needed));
  }
  if (ModifiedNs(st) == checked_mtime_ns_) return Status::OK();
  // Written since: by LMDB (another process's update) or by anything else.
  SDB_RETURN_IF_ERROR(CheckMetas(fd, name_).status());
  if (check_pages_) {
    Status checked;
    for (int attempt = 0; attempt < 8; ++attempt) {
      SDB_ASSIGN_OR_RETURN(Txn txn, Txn::Begin(*this, /*read_only=*/true));
      checked = CheckPages(fd, name_, mdb_txn_id(txn.get()));
      if (checked.code() != Status::Code::kNotFound) break;
    }
    SDB_RETURN_IF_ERROR(checked);
  }
  checked_mtime_ns_ = ModifiedNs(st);
  checked_bytes_ = static_cast<uint64_t>(st.st_size);
  return Status::OK();
}

size_t Env::page_bytes() const {
  MDB_stat stat_info;
  mdb_env_stat(env_, &stat_info);
  return stat_info.ms_psize;
}

uint64_t Env::map_bytes() const {
  MDB_envinfo info;
  mdb_env_info(env_, &info);
  return info.me_mapsize;
}

Status Env::SetMapBytes(uint64_t bytes) {
  const int rc = mdb_env_set_mapsize(env_, bytes);
  if (rc != MDB_SUCCESS) return FromCode(rc, "grow the map");
  GuardMap();
  return Status::OK();
}

Status Env::Sync() {
  const int rc = mdb_env_sync(env_, 1);
  return rc == MDB_SUCCESS ? Status::OK() : FromCode(rc, "flush");
}

Result<Txn> Txn::Begin(Env& env, bool read_only) {
  MDB_txn* txn = nullptr;
  int rc = mdb_txn_begin(env.get(), nullptr, read_only ? MDB_RDONLY : 0, &txn);
  if (rc == MDB_MAP_RESIZED) {
    // Another process grew the map: adopt its size and try again.
    rc = mdb_env_set_mapsize(env.get(), 0);
    if (rc == MDB_SUCCESS) env.GuardMap();
    if (rc == MDB_SUCCESS) rc = mdb_txn_begin(env.get(), nullptr, read_only ? MDB_RDONLY : 0, &txn);
  }
  if (rc != MDB_SUCCESS) return env.FromCode(rc, "begin a transaction");
  Txn out(&env, txn);
  if (read_only) {
    // A file cut short since it was opened would fault on first touch of a
    // page past its end (the pages of this snapshot were checked at open).
    MDB_envinfo info;
    mdb_env_info(env.get(), &info);
    int fd = -1;
    struct stat st {};
    if (mdb_env_get_fd(env.get(), &fd) == MDB_SUCCESS && fstat(fd, &st) == 0) {
      MDB_stat stat_info;
      mdb_env_stat(env.get(), &stat_info);
      const uint64_t needed = (static_cast<uint64_t>(info.me_last_pgno) + 1) * stat_info.ms_psize;
      if (static_cast<uint64_t>(st.st_size) < needed) {
        return Status::Corruption(env.name() + ": truncated since it was opened: " +
                                  std::to_string(st.st_size) + " bytes, but its pages need " +
                                  std::to_string(needed));
      }
    }
  }
  return out;
}

Txn& Txn::operator=(Txn&& other) noexcept {
  if (this != &other) {
    Abort();
    env_ = other.env_;
    txn_ = other.txn_;
    other.txn_ = nullptr;
  }
  return *this;
}

Status Txn::Commit() {
  const int rc = CommitCode();
  return rc == MDB_SUCCESS ? Status::OK() : env_->FromCode(rc, "commit");
}

int Txn::CommitCode() {
  MDB_txn* txn = txn_;
  txn_ = nullptr;
  return mdb_txn_commit(txn);  // frees the transaction either way
}

void Txn::Abort() {
  if (txn_ != nullptr) mdb_txn_abort(txn_);
  txn_ = nullptr;
}

Result<MDB_dbi> Txn::OpenDb(const char* name, bool create) {
  MDB_dbi dbi = 0;
  const int rc = mdb_dbi_open(txn_, name, create ? MDB_CREATE : 0, &dbi);
  const std::string what = name ? std::string("database '") + name + "'" : "the unnamed database";
  if (rc == MDB_NOTFOUND) {
    return Status::InvalidArgument(env_->name() + ": no " + what + " in this LMDB file");
  }
  if (rc != MDB_SUCCESS) return env_->FromCode(rc, "open " + what);
  return dbi;
}

Result<std::span<const uint8_t>> Txn::Get(MDB_dbi dbi, std::span<const uint8_t> key,
                                          bool* found) {
  MDB_val k = Val(key.data(), key.size()), v;
  const int rc = mdb_get(txn_, dbi, &k, &v);
  *found = rc == MDB_SUCCESS;
  if (rc == MDB_NOTFOUND) return std::span<const uint8_t>();
  if (rc != MDB_SUCCESS) return env_->FromCode(rc, "read");
  return std::span<const uint8_t>(static_cast<const uint8_t*>(v.mv_data), v.mv_size);
}

Status Txn::Put(MDB_dbi dbi, std::span<const uint8_t> key, std::span<const uint8_t> value,
                unsigned flags) {
  MDB_val k = Val(key.data(), key.size()), v = Val(value.data(), value.size());
  const int rc = mdb_put(txn_, dbi, &k, &v, flags);
  return rc == MDB_SUCCESS ? Status::OK() : env_->FromCode(rc, "write");
}

Result<Cursor> Cursor::Open(Txn& txn, MDB_dbi dbi) {
  MDB_cursor* c = nullptr;
  const int rc = mdb_cursor_open(txn.get(), dbi, &c);
  if (rc != MDB_SUCCESS) return txn.env().FromCode(rc, "open a cursor");
  return Cursor(c);
}

Status BatchWriter::Put(MDB_dbi dbi, std::span<const uint8_t> key,
                        std::span<const uint8_t> value, bool append) {
  entries_.push_back(Entry{dbi, static_cast<uint32_t>(key.size()),
                           static_cast<uint32_t>(value.size()), append});
  bytes_.insert(bytes_.end(), key.begin(), key.end());
  bytes_.insert(bytes_.end(), value.begin(), value.end());
  if (bytes_.size() + entries_.size() * 16 >= batch_bytes_) return Flush();
  return Status::OK();
}

Status BatchWriter::TryCommit(int* rc) {
  *rc = MDB_SUCCESS;
  SDB_ASSIGN_OR_RETURN(Txn txn, Txn::Begin(env_, /*read_only=*/false));
  const uint8_t* p = bytes_.data();
  for (const Entry& e : entries_) {
    MDB_val k = Val(p, e.key_size), v = Val(p + e.key_size, e.value_size);
    p += e.key_size + e.value_size;
    *rc = mdb_put(txn.get(), e.dbi, &k, &v, e.append ? MDB_APPEND : 0);
    if (*rc == MDB_MAP_FULL) return Status::OK();  // the transaction aborts here
    if (*rc != MDB_SUCCESS) return env_.FromCode(*rc, "write");
  }
  *rc = txn.CommitCode();
  if (*rc != MDB_SUCCESS && *rc != MDB_MAP_FULL) return env_.FromCode(*rc, "commit");
  return Status::OK();
}

Status BatchWriter::Flush() {
  if (entries_.empty()) return Status::OK();
  while (true) {
    int rc;
    SDB_RETURN_IF_ERROR(TryCommit(&rc));
    if (rc == MDB_SUCCESS) break;
    // MDB_MAP_FULL: nothing of this batch was kept; double the map, replay.
    SDB_RETURN_IF_ERROR(env_.SetMapBytes(env_.map_bytes() * 2));
    ++growths_;
  }
  entries_.clear();
  bytes_.clear();
  return Status::OK();
}

}  // namespace simplexdb::lmdb
