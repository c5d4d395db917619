#include "storage/common/block_cache.h"

#include <atomic>
#include <cassert>

namespace simplexdb {

BlockCache::BlockCache(size_t capacity_bytes, int shards)
    : capacity_(capacity_bytes),
      shard_capacity_(capacity_bytes / static_cast<size_t>(shards)) {
  assert(shards >= 1);
  for (int i = 0; i < shards; ++i) shards_.push_back(std::make_unique<Shard>());
}

BlockCache::Shard& BlockCache::ShardOf(const Key& key) {
  // The high half picks the shard; the map's buckets use the low bits.
  return *shards_[(Mix(key) >> 32) % shards_.size()];
}

std::shared_ptr<const BlockCache::Block> BlockCache::Lookup(Key key) {
  Shard& s = ShardOf(key);
  std::lock_guard<std::mutex> lock(s.mu);
  const auto it = s.map.find(key);
  if (it == s.map.end()) {
    ++s.stats.misses;
    return nullptr;
  }
  ++s.stats.hits;
  s.lru.splice(s.lru.begin(), s.lru, it->second);
  return it->second->second;
}

std::shared_ptr<const BlockCache::Block> BlockCache::Insert(Key key,
                                                            std::shared_ptr<const Block> block) {
  Shard& s = ShardOf(key);
  std::lock_guard<std::mutex> lock(s.mu);
  const auto it = s.map.find(key);
  if (it != s.map.end()) {
    s.lru.splice(s.lru.begin(), s.lru, it->second);
    return it->second->second;
  }
  s.charge += block->size();
  s.lru.emplace_front(key, block);
  s.map.emplace(key, s.lru.begin());
  EvictOverBudget(s);
  return block;
}

void BlockCache::EvictOverBudget(Shard& s) {
  // Keep at least the newest entry, even if it alone exceeds the budget.
  while (s.charge > shard_capacity_ && s.lru.size() > 1) {
    auto& [key, block] = s.lru.back();
    s.charge -= block->size();
    s.map.erase(key);
    s.lru.pop_back();
    ++s.stats.evictions;
  }
}

size_t BlockCache::EraseStore(uint64_t store) {
  size_t erased = 0;
  for (const auto& s : shards_) {
    std::lock_guard<std::mutex> lock(s->mu);
    for (auto it = s->lru.begin(); it != s->lru.end();) {
      if (it->first.store != store) {
        ++it;
        continue;
      }
      s->charge -= it->second->size();
      s->map.erase(it->first);
      it = s->lru.erase(it);
      ++erased;
    }
  }
  return erased;
}

size_t BlockCache::charge() const {
  size_t total = 0;
  for (const auto& s : shards_) {
    std::lock_guard<std::mutex> lock(s->mu);
    total += s->charge;
  }
  return total;
}

BlockCache::Stats BlockCache::stats() const {
  Stats total;
  for (const auto& s : shards_) {
    std::lock_guard<std::mutex> lock(s->mu);
    total.hits += s->stats.hits;
    total.misses += s->stats.misses;
    total.evictions += s->stats.evictions;
  }
  return total;
}

uint64_t BlockCache::NewStoreId() {
  static std::atomic<uint64_t> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace simplexdb
