// Files: an output written under a temporary name and renamed into place
// when complete, and a read-only memory mapping (Boost.Interprocess).
// Errors from the operating system become a Status naming the file and the
// reason (a full disk is ResourceExhausted) here, once.
//
// Thread safety: AtomicFileWriter::Append and WriteAt may be called from
// several threads at once; Commit from one. MappedFile is immutable.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "util/status.h"

namespace boost::interprocess {
class file_mapping;
class mapped_region;
}  // namespace boost::interprocess

namespace simplexdb {

// The Status for a failed system call on `path` with errno `err`.
Status StatusFromErrno(int err, const std::string& path, const std::string& action);

// `<final_path>.tmp.<pid>`: where this process writes what becomes
// `final_path`.
std::string TemporaryPathFor(const std::string& final_path);

// Removes the temporaries of `final_path` (`.tmp.<pid>`, and LMDB's
// `.tmp.<pid>-lock`) left by processes that no longer run.
void RemoveStaleTemporaries(const std::string& final_path);

// Renames `from` to `to` and flushes the directory (best effort): after it
// returns, the file is durable under its new name.
Status RenameDurably(const std::string& from, const std::string& to);

class AtomicFileWriter {
 public:
  // Creates `<final_path>.tmp.<pid>` for writing. Stale temporaries of the
  // same final path left by processes that no longer run (a build killed
  // part-way) are removed first.
  static Result<std::unique_ptr<AtomicFileWriter>> Create(const std::string& final_path);

  // Unless committed, removes the temporary file.
  ~AtomicFileWriter();

  // Writes `bytes` at a fresh offset at the end and returns that offset.
  Result<uint64_t> Append(std::span<const uint8_t> bytes);
  // Writes `bytes` at `offset` (for the header, written last).
  Status WriteAt(uint64_t offset, std::span<const uint8_t> bytes);
  // Reserves `size` bytes at the end (zero until written).
  uint64_t Reserve(uint64_t size) { return end_.fetch_add(size); }
  uint64_t size() const { return end_.load(); }

  // Flushes to disk, renames to the final path, and flushes the directory:
  // after it returns, the store is durable under its final name.
  Status Commit();

  const std::string& final_path() const { return final_path_; }
  const std::string& temp_path() const { return temp_path_; }

 private:
  AtomicFileWriter(std::string final_path, std::string temp_path, int fd);

  std::string final_path_;
  std::string temp_path_;
  int fd_;
  std::atomic<uint64_t> end_{0};
  bool committed_ = false;
};

class MappedFile {
 public:
  // Maps `path` read-only. Many processes may map the same file.
  static Result<std::unique_ptr<MappedFile>> Open(const std::string& path);
  ~MappedFile();

  std::span<const uint8_t> bytes() const { return bytes_; }
  const std::string& path() const { return path_; }

 private:
  MappedFile() = default;
  std::string path_;
  std::unique_ptr<boost::interprocess::file_mapping> mapping_;
  std::unique_ptr<boost::interprocess::mapped_region> region_;
  std::span<const uint8_t> bytes_;
};

}  // namespace simplexdb
