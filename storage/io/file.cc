#include "storage/io/file.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/interprocess/file_mapping.hpp>
#include <boost/interprocess/mapped_region.hpp>
#include <cerrno>
#include <cstring>
#include <string_view>

namespace simplexdb {

Status StatusFromErrno(int err, const std::string& path, const std::string& action) {
  const std::string msg = path + ": cannot " + action + ": " + std::strerror(err);
  switch (err) {
    case ENOENT: return Status::NotFound(msg);
    case ENOSPC:
    case EDQUOT: return Status::ResourceExhausted(msg);
    case EACCES:
    case EPERM:
    case EISDIR:
    case ENOTDIR:
    case ENAMETOOLONG: return Status::InvalidArgument(msg);
    default: return Status::IOError(msg);
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

}  // namespace

void RemoveStaleTemporaries(const std::string& final_path) {
  const std::string dir = DirectoryOf(final_path);
  const std::string prefix = BaseOf(final_path) + ".tmp.";
  DIR* d = opendir(dir.c_str());
  if (d == nullptr) return;
  while (const dirent* e = readdir(d)) {
    const std::string_view name = e->d_name;
    if (name.substr(0, prefix.size()) != prefix) continue;
    const std::string pid_text(name.substr(prefix.size()));
    char* end = nullptr;
    const long pid = std::strtol(pid_text.c_str(), &end, 10);
    const std::string_view rest = end;
    if (end == pid_text.c_str() || (!rest.empty() && rest != "-lock") || pid <= 0) continue;
    if (kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
      unlink((dir + "/" + std::string(name)).c_str());
    }
  }
  closedir(d);
}

std::string TemporaryPathFor(const std::string& final_path) {
  return final_path + ".tmp." + std::to_string(getpid());
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
  RemoveStaleTemporaries(final_path);
  const std::string temp = TemporaryPathFor(final_path);
  const int fd = open(temp.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return StatusFromErrno(errno, temp, "create");
  return std::unique_ptr<AtomicFileWriter>(new AtomicFileWriter(final_path, temp, fd));
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) close(fd_);
  if (!committed_) unlink(temp_path_.c_str());
}

Result<uint64_t> AtomicFileWriter::Append(std::span<const uint8_t> bytes) {
  const uint64_t offset = end_.fetch_add(bytes.size());
  SDB_RETURN_IF_ERROR(WriteFully(fd_, offset, bytes, temp_path_));
  return offset;
}

Status AtomicFileWriter::WriteAt(uint64_t offset, std::span<const uint8_t> bytes) {
  return WriteFully(fd_, offset, bytes, temp_path_);
}

Status AtomicFileWriter::Commit() {
  // Reserved space past the last write must exist in the file too.
  if (ftruncate(fd_, static_cast<off_t>(end_.load())) != 0) {
    return StatusFromErrno(errno, temp_path_, "set the size of");
  }
  if (fsync(fd_) != 0) return StatusFromErrno(errno, temp_path_, "flush");
  if (close(fd_) != 0) {
    fd_ = -1;
    return StatusFromErrno(errno, temp_path_, "close");
  }
  fd_ = -1;
  SDB_RETURN_IF_ERROR(RenameDurably(temp_path_, final_path_));
  committed_ = true;
  return Status::OK();
}

MappedFile::~MappedFile() = default;

Result<std::unique_ptr<MappedFile>> MappedFile::Open(const std::string& path) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return StatusFromErrno(errno, path, "open");
  if (!S_ISREG(st.st_mode)) return Status::InvalidArgument(path + ": not a regular file");
  std::unique_ptr<MappedFile> f(new MappedFile());
  f->path_ = path;
  if (st.st_size == 0) return f;  // nothing to map; readers see zero bytes
  try {
    namespace bip = boost::interprocess;
    f->mapping_ = std::make_unique<bip::file_mapping>(path.c_str(), bip::read_only);
    f->region_ = std::make_unique<bip::mapped_region>(*f->mapping_, bip::read_only);
  } catch (const std::exception& e) {
    return Status::IOError(path + ": cannot map: " + e.what());
  }
  f->bytes_ = std::span<const uint8_t>(static_cast<const uint8_t*>(f->region_->get_address()),
                                       f->region_->get_size());
  return f;
}

}  // namespace simplexdb
