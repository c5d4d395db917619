// ReadOnlyFile: a file opened for reading by descriptor, for readers that
// parse a header and then read bytes at chosen positions (the volume
// readers). It is the reading half of io's file layer; the writing half is
// AtomicFileWriter and the mapping half MappedFile (storage/io/file.h).
//
// Every operating-system failure becomes a Status through StatusFromErrno
// (storage/io/file.h): its code and words are the one errno table's, and the
// message starts with the file's path and says what was attempted ("open",
// "stat", "read at byte 4096", "seek to byte 352"). Interrupted system calls
// (EINTR) are retried, never reported.
//
// Thread safety: ReadUpTo and Size may be called from several threads at
// once (pread does not move a shared position). Seek, Release and moves
// need the caller's exclusion.
//
// Lifetime: a ReadOnlyFile owns its descriptor and closes it when destroyed,
// unless Release handed it over. path() lives as long as the object.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

#include "util/status.h"

namespace simplexdb {

class ReadOnlyFile {
 public:
  // Opens `path` read-only (close-on-exec). Errors: StatusFromErrno(errno,
  // path, "open" or "stat") when the system refuses (a missing file is
  // NotFound); StatusFromErrno(EISDIR, path, "read") for a directory, which
  // open(2) accepts but read(2) refuses; InvalidArgument "<path>: cannot
  // read: is a FIFO (expected a regular file)" for a FIFO, a socket or a
  // device, without waiting for a FIFO's writer.
  static Result<ReadOnlyFile> Open(const std::string& path);

  ReadOnlyFile(ReadOnlyFile&& other) noexcept;
  ReadOnlyFile& operator=(ReadOnlyFile&& other) noexcept;
  ReadOnlyFile(const ReadOnlyFile&) = delete;
  ReadOnlyFile& operator=(const ReadOnlyFile&) = delete;
  // Closes the descriptor unless it was released.
  ~ReadOnlyFile();

  // The size in bytes now (fstat). Errors: StatusFromErrno(errno, path,
  // "stat"). REQUIRES: not released.
  Result<uint64_t> Size() const;

  // Reads up to `n` bytes at byte `pos` into out[0 .. n) and returns how
  // many were read: fewer than `n` only when the file ends first (0 at or
  // past the end). Loops over short reads. Errors: StatusFromErrno(errno,
  // path, "read at byte <p>") with p the byte that failed; out[0 .. n) then
  // holds unspecified bytes. REQUIRES: not released; `out` holds n bytes.
  // Cost: one pread per 2 GiB in the common case.
  Result<size_t> ReadUpTo(uint64_t pos, size_t n, std::byte* out) const;

  // Moves the descriptor's position to byte `pos` (lseek SEEK_SET), for a
  // library that reads from the position (zlib's gzdopen). Errors:
  // StatusFromErrno(errno, path, "seek to byte <pos>"). REQUIRES: not
  // released.
  Status Seek(uint64_t pos);

  // The descriptor, for a library that reads it itself (zlib's gzdopen).
  // Still owned by this object: valid until Release, a move or destruction.
  // -1 once released.
  int fd() const noexcept { return fd_; }

  // Hands the descriptor over to the caller, who must close it (gzdopen's
  // gzclose does), typically once the library took it. The object stays,
  // without a descriptor: only path() and destruction remain usable.
  int Release() noexcept;

  const std::string& path() const { return path_; }

 private:
  ReadOnlyFile(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  void Close() noexcept;

  std::string path_;
  int fd_ = -1;  // -1: released or moved from
};

}  // namespace simplexdb
