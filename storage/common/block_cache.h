// A bounded, thread-safe cache of decoded blocks, shared by the readers of
// one or more stores.
//
// Keys: a block is cached under {store id, block number}. Every store draws
// its id from NewStoreId(), a 64-bit counter that is never reset, so ids are
// never reused within a process and stores sharing a cache never see each
// other's blocks. A store calls EraseStore(its id) when it is closed, so a
// long-running process that opens stores repeatedly does not fill a shared
// cache with blocks nobody can look up again.
//
// The budget is in bytes of decoded data. Blocks are shared_ptr's: a block
// evicted (or erased) while a reader still holds it stays alive until the
// reader lets go, so memory in use is the budget plus the blocks readers
// hold right now (a reader holds a handful). Eviction is least-recently-used
// per shard; keys spread over shards by hash, so contention stays low with
// many threads.
//
// Thread safety: every method may be called concurrently.
//
// Lifetimes: what Lookup and Insert return is a shared_ptr that keeps its
// block alive by itself, after eviction, EraseStore or the cache's end.
//
// Cost: Lookup and Insert lock one shard and do one hash-map operation
// (O(1) expected; Insert may evict a few blocks). EraseStore locks each
// shard in turn and walks every block it caches: O(blocks cached), once per
// store close. charge() and stats() lock every shard. Nothing here fails:
// no Status to return.
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

  // A block of one store: store ids come from NewStoreId(), block numbers
  // are the store's own.
  struct Key {
    uint64_t store = 0;
    uint64_t block = 0;
    friend bool operator==(const Key&, const Key&) = default;
  };

  // REQUIRES: shards >= 1.
  explicit BlockCache(size_t capacity_bytes, int shards = 16);

  // The block cached under `key`, or null.
  std::shared_ptr<const Block> Lookup(Key key);

  // Caches `block` under `key` and returns what the cache now holds for the
  // key: another thread may have inserted the same block first.
  std::shared_ptr<const Block> Insert(Key key, std::shared_ptr<const Block> block);

  // Drops every block of `store` from the cache (readers holding one keep
  // it) and returns how many. Call when the store is closed, after its last
  // Lookup/Insert: a block inserted concurrently may survive the call.
  // O(blocks cached), see above.
  size_t EraseStore(uint64_t store);

  size_t capacity() const { return capacity_; }
  // Bytes currently charged (decoded blocks held by the cache).
  size_t charge() const;

  struct Stats {
    uint64_t hits = 0;
    uint64_t misses = 0;
    uint64_t evictions = 0;  // blocks dropped for the budget (not EraseStore)
  };
  Stats stats() const;

  // A fresh store id, never returned before in this process (a 64-bit
  // counter: it would take centuries of opens to wrap). Never 0.
  static uint64_t NewStoreId();

 private:
  struct KeyHash {
    size_t operator()(const Key& k) const { return static_cast<size_t>(Mix(k)); }
  };
  // A 64-bit mix of both halves: consecutive blocks and consecutive stores
  // spread over shards and buckets alike.
  static uint64_t Mix(const Key& k) {
    uint64_t h = (k.store * 0x9E3779B97F4A7C15ULL) ^ k.block;
    h *= 0xBF58476D1CE4E5B9ULL;
    return h ^ (h >> 31);
  }
  struct Shard {
    std::mutex mu;
    std::list<std::pair<Key, std::shared_ptr<const Block>>> lru;  // front: newest
    std::unordered_map<Key, decltype(lru)::iterator, KeyHash> map;
    size_t charge = 0;
    Stats stats;
  };
  Shard& ShardOf(const Key& key);
  void EvictOverBudget(Shard& s);

  size_t capacity_;
  size_t shard_capacity_;
  std::vector<std::unique_ptr<Shard>> shards_;
};

}  // namespace simplexdb
