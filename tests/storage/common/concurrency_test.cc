// Stores are read by many threads and processes at once; the block cache
// stays within its budget.
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <map>
#include <random>
#include <thread>

#include "storage/common/block_cache.h"
#include "storage/dense/dense_prefetch.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/generate.h"
#include "tests/storage/common/smooth_store.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::SmoothHtStore;
using testing::TempDir;

// 33^3, 1 KiB blocks that compress.
struct Fixture {
  TempDir dir;
  SmoothHtStore store{dir.path(), "s", 33, GenerateOptions{}.seed, /*block_bits=*/9};
};

TEST(Concurrency, ThreadsShareAStoreAndASmallCache) {
  const Fixture f;
  DenseStore::Options options;
  options.cache_bytes = 16 << 10;  // far smaller than the store: constant eviction
  auto store = *DenseStore::Open(f.store.path, options);
  std::vector<std::thread> threads;
  std::atomic<int> mismatches{0};
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      DenseStore::Reader<3> reader(*store);
      std::mt19937_64 rng(t);
      for (int i = 0; i < 20000; ++i) {
        const size_t k = rng() % f.store.codes.size();
        const Result<double> e = reader.ErrorBound(f.store.codes[k]);
        if (!e.ok() || *e != f.store.expected[k]) ++mismatches;
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(mismatches.load(), 0);
  EXPECT_GT(store->stats().blocks_decoded, 100u);
  EXPECT_LE(store->cache()->charge(), options.cache_bytes + 4 * 1024)
      << "the cache exceeds its budget by more than a few blocks";
}

// A walk's reader and a RegionPrefetcher working ahead of it share a store
// and a small cache: the walk reads every bound as a lone reader does,
// region by region, while the prefetcher walks the region after; and a
// prefetcher dropped in the middle of its work stops.
TEST(Concurrency, APrefetcherWorksAheadOfAWalk) {
  // 65^3 (125 grid bricks): a cache of 16 KiB is small enough for regions
  // (DenseStore::RegionWalkPays).
  struct {
    TempDir dir;
    SmoothHtStore store{dir.path(), "s", 65, GenerateOptions{}.seed, /*block_bits=*/9};
  } f;
  DenseStore::Options options;
  options.cache_bytes = 16 << 10;
  auto store = *DenseStore::Open(f.store.path, options);
  DenseStore::Reader<3> reader(*store);
  ASSERT_TRUE(reader.has_regions());
  // The nodes of the last octave by region (Morton order), the others apart.
  std::map<uint64_t, std::vector<size_t>> regions;
  for (size_t k = 0; k < f.store.codes.size(); ++k) regions[reader.Region(f.store.codes[k])].push_back(k);
  ASSERT_GE(regions.size(), 100u);  // 125 grid bricks, and kAnyRegion
  int mismatches = 0;
  {
    RegionPrefetcher<3> ahead(*store);
    for (auto it = regions.begin(); it != regions.end(); ++it) {
      if (const auto next = std::next(it); next != regions.end()) {
        std::vector<TetCode> codes;
        for (const size_t k : next->second) codes.push_back(f.store.codes[k]);
        ahead.Ahead(next->first, codes, /*threshold=*/0);
      }
      for (const size_t k : it->second) {
        const Result<double> e = reader.ErrorBound(f.store.codes[k]);
        if (!e.ok() || *e != f.store.expected[k]) ++mismatches;
      }
    }
    EXPECT_GT(ahead.looked_up(), 0u);
  }
  EXPECT_EQ(mismatches, 0);
  // Dropped at once with all of the store to walk: the destructor returns.
  auto again = *DenseStore::Open(f.store.path, options);
  {
    RegionPrefetcher<3> ahead(*again);
    ahead.Ahead(regions.rbegin()->first, f.store.codes, 0);
  }
  EXPECT_LE(store->cache()->charge(), options.cache_bytes + 4 * 1024);
}

TEST(Concurrency, ProcessesOpenTheSameStore) {
  const Fixture f;
  std::vector<pid_t> children;
  for (int p = 0; p < 4; ++p) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      // In the child: no gtest assertions, just an exit status.
      auto store = DenseStore::Open(f.store.path);
      if (!store.ok()) _exit(2);
      DenseStore::Reader<3> reader(**store);
      for (size_t k = 0; k < f.store.codes.size(); ++k) {
        const Result<double> e = reader.ErrorBound(f.store.codes[k]);
        if (!e.ok() || *e != f.store.expected[k]) _exit(1);
      }
      _exit((*store)->Verify().ok() ? 0 : 3);
    }
    children.push_back(pid);
  }
  for (pid_t pid : children) {
    int status = 0;
    waitpid(pid, &status, 0);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
  }
}

TEST(BlockCache, EvictsLeastRecentlyUsedWithinBudget) {
  BlockCache cache(10 * 100, /*shards=*/1);
  const auto K = [](uint64_t block) { return BlockCache::Key{1, block}; };
  const auto block = [](uint8_t v) { return std::make_shared<const BlockCache::Block>(100, v); };
  for (uint64_t k = 0; k < 10; ++k) cache.Insert(K(k), block(static_cast<uint8_t>(k)));
  EXPECT_EQ(cache.charge(), 1000u);
  ASSERT_NE(cache.Lookup(K(0)), nullptr);  // 0 is now the most recent
  cache.Insert(K(10), block(10));          // evicts 1, the least recent
  EXPECT_EQ(cache.Lookup(K(1)), nullptr);
  EXPECT_NE(cache.Lookup(K(0)), nullptr);
  EXPECT_EQ(cache.charge(), 1000u);
  // A block held by a reader survives its eviction.
  std::shared_ptr<const BlockCache::Block> held = cache.Lookup(K(2));
  for (uint64_t k = 100; k < 120; ++k) cache.Insert(K(k), block(1));
  EXPECT_EQ(cache.Lookup(K(2)), nullptr);
  EXPECT_EQ((*held)[0], 2);
  // Inserting a key twice keeps the first block.
  auto first = cache.Insert(K(500), block(5));
  auto second = cache.Insert(K(500), block(6));
  EXPECT_EQ(first, second);
  const BlockCache::Stats s = cache.stats();
  EXPECT_GT(s.evictions, 10u);
  EXPECT_GT(s.hits, 0u);
}

}  // namespace
}  // namespace simplexdb
