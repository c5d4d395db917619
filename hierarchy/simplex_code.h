// SimplexCode<D>: the location code of a simplex in a hierarchy of bisected
// simplices, as a small value type (8 bytes, trivially copyable).
//
//   D = 3: the Hierarchy of Tetrahedra (HT), seed chapter 3. The cube is split
//          into 6 root tetrahedra sharing its main diagonal.
//   D = 4: the Hierarchy of Pentatopes (HP), seed chapter 4. The hypercube is
//          split into 24 root pentatopes sharing its main diagonal.
//
// A node is (top, path, level): `top` is the root simplex, `path` holds one
// bit per level (0 = child 0, 1 = child 1), `level` is the depth (roots are
// level 0). Text form: "T:bits", e.g. "2:10011" is the seed's 210011; a root
// is "2:".
//
// Packed key (one uint64_t), most significant bit first:
//
//   | top: kTopBits | path: kMaxLevel bits, level 1 first, | level: 6 bits |
//   |               | zero below the code's own level       |               |
//
//   HT: kTopBits = 3, kMaxLevel = 55.   HP: kTopBits = 5, kMaxLevel = 53.
//
// The path is left-aligned, so the unsigned order of keys is depth-first
// preorder: a node sorts before its descendants, child 0's subtree before
// child 1's, and roots in index order. A subtree is the contiguous key range
// [range_min(), range_max()]. This is the order of the LMDB keys and of the
// blocks on disk.
//
// Inside algorithms the path is used right-aligned (path()): bit 0 is the
// code's own child index, bit i the child index of its i-th ancestor. This is
// the seed's "location code" word: CODE XOR 1 flips the last level.
//
// None() is a distinguished invalid code (all key bits set; its top is out of
// range) returned for "no neighbor" at the domain boundary.
//
// Geometry, neighbors and clusters are free functions over this type, in
// hierarchy/geometry.h, hierarchy/neighbors.h (ht_ and hp_neighbors.h) and
// hierarchy/cluster.h.
//
// Every accessor below except key(), is_none() and is_valid() REQUIRES a
// valid code; None() is not one (it is what a neighbor query returns at the
// boundary: test is_none() before using the answer).
//
// Thread safety: a value type; all methods are const and reentrant.
#pragma once

#include <cassert>
#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>

#include "hierarchy/code_text.h"
#include "util/status.h"

namespace simplexdb {

template <int D>
class SimplexCode {
  static_assert(D == 3 || D == 4, "only the HT (3) and HP (4) exist");

 public:
  static constexpr int kDim = D;
  // Root simplices: the D! simplices of the cube split sharing its diagonal.
  static constexpr int kRoots = D == 3 ? 6 : 24;
  static constexpr int kTopBits = D == 3 ? 3 : 5;
  static constexpr int kLevelBits = 6;
  static constexpr int kMaxLevel = 64 - kTopBits - kLevelBits;  // 55 / 53
  // Every kPeriod levels the shapes repeat at half the size (HT: 1/8, 1/2,
  // 1/4 pyramids; HP: h-, c-, s-, e-pentatopes).
  static constexpr int kPeriod = D;

  // The None() code.
  constexpr SimplexCode() noexcept = default;
  static constexpr SimplexCode None() noexcept { return SimplexCode(); }

  // REQUIRES: 0 <= top < kRoots.
  static constexpr SimplexCode Root(int top) noexcept {
    return FromPath(top, 0, 0);
  }

  // `path` is right-aligned (bit 0 is the deepest level).
  // REQUIRES: 0 <= top < kRoots, 0 <= level <= kMaxLevel, path < 2^level.
  static constexpr SimplexCode FromPath(int top, uint64_t path,
                                        int level) noexcept {
    assert(top >= 0 && top < kRoots);
    assert(level >= 0 && level <= kMaxLevel);
    assert((path >> level) == 0);
    return SimplexCode(static_cast<uint64_t>(top) << (64 - kTopBits) |
                       path << (kLevelBits + kMaxLevel - level) |
                       static_cast<uint64_t>(level));
  }

  // Any bit pattern; check is_valid() before use when it comes from outside.
  static constexpr SimplexCode FromKey(uint64_t key) noexcept {
    return SimplexCode(key);
  }

  // Parses "T:bits". Fails with InvalidArgument naming the text and what was
  // expected.
  static Result<SimplexCode> Parse(std::string_view text);

  constexpr bool is_none() const noexcept { return key_ == kNoneKey; }

  // True for a code that names a simplex: top in range, level in range, no
  // path bits below the level.
  constexpr bool is_valid() const noexcept {
    if (top() >= kRoots || level() > kMaxLevel) return false;
    const int unused = kMaxLevel - level();
    const uint64_t below = (uint64_t{1} << unused) - 1;
    return ((key_ >> kLevelBits) & below) == 0;
  }

  constexpr uint64_t key() const noexcept { return key_; }
  constexpr int top() const noexcept {
    return static_cast<int>(key_ >> (64 - kTopBits));
  }
  constexpr int level() const noexcept {
    return static_cast<int>(key_ & kLevelMask);
  }
  // Right-aligned path: bit i is the child index at level level() - i.
  constexpr uint64_t path() const noexcept {
    assert(is_valid());
    return ((key_ >> kLevelBits) & kPathMask) >> (kMaxLevel - level());
  }
  // The child index chosen at level `l` (the seed's path[l]).
  // REQUIRES: 1 <= l <= level().
  constexpr int bit_at(int l) const noexcept {
    assert(is_valid() && l >= 1 && l <= level());
    return static_cast<int>((key_ >> (kLevelBits + kMaxLevel - l)) & 1);
  }
  // 0 or 1: which child of its parent this is. REQUIRES: level() > 0.
  constexpr int child_index() const noexcept { return bit_at(level()); }

  // REQUIRES: level() > 0.
  constexpr SimplexCode parent() const noexcept { return ancestor(level() - 1); }

  // The ancestor at level `l` (the code itself when l == level()).
  // REQUIRES: 0 <= l <= level().
  constexpr SimplexCode ancestor(int l) const noexcept {
    assert(is_valid() && l >= 0 && l <= level());
    const uint64_t keep = ~((uint64_t{1} << (kLevelBits + kMaxLevel - l)) - 1);
    return SimplexCode((key_ & keep) | static_cast<uint64_t>(l));
  }

  // REQUIRES: level() < kMaxLevel, i in {0, 1}.
  constexpr SimplexCode child(int i) const noexcept {
    assert(is_valid() && level() < kMaxLevel && (i == 0 || i == 1));
    const int l = level() + 1;
    return SimplexCode(((key_ & ~kLevelMask) |
                        static_cast<uint64_t>(i) << (kLevelBits + kMaxLevel - l)) |
                       static_cast<uint64_t>(l));
  }

  // The other child of the parent. REQUIRES: level() > 0.
  constexpr SimplexCode sibling() const noexcept {
    assert(is_valid() && level() > 0);
    return SimplexCode(key_ ^ (uint64_t{1} << (kLevelBits + kMaxLevel - level())));
  }

  // Same level and path under another root. REQUIRES: 0 <= top < kRoots.
  constexpr SimplexCode with_top(int top) const noexcept {
    assert(is_valid() && top >= 0 && top < kRoots);
    constexpr uint64_t kBelowTop = (uint64_t{1} << (64 - kTopBits)) - 1;
    return SimplexCode((key_ & kBelowTop) |
                       static_cast<uint64_t>(top) << (64 - kTopBits));
  }

  // Same top and level, another right-aligned path.
  // REQUIRES: path < 2^level().
  constexpr SimplexCode with_path(uint64_t path) const noexcept {
    return FromPath(top(), path, level());
  }

  // True when `other` is this code or one of its descendants.
  constexpr bool contains(SimplexCode other) const noexcept {
    return range_min() <= other.key_ && other.key_ <= range_max();
  }
  // True when `other` is a proper descendant.
  constexpr bool is_ancestor_of(SimplexCode other) const noexcept {
    return other.key_ != key_ && contains(other);
  }

  // The smallest and largest keys of this subtree (preorder key range).
  constexpr uint64_t range_min() const noexcept { return key_; }
  constexpr uint64_t range_max() const noexcept {
    assert(is_valid());
    const uint64_t below =
        (uint64_t{1} << (kLevelBits + kMaxLevel - level())) - 1;
    return key_ | below;
  }

  // Index of this node in its root's binary tree stored as a heap array:
  // the root is 0 and node i has children 2i+1 and 2i+2, so the index is
  // 2^level - 1 + path. Every level is kept together, in path order.
  constexpr uint64_t heap_index() const noexcept {
    assert(is_valid());
    return ((uint64_t{1} << level()) - 1) + path();
  }

  // "T:bits"; "none" for None().
  std::string ToString() const;

  friend constexpr bool operator==(SimplexCode, SimplexCode) = default;
  friend constexpr std::strong_ordering operator<=>(SimplexCode a,
                                                    SimplexCode b) {
    return a.key_ <=> b.key_;
  }

 private:
  static constexpr uint64_t kNoneKey = ~uint64_t{0};
  static constexpr uint64_t kLevelMask = (uint64_t{1} << kLevelBits) - 1;
  static constexpr uint64_t kPathMask = (uint64_t{1} << kMaxLevel) - 1;

  explicit constexpr SimplexCode(uint64_t key) noexcept : key_(key) {}

  uint64_t key_ = kNoneKey;
};

template <int D>
std::ostream& operator<<(std::ostream& os, SimplexCode<D> code) {
  return os << code.ToString();
}

using TetCode = SimplexCode<3>;
using PentaCode = SimplexCode<4>;

template <int D>
std::string SimplexCode<D>::ToString() const {
  if (is_none()) return "none";
  std::string s = std::to_string(top());
  s.push_back(':');
  for (int l = 1; l <= level(); ++l) s.push_back(bit_at(l) ? '1' : '0');
  return s;
}

template <int D>
Result<SimplexCode<D>> SimplexCode<D>::Parse(std::string_view text) {
  static constexpr internal::CodeTextWords kWords = {
      "location code", "expected T:bits, e.g. 2:10011", "a root index", "root"};
  SDB_ASSIGN_OR_RETURN(const internal::CodeText parsed,
                       internal::ParseCodeText(text, kRoots, kWords));
  const std::string_view bits = parsed.bits;
  if (bits.size() > static_cast<size_t>(kMaxLevel)) {
    return internal::BadCodeText(text, kWords,
                                 "level " + std::to_string(bits.size()) +
                                     " exceeds the maximum level " + std::to_string(kMaxLevel));
  }
  uint64_t path = 0;
  for (char c : bits) {
    if (c != '0' && c != '1') {
      return internal::BadCodeText(text, kWords, "path bits must be 0 or 1");
    }
    path = path << 1 | static_cast<uint64_t>(c - '0');
  }
  return FromPath(parsed.root, path, static_cast<int>(bits.size()));
}

}  // namespace simplexdb

template <int D>
struct std::hash<simplexdb::SimplexCode<D>> {
  size_t operator()(simplexdb::SimplexCode<D> c) const noexcept {
    return static_cast<size_t>(simplexdb::internal::MixKey(c.key()));
  }
};
