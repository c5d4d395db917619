// A bounded, thread-safe cache of decoded blocks, shared by the readers of
// one or more stores.
//
// The budget is in bytes of decoded data. Blocks are shared_ptr's: a block
// evicted while a reader still holds it stays alive until the reader lets
// go, so memory in use is the budget plus the blocks readers hold right now
// (a reader holds a handful). Eviction is least-recently-used per shard;
// keys spread over shards by hash, so contention stays low with many
// threads.
//
// Thread safety: every method may be called concurrently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace simplexdb {

class BlockCache {
 public:
  using Block = std::vector<uint8_t>;

  // REQUIRES: shards >= 1.
  explicit BlockCache(size_t capacity_bytes, int shards = 16);

  // The block cached under `key`, or null.
  std::shared_ptr<const Block> Lookup(uint64_t key);

  // Caches `block` under `key` and returns what the cache now holds for the
  // key: another thread may have inserted the same block first.
  std::shared_ptr<const Block> Insert(uint64_t key, std::shared_ptr<const Block> block);

  size_t capacity() const { return capacity_; }
  // Bytes currently charged (decoded blocks held by the cache).
  size_t charge() const;

  struct Stats {
    uint64_t hits = 0;
    uint64_t misses = 0;
    uint64_t evictions = 0;
  };
  Stats stats() const;

  // A fresh key space for a store: keys are (store id << 48) | block.
  static uint64_t NewStoreId();

 private:
  struct Shard {
    std::mutex mu;
    std::list<std::pair<uint64_t, std::shared_ptr<const Block>>> lru;  // front: newest
    std::unordered_map<uint64_t, decltype(lru)::iterator> map;
    size_t charge = 0;
    Stats stats;
  };
  Shard& ShardOf(uint64_t key);
  void EvictOverBudget(Shard& s);

  size_t capacity_;
  size_t shard_capacity_;
  std::vector<std::unique_ptr<Shard>> shards_;
};

}  // namespace simplexdb
