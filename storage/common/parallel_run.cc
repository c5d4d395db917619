#include "storage/common/parallel_run.h"

#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include "util/out_of_memory.h"

namespace simplexdb {

using Clock = std::chrono::steady_clock;

Status RunParallel(uint64_t count, int threads, const char* phase, Clock::time_point start,
                   const std::function<void(const BuildProgress&)>& progress,
                   const std::function<Status(int worker, uint64_t item)>& work) {
  std::atomic<uint64_t> next{0};
  std::atomic<uint64_t> done{0};
  std::atomic<bool> failed{false};
  std::mutex mu;
  std::condition_variable finished;
  int running = threads;
  Status first_failure;
  // Out of memory, recorded without allocating (a message is made once the
  // workers are joined): the item that threw, the thread that did not start.
  constexpr uint64_t kNone = ~uint64_t{0};
  std::atomic<uint64_t> item_out_of_memory{kNone};
  int thread_not_started = 0;
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(threads));
  const auto worker = [&](int w) {
    while (!failed.load(std::memory_order_relaxed)) {
      const uint64_t item = next.fetch_add(1);
      if (item >= count) break;
      Status s;
      try {
        s = work(w, item);
      } catch (const std::bad_alloc&) {
        // Out of a worker thread an exception would end the process, and
        // making a message here could throw again.
        uint64_t none = kNone;
        item_out_of_memory.compare_exchange_strong(none, item);
        failed.store(true);
        break;
      }
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(mu);
        if (!failed.exchange(true)) first_failure = std::move(s);
        break;
      }
      done.fetch_add(1, std::memory_order_relaxed);
    }
    std::lock_guard<std::mutex> lock(mu);
    if (--running == 0) finished.notify_all();
  };
  for (int w = 0; w < threads; ++w) {
    try {
      pool.emplace_back(worker, w);
    } catch (const std::exception&) {
      // std::system_error or std::bad_alloc: no room for another thread's
      // stack or state (ulimit -v). Fail the run; the
      // workers started so far stop at once and are joined below.
      std::lock_guard<std::mutex> lock(mu);
      if (!failed.exchange(true)) thread_not_started = w + 1;
      running -= threads - w;
      if (running == 0) finished.notify_all();
      break;
    }
  }
  if (progress) {
    // Report a few times a second; wake as soon as the workers are done.
    std::unique_lock<std::mutex> lock(mu);
    while (!finished.wait_for(lock, std::chrono::milliseconds(200), [&] { return running == 0; })) {
      lock.unlock();
      const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
      progress(BuildProgress{phase, done.load(), count, seconds});
      lock.lock();
    }
  }
  for (auto& t : pool) t.join();
  if (first_failure.ok() && thread_not_started > 0) {
    return NotEnoughMemory("the " + std::string(phase) + " work's thread " +
                               std::to_string(thread_not_started) + " of " + std::to_string(threads),
                           "its stack");
  }
  if (first_failure.ok() && item_out_of_memory.load() != kNone) {
    return NotEnoughMemory("the " + std::string(phase) + " work, item " +
                               std::to_string(item_out_of_memory.load()) + " of " +
                               std::to_string(count),
                           "a worker's buffers");
  }
  if (progress && !failed.load()) {
    progress(BuildProgress{phase, count, count,
                                std::chrono::duration<double>(Clock::now() - start).count()});
  }
  return first_failure;
}

}  // namespace simplexdb
