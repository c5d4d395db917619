// Diamonds and the hierarchical Z-order (HZ) of their vertices: the
// addressing of store format 2 (DESIGN.md, "Stores, format 2").
//
// Every vertex of the grid [0, 2^k]^D except the domain's 2^D corners is the
// midpoint of exactly one split edge: the split vertex of every node of one
// cluster (a diamond), all at one level, its creation level. So one record
// per vertex holds its diamond's error and its field value.
//
// Creation level, from the vertex alone. With s the number of trailing zero
// bits common to all coordinates (s < k off the corners), the vertex is the
// centre of a face of dimension m (m = the number of coordinates that are odd
// multiples of 2^s, 1 <= m <= D) of a cube of side 2^(s+1), which is a cube
// of octave o = k - 1 - s. The HT creates cube centres (m = 3) at level 3o,
// face centres at 3o + 1 and edge midpoints at 3o + 2; the HP likewise, four
// levels an octave:
//
//   level = D * o + (D - m)
//
// HZ order. Positions are a virtual address space over the vertices. Octave
// o holds, for each odd-axis pattern (a non-zero mask of D bits; patterns
// with more odd axes, which are created first, come first), one segment of
// 2^(D (o + 1)) positions: the vertices of that pattern by the Morton order
// of their cube u = g >> (s + 1) (o + 1 bits per axis: u[a] runs to 2^o on
// the axes where the pattern is even, the upper faces of the domain). The
// 2^D corners come first, at the Morton index of their bits g[a] >> k:
//
//   position = (1 + segment) * 2^(D (o + 1)) + Morton(u)      (corners: 0 .. 2^D - 1)
//
// Octave o fills [2^(D (o + 1)), 2^(D (o + 2))): 2^D - 1 segments after the
// 2^(D (o + 1)) positions before it. So every segment is an aligned run of a
// power of two, and so is the part of it inside any aligned cube of the
// domain: a store's blocks (fixed runs of positions) at the fine levels are
// regions of space, and a builder can fill them brick by brick. Level c
// (octave o, m odd axes) is the C(D, m) segments of its patterns:
//
//   LevelSize(c) = C(D, m) * 2^(D (o + 1))
//
// A level's space is about 2^D times the vertices it holds: the positions
// past the grid's upper faces hold no vertex (IsVertex() is false). Stores
// keep only the blocks that hold data, so the holes cost nothing; the
// coarse levels share the first blocks.
//
// Code -> vertex. SplitVertex(code) walks the code one octave (D levels) per
// step through a table of the reference cube's simplex shapes: every node at
// a level D * o is a simplex whose vertices are corners of a cube of octave o
// (the shapes repeat each octave at half the size, seed 3.2, 4.2), so a
// state (which corners, in which order) and the next D path bits give the
// sub-cube and the next state. The tables are derived from the split rules
// at first use.
//
// Thread safety: pure functions and immutable values (the tables are built
// once, thread-safely); a SplitVertexCursor is one thread's at a time.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cstdint>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"

namespace simplexdb {

namespace internal {

// Morton (Z-order) interleaving of D coordinates: bit b of coordinate a goes
// to bit D * b + a. HT: 21 bits per axis, HP: 16.
template <int D>
constexpr uint64_t SpreadBits(uint64_t x) {
  if constexpr (D == 3) {
    x &= 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
  } else {
    x &= 0xffff;
    x = (x | x << 24) & 0x000000ff000000ffULL;
    x = (x | x << 12) & 0x000f000f000f000fULL;
    x = (x | x << 6) & 0x0303030303030303ULL;
    x = (x | x << 3) & 0x1111111111111111ULL;
  }
  return x;
}

template <int D>
constexpr uint64_t GatherBits(uint64_t x) {
  if constexpr (D == 3) {
    x &= 0x1249249249249249ULL;
    x = (x | x >> 2) & 0x10c30c30c30c30c3ULL;
    x = (x | x >> 4) & 0x100f00f00f00f00fULL;
    x = (x | x >> 8) & 0x1f0000ff0000ffULL;
    x = (x | x >> 16) & 0x1f00000000ffffULL;
    x = (x | x >> 32) & 0x1fffff;
  } else {
    x &= 0x1111111111111111ULL;
    x = (x | x >> 3) & 0x0303030303030303ULL;
    x = (x | x >> 6) & 0x000f000f000f000fULL;
    x = (x | x >> 12) & 0x000000ff000000ffULL;
    x = (x | x >> 24) & 0xffff;
  }
  return x;
}

template <int D>
constexpr uint64_t Morton(const std::array<int64_t, D>& u) {
  uint64_t m = 0;
  for (int a = 0; a < D; ++a) m |= SpreadBits<D>(static_cast<uint64_t>(u[a])) << a;
  return m;
}

template <int D>
constexpr std::array<int64_t, D> FromMorton(uint64_t m) {
  std::array<int64_t, D> u{};
  for (int a = 0; a < D; ++a) u[a] = static_cast<int64_t>(GatherBits<D>(m >> a));
  return u;
}

// The segments of an octave: one per odd-axis pattern (a non-zero mask of D
// bits), ordered by level (more odd axes first: m = D, D - 1, ..., 1) and
// then by mask. count[m] patterns have m odd axes; first[m] is the first of
// them.
template <int D>
struct OddPatterns {
  static constexpr int kSegments = (1 << D) - 1;
  std::array<uint8_t, kSegments> mask_of{};      // segment -> mask
  std::array<uint8_t, 1 << D> segment_of{};      // mask -> segment (mask 0: unused)
  std::array<uint8_t, D + 1> count{};
  std::array<uint8_t, D + 1> first{};
};

template <int D>
constexpr OddPatterns<D> DeriveOddPatterns() {
  OddPatterns<D> p{};
  int next = 0;
  for (int m = D; m >= 1; --m) {
    p.first[m] = static_cast<uint8_t>(next);
    for (int mask = 1; mask < (1 << D); ++mask) {
      if (std::popcount(static_cast<unsigned>(mask)) != m) continue;
      p.mask_of[next] = static_cast<uint8_t>(mask);
      p.segment_of[mask] = static_cast<uint8_t>(next++);
      ++p.count[m];
    }
  }
  return p;
}

template <int D>
inline constexpr OddPatterns<D> kOddPatterns = DeriveOddPatterns<D>();

// The octave tables. A state is a simplex at the start of an octave given by
// which corners of its cube its vertices are, in order: vertex i is corner
// mask corners[i] (bit a set: the far side along axis a).
template <int D>
struct OctaveTables {
  static constexpr int kMaxStates = D == 3 ? 48 : 384;  // D! * 2^D shapes at most
  static constexpr int kSteps = 1 << D;                 // D path bits per octave
  int states = 0;
  std::array<std::array<uint8_t, D + 1>, kMaxStates> corners{};
  std::array<uint32_t, kMaxStates> keys{};  // corners packed, D bits each: for the search
  // step[state][bits]: low D bits the sub-cube (bit a: the far half along a),
  // the rest the state there. `bits` holds the D path bits of the octave,
  // the first level's bit highest.
  std::array<std::array<uint16_t, kSteps>, kMaxStates> step{};
  // split[state][(2^r - 1) + bits]: the split vertex of the node r levels
  // into the octave (r < D, `bits` its r path bits, first highest), in units
  // of half the cube's side: 2 bits per axis, values 0..2.
  std::array<std::array<uint8_t, kSteps - 1>, kMaxStates> split{};
  std::array<uint16_t, SimplexCode<D>::kRoots> root_state{};
};

template <int D>
constexpr int FindOrAddState(OctaveTables<D>& t, const std::array<uint8_t, D + 1>& c) {
  uint32_t key = 0;
  for (int i = 0; i <= D; ++i) key |= uint32_t{c[i]} << (D * i);
  for (int s = 0; s < t.states; ++s) {
    if (t.keys[s] == key) return s;
  }
  if (t.states == OctaveTables<D>::kMaxStates) throw "more simplex shapes than D! * 2^D";
  t.corners[t.states] = c;
  t.keys[t.states] = key;
  return t.states++;
}

// The vertices, in units of half the cube's side, of the node `r` levels
// into an octave below state corners `c`, reached by path bits `bits`.
template <int D>
constexpr SimplexVertices<D> DescendInOctave(const std::array<uint8_t, D + 1>& c, int r,
                                             uint32_t bits) {
  SimplexVertices<D> v{};
  for (int i = 0; i <= D; ++i) {
    for (int a = 0; a < D; ++a) v[i][a] = (c[i] >> a & 1) * 2;
  }
  uint64_t path = 0;
  for (int j = 0; j < r; ++j) {
    const int child = static_cast<int>(bits >> (r - 1 - j) & 1);
    SimplexVertices<D> next{};
    internal::Split<D>(v, SplitRules<D>::CaseOf(j, path), child, next,
                       [](const Point<D>& a, const Point<D>& b) {
                         Point<D> m{};
                         for (int x = 0; x < D; ++x) {
                           if ((a[x] + b[x]) % 2 != 0) throw "a split vertex off the half lattice";
                           m[x] = (a[x] + b[x]) / 2;
                         }
                         return m;
                       });
    v = next;
    path = path << 1 | static_cast<uint64_t>(child);
  }
  return v;
}

template <int D>
constexpr OctaveTables<D> DeriveOctaveTables() {
  OctaveTables<D> t{};
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    const SimplexVertices<D> root = RootVertices<D>(top);
    std::array<uint8_t, D + 1> c{};
    for (int i = 0; i <= D; ++i) {
      for (int a = 0; a < D; ++a) c[i] |= static_cast<uint8_t>((root[i][a] != 0) << a);
    }
    t.root_state[top] = static_cast<uint16_t>(FindOrAddState(t, c));
  }
  for (int s = 0; s < t.states; ++s) {  // t.states grows as new shapes appear
    const std::array<uint8_t, D + 1> c = t.corners[s];
    for (uint32_t bits = 0; bits < (1u << D); ++bits) {
      const SimplexVertices<D> v = DescendInOctave<D>(c, D, bits);
      int offset = 0;
      std::array<uint8_t, D + 1> sub{};
      for (int a = 0; a < D; ++a) {
        int lo = 2;
        for (int i = 0; i <= D; ++i) lo = std::min(lo, static_cast<int>(v[i][a]));
        if (lo > 1) throw "a simplex outside its cube";
        offset |= lo << a;
        for (int i = 0; i <= D; ++i) {
          const int rel = v[i][a] - lo;
          if (rel != 0 && rel != 1) throw "a simplex whose vertices are not corners of a sub-cube";
          sub[i] |= static_cast<uint8_t>(rel << a);
        }
      }
      const int next = FindOrAddState(t, sub);
      t.step[s][bits] = static_cast<uint16_t>(next << D | offset);
    }
    for (int r = 0; r < D; ++r) {
      for (uint32_t bits = 0; bits < (1u << r); ++bits) {
        const SimplexVertices<D> v = DescendInOctave<D>(c, r, bits);
        const auto edge = SplitRules<D>::kCaseToSplitEdge[SplitRules<D>::CaseOf(
            r, bits)];  // CaseOf reads the last two path bits, which `bits` ends with
        uint8_t w = 0;
        for (int a = 0; a < D; ++a) {
          w |= static_cast<uint8_t>((v[edge[0]][a] + v[edge[1]][a]) / 2 << (2 * a));
        }
        t.split[s][(1u << r) - 1 + bits] = w;
      }
    }
  }
  return t;
}

// Built once, at first use (about 6,000 simplex splits for the HP: more
// than a compiler's constant evaluation allows).
template <int D>
const OctaveTables<D>& TheOctaveTables() {
  static const OctaveTables<D> tables = DeriveOctaveTables<D>();
  return tables;
}

}  // namespace internal

// The vertex that splitting `code` creates (the midpoint of its split edge),
// in lattice coordinates: SplitMidpoint(code, Vertices(code)) without the
// vertices. O(level / D): one table step per octave.
// REQUIRES: code.is_valid().
template <int D>
Point<D> SplitVertex(SimplexCode<D> code) {
  assert(code.is_valid());
  const auto& t = internal::TheOctaveTables<D>();
  const int level = code.level();
  const int octaves = level / D, r = level % D;
  const uint64_t path = code.path();
  uint32_t state = t.root_state[code.top()];
  std::array<uint32_t, D> cube{};  // the octave cube's corner, one bit per octave
  for (int o = 0; o < octaves; ++o) {
    const uint32_t bits = static_cast<uint32_t>(path >> (level - D * (o + 1))) & ((1u << D) - 1);
    const uint32_t e = t.step[state][bits];
    for (int a = 0; a < D; ++a) cube[a] = cube[a] << 1 | (e >> a & 1);
    state = e >> D;
  }
  const uint32_t w = t.split[state][(1u << r) - 1 + (path & ((uint64_t{1} << r) - 1))];
  const int side = kCoordBits<D> - octaves;  // the cube's side is 2^side
  Point<D> v{};
  for (int a = 0; a < D; ++a) {
    v[a] = static_cast<int32_t>((cube[a] << side) + ((w >> (2 * a) & 3) << (side - 1)));
  }
  return v;
}

// SplitVertex for a sequence of codes that share long prefixes (a walk of
// the hierarchy): keeps the octave steps of the last code and restarts from
// the last octave the new code shares with it. A depth-first walk then costs
// O(1) table steps per code, against O(level / D) for SplitVertex.
// Thread safety: one thread's at a time (it is a cache).
template <int D>
class SplitVertexCursor {
 public:
  // REQUIRES: code.is_valid().
  Point<D> Of(SimplexCode<D> code) {
    assert(code.is_valid());
    const auto& t = *tables_;
    const int level = code.level();
    const int octaves = level / D, r = level % D;
    // The levels both codes have and agree on: the first differing key bit
    // below the root's bits.
    constexpr int kTopBits = SimplexCode<D>::kTopBits;
    const uint64_t diff = (code.key() ^ last_key_) >> SimplexCode<D>::kLevelBits;
    int shared = diff == 0 ? SimplexCode<D>::kMaxLevel
                           : std::countl_zero(diff) - SimplexCode<D>::kLevelBits - kTopBits;
    shared = std::min({shared, level, last_level_});
    int o = shared < 0 ? 0 : shared / D;
    if (o == 0) {
      state_[0] = t.root_state[code.top()];
      cube_[0] = {};
    }
    const uint64_t path = code.path();
    for (; o < octaves; ++o) {
      const uint32_t bits = static_cast<uint32_t>(path >> (level - D * (o + 1))) & ((1u << D) - 1);
      const uint32_t e = t.step[state_[o]][bits];
      for (int a = 0; a < D; ++a) cube_[o + 1][a] = cube_[o][a] << 1 | (e >> a & 1);
      state_[o + 1] = static_cast<uint16_t>(e >> D);
    }
    last_key_ = code.key();
    last_level_ = level;
    const uint32_t w =
        t.split[state_[octaves]][(1u << r) - 1 + (path & ((uint64_t{1} << r) - 1))];
    const int side = kCoordBits<D> - octaves;
    Point<D> v{};
    for (int a = 0; a < D; ++a) {
      v[a] = static_cast<int32_t>((cube_[octaves][a] << side) + ((w >> (2 * a) & 3) << (side - 1)));
    }
    return v;
  }

 private:
  static constexpr int kMaxOctaves = SimplexCode<D>::kMaxLevel / D + 1;
  const internal::OctaveTables<D>* tables_ = &internal::TheOctaveTables<D>();
  uint64_t last_key_ = SimplexCode<D>::None().key();
  int last_level_ = -1;  // no code yet: nothing is shared
  std::array<uint16_t, kMaxOctaves + 1> state_{};
  std::array<std::array<uint32_t, D>, kMaxOctaves + 1> cube_{};
};

// The HZ order of the grid [0, 2^k]^D (the header comment above).
// Thread safety: an immutable value.
template <int D>
class HzOrder {
 public:
  using GridPoint = std::array<int64_t, D>;
  static constexpr int kCorners = 1 << D;

  // REQUIRES: 1 <= domain_bits <= kCoordBits<D> - 1 (HT 18, HP 13).
  explicit constexpr HzOrder(int domain_bits) : k_(domain_bits) {
    assert(domain_bits >= 1 && domain_bits < kCoordBits<D>);
    begin_[0] = kCorners;
    for (int c = 0; c < levels(); ++c) begin_[c + 1] = begin_[c] + LevelSize(c);
  }

  int domain_bits() const { return k_; }
  // Creation levels run 0 .. levels() - 1: the internal levels of the hierarchy.
  constexpr int levels() const { return D * k_; }
  // The virtual positions: [0, size()).
  uint64_t size() const { return begin_[levels()]; }

  // The level whose splits create `g`, or -1 for a corner of the domain.
  // REQUIRES: g in [0, 2^k]^D.
  int Level(const GridPoint& g) const {
    uint64_t any = 0;
    for (int a = 0; a < D; ++a) any |= static_cast<uint64_t>(g[a]);
    const int s = any == 0 ? k_ : std::countr_zero(any);
    if (s >= k_) return -1;
    int m = 0;
    for (int a = 0; a < D; ++a) m += static_cast<int>(g[a] >> s & 1);
    return D * (k_ - 1 - s) + (D - m);
  }

  // The level-c positions are [LevelBegin(c), LevelEnd(c)); level -1 is the
  // corners. REQUIRES: -1 <= c < levels().
  uint64_t LevelBegin(int c) const { return c < 0 ? 0 : begin_[c]; }
  uint64_t LevelEnd(int c) const { return begin_[c + 1]; }
  static constexpr uint64_t LevelSize(int c) {
    return uint64_t{internal::kOddPatterns<D>.count[D - c % D]} << (D * (c / D + 1));
  }

  // The position of grid point g. REQUIRES: g in [0, 2^k]^D.
  uint64_t Position(const GridPoint& g) const { return PositionAtLevel(g, Level(g)); }

  // The same, when the caller knows g's level. REQUIRES: level == Level(g).
  uint64_t PositionAtLevel(const GridPoint& g, int level) const {
    assert(level == Level(g));
    if (level < 0) {
      uint64_t corner = 0;
      for (int a = 0; a < D; ++a) corner |= static_cast<uint64_t>(g[a] >> k_) << a;
      return corner;
    }
    const int s = k_ - 1 - level / D;
    uint32_t odd = 0;
    GridPoint u{};
    for (int a = 0; a < D; ++a) {
      odd |= static_cast<uint32_t>(g[a] >> s & 1) << a;
      u[a] = g[a] >> (s + 1);
    }
    return (uint64_t{1} + internal::kOddPatterns<D>.segment_of[odd]) << (D * (level / D + 1)) |
           internal::Morton<D>(u);
  }

  // The position of the vertex `code` creates. O(level / D).
  // REQUIRES: code.is_valid(), code.level() < levels().
  uint64_t PositionOf(SimplexCode<D> code) const {
    assert(code.level() < levels());
    return PositionAtLevel(LatticeToGrid<D>(SplitVertex(code), k_), code.level());
  }

  // The level of position `p`. REQUIRES: p < size().
  int LevelAt(uint64_t p) const {
    return static_cast<int>(std::upper_bound(begin_.begin(), begin_.begin() + levels() + 1, p) -
                            begin_.begin()) -
           1;
  }

  // Whether position p names a grid point (false for the holes past the
  // upper faces). REQUIRES: p < size().
  bool IsVertex(uint64_t p) const {
    GridPoint g;
    return Decode(p, g);
  }

  // The grid point at position p. REQUIRES: IsVertex(p).
  GridPoint PointAt(uint64_t p) const {
    GridPoint g{};
    [[maybe_unused]] const bool ok = Decode(p, g);
    assert(ok);
    return g;
  }

  // Decodes p into g; false when p is a hole. REQUIRES: p < size().
  bool Decode(uint64_t p, GridPoint& g) const {
    assert(p < size());
    const int c = LevelAt(p);
    if (c < 0) {
      for (int a = 0; a < D; ++a) g[a] = static_cast<int64_t>(p >> a & 1) << k_;
      return true;
    }
    const int o = c / D;
    const uint64_t cell = p & ((uint64_t{1} << (D * (o + 1))) - 1);
    const uint32_t odd = internal::kOddPatterns<D>.mask_of[(p >> (D * (o + 1))) - 1];
    const int s = k_ - 1 - o;
    const GridPoint u = internal::FromMorton<D>(cell);
    const int64_t side = int64_t{1} << k_;
    bool inside = true;
    for (int a = 0; a < D; ++a) {
      g[a] = (u[a] << (s + 1)) | (static_cast<int64_t>(odd >> a & 1) << s);
      inside = inside && g[a] <= side;
    }
    return inside;
  }

 private:
  int k_;
  std::array<uint64_t, D * (kCoordBits<D> - 1) + 1> begin_{};
};

}  // namespace simplexdb
