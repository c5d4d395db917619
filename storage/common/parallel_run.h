// RunParallel: the dense builder's work loop. Items 0..count-1 go to
// `threads` workers in order of a shared counter (each item to exactly one
// worker); the calling thread reports progress meanwhile.
//
// Thread safety: `work` is called concurrently from the workers, at most
// once per item, with the worker's index (0..threads-1) so it can keep
// per-worker state without locks. `progress` is called from the calling
// thread only, a few times a second and once at the end (done == count)
// when every item succeeded.
// Lifetimes: nothing is kept after the call returns; the workers are joined.
// Errors: the first failed item's Status (ResourceExhausted "not enough
// memory for ..." when an item throws std::bad_alloc or a worker thread
// cannot start); the workers stop taking items
// after a failure (items already running finish).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>

#include "storage/error/progress.h"
#include "util/status.h"

namespace simplexdb {

// `phase` names the work in the progress records; `start` is when the
// build began (progress reports seconds since then).
// REQUIRES: threads >= 1.
Status RunParallel(uint64_t count, int threads, const char* phase,
                   std::chrono::steady_clock::time_point start,
                   const std::function<void(const BuildProgress&)>& progress,
                   const std::function<Status(int worker, uint64_t item)>& work);

}  // namespace simplexdb
