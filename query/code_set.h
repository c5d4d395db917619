// CodeSet: a set of packed location codes (SimplexCode::key()), the split
// nodes of an extracted mesh. Open addressing with linear probing and
// backward-shift deletion, at most half full: one cache line per lookup in
// the common case, and no tombstones, so incremental refinement can merge
// (erase) as often as it splits.
//
// Boost 1.74 (Debian's) has no flat hash set and std::unordered_set costs a
// node allocation per key; selective refinement inserts one key per split and
// looks one up per candidate leaf, so this is the hot structure of the query
// layer.
//
// Keys may be any value except ~0 (SimplexCode::None()'s key, which marks an
// empty slot); REQUIRES of every method taking a key.
//
// Thread safety: none; one set per query (const methods write nothing, so
// readers may share a set no one changes).
//
// Lifetimes: nothing is handed out by reference; ForEach passes keys by
// value, and the set must not change during ForEach.
//
// Errors: none; insert and reserve throw std::bad_alloc when the table
// cannot grow.
#pragma once

#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace simplexdb {

class CodeSet {
 public:
  static constexpr uint64_t kEmpty = ~uint64_t{0};

  CodeSet() { Rehash(16); }

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  // Bytes held by the table.
  size_t memory_bytes() const { return slots_.size() * sizeof(uint64_t); }

  // O(1) expected.
  bool contains(uint64_t key) const {
    assert(key != kEmpty);
    for (size_t i = Home(key);; i = (i + 1) & mask_) {
      const uint64_t k = slots_[i];
      if (k == key) return true;
      if (k == kEmpty) return false;
    }
  }

  // True when `key` was not there. O(1) amortized.
  bool insert(uint64_t key) {
    assert(key != kEmpty);
    if (2 * (size_ + 1) > slots_.size()) Rehash(slots_.size() * 2);
    for (size_t i = Home(key);; i = (i + 1) & mask_) {
      uint64_t& k = slots_[i];
      if (k == key) return false;
      if (k == kEmpty) {
        k = key;
        ++size_;
        return true;
      }
    }
  }

  // True when `key` was there. Backward-shift deletion keeps every probe
  // sequence unbroken.
  bool erase(uint64_t key) {
    assert(key != kEmpty);
    size_t i = Home(key);
    for (;; i = (i + 1) & mask_) {
      if (slots_[i] == key) break;
      if (slots_[i] == kEmpty) return false;
    }
    for (size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      const uint64_t k = slots_[j];
      if (k == kEmpty) break;
      // k may move back to the hole at i unless its home lies cyclically in
      // (i, j]: then the hole is before its home and it must stay.
      const size_t home = Home(k);
      const bool home_in_gap = i <= j ? (i < home && home <= j) : (i < home || home <= j);
      if (!home_in_gap) {
        slots_[i] = k;
        i = j;
      }
    }
    slots_[i] = kEmpty;
    --size_;
    return true;
  }

  void clear() {
    std::fill(slots_.begin(), slots_.end(), kEmpty);
    size_ = 0;
  }

  // Makes room for `n` keys without rehashing.
  void reserve(size_t n) {
    size_t want = 16;
    while (want < 2 * n) want *= 2;
    if (want > slots_.size()) Rehash(want);
  }

  // Calls f(key) for every key, in no particular order.
  template <class F>
  void ForEach(F&& f) const {
    for (uint64_t k : slots_) {
      if (k != kEmpty) f(k);
    }
  }

 private:
  // The splitmix64 finalizer: location codes share long prefixes and their
  // low six bits (the level), so the multiply alone would cluster.
  size_t Home(uint64_t x) const {
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return static_cast<size_t>(x) & mask_;
  }

  void Rehash(size_t capacity) {
    std::vector<uint64_t> old(capacity, kEmpty);
    old.swap(slots_);
    mask_ = capacity - 1;
    size_ = 0;
    for (uint64_t k : old) {
      if (k != kEmpty) insert(k);
    }
  }

  std::vector<uint64_t> slots_;
  size_t mask_ = 0;
  size_t size_ = 0;
};

}  // namespace simplexdb
