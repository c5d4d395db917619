// A fuzz input as a file, without touching the disk: the store readers
// take paths and map files, so each input is written to a memfd and opened
// by its /proc/self/fd path. Closed when the object goes.
#ifndef SIMPLEXDB_TESTS_FUZZ_MEMORY_FILE_H_
#define SIMPLEXDB_TESTS_FUZZ_MEMORY_FILE_H_

#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <string>

namespace simplexdb::fuzz {

class MemoryFile {
 public:
  MemoryFile(const uint8_t* data, size_t size) : fd_(memfd_create("input", 0)) {
    if (fd_ < 0) return;
    for (size_t done = 0; done < size;) {
      const ssize_t n = write(fd_, data + done, size - done);
      if (n <= 0) break;
      done += static_cast<size_t>(n);
    }
    path_ = "/proc/self/fd/" + std::to_string(fd_);
  }
  ~MemoryFile() {
    if (fd_ >= 0) close(fd_);
  }
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;

  bool ok() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }

 private:
  int fd_;
  std::string path_;
};

}  // namespace simplexdb::fuzz

#endif  // SIMPLEXDB_TESTS_FUZZ_MEMORY_FILE_H_
