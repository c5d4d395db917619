// Mapped files that shrink under their readers: a fault, not a signal.
//
// A read of a mapped page past the end of a file that was truncated after
// it was mapped raises SIGBUS, which ends the process (a Python
// interpreter, a ParaView session, a server) before any check can run. The
// stores' mappings are registered here: a SIGBUS whose address lies in a
// registered range is absorbed by mapping a page of zeros over the
// faulting page and marking the range, and the read that faulted goes on
// with zeros. Every reader's data is checksummed (blocks, bricks, index,
// LMDB pages checked at open) and every operation asks MappedFile::
// CheckUnchanged (storage/io/file.h) or lmdb::Env::CheckUnchanged before
// and after it reads, so the zeros never become an answer: the operation
// fails with IOError naming the file. A SIGBUS elsewhere goes to the
// handler that was installed before (the default one ends the process as
// before).
//
// The handler is installed when the first range is registered and stays
// for the life of the process; a program that installs its own SIGBUS
// handler afterwards and does not chain to ours gets its signals back for
// our ranges too (the checks before each operation still refuse a file
// that shrank, so only a truncation during an operation would then end
// it).
//
// Thread safety: Register, Unregister and Faulted may be called from any
// thread; the handler reads the table without locks.
// Cost: nothing on the reads; Register and Unregister scan a fixed table
// of 1024 ranges (more open mappings than that are simply not guarded).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace simplexdb {

class MappingGuard {
 public:
  // Guards [base, base + bytes) until Unregister. Returns null when the
  // table is full or bytes is 0 (then the range is not guarded).
  static MappingGuard* Register(const void* base, size_t bytes);
  // Guards the mapping of the file open as `fd` that another library made
  // (LMDB's map: it does not say where it is), found in /proc/self/maps by
  // the file's device and inode. Null when it is not mapped, or as Register.
  static MappingGuard* RegisterMappingOf(int fd);
  // REQUIRES: `guard` from Register, not yet unregistered, and no read of
  // the range in flight (call before unmapping it).
  static void Unregister(MappingGuard* guard);

  // Whether a read of the range has faulted since Register (the file
  // shrank under it). `guard` may be null (an unguarded range): false.
  static bool Faulted(const MappingGuard* guard);

  // One entry of the table (public for the table's own definition).
  std::atomic<uintptr_t> begin{0}, end{0};  // 0, 0: free
  std::atomic<bool> taken{false};
  std::atomic<bool> faulted{false};
};

}  // namespace simplexdb
