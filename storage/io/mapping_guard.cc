#include "storage/io/mapping_guard.h"

#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <array>
#include <cinttypes>
#include <cstdio>
#include <mutex>

namespace simplexdb {
namespace {

constexpr size_t kRanges = 1024;
std::array<MappingGuard, kRanges> g_ranges;
struct sigaction g_previous;  // the disposition before ours
std::once_flag g_installed;

// Passes a signal that is not ours to what was there before.
void Chain(int sig, siginfo_t* info, void* context) {
  if ((g_previous.sa_flags & SA_SIGINFO) != 0 && g_previous.sa_sigaction != nullptr) {
    g_previous.sa_sigaction(sig, info, context);
    return;
  }
  if (g_previous.sa_handler != SIG_DFL && g_previous.sa_handler != SIG_IGN &&
      g_previous.sa_handler != nullptr) {
    g_previous.sa_handler(sig);
    return;
  }
  // The default action: a fault comes back when the instruction runs again
  // and ends the process as it would have; a signal sent by kill is raised
  // again.
  signal(sig, SIG_DFL);
  if (info == nullptr || info->si_code <= 0) raise(sig);
}

// Async-signal-safe: atomics, mmap, the chain above.
void OnSigbus(int sig, siginfo_t* info, void* context) {
  const auto address = reinterpret_cast<uintptr_t>(info == nullptr ? nullptr : info->si_addr);
  if (info != nullptr && info->si_code > 0) {
    for (MappingGuard& r : g_ranges) {
      const uintptr_t begin = r.begin.load(std::memory_order_acquire);
      if (begin == 0 || address < begin || address >= r.end.load(std::memory_order_acquire)) continue;
      const auto page_size = static_cast<uintptr_t>(sysconf(_SC_PAGESIZE));
      void* page = reinterpret_cast<void*>(address & ~(page_size - 1));
      // Zeros over the page that is no longer in the file; the read goes on.
      if (mmap(page, page_size, PROT_READ, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1, 0) != MAP_FAILED) {
        r.faulted.store(true, std::memory_order_release);
        return;
      }
      break;
    }
  }
  Chain(sig, info, context);
}

void Install() {
  struct sigaction action {};
  action.sa_sigaction = OnSigbus;
  action.sa_flags = SA_SIGINFO | SA_NODEFER;
  sigemptyset(&action.sa_mask);
  sigaction(SIGBUS, &action, &g_previous);
}

}  // namespace

MappingGuard* MappingGuard::Register(const void* base, size_t bytes) {
  if (base == nullptr || bytes == 0) return nullptr;
  std::call_once(g_installed, Install);
  for (MappingGuard& r : g_ranges) {
    bool expected = false;
    if (!r.taken.compare_exchange_strong(expected, true, std::memory_order_acq_rel)) continue;
    r.faulted.store(false, std::memory_order_relaxed);
    r.end.store(reinterpret_cast<uintptr_t>(base) + bytes, std::memory_order_release);
    r.begin.store(reinterpret_cast<uintptr_t>(base), std::memory_order_release);
    return &r;
  }
  return nullptr;  // more open mappings than the table holds: not guarded
}

MappingGuard* MappingGuard::RegisterMappingOf(int fd) {
  struct stat st;
  if (fstat(fd, &st) != 0) return nullptr;
  FILE* maps = std::fopen("/proc/self/maps", "r");
  if (maps == nullptr) return nullptr;
  MappingGuard* guard = nullptr;
  char line[4096];
  while (guard == nullptr && std::fgets(line, sizeof line, maps) != nullptr) {
    // "begin-end perms offset major:minor inode path"
    uintptr_t begin = 0, end = 0;
    unsigned major_id = 0, minor_id = 0;
    uint64_t offset = 0, inode = 0;
    char perms[8] = {};
    if (std::sscanf(line, "%" SCNxPTR "-%" SCNxPTR " %7s %" SCNx64 " %x:%x %" SCNu64, &begin, &end, perms,
                    &offset, &major_id, &minor_id, &inode) != 7) {
      continue;
    }
    if (inode == st.st_ino && major_id == major(st.st_dev) && minor_id == minor(st.st_dev) && offset == 0) {
      guard = Register(reinterpret_cast<const void*>(begin), end - begin);
    }
  }
  std::fclose(maps);
  return guard;
}

void MappingGuard::Unregister(MappingGuard* guard) {
  if (guard == nullptr) return;
  guard->begin.store(0, std::memory_order_release);
  guard->end.store(0, std::memory_order_release);
  guard->taken.store(false, std::memory_order_release);
}

bool MappingGuard::Faulted(const MappingGuard* guard) {
  return guard != nullptr && guard->faulted.load(std::memory_order_acquire);
}

}  // namespace simplexdb
