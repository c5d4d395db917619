// Files: the one errno -> Status table, the one atomic writer every output
// of every command goes through, the one naming pattern of temporaries, and
// read-only memory mappings (Boost.Interprocess).
//
// Errors. StatusFromErrno is the only place an errno becomes a Status
// (lmdb.cc sends LMDB's errno-valued codes here too), so the same errno
// gives the same code and the same words wherever it arises:
// "<path>: cannot <action>: <strerror>". The table:
//
//   errno                        Status             why
//   ENOENT, ENOTDIR              NotFound           the file, or a folder on
//                                                   its way, does not exist
//                                                   (ENOTDIR: a component of
//                                                   the path is a regular file)
//   ENOSPC, EDQUOT, EFBIG,       ResourceExhausted  a disk, quota, file-size,
//   ENOMEM, EMFILE, ENFILE                          memory or descriptor budget
//                                                   is full: free some, retry
//   EISDIR                       InvalidArgument    the name given cannot be
//                                                   this file at all
//   ENAMETOOLONG                 IOError            the system's limit on a
//                                                   name (as Python's OSError)
//   EACCES, EPERM, EROFS, EIO    IOError            the name is fine and the
//   and every other errno                           system refused the read or
//                                                   write (permissions, a
//                                                   read-only mount, a failing
//                                                   device)
//
// Temporaries. Everything written on the way to an output OUT is named
//
//   OUT.tmp.<pid><suffix>   suffix empty, or beginning with '.' or '-'
//
//   OUT.tmp.<pid>           OUT until it is complete (AtomicFileWriter,
//                           TemporaryFile); a second writer of OUT in the
//                           same process (another thread) gets OUT.tmp.<pid>.2
//   OUT.tmp.<pid>-lock      LMDB's lock file beside it
//   OUT.tmp.<pid>.<role>    a scratch file of the command that writes OUT
//                           (TemporaryFile with a role: the dense store an
//                           `import --sparse` goes through, `.dense`; the raw
//                           field of a `convert --to dense`, `.field`), and
//                           `.<role>.tmp.<pid>` while that is being written
//
// A process that dies (kill -9, power loss) leaves only names of this
// pattern, never a half-written OUT; the next AtomicFileWriter::Create or
// PrepareOutput of the same OUT removes those of processes that no longer
// run.
//
// Thread safety: the free functions are reentrant. AtomicFileWriter::Append,
// WriteAt and Reserve may be called from several threads at once; Commit
// from one, after every write returned. Writers of the same output in one
// process get distinct temporaries; the last Commit wins. A TemporaryFile
// belongs to one thread. MappedFile is immutable.
#pragma once

#include <sys/stat.h>
#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "util/status.h"

namespace boost::interprocess {
class file_mapping;
class mapped_region;
}  // namespace boost::interprocess

namespace simplexdb {

// The Status for a system call that failed with errno `err` while doing
// `action` (a verb phrase: "open", "write", "set the size of") on `path`:
// the code from the table above, the message
// "<path>: cannot <action>: <strerror(err)>". REQUIRES: err != 0.
Status StatusFromErrno(int err, const std::string& path, const std::string& action);

// `<final_path>.tmp.<pid>`: the first temporary name of `final_path` in
// this process (the writers above add suffixes when it is taken).
std::string TemporaryPathFor(const std::string& final_path);

// True when `name` (a file name, no folder) is one of the temporaries of
// the output named `final_name` (no folder either), of any process.
bool IsTemporaryOf(std::string_view name, std::string_view final_name);

// What a file of `mode` (stat's st_mode) is when it is not a regular file
// ("a FIFO", "a character device", "a directory", ...), for messages that
// refuse it as an input or an output; nullptr for a regular file.
const char* KindOfNonRegularFile(mode_t mode);

// Removes the temporaries of `final_path` (every pattern above) left by
// processes that no longer run (exited ones not yet reaped included). Best
// effort: what cannot be listed or removed stays.
void RemoveStaleTemporaries(const std::string& final_path);

// What a command does before it writes anything for `final_path`: checks
// that its folder exists, so that a missing one is reported by the output's
// name and not a temporary's (NotFound: "<final_path>: cannot create: No
// such file or directory"; ENOTDIR when a component is a regular file);
// checks that `final_path` is nothing but a regular file or a new name, as
// ResolveOutput does without inputs or force (InvalidArgument otherwise:
// replacing a device, a FIFO, a socket, a folder or a symlink by a regular
// file destroys what was there); then removes the stale temporaries of
// `final_path`. Nothing is touched when it fails.
Status PrepareOutput(const std::string& final_path);

// How a command may write its output (ResolveOutput).
struct OutputOptions {
  // A symlink to a regular file is written through: its target is replaced
  // (atomically, as any output) and the link stays. Without it a symlink is
  // refused.
  bool force = false;
  // The files the command reads (every file of a time series): the output
  // must be none of them, by any name (hard link, symlink, `./x` for `x`).
  std::vector<std::string> inputs;
};

// The check a command makes on its output `path` before it writes anything
// (after opening its inputs, to know every file they name). Returns the
// path to write: `path` itself or, with options.force and `path` a symlink
// to a regular file, the file the link resolves to (absolute); write that
// path and the link stays a link.
// Errors (InvalidArgument, naming `path`, nothing touched):
//   "<path>: cannot write: is the input [<input>]"      same device and inode
//   "<path>: cannot write: is a character device"       and block device,
//                                                       FIFO, socket, folder
//   "<path>: cannot write: is a symlink (--force ...)"   without force
//   "<path>: cannot write: is a dangling symlink"       with or without force
// and the folder checks of PrepareOutput. An input that cannot be stat()ed
// is not compared (its reader reports it).
Result<std::string> ResolveOutput(const std::string& path, const OutputOptions& options);

// Renames `from` to `to` and flushes the directory (best effort: some file
// systems cannot sync a directory): after it returns, the file is durable
// under its new name. Errors name `to`.
Status RenameDurably(const std::string& from, const std::string& to);

class AtomicFileWriter {
 public:
  // PrepareOutput(final_path), then creates its temporary for writing
  // (mode 0644 less the umask). Errors name `final_path`: NotFound for a
  // missing folder, IOError when the folder refuses a new file (EACCES,
  // EROFS), ResourceExhausted when it has no room for one.
  static Result<std::unique_ptr<AtomicFileWriter>> Create(const std::string& final_path);

  // Unless committed, closes and removes the temporary: an output that
  // failed or was abandoned leaves nothing, and an earlier file of the same
  // name stays as it was.
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  // Writes `bytes` at a fresh offset at the end and returns that offset.
  // Errors (naming the final path): ResourceExhausted for a full disk,
  // IOError otherwise.
  Result<uint64_t> Append(std::span<const uint8_t> bytes);
  Result<uint64_t> Append(std::string_view text) {
    return Append({reinterpret_cast<const uint8_t*>(text.data()), text.size()});
  }
  // Writes `bytes` at `offset` (for a header written last, or parts written
  // by several threads). Same errors as Append.
  Status WriteAt(uint64_t offset, std::span<const uint8_t> bytes);
  // Reserves `size` bytes at the end (zero until written) and returns their
  // offset.
  uint64_t Reserve(uint64_t size) { return end_.fetch_add(size); }
  uint64_t size() const { return end_.load(); }

  // Sets the file's size to size(), flushes it to disk, renames it to the
  // final path and flushes the folder: after it returns OK, the output is
  // durable under its final name. On error the temporary is removed when
  // the writer goes away. REQUIRES: called once, with no write running.
  Status Commit();

  const std::string& final_path() const { return final_path_; }
  const std::string& temp_path() const { return temp_path_; }

 private:
  AtomicFileWriter(std::string final_path, std::string temp_path, int fd);

  std::string final_path_;
  std::string temp_path_;
  int fd_;
  std::atomic<uint64_t> end_{0};
  std::atomic<uint64_t> writeback_from_{0};  // Append has started the disk on what is before
  bool committed_ = false;
};

// Writes `bytes` as the whole of `path` through an AtomicFileWriter (for a
// small output made in memory: a JSON report, a .pvd collection). Errors:
// those of Create, Append and Commit.
Status WriteFileAtomically(const std::string& path, std::string_view bytes);

// A name in the temporaries' pattern that other code fills: LMDB writes its
// own file; a command writes a scratch file it needs on the way to its
// output. Unless committed, the file and LMDB's `<path()>-lock` are removed
// when this goes away (and by the next RemoveStaleTemporaries of the output
// if the process dies first). Creates no file itself.
class TemporaryFile {
 public:
  // With an empty `role`: the temporary of `final_path`, renamed into place
  // by Commit. With a role ("dense", "field"): the scratch file
  // `<final_path>.tmp.<pid>.<role>`, never committed. A leftover file of
  // the same name (from an earlier process with this pid) is removed.
  explicit TemporaryFile(const std::string& final_path, std::string_view role = {});
  ~TemporaryFile();
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;

  const std::string& path() const { return path_; }
  const std::string& final_path() const { return final_path_; }

  // RenameDurably(path(), final_path()), then removes `<path()>-lock`.
  // REQUIRES: no role; the file complete, flushed and closed (for LMDB:
  // Env::Sync() and the environment closed).
  Status Commit();

 private:
  std::string final_path_;
  std::string path_;
  bool committed_ = false;
};

// A scratch file for bytes a writer makes before it knows where they go
// (items of a store made out of its order, storage/dense/dense_writer.h):
// created as `<final_path>.tmp.<pid>.<role>` and unlinked at once, so it
// goes with the process however that ends (the caller has checked the
// output's folder: PrepareOutput). Append and ReadAt may be
// called from several threads at once. Errors name `final_path` and the
// scratch file, as AtomicFileWriter's.
class ScratchFile {
 public:
  static Result<std::unique_ptr<ScratchFile>> Create(const std::string& final_path, std::string_view role);
  ~ScratchFile();
  ScratchFile(const ScratchFile&) = delete;
  ScratchFile& operator=(const ScratchFile&) = delete;

  // Writes `bytes` at the end and returns their offset.
  Result<uint64_t> Append(std::span<const uint8_t> bytes);
  // Reads out.size() bytes from `offset`. REQUIRES: within what was appended.
  Status ReadAt(uint64_t offset, std::span<uint8_t> out) const;

 private:
  ScratchFile(std::string what, int fd) : what_(std::move(what)), fd_(fd) {}
  std::string what_;
  int fd_;
  std::atomic<uint64_t> end_{0};
};

// An existing file opened to write parts of it in place: another
// process's AtomicFileWriter temporary on a file system both see (the
// ranks of an MPI run writing one store). Errors name `path`.
class FilePartWriter {
 public:
  static Result<std::unique_ptr<FilePartWriter>> Open(const std::string& path);
  ~FilePartWriter();
  FilePartWriter(const FilePartWriter&) = delete;
  FilePartWriter& operator=(const FilePartWriter&) = delete;

  Status WriteAt(uint64_t offset, std::span<const uint8_t> bytes);
  // Flushes what was written to the disk (fdatasync).
  Status Sync();

 private:
  FilePartWriter(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  std::string path_;
  int fd_;
};

class MappingGuard;

// A file's modification time from fstat, in nanoseconds: the mark the
// readers of mapped files compare to see that it was written since.
int64_t ModifiedNs(const struct stat& st);

class MappedFile {
 public:
  // Maps `path` read-only. Many processes may map the same file. Errors:
  // the table above for a file that cannot be found or opened;
  // InvalidArgument when `path` is not a regular file; IOError when the
  // mapping fails. An empty file maps to zero bytes. The mapping is
  // guarded (storage/io/mapping_guard.h): a read past the end of a file
  // truncated under it reads zeros and marks it instead of raising SIGBUS.
  static Result<std::unique_ptr<MappedFile>> Open(const std::string& path);
  ~MappedFile();

  // Valid as long as this MappedFile.
  std::span<const uint8_t> bytes() const { return bytes_; }
  const std::string& path() const { return path_; }

  // OK while the file is as it was mapped: the same size and modification
  // time, and no read of the mapping has faulted. Else IOError "<path>:
  // the file changed after it was opened (<what>): open it again". Readers
  // ask before an operation (a truncated or rewritten file is refused
  // before anything is read) and after it (what was read while it changed
  // is not an answer). Cost: one fstat.
  Status CheckUnchanged() const;

 private:
  MappedFile() = default;
  std::string path_;
  std::unique_ptr<boost::interprocess::file_mapping> mapping_;
  std::unique_ptr<boost::interprocess::mapped_region> region_;
  std::span<const uint8_t> bytes_;
  int fd_ = -1;                // the mapped file, for fstat
  uint64_t size_ = 0;          // its size when mapped
  int64_t mtime_ns_ = 0;       // and its modification time
  MappingGuard* guard_ = nullptr;
};

// A new file of a given size mapped read-write, for scratch data larger than
// memory should hold (convert --to dense rebuilds the raw field in one).
// The file is removed when this goes away; name it with TemporaryFile so a
// killed process's copy is removed by the next run of the same output.
class WritableScratchMapping {
 public:
  // Creates `path` (truncating it) with `bytes` zero bytes and maps it.
  // Errors: the table above for a file that cannot be created or sized
  // (ResourceExhausted when the disk is full); IOError when the mapping
  // fails.
  static Result<std::unique_ptr<WritableScratchMapping>> Create(const std::string& path,
                                                                uint64_t bytes);
  // Unmaps and removes the file.
  ~WritableScratchMapping();

  // Valid as long as this object.
  std::byte* data() const { return data_; }
  const std::string& path() const { return path_; }
  // Writes the mapped pages to the file (before another reader opens it).
  Status Flush();

 private:
  explicit WritableScratchMapping(std::string path);
  std::string path_;
  std::unique_ptr<boost::interprocess::file_mapping> mapping_;
  std::unique_ptr<boost::interprocess::mapped_region> region_;
  std::byte* data_ = nullptr;
};

}  // namespace simplexdb
