#include "storage/dense/dense_prefetch.h"

namespace simplexdb {

template <int D>
RegionPrefetcher<D>::RegionPrefetcher(const DenseStore& store)
    : store_(store), thread_([this] { Run(); }) {}

template <int D>
RegionPrefetcher<D>::~RegionPrefetcher() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
    generation_.fetch_add(1, std::memory_order_relaxed);
  }
  wake_.notify_one();
  thread_.join();
}

template <int D>
void RegionPrefetcher<D>::Ahead(uint64_t region, std::span<const SimplexCode<D>> codes, double threshold) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    next_.assign(codes.begin(), codes.end());  // the walk's LIFO order
    next_region_ = region;
    next_threshold_ = threshold;
    generation_.fetch_add(1, std::memory_order_relaxed);
  }
  wake_.notify_one();
}

template <int D>
uint64_t RegionPrefetcher<D>::looked_up() const {
  return looked_up_.load(std::memory_order_relaxed);
}

template <int D>
void RegionPrefetcher<D>::Run() {
  DenseStore::Reader<D> reader(store_);
  std::vector<SimplexCode<D>> stack;
  uint64_t done = 0;  // the generation last taken
  while (true) {
    double threshold = 0;
    uint64_t region = 0;
    {
      std::unique_lock<std::mutex> lock(mu_);
      wake_.wait(lock, [&] { return stop_ || generation_.load(std::memory_order_relaxed) != done; });
      if (stop_) return;
      done = generation_.load(std::memory_order_relaxed);
      stack.swap(next_);
      next_.clear();
      threshold = next_threshold_;
      region = next_region_;
    }
    uint64_t n = 0;
    while (!stack.empty() && generation_.load(std::memory_order_relaxed) == done) {
      const SimplexCode<D> c = stack.back();
      stack.pop_back();
      ++n;
      // A failure is the walk's to meet and report (see the header).
      const Result<double> e = reader.ErrorBoundForThreshold(c, threshold);
      if (!e.ok() || !(*e > threshold)) continue;
      const uint64_t both = reader.ChildrenRegion(c);
      for (const SimplexCode<D> child : {c.child(1), c.child(0)}) {
        if ((both == DenseStore::Reader<D>::kPerChild ? reader.Region(child) : both) == region) {
          stack.push_back(child);
        }
      }
    }
    stack.clear();
    looked_up_.fetch_add(n, std::memory_order_relaxed);
  }
}

template class RegionPrefetcher<3>;
template class RegionPrefetcher<4>;

}  // namespace simplexdb
