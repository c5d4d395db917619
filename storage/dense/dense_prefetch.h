// Work ahead of an out-of-core walk, on another core: a walk that takes the
// store a region at a time (query/refine.h, DepthFirstByRegion) names the
// region it takes up next and the nodes waiting there; a RegionPrefetcher
// walks that region ahead on its own thread and reader while the walk is
// busy with the region before: from the waiting nodes down, a node's
// children in the same region when its error exceeds the threshold. That
// is the walk's own descent there but for the splits that conformity
// forces, so what the walk would pay for later is paid ahead: the bricks
// around the region's finest box decoded into the store's cache and the
// finest errors the walk will ask for computed into the box that readers
// share (DenseStore::FinestCodes). Nothing it computes differs from what
// the walk would: the same readers, the same cache, no mesh of its own.
//
// Thread safety: Ahead() and the destructor are for one thread (the walk's);
// the prefetcher's thread reads the store as any other reader does
// (DenseStore: any number of readers at once).
// Lifetimes: the store outlives the prefetcher; the destructor stops and
// joins the thread.
// Errors: none reported. A lookup that fails ahead (a damaged block) is
// left for the walk, which meets the same failure and reports it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "storage/dense/dense_store.h"

namespace simplexdb {

template <int D>
class RegionPrefetcher {
 public:
  // REQUIRES: store.dimension() == D; the store outlives the prefetcher.
  explicit RegionPrefetcher(const DenseStore& store);
  ~RegionPrefetcher();
  RegionPrefetcher(const RegionPrefetcher&) = delete;
  RegionPrefetcher& operator=(const RegionPrefetcher&) = delete;

  // Walks `region` (DenseStore::Reader::Region) ahead from `codes`, a LIFO
  // list as the walk keeps it (the last taken first), with `threshold` as the query's
  // (DenseStore::Reader::ErrorBoundForThreshold); drops whatever is left
  // of the previous call's walk. Returns at once (copies the codes).
  void Ahead(uint64_t region, std::span<const SimplexCode<D>> codes, double threshold);

  // Nodes looked up ahead so far (for tests and statistics).
  uint64_t looked_up() const;

 private:
  void Run();

  const DenseStore& store_;
  mutable std::mutex mu_;
  std::condition_variable wake_;
  std::vector<SimplexCode<D>> next_;  // under mu_: the newest request
  double next_threshold_ = 0;
  uint64_t next_region_ = 0;
  // Requests made (written under mu_): the thread drops a request as soon
  // as a newer one is made.
  std::atomic<uint64_t> generation_{0};
  bool stop_ = false;  // under mu_
  std::atomic<uint64_t> looked_up_{0};
  std::thread thread_;       // last: starts after the rest is made
};

extern template class RegionPrefetcher<3>;
extern template class RegionPrefetcher<4>;

}  // namespace simplexdb
