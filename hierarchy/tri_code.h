// TriCode<P>: the location code of a triangle in a triangle quadtree on the
// sphere (seed chapter 2), as a small value type (8 bytes, trivially
// copyable).
//
// The sphere is approximated by a Platonic solid P with triangular faces
// (icosahedron: 20 base faces, octahedron: 8, tetrahedron: 4), and every base
// face is the root of a quadtree: a triangle splits at its edge midpoints
// into four triangles of half the side. A node is (face, path, level): `face`
// is the base face (numbered as the seed's Figs. 5, 15 and 17,
// hierarchy/tri_polyhedron.h), `path` two bits per level (the child type,
// section 2.1), `level` the depth (base faces are level 0).
//
// Child types (section 2.1, Fig. 1):
//
//   tip-up parent:    00 top,    01 bottom-left, 10 center, 11 bottom-right
//   tip-down parent:  00 bottom, 01 top-left,    10 center, 11 top-right
//
// Child 10 has the opposite orientation of its parent, the other three the
// same. Seen as (apex, left, right) — the apex is the vertex opposite the
// horizontal edge, "left" and "right" the ends of that edge — both rules are
// one: 00 is the apex child, 01 the left one, 11 the right one, 10 the center
// (hierarchy/tri_geometry.h).
//
// Text form: "F:bits", the base face in decimal, then two binary digits per
// level, shallowest first: "2:0110" is face 2, child 01, then its child 10.
// A base face is "2:". (The seed writes the face as a 6-, 4- or 2-bit field
// in front of the path: its "000010 01 00 01 01 00 01" is our "2:010001010001".)
//
// Packed key (one uint64_t), most significant bit first:
//
//   | face: kFaceBits | path: 2 * kMaxLevel bits, level 1 first, | 0.. | level: 5 bits |
//   |                 | zero below the code's own level           |     |               |
//
//   icosahedron: kFaceBits = 5, kMaxLevel = 27 (5 + 54 + 5 = 64 bits)
//   octahedron:  kFaceBits = 3, kMaxLevel = 28 (3 + 56 + 5 = 64 bits)
//   tetrahedron: kFaceBits = 2, kMaxLevel = 28 (2 + 56 + 5 = 63 bits, one spare)
//
// Level 27 on the icosahedron splits each of its edges (7,054 km on the
// Earth) into 2^27 parts: about 5 cm. The path is left-aligned, so the
// unsigned order of keys is depth-first preorder (a node before its
// descendants, children in the order 00, 01, 10, 11, faces in index order):
// the seed's list L sorted by "base triangle number, path, depth" (2.6).
//
// Inside algorithms the path is used right-aligned (path()): bits 1..0 are
// the code's own child type, bits 2i+1..2i the child type of its i-th
// ancestor. This is the seed's CODE word for the constant-time algorithm
// (2.4) with the node's own pair at the bottom, so moving right adds 1 at
// every depth. (2.4.1 says a node at depth i of a code left-aligned to depth
// n adds "2^i": the lowest bit of its pair is 4^(n-i) = 2^(2(n-i)).)
//
// None() is a distinguished invalid code (all key bits set: level 31 is out
// of range) returned where no triangle is meant.
//
// Every accessor below except key(), is_none() and is_valid() REQUIRES a
// valid code.
//
// Thread safety: a value type; all methods are const and reentrant.
#pragma once

#include <bit>
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

// The Platonic solids with triangular faces (section 2.5).
enum class Polyhedron : uint8_t { kTetrahedron, kOctahedron, kIcosahedron };

// Faces of P.
template <Polyhedron P>
inline constexpr int kPolyhedronFaces = P == Polyhedron::kIcosahedron  ? 20
                                        : P == Polyhedron::kOctahedron ? 8
                                                                       : 4;

template <Polyhedron P>
class TriCode {
 public:
  static constexpr Polyhedron kPolyhedron = P;
  static constexpr int kFaces = kPolyhedronFaces<P>;
  static constexpr int kFaceBits = P == Polyhedron::kIcosahedron  ? 5
                                   : P == Polyhedron::kOctahedron ? 3
                                                                  : 2;
  static constexpr int kLevelBits = 5;
  static constexpr int kMaxLevel = (64 - kFaceBits - kLevelBits) / 2;  // 27 / 28 / 28
  static_assert(kMaxLevel < (1 << kLevelBits));

  // The None() code.
  constexpr TriCode() noexcept = default;
  static constexpr TriCode None() noexcept { return TriCode(); }

  // REQUIRES: 0 <= face < kFaces.
  static constexpr TriCode Face(int face) noexcept { return FromPath(face, 0, 0); }

  // `path` is right-aligned: bits 1..0 are the deepest level's child type.
  // REQUIRES: 0 <= face < kFaces, 0 <= level <= kMaxLevel, path < 4^level.
  static constexpr TriCode FromPath(int face, uint64_t path, int level) noexcept {
    assert(face >= 0 && face < kFaces);
    assert(level >= 0 && level <= kMaxLevel);
    assert((path >> (2 * level)) == 0);
    return TriCode(static_cast<uint64_t>(face) << (64 - kFaceBits) |
                   path << (kPathShift + 2 * (kMaxLevel - level)) |
                   static_cast<uint64_t>(level));
  }

  // Any bit pattern; check is_valid() before use when it comes from outside.
  static constexpr TriCode FromKey(uint64_t key) noexcept { return TriCode(key); }

  // Parses "F:bits" (an even number of bits). Fails with InvalidArgument
  // naming the text and what was expected.
  static Result<TriCode> Parse(std::string_view text);

  constexpr bool is_none() const noexcept { return key_ == kNoneKey; }

  // True for a code that names a triangle: face and level in range, no path
  // bits below the level, spare bits zero.
  constexpr bool is_valid() const noexcept {
    if (face() >= kFaces || level() > kMaxLevel) return false;
    const int unused = kPathShift + 2 * (kMaxLevel - level());
    const uint64_t below = (uint64_t{1} << unused) - 1;
    return (key_ & below & ~kLevelMask) == 0;
  }

  constexpr uint64_t key() const noexcept { return key_; }
  constexpr int face() const noexcept { return static_cast<int>(key_ >> (64 - kFaceBits)); }
  constexpr int level() const noexcept { return static_cast<int>(key_ & kLevelMask); }

  // Right-aligned path: bits 2i+1..2i are the child type at level level() - i.
  constexpr uint64_t path() const noexcept {
    assert(is_valid());
    return ((key_ >> kPathShift) & kPathMask) >> (2 * (kMaxLevel - level()));
  }

  // The child type (0..3, the seed's CODE[l]) chosen at level `l`.
  // REQUIRES: 1 <= l <= level().
  constexpr int child_type_at(int l) const noexcept {
    assert(is_valid() && l >= 1 && l <= level());
    return static_cast<int>((key_ >> (kPathShift + 2 * (kMaxLevel - l))) & 3);
  }
  // Which child of its parent this is. REQUIRES: level() > 0.
  constexpr int child_type() const noexcept { return child_type_at(level()); }

  // True when the triangle points the other way from its base face: an odd
  // number of center (10) children on its path. O(1): a popcount.
  constexpr bool flipped() const noexcept {
    const uint64_t p = path();
    // A pair is 10 when its high bit is set and its low bit is clear.
    return (std::popcount((p >> 1) & ~p & 0x5555555555555555ULL) & 1) != 0;
  }

  // REQUIRES: level() > 0.
  constexpr TriCode parent() const noexcept { return ancestor(level() - 1); }

  // The ancestor at level `l` (the code itself when l == level()).
  // REQUIRES: 0 <= l <= level().
  constexpr TriCode ancestor(int l) const noexcept {
    assert(is_valid() && l >= 0 && l <= level());
    const uint64_t keep = ~((uint64_t{1} << (kPathShift + 2 * (kMaxLevel - l))) - 1);
    return TriCode((key_ & keep) | static_cast<uint64_t>(l));
  }

  // REQUIRES: level() < kMaxLevel, 0 <= type <= 3.
  constexpr TriCode child(int type) const noexcept {
    assert(is_valid() && level() < kMaxLevel && type >= 0 && type <= 3);
    const int l = level() + 1;
    return TriCode((key_ & ~kLevelMask) |
                   static_cast<uint64_t>(type) << (kPathShift + 2 * (kMaxLevel - l)) |
                   static_cast<uint64_t>(l));
  }

  // Same level and path on another base face. REQUIRES: 0 <= face < kFaces.
  constexpr TriCode with_face(int face) const noexcept {
    assert(is_valid() && face >= 0 && face < kFaces);
    constexpr uint64_t kBelowFace = (uint64_t{1} << (64 - kFaceBits)) - 1;
    return TriCode((key_ & kBelowFace) | static_cast<uint64_t>(face) << (64 - kFaceBits));
  }

  // True when `other` is this code or one of its descendants.
  constexpr bool contains(TriCode other) const noexcept {
    return range_min() <= other.key_ && other.key_ <= range_max();
  }
  // True when `other` is a proper descendant.
  constexpr bool is_ancestor_of(TriCode other) const noexcept {
    return other.key_ != key_ && contains(other);
  }

  // The smallest and largest keys of this subtree (preorder key range).
  constexpr uint64_t range_min() const noexcept { return key_; }
  constexpr uint64_t range_max() const noexcept {
    assert(is_valid());
    return key_ | ((uint64_t{1} << (kPathShift + 2 * (kMaxLevel - level()))) - 1);
  }

  // "F:bits"; "none" for None().
  std::string ToString() const;

  friend constexpr bool operator==(TriCode, TriCode) = default;
  friend constexpr std::strong_ordering operator<=>(TriCode a, TriCode b) {
    return a.key_ <=> b.key_;
  }

 private:
  static constexpr uint64_t kNoneKey = ~uint64_t{0};
  static constexpr uint64_t kLevelMask = (uint64_t{1} << kLevelBits) - 1;
  // Bits between the path and the level (one for the tetrahedron).
  static constexpr int kPathShift = 64 - kFaceBits - 2 * kMaxLevel;
  static constexpr uint64_t kPathMask = (uint64_t{1} << (2 * kMaxLevel)) - 1;

  explicit constexpr TriCode(uint64_t key) noexcept : key_(key) {}

  uint64_t key_ = kNoneKey;
};

template <Polyhedron P>
std::ostream& operator<<(std::ostream& os, TriCode<P> code) {
  return os << code.ToString();
}

using IcosaCode = TriCode<Polyhedron::kIcosahedron>;
using OctaCode = TriCode<Polyhedron::kOctahedron>;
using TetraCode = TriCode<Polyhedron::kTetrahedron>;

template <Polyhedron P>
std::string TriCode<P>::ToString() const {
  if (is_none()) return "none";
  std::string s = std::to_string(face());
  s.push_back(':');
  for (int l = 1; l <= level(); ++l) {
    const int t = child_type_at(l);
    s.push_back(static_cast<char>('0' + (t >> 1)));
    s.push_back(static_cast<char>('0' + (t & 1)));
  }
  return s;
}

template <Polyhedron P>
Result<TriCode<P>> TriCode<P>::Parse(std::string_view text) {
  static constexpr internal::CodeTextWords kWords = {
      "triangle code", "expected F:bits, e.g. 2:0110 (face 2, children 01 then 10)",
      "a base face", "face"};
  SDB_ASSIGN_OR_RETURN(const internal::CodeText parsed,
                       internal::ParseCodeText(text, kFaces, kWords));
  const std::string_view bits = parsed.bits;
  if (bits.size() % 2 != 0) {
    return internal::BadCodeText(text, kWords,
                                 "the path has an odd number of bits: two per level");
  }
  if (bits.size() > static_cast<size_t>(2 * kMaxLevel)) {
    return internal::BadCodeText(text, kWords,
                                 "level " + std::to_string(bits.size() / 2) +
                                     " exceeds the maximum level " + std::to_string(kMaxLevel));
  }
  uint64_t path = 0;
  for (char c : bits) {
    if (c != '0' && c != '1') {
      return internal::BadCodeText(text, kWords, "path bits must be 0 or 1");
    }
    path = path << 1 | static_cast<uint64_t>(c - '0');
  }
  return FromPath(parsed.root, path, static_cast<int>(bits.size() / 2));
}

}  // namespace simplexdb

template <simplexdb::Polyhedron P>
struct std::hash<simplexdb::TriCode<P>> {
  size_t operator()(simplexdb::TriCode<P> c) const noexcept {
    return static_cast<size_t>(simplexdb::internal::MixKey(c.key()));
  }
};
