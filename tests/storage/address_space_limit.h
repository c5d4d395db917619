// An address-space limit (RLIMIT_AS) for tests that prove a reader or a
// command fails on a huge claim without trying to allocate it: under the
// limit, an attempted allocation of gigabytes throws bad_alloc (or the
// command exits 70) instead of passing slowly on a machine with the memory.
//
// Sanitizers reserve terabytes of shadow memory, so under them the limit is
// not set (kAddressSpaceLimited is false) and the tests check only results.
#pragma once

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <new>
#include <string>

#include <gtest/gtest.h>

namespace simplexdb::testing {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kAddressSpaceLimited = false;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
inline constexpr bool kAddressSpaceLimited = false;
#else
inline constexpr bool kAddressSpaceLimited = true;
#endif
#else
inline constexpr bool kAddressSpaceLimited = true;
#endif

inline constexpr uint64_t kOneGiB = uint64_t{1} << 30;

// Lowers this process's soft RLIMIT_AS for its lifetime (children started
// meanwhile inherit it), then restores it.
class ScopedAddressSpaceLimit {
 public:
  explicit ScopedAddressSpaceLimit(uint64_t bytes) {
    if (!kAddressSpaceLimited) return;
    EXPECT_EQ(getrlimit(RLIMIT_AS, &saved_), 0) << std::strerror(errno);
    rlimit lowered = saved_;
    if (saved_.rlim_cur == RLIM_INFINITY || saved_.rlim_cur > bytes) lowered.rlim_cur = bytes;
    EXPECT_EQ(setrlimit(RLIMIT_AS, &lowered), 0) << std::strerror(errno);
    set_ = true;
  }
  ~ScopedAddressSpaceLimit() {
    if (set_) setrlimit(RLIMIT_AS, &saved_);
  }
  ScopedAddressSpaceLimit(const ScopedAddressSpaceLimit&) = delete;
  ScopedAddressSpaceLimit& operator=(const ScopedAddressSpaceLimit&) = delete;

 private:
  rlimit saved_{};
  bool set_ = false;
};

// What a child process reported: `text` when it ran to the end, or why not.
struct LimitedRun {
  bool finished = false;  // ran `fn` to its end and reported
  bool bad_alloc = false;  // an allocation failed under the limit
  int wait_status = 0;
  std::string text;
};

// Runs `fn` (returning a std::string) in a forked child under an
// address-space limit of `bytes`, and returns what it returned.
template <class F>
LimitedRun RunUnderAddressSpaceLimit(uint64_t bytes, F fn) {
  int fds[2];
  LimitedRun run;
  if (pipe(fds) != 0) {
    ADD_FAILURE() << "pipe: " << std::strerror(errno);
    return run;
  }
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    int code = 0;
    try {
      ScopedAddressSpaceLimit limit(bytes);
      const std::string text = fn();
      size_t done = 0;
      while (done < text.size()) {
        const ssize_t n = write(fds[1], text.data() + done, text.size() - done);
        if (n <= 0) break;
        done += static_cast<size_t>(n);
      }
    } catch (const std::bad_alloc&) {
      code = 3;
    } catch (...) {
      code = 4;
    }
    close(fds[1]);
    _exit(code);
  }
  close(fds[1]);
  char buf[4096];
  ssize_t n;
  while ((n = read(fds[0], buf, sizeof buf)) > 0) run.text.append(buf, static_cast<size_t>(n));
  close(fds[0]);
  waitpid(pid, &run.wait_status, 0);
  run.finished = WIFEXITED(run.wait_status) && WEXITSTATUS(run.wait_status) == 0;
  run.bad_alloc = WIFEXITED(run.wait_status) && WEXITSTATUS(run.wait_status) == 3;
  return run;
}

}  // namespace simplexdb::testing
