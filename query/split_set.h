// SplitSet<D>: the split nodes of a mesh. Nodes at the shallow levels
// (where almost every extracted mesh lives) are bits of one bitmap indexed by
// (root, heap index); deeper nodes go to a CodeSet (a hash set).
//
// Why: selective refinement asks "is this node split?" once or more per
// candidate and per cluster member. With a hash set every query of a large
// mesh is a cache miss into a table of 8 bytes per node at half load; the
// bitmap holds the same answer in 2 bits per node of the complete tree down
// to kBitmapLevels, so the mesh of a 129^3 grid (21 levels) needs 3 MiB of
// bitmap. Its memory comes from calloc: pages never touched are never
// committed, so a small mesh over a deep hierarchy costs little.
//
// Thread safety: none; one set per mesh (const methods write nothing, so
// readers may share a set no one changes).
//
// Lifetimes: nothing is handed out by reference; ForEach passes codes by
// value, and the set must not change during ForEach.
//
// Errors: none; insert throws std::bad_alloc when the bitmap or the hash
// table cannot be allocated.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>

#include "hierarchy/simplex_code.h"
#include "query/code_set.h"

namespace simplexdb {

template <int D>
class SplitSet {
 public:
  using Code = SimplexCode<D>;
  // Levels [0, kBitmapLevels) are in the bitmap: 2^kBitmapLevels bits per
  // root, 48 MiB for the HT and 192 MiB for the HP at most (reserved, only
  // touched where nodes are split).
  static constexpr int kBitmapLevels = 26;

  SplitSet() = default;

  bool contains(Code c) const {
    if (c.level() < kBitmapLevels) {
      const uint64_t i = Index(c);
      return bits_ != nullptr && (bits_[i >> 6] >> (i & 63) & 1);
    }
    return deep_.contains(c.key());
  }

  // True when `c` was not there.
  bool insert(Code c) {
    if (c.level() < kBitmapLevels) {
      if (bits_ == nullptr) Allocate();
      const uint64_t i = Index(c);
      uint64_t& w = bits_[i >> 6];
      const uint64_t m = uint64_t{1} << (i & 63);
      if (w & m) return false;
      w |= m;
      ++shallow_;
      return true;
    }
    return deep_.insert(c.key());
  }

  bool erase(Code c) {
    if (c.level() < kBitmapLevels) {
      if (bits_ == nullptr) return false;
      const uint64_t i = Index(c);
      uint64_t& w = bits_[i >> 6];
      const uint64_t m = uint64_t{1} << (i & 63);
      if (!(w & m)) return false;
      w &= ~m;
      --shallow_;
      return true;
    }
    return deep_.erase(c.key());
  }

  size_t size() const { return shallow_ + deep_.size(); }

  void clear() {
    bits_.reset();
    shallow_ = 0;
    deep_.clear();
  }

  // Calls f(code) for every node, in no particular order. O(bitmap words
  // + deep nodes).
  template <class F>
  void ForEach(F&& f) const {
    if (bits_ != nullptr) {
      for (uint64_t w = 0; w < kWords; ++w) {
        for (uint64_t bits = bits_[w]; bits != 0; bits &= bits - 1) {
          const uint64_t i = w * 64 + static_cast<uint64_t>(__builtin_ctzll(bits));
          f(FromIndex(i));
        }
      }
    }
    deep_.ForEach([&](uint64_t key) { f(Code::FromKey(key)); });
  }

 private:
  static constexpr uint64_t kPerRoot = uint64_t{1} << kBitmapLevels;
  static constexpr uint64_t kWords = Code::kRoots * kPerRoot / 64;

  // Root-major heap order: root r's node with heap index h is bit
  // r * 2^kBitmapLevels + h (h < 2^kBitmapLevels - 1).
  static uint64_t Index(Code c) { return uint64_t(c.top()) * kPerRoot + c.heap_index(); }
  static Code FromIndex(uint64_t i) {
    const int top = static_cast<int>(i / kPerRoot);
    const uint64_t h = i % kPerRoot;
    const int level = 63 - __builtin_clzll(h + 1);
    return Code::FromPath(top, h + 1 - (uint64_t{1} << level), level);
  }

  void Allocate() {
    // calloc of this size maps fresh zero pages: nothing is committed until
    // a node in a page is split.
    bits_.reset(static_cast<uint64_t*>(std::calloc(kWords, sizeof(uint64_t))));
    if (bits_ == nullptr) throw std::bad_alloc();
  }

  struct Free {
    void operator()(uint64_t* p) const { std::free(p); }
  };
  std::unique_ptr<uint64_t[], Free> bits_;
  uint64_t shallow_ = 0;
  CodeSet deep_;
};

}  // namespace simplexdb
