#include "storage/io/read_only_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>

#include "storage/io/file.h"

namespace simplexdb {

Result<ReadOnlyFile> ReadOnlyFile::Open(const std::string& path) {
  int fd;
  do {
    // O_NONBLOCK: opening a FIFO for reading would wait for a writer.
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) return StatusFromErrno(errno, path, "open");
  ReadOnlyFile file(path, fd);
  struct stat st;
  if (::fstat(fd, &st) != 0) return StatusFromErrno(errno, path, "stat");
  // open(2) accepts a directory; read(2) would fail with EISDIR. Say so
  // now, in the words of the one errno table.
  if (S_ISDIR(st.st_mode)) return StatusFromErrno(EISDIR, path, "read");
  // The readers read at positions and check sizes against the file: a
  // FIFO, a socket or a device (whose size is 0, or which never ends)
  // cannot be read so.
  if (const char* kind = KindOfNonRegularFile(st.st_mode)) {
    return Status::InvalidArgument(path + ": cannot read: is " + kind +
                                   " (expected a regular file)");
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) {
    return StatusFromErrno(errno, path, "open");
  }
  return file;
}

ReadOnlyFile::ReadOnlyFile(ReadOnlyFile&& other) noexcept
    : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)) {}

ReadOnlyFile& ReadOnlyFile::operator=(ReadOnlyFile&& other) noexcept {
  if (this != &other) {
    Close();
    path_ = std::move(other.path_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

ReadOnlyFile::~ReadOnlyFile() { Close(); }

void ReadOnlyFile::Close() noexcept {
  // A failed close of a file only read loses nothing: ignored.
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

Result<uint64_t> ReadOnlyFile::Size() const {
  struct stat st;
  if (::fstat(fd_, &st) != 0) return StatusFromErrno(errno, path_, "stat");
  return static_cast<uint64_t>(st.st_size);
}

Result<size_t> ReadOnlyFile::ReadUpTo(uint64_t pos, size_t n, std::byte* out) const {
  size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd_, out + done, n - done, static_cast<off_t>(pos + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      return StatusFromErrno(errno, path_, "read at byte " + std::to_string(pos + done));
    }
    if (r == 0) break;  // the end of the file
    done += static_cast<size_t>(r);
  }
  return done;
}

Status ReadOnlyFile::Seek(uint64_t pos) {
  if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) {
    return StatusFromErrno(errno, path_, "seek to byte " + std::to_string(pos));
  }
  return Status::OK();
}

int ReadOnlyFile::Release() noexcept { return std::exchange(fd_, -1); }

}  // namespace simplexdb
