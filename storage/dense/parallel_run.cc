#include "storage/dense/parallel_run.h"

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
        // Out of a worker thread an exception would end the process.
        s = NotEnoughMemory("the " + std::string(phase) + " work, item " +
                                std::to_string(item) + " of " + std::to_string(count),
                            "a worker's buffers");
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
      if (!failed.exchange(true)) {
        first_failure = NotEnoughMemory("the " + std::string(phase) + " work's thread " +
                                            std::to_string(w + 1) + " of " +
                                            std::to_string(threads),
                                        "its stack");
      }
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
  if (progress && !failed.load()) {
    progress(BuildProgress{phase, count, count,
                                std::chrono::duration<double>(Clock::now() - start).count()});
  }
  return first_failure;
}

}  // namespace simplexdb
