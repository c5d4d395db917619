// Stores sharing one BlockCache: store ids never wrap, so one store is never
// served another's blocks, and a closed store leaves nothing in the cache.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "storage/common/block_cache.h"
#include "storage/dense/dense_store.h"
#include "tests/storage/common/smooth_store.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/sanitizer.h"

namespace simplexdb {
namespace {

using testing::SmoothHtStore;
using testing::TempDir;

// A 17^3 HT store of a smooth field (seeded) in small zstd blocks, and the
// error bound of every internal node as read from it alone.
struct SmallStore : SmoothHtStore {
  SmallStore(const TempDir& dir, const std::string& name, uint64_t seed)
      : SmoothHtStore(dir.path(), name, 17, seed, /*block_bits=*/7) {}

  // Nodes whose bound read through `store` differs from the store's own.
  int Mismatches(const DenseStore& store) const {
    DenseStore::Reader<3> reader(store);
    int bad = 0;
    for (size_t k = 0; k < codes.size(); ++k) {
      const Result<double> e = reader.ErrorBound(codes[k]);
      if (!e.ok() || *e != expected[k]) ++bad;
    }
    return bad;
  }
};

DenseStore::Options Shared(const std::shared_ptr<BlockCache>& cache) {
  DenseStore::Options o;
  o.cache = cache;
  return o;
}

// The old ids were 16 bits: the 65,537th store opened after `a` took a's
// key space and read a's decoded blocks as its own.
TEST(BlockCacheSharing, StoreIdsDoNotWrapAfter65536Opens) {
  // 65,536 opens check the id counter, not memory (ClosingAStoreErasesItsBlocks
  // and the concurrency tests give the sanitizer the cache's lifetimes): a
  // minute under AddressSanitizer, seven seconds in the release run.
  if (testing::UnderAddressSanitizer()) GTEST_SKIP() << "the release run covers it";
  const TempDir dir;
  const SmallStore a(dir, "a", 1);
  const SmallStore b(dir, "b", 2);
  ASSERT_EQ(a.codes, b.codes);
  ASSERT_NE(a.expected, b.expected) << "the two stores must differ";
  auto cache = std::make_shared<BlockCache>(size_t{64} << 20);
  auto store_a = *DenseStore::Open(a.path, Shared(cache));
  ASSERT_EQ(a.Mismatches(*store_a), 0);  // a's blocks are now in the cache
  ASSERT_GT(store_a->stats().blocks_decoded, 0u) << "the store must have zstd blocks";
  // Open (and close) 65,535 more stores: each open draws one store id.
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 65535; ++i) {
    auto s = DenseStore::Open(b.path, Shared(cache));
    ASSERT_TRUE(s.ok()) << s.status().ToString();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RecordProperty("seconds_for_65535_opens", std::to_string(seconds));
  auto store_b = *DenseStore::Open(b.path, Shared(cache));
  EXPECT_EQ(b.Mismatches(*store_b), 0) << "b was served a's blocks";
  EXPECT_EQ(a.Mismatches(*store_a), 0) << "a was served b's blocks";
}

TEST(BlockCacheSharing, ClosingAStoreErasesItsBlocks) {
  const TempDir dir;
  const SmallStore a(dir, "a", 1);
  const SmallStore b(dir, "b", 2);
  auto cache = std::make_shared<BlockCache>(size_t{64} << 20);
  auto store_b = *DenseStore::Open(b.path, Shared(cache));
  ASSERT_EQ(b.Mismatches(*store_b), 0);
  const size_t b_charge = cache->charge();
  ASSERT_GT(b_charge, 0u);
  {
    auto store_a = *DenseStore::Open(a.path, Shared(cache));
    ASSERT_EQ(a.Mismatches(*store_a), 0);
    EXPECT_GT(cache->charge(), b_charge);
  }
  // a's blocks are gone; b's stay and are still hits.
  EXPECT_EQ(cache->charge(), b_charge);
  const BlockCache::Stats before = cache->stats();
  ASSERT_EQ(b.Mismatches(*store_b), 0);
  EXPECT_EQ(cache->stats().misses, before.misses) << "b's blocks were erased too";
  store_b.reset();
  EXPECT_EQ(cache->charge(), 0u);
}

TEST(BlockCache, KeysDifferingOnlyAbove16BitsAreDistinct) {
  BlockCache cache(size_t{1} << 20, /*shards=*/4);
  const auto block = [](uint8_t v) { return std::make_shared<const BlockCache::Block>(8, v); };
  // The old keys were (id & 0xFFFF) << 48 | block: these three collided.
  const uint64_t ids[] = {7, 7 + (uint64_t{1} << 16), 7 + (uint64_t{1} << 40)};
  for (int i = 0; i < 3; ++i) cache.Insert({ids[i], 3}, block(static_cast<uint8_t>(i)));
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(ids[i]);
    const auto hit = cache.Lookup({ids[i], 3});
    ASSERT_NE(hit, nullptr);
    EXPECT_EQ((*hit)[0], i);
  }
  // Block numbers past 48 bits stay apart from the store id too.
  cache.Insert({1, uint64_t{1} << 48}, block(9));
  EXPECT_EQ(cache.Lookup({2, 0}), nullptr);
  // Ids are fresh and never 0 (the builder's private cache uses 0).
  const uint64_t first = BlockCache::NewStoreId();
  const uint64_t second = BlockCache::NewStoreId();
  EXPECT_NE(first, 0u);
  EXPECT_GT(second, first);
}

TEST(BlockCache, EraseStoreDropsOnlyThatStoresBlocks) {
  BlockCache cache(size_t{1} << 20, /*shards=*/4);
  const auto block = [](uint8_t v) { return std::make_shared<const BlockCache::Block>(100, v); };
  for (uint64_t b = 0; b < 50; ++b) {
    cache.Insert({1, b}, block(1));
    cache.Insert({2, b}, block(2));
  }
  EXPECT_EQ(cache.charge(), 100u * 100);
  const auto held = cache.Lookup({1, 7});
  EXPECT_EQ(cache.EraseStore(1), 50u);
  EXPECT_EQ(cache.charge(), 50u * 100);
  for (uint64_t b = 0; b < 50; ++b) {
    EXPECT_EQ(cache.Lookup({1, b}), nullptr);
    EXPECT_NE(cache.Lookup({2, b}), nullptr);
  }
  EXPECT_EQ((*held)[0], 1) << "a block a reader holds outlives EraseStore";
  EXPECT_EQ(cache.EraseStore(1), 0u);
  EXPECT_EQ(cache.EraseStore(2), 50u);
  EXPECT_EQ(cache.charge(), 0u);
  EXPECT_EQ(cache.stats().evictions, 0u) << "erasing is not eviction";
}

}  // namespace
}  // namespace simplexdb
