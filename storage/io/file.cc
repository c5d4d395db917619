#include "storage/io/file.h"
#include "storage/io/mapping_guard.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/interprocess/file_mapping.hpp>
#include <boost/interprocess/mapped_region.hpp>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <set>
#include <system_error>

namespace simplexdb {

Status StatusFromErrno(int err, const std::string& path, const std::string& action) {
  // std::generic_category's message is strerror's text, without strerror's
  // shared buffer.
  const std::string msg =
      path + ": cannot " + action + ": " + std::generic_category().message(err);
  switch (err) {
    case ENOENT:
    case ENOTDIR: return Status::NotFound(msg);
    case ENOSPC:
    case EDQUOT:
    case EFBIG:
    case ENOMEM:
    case EMFILE:
    case ENFILE: return Status::ResourceExhausted(msg);
    case EISDIR: return Status::InvalidArgument(msg);
    default: return Status::IOError(msg);  // EACCES, EPERM, EROFS, EIO, ...
  }
}

namespace {

std::string DirectoryOf(const std::string& path) {
  const size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::string BaseOf(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// The process id in a temporary's name, or 0 when `name` is not one of
// `final_name`'s temporaries.
long TemporaryOwner(std::string_view name, std::string_view final_name) {
  if (name.size() <= final_name.size() + 5 || name.substr(0, final_name.size()) != final_name ||
      name.substr(final_name.size(), 5) != ".tmp.") {
    return 0;
  }
  const std::string_view rest = name.substr(final_name.size() + 5);
  size_t digits = 0;
  long pid = 0;
  while (digits < rest.size() && digits < 10 && rest[digits] >= '0' && rest[digits] <= '9') {
    pid = pid * 10 + (rest[digits] - '0');
    ++digits;
  }
  if (digits == 0 || pid <= 0) return 0;
  if (digits < rest.size() && rest[digits] != '.' && rest[digits] != '-') return 0;
  return pid;
}

// The temporary names this process holds, so that two writers of the same
// output in one process (two threads) never share one.
class HeldNames {
 public:
  // `base`, or `base.2`, `base.3`, ... : the first one not held.
  std::string Claim(const std::string& base) {
    std::lock_guard<std::mutex> lock(mu_);
    std::string name = base;
    for (int n = 2; held_.count(name) != 0; ++n) name = base + "." + std::to_string(n);
    held_.insert(name);
    return name;
  }
  void Release(const std::string& name) {
    std::lock_guard<std::mutex> lock(mu_);
    held_.erase(name);
  }

 private:
  std::mutex mu_;
  std::set<std::string> held_;
};

HeldNames& Held() {
  static HeldNames* names = new HeldNames();  // never destroyed: used until exit
  return *names;
}

}  // namespace

std::string TemporaryPathFor(const std::string& final_path) {
  return final_path + ".tmp." + std::to_string(getpid());
}

bool IsTemporaryOf(std::string_view name, std::string_view final_name) {
  return TemporaryOwner(name, final_name) != 0;
}

namespace {

// Whether process `pid` still runs: it exists and has not exited. A zombie
// (exited, not yet reaped: an MPI rank whose mpirun returned first, under
// a PID 1 that does not reap) holds no file, so its temporaries are stale.
bool ProcessRuns(long pid) {
  if (kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) return false;
  std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (f == nullptr) return true;  // no /proc: trust kill()
  char line[512];
  const bool read = std::fgets(line, sizeof line, f) != nullptr;
  std::fclose(f);
  // "pid (comm) S ...": the state follows the last ')', comm may hold any.
  const char* close = read ? std::strrchr(line, ')') : nullptr;
  if (close == nullptr || close[1] != ' ') return true;
  return close[2] != 'Z' && close[2] != 'X';
}

}  // namespace

void RemoveStaleTemporaries(const std::string& final_path) {
  const std::string dir = DirectoryOf(final_path);
  const std::string base = BaseOf(final_path);
  DIR* d = opendir(dir.c_str());
  if (d == nullptr) return;
  while (const dirent* e = readdir(d)) {
    const std::string name = e->d_name;
    const long pid = TemporaryOwner(name, base);
    if (pid == 0 || pid == getpid()) continue;
    if (!ProcessRuns(pid)) unlink((dir + "/" + name).c_str());
  }
  closedir(d);
}

const char* KindOfNonRegularFile(mode_t mode) {
  if (S_ISREG(mode)) return nullptr;
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISLNK(mode)) return "a symlink";
  return "not a regular file";
}

namespace {

// The folder `final_path` is to be created in exists.
Status CheckOutputFolder(const std::string& final_path) {
  if (final_path.empty()) return Status::InvalidArgument("the output path is empty: name a file to write");
  if (final_path.find('\0') != std::string::npos) {
    return Status::InvalidArgument("the output path holds a NUL byte, which no file name can");
  }
  struct stat st;
  if (stat(DirectoryOf(final_path).c_str(), &st) != 0) {
    return StatusFromErrno(errno, final_path, "create");
  }
  if (!S_ISDIR(st.st_mode)) return StatusFromErrno(ENOTDIR, final_path, "create");
  return Status::OK();
}

Status Refuse(const std::string& path, const std::string& why) {
  return Status::InvalidArgument(path + ": cannot write: " + why);
}

// `path` is a new name or a regular file, not a symlink; a symlink is
// described by what it points to.
Status CheckOutputKind(const std::string& path) {
  struct stat st;
  if (lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return Status::OK();  // a new name
    return StatusFromErrno(errno, path, "create");
  }
  if (S_ISLNK(st.st_mode)) {
    struct stat target;
    if (stat(path.c_str(), &target) != 0) {
      if (errno == ENOENT) return Refuse(path, "is a dangling symlink (it points to no file)");
      return StatusFromErrno(errno, path, "follow the symlink");
    }
    if (const char* kind = KindOfNonRegularFile(target.st_mode)) {
      return Refuse(path, std::string("is a symlink to ") + kind);
    }
    return Refuse(path,
                  "is a symlink (writing would replace the link by a file; --force writes the "
                  "file it points to and keeps the link)");
  }
  if (const char* kind = KindOfNonRegularFile(st.st_mode)) return Refuse(path, std::string("is ") + kind);
  return Status::OK();
}

}  // namespace

Status PrepareOutput(const std::string& final_path) {
  SDB_RETURN_IF_ERROR(CheckOutputFolder(final_path));
  SDB_RETURN_IF_ERROR(CheckOutputKind(final_path));
  RemoveStaleTemporaries(final_path);
  return Status::OK();
}

Result<std::string> ResolveOutput(const std::string& path, const OutputOptions& options) {
  SDB_RETURN_IF_ERROR(CheckOutputFolder(path));
  // stat() follows a symlink: a link to an input is that input too.
  struct stat out;
  if (stat(path.c_str(), &out) == 0) {
    for (const std::string& input : options.inputs) {
      struct stat in;
      if (stat(input.c_str(), &in) == 0 && in.st_dev == out.st_dev && in.st_ino == out.st_ino) {
        return Refuse(path, input == path ? "is the input" : "is the input " + input);
      }
    }
  }
  struct stat st;
  if (options.force && lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode)) {
    struct stat target;
    if (stat(path.c_str(), &target) == 0 && S_ISREG(target.st_mode)) {
      char* resolved = realpath(path.c_str(), nullptr);
      if (resolved == nullptr) return StatusFromErrno(errno, path, "follow the symlink");
      std::string real = resolved;
      std::free(resolved);
      SDB_RETURN_IF_ERROR(CheckOutputKind(real));
      return real;
    }
  }
  SDB_RETURN_IF_ERROR(CheckOutputKind(path));
  return path;
}

Status RenameDurably(const std::string& from, const std::string& to) {
  if (rename(from.c_str(), to.c_str()) != 0) {
    return StatusFromErrno(errno, to, "rename " + from + " to");
  }
  const std::string dir = DirectoryOf(to);
  const int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    fsync(dfd);  // best effort: some file systems refuse to sync directories
    close(dfd);
  }
  return Status::OK();
}

namespace {

Status WriteFully(int fd, uint64_t offset, std::span<const uint8_t> bytes, const std::string& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = pwrite(fd, bytes.data() + done, bytes.size() - done,
                             static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      return StatusFromErrno(errno, path, "write");
    }
    done += static_cast<size_t>(n);
  }
  return Status::OK();
}

}  // namespace

AtomicFileWriter::AtomicFileWriter(std::string final_path, std::string temp_path, int fd)
    : final_path_(std::move(final_path)), temp_path_(std::move(temp_path)), fd_(fd) {}

Result<std::unique_ptr<AtomicFileWriter>> AtomicFileWriter::Create(const std::string& final_path) {
  SDB_RETURN_IF_ERROR(PrepareOutput(final_path));
  const std::string temp = Held().Claim(TemporaryPathFor(final_path));
  int fd;
  do {
    fd = open(temp.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int err = errno;
    Held().Release(temp);
    return StatusFromErrno(err, final_path, "create");
  }
  return std::unique_ptr<AtomicFileWriter>(new AtomicFileWriter(final_path, temp, fd));
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) close(fd_);
  if (!committed_) unlink(temp_path_.c_str());
  Held().Release(temp_path_);
}

Result<uint64_t> AtomicFileWriter::Append(std::span<const uint8_t> bytes) {
  const uint64_t offset = end_.fetch_add(bytes.size());
  SDB_RETURN_IF_ERROR(WriteFully(fd_, offset, bytes, final_path_));
  // The disk starts on what was appended a few MiB at a time, while the
  // writer goes on: Commit's flush then waits for the last few only (for a
  // 45 MiB store it waited 0.19 s, a tenth of the build). Initiating
  // writeback is a hint: its errors are Commit's fsync's to report.
  constexpr uint64_t kWritebackBytes = uint64_t{8} << 20;
  const uint64_t end = offset + bytes.size();
  uint64_t from = writeback_from_.load();
  while (end >= from + kWritebackBytes) {
    if (writeback_from_.compare_exchange_weak(from, end)) {
      sync_file_range(fd_, static_cast<off_t>(from), static_cast<off_t>(end - from),
                      SYNC_FILE_RANGE_WRITE);
      break;
    }
  }
  return offset;
}

Status AtomicFileWriter::WriteAt(uint64_t offset, std::span<const uint8_t> bytes) {
  return WriteFully(fd_, offset, bytes, final_path_);
}

Status AtomicFileWriter::Commit() {
  // Reserved space past the last write must exist in the file too.
  if (ftruncate(fd_, static_cast<off_t>(end_.load())) != 0) {
    return StatusFromErrno(errno, final_path_, "set the size of");
  }
  if (fsync(fd_) != 0) return StatusFromErrno(errno, final_path_, "flush");
  const int fd = fd_;
  fd_ = -1;
  if (close(fd) != 0) return StatusFromErrno(errno, final_path_, "close");
  SDB_RETURN_IF_ERROR(RenameDurably(temp_path_, final_path_));
  committed_ = true;
  return Status::OK();
}

Result<std::unique_ptr<ScratchFile>> ScratchFile::Create(const std::string& final_path, std::string_view role) {
  const std::string path = TemporaryPathFor(final_path) + "." + std::string(role);
  int fd;
  do {
    fd = open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return StatusFromErrno(errno, final_path, "create the scratch file " + path);
  unlink(path.c_str());
  return std::unique_ptr<ScratchFile>(new ScratchFile(final_path + " (scratch file " + path + ")", fd));
}

ScratchFile::~ScratchFile() { close(fd_); }

Result<uint64_t> ScratchFile::Append(std::span<const uint8_t> bytes) {
  const uint64_t offset = end_.fetch_add(bytes.size());
  SDB_RETURN_IF_ERROR(WriteFully(fd_, offset, bytes, what_));
  return offset;
}

Status ScratchFile::ReadAt(uint64_t offset, std::span<uint8_t> out) const {
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n = pread(fd_, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return StatusFromErrno(errno, what_, "read");
    if (n == 0) return Status::IOError(what_ + ": cannot read: it ends at " + std::to_string(offset + done));
    done += static_cast<size_t>(n);
  }
  return Status::OK();
}

Result<std::unique_ptr<FilePartWriter>> FilePartWriter::Open(const std::string& path) {
  int fd;
  do {
    fd = open(path.c_str(), O_WRONLY | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return StatusFromErrno(errno, path, "open for writing");
  return std::unique_ptr<FilePartWriter>(new FilePartWriter(path, fd));
}

FilePartWriter::~FilePartWriter() { close(fd_); }

Status FilePartWriter::WriteAt(uint64_t offset, std::span<const uint8_t> bytes) {
  return WriteFully(fd_, offset, bytes, path_);
}

Status FilePartWriter::Sync() {
  if (fdatasync(fd_) != 0) return StatusFromErrno(errno, path_, "flush");
  return Status::OK();
}

Status WriteFileAtomically(const std::string& path, std::string_view bytes) {
  SDB_ASSIGN_OR_RETURN(std::unique_ptr<AtomicFileWriter> file, AtomicFileWriter::Create(path));
  SDB_ASSIGN_OR_RETURN(const uint64_t at, file->Append(bytes));
  (void)at;
  return file->Commit();
}

TemporaryFile::TemporaryFile(const std::string& final_path, std::string_view role)
    : final_path_(final_path),
      path_(Held().Claim(role.empty() ? TemporaryPathFor(final_path)
                                      : TemporaryPathFor(final_path) + "." + std::string(role))) {
  unlink(path_.c_str());
  unlink((path_ + "-lock").c_str());
}

TemporaryFile::~TemporaryFile() {
  if (!committed_) unlink(path_.c_str());
  unlink((path_ + "-lock").c_str());
  Held().Release(path_);
}

Status TemporaryFile::Commit() {
  SDB_RETURN_IF_ERROR(RenameDurably(path_, final_path_));
  committed_ = true;
  unlink((path_ + "-lock").c_str());
  return Status::OK();
}

namespace {

// Maps all of `path` with `mode`; Boost's exceptions become IOError here.
Status MapWhole(const std::string& path, boost::interprocess::mode_t mode,
                std::unique_ptr<boost::interprocess::file_mapping>& mapping,
                std::unique_ptr<boost::interprocess::mapped_region>& region) {
  try {
    namespace bip = boost::interprocess;
    mapping = std::make_unique<bip::file_mapping>(path.c_str(), mode);
    region = std::make_unique<bip::mapped_region>(*mapping, mode);
  } catch (const std::exception& e) {
    return Status::IOError(path + ": cannot map: " + e.what());
  }
  return Status::OK();
}

}  // namespace

MappedFile::~MappedFile() {
  MappingGuard::Unregister(guard_);
  region_.reset();
  mapping_.reset();
  if (fd_ >= 0) close(fd_);
}

int64_t ModifiedNs(const struct stat& st) {
  return static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
}

Result<std::unique_ptr<MappedFile>> MappedFile::Open(const std::string& path) {
  std::unique_ptr<MappedFile> f(new MappedFile());
  f->path_ = path;
  f->fd_ = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO is refused, not waited on
  if (f->fd_ < 0) return StatusFromErrno(errno, path, "open");
  struct stat st;
  if (fstat(f->fd_, &st) != 0) return StatusFromErrno(errno, path, "stat");
  if (const char* kind = KindOfNonRegularFile(st.st_mode)) {
    return Status::InvalidArgument(path + ": cannot read: is " + kind + " (expected a regular file)");
  }
  f->size_ = static_cast<uint64_t>(st.st_size);
  f->mtime_ns_ = ModifiedNs(st);
  if (st.st_size == 0) return f;  // nothing to map; readers see zero bytes
  SDB_RETURN_IF_ERROR(MapWhole(path, boost::interprocess::read_only, f->mapping_, f->region_));
  f->bytes_ = std::span<const uint8_t>(static_cast<const uint8_t*>(f->region_->get_address()),
                                       f->region_->get_size());
  f->guard_ = MappingGuard::Register(f->bytes_.data(), f->bytes_.size());
  // The name mapped is the file described: not replaced in between.
  struct stat now;
  if (stat(path.c_str(), &now) != 0) return StatusFromErrno(errno, path, "stat");
  if (now.st_ino != st.st_ino || now.st_dev != st.st_dev || f->bytes_.size() != f->size_) {
    return Status::IOError(path + ": the file was replaced while it was being opened: open it again");
  }
  return f;
}

Status MappedFile::CheckUnchanged() const {
  const auto changed = [&](const std::string& what) {
    return Status::IOError(path_ + ": the file changed after it was opened (" + what + "): open it again");
  };
  if (MappingGuard::Faulted(guard_)) return changed("a read went past its end");
  struct stat st;
  if (fd_ < 0 || fstat(fd_, &st) != 0) return StatusFromErrno(errno, path_, "stat");
  if (static_cast<uint64_t>(st.st_size) != size_) {
    return changed(std::to_string(st.st_size) + " bytes now, " + std::to_string(size_) + " then");
  }
  if (ModifiedNs(st) != mtime_ns_) return changed("written since");
  return Status::OK();
}

WritableScratchMapping::WritableScratchMapping(std::string path) : path_(std::move(path)) {}

Result<std::unique_ptr<WritableScratchMapping>> WritableScratchMapping::Create(
    const std::string& path, uint64_t bytes) {
  std::unique_ptr<WritableScratchMapping> f(new WritableScratchMapping(path));
  const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return StatusFromErrno(errno, path, "create");
  const int rc = ftruncate(fd, static_cast<off_t>(bytes));
  const int err = errno;
  close(fd);
  if (rc != 0) return StatusFromErrno(err, path, "set the size of");
  SDB_RETURN_IF_ERROR(MapWhole(path, boost::interprocess::read_write, f->mapping_, f->region_));
  f->data_ = static_cast<std::byte*>(f->region_->get_address());
  return f;
}

WritableScratchMapping::~WritableScratchMapping() {
  region_.reset();
  mapping_.reset();
  unlink(path_.c_str());
}

Status WritableScratchMapping::Flush() {
  return region_->flush() ? Status::OK() : Status::IOError(path_ + ": cannot flush the mapping");
}

}  // namespace simplexdb
