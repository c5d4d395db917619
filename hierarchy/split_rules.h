// The bisection rules of the seed as tables, and the per-level facts that
// follow from them.
//
// Conventions used throughout hierarchy/:
//   * Vertex positions are 0-based in code: position 0 is the seed's v1,
//     position D is v_{D+1}.
//   * Face (neighbor) types are 1-based as in the seed. Type k is the face
//     opposite vertex position D+1-k:
//       HT (3.2): 1 = v1v2v3, 2 = v1v2v4, 3 = v1v3v4, 4 = v2v3v4.
//       HP (4.3): 1 = v1v2v3v4, 2 = v1v2v3v5, 3 = v1v2v4v5, 4 = v1v3v4v5,
//                 5 = v2v3v4v5.
//   * A child produced by a split is [vm, p_1, ..., p_D]: the midpoint vm of
//     the split edge first, then D vertices of the parent, in an order fixed
//     by the rule. Each child keeps one endpoint of the split edge.
//
// Nothing here allocates; every table is constexpr.
#pragma once

#include <array>
#include <cstdint>

namespace simplexdb {

// Face type k <-> the vertex position it omits.
template <int D>
constexpr int OmittedVertex(int face_type) {
  return D + 1 - face_type;
}
template <int D>
constexpr int FaceTypeOmitting(int position) {
  return D + 1 - position;
}

template <int D>
struct SplitRules;

// HT, section 3.1.2. Shapes cycle with the level: level = 0 mod 3 is a 1/8
// pyramid (the six roots too), 1 mod 3 a 1/2 pyramid, 2 mod 3 a 1/4 pyramid.
// Every shape splits its edge v3v4.
template <>
struct SplitRules<3> {
  static constexpr int kCases = 4;

  // case -> the edge being bisected (vertex positions).
  static constexpr std::array<std::array<uint8_t, 2>, kCases> kCaseToSplitEdge =
      {{{2, 3}, {2, 3}, {2, 3}, {2, 3}}};

  // [case][child][j]: the parent's vertex position that becomes the child's
  // vertex j+1 (vertex 0 of the child is the midpoint).
  //   A = [vm, v1, v2, v3], B = [vm, v1, v2, v4], C = [vm, v2, v1, v3].
  // Case 0, 1/8 pyramid:  t0 = B, t1 = C.
  // Case 1, 1/2 pyramid:  t0 = A, t1 = B.
  // Case 2, 1/4 pyramid whose parent is child 0:  t0 = A, t1 = B.
  // Case 3, 1/4 pyramid whose parent is child 1:  t0 = B, t1 = A.
  // SEED-ERRATA item 1: "the parent was child 0" names the 1/4 pyramid's
  // parent (bit 1 of its 3-bit group), not the 1/4 pyramid's own bit. Only
  // this reading reproduces Fig. 38 and the 210011 walk-through of 3.2.3
  // (tests/hierarchy/ht_neighbors_test.cc checks both).
  static constexpr std::array<std::array<std::array<uint8_t, 3>, 2>, kCases>
      kCaseChildToParentVertex = {{
          {{{0, 1, 3}, {1, 0, 2}}},  // B, C
          {{{0, 1, 2}, {0, 1, 3}}},  // A, B
          {{{0, 1, 2}, {0, 1, 3}}},  // A, B
          {{{0, 1, 3}, {0, 1, 2}}},  // B, A
      }};

  // The case that splits the simplex at `level` with right-aligned `path`.
  static constexpr int CaseOf(int level, uint64_t path) {
    switch (level % 3) {
      case 0: return 0;
      case 1: return 1;
      default: return 2 + static_cast<int>((path >> 1) & 1);
    }
  }

  // Roots: for the axis permutation (a, b, c) numbered in lexicographic
  // order, vertex position i is the sum of the first kRootVertexHotness[i]
  // unit vectors e_a, e_b, e_c: v1 = e_a, v2 = e_a + e_b, v3 = (1,1,1),
  // v4 = origin (SEED-ERRATA item 3).
  static constexpr std::array<uint8_t, 4> kRootVertexHotness = {1, 2, 3, 0};
};

// HP, section 4.2, Fig. 52. Shapes cycle with the level: h (0 mod 4, the 24
// roots too), c (1), s (2), e (3). The c- and s-rules depend on the child
// bits of the node (P) and of its parent (G).
template <>
struct SplitRules<4> {
  static constexpr int kCases = 8;

  // Fig. 52 cases 1..8 are cases 0..7 here.
  static constexpr std::array<std::array<uint8_t, 2>, kCases> kCaseToSplitEdge =
      {{{3, 4},    // 1: h           v4v5
        {3, 4},    // 2: c, P = 0    v4v5
        {1, 4},    // 3: c, P = 1    v2v5
        {3, 4},    // 4: s, G0 P0    v4v5
        {2, 4},    // 5: s, G0 P1    v3v5
        {2, 3},    // 6: s, G1 P0    v3v4
        {2, 4},    // 7: s, G1 P1    v3v5
        {3, 4}}};  // 8: e           v4v5

  static constexpr std::array<std::array<std::array<uint8_t, 4>, 2>, kCases>
      kCaseChildToParentVertex = {{
          {{{0, 1, 2, 4}, {0, 1, 2, 3}}},  // 1: [vm,v1,v2,v3,v5] [vm,v1,v2,v3,v4]
          {{{0, 1, 2, 4}, {0, 1, 2, 3}}},  // 2: [vm,v1,v2,v3,v5] [vm,v1,v2,v3,v4]
          {{{0, 4, 2, 3}, {0, 1, 2, 3}}},  // 3: [vm,v1,v5,v3,v4] [vm,v1,v2,v3,v4]
          {{{0, 1, 2, 3}, {0, 1, 2, 4}}},  // 4: [vm,v1,v2,v3,v4] [vm,v1,v2,v3,v5]
          {{{0, 1, 2, 3}, {0, 1, 4, 3}}},  // 5: [vm,v1,v2,v3,v4] [vm,v1,v2,v5,v4]
          {{{0, 1, 4, 2}, {0, 1, 4, 3}}},  // 6: [vm,v1,v2,v5,v3] [vm,v1,v2,v5,v4]
          {{{0, 1, 2, 3}, {0, 1, 4, 3}}},  // 7: [vm,v1,v2,v3,v4] [vm,v1,v2,v5,v4]
          {{{0, 1, 2, 3}, {0, 1, 2, 4}}},  // 8: [vm,v1,v2,v3,v4] [vm,v1,v2,v3,v5]
      }};

  static constexpr int CaseOf(int level, uint64_t path) {
    const int p = static_cast<int>(path & 1);         // the node's own bit
    const int g = static_cast<int>((path >> 1) & 1);  // its parent's bit
    switch (level % 4) {
      case 0: return 0;
      case 1: return 1 + p;
      case 2: return 3 + 2 * g + p;
      default: return 7;
    }
  }

  // v1 = three-hot, v2 = two-hot, v3 = one-hot, v4 = origin, v5 = all ones
  // (SEED-ERRATA item 3).
  static constexpr std::array<uint8_t, 5> kRootVertexHotness = {3, 2, 1, 0, 4};
};

// What a split does to faces. For a child of a simplex split by `case`:
//   kFaceToParentFace[case][child][k-1] == 0: the child's type-k face cuts
//       through the parent; it is shared with the sibling.
//   == k' (1..D+1): the child's type-k face lies inside the parent's type-k'
//       face, so the type-k neighbor of the child is a child of the parent's
//       type-k' neighbor.
// Derived from the rules alone: a child face that omits the midpoint is the
// parent face omitting the endpoint the child lacks; one that omits the
// child's own endpoint of the split edge is the cut; any other face omits a
// parent vertex w, contains the whole split edge's line, and so lies in the
// parent face omitting w.
template <int D>
struct FaceTransitions {
  using Rules = SplitRules<D>;
  static constexpr int kCases = Rules::kCases;
  using Table = std::array<std::array<std::array<int8_t, D + 1>, 2>, kCases>;

  static constexpr Table Derive() {
    Table t{};
    for (int c = 0; c < kCases; ++c) {
      const int a = Rules::kCaseToSplitEdge[c][0];
      const int b = Rules::kCaseToSplitEdge[c][1];
      for (int child = 0; child < 2; ++child) {
        const auto& from = Rules::kCaseChildToParentVertex[c][child];
        bool has_a = false;
        for (int j = 0; j < D; ++j) has_a = has_a || from[j] == a;
        for (int k = 1; k <= D + 1; ++k) {
          const int omitted = OmittedVertex<D>(k);
          int up;
          if (omitted == 0) {
            up = FaceTypeOmitting<D>(has_a ? b : a);
          } else {
            const int w = from[omitted - 1];
            up = (w == a || w == b) ? 0 : FaceTypeOmitting<D>(w);
          }
          t[c][child][k - 1] = static_cast<int8_t>(up);
        }
      }
    }
    return t;
  }

  // Every rule keeps exactly one endpoint of its split edge and every other
  // vertex once; checked at compile time.
  static constexpr bool RulesAreBisections() {
    for (int c = 0; c < kCases; ++c) {
      const int a = Rules::kCaseToSplitEdge[c][0];
      const int b = Rules::kCaseToSplitEdge[c][1];
      bool kept_a[2] = {false, false};
      for (int child = 0; child < 2; ++child) {
        int seen[D + 1] = {};
        for (int j = 0; j < D; ++j) ++seen[Rules::kCaseChildToParentVertex[c][child][j]];
        if (seen[a] + seen[b] != 1) return false;
        for (int v = 0; v <= D; ++v) {
          if (v != a && v != b && seen[v] != 1) return false;
        }
        kept_a[child] = seen[a] == 1;
      }
      if (kept_a[0] == kept_a[1]) return false;  // children must differ
    }
    return true;
  }
  static_assert(RulesAreBisections());

  static constexpr Table kFaceToParentFace = Derive();
};

// One step of the nearest-common-ancestor climb: a simplex at `level` >= 1
// whose right-aligned path is `path` seeks its face of type `type`. Returns 0
// when that face is shared with its sibling (flip the last bit), otherwise
// the type of the parent's face that contains it (continue one level up).
template <int D>
constexpr int ClimbOneLevel(int level, uint64_t path, int type) {
  const int c = SplitRules<D>::CaseOf(level - 1, path >> 1);
  return FaceTransitions<D>::kFaceToParentFace[c][path & 1][type - 1];
}

// The partial group at the bottom of a code. A code at level L = D*G + r
// (0 <= r < D) ends with r levels below the last full period; the seed's
// grouped algorithms (Figs. 38 and 53) start at level D*G, so the last r
// levels are stepped through one at a time first (3.3: "a maximum of two
// steps" in the HT; up to three in the HP, SEED-ERRATA item 6). The result
// depends only on r, the r tail bits and the face type, so it is a table.
//
//   flip != 0: the neighbor differs in the tail bits set in `flip` (one bit;
//              bit 0 is the deepest level), and `type` is 0.
//   flip == 0: continue with face type `type` of the ancestor at level D*G.
struct TailStep {
  uint8_t flip;
  uint8_t type;
};

template <int D>
struct TailSteps {
  // [r][tail bits][k-1]
  using Table = std::array<std::array<std::array<TailStep, D + 1>, 1 << (D - 1)>, D>;

  static constexpr Table Derive() {
    Table t{};
    for (int r = 0; r < D; ++r) {
      for (uint64_t bits = 0; bits < (uint64_t{1} << r); ++bits) {
        for (int k = 1; k <= D + 1; ++k) {
          TailStep s{0, static_cast<uint8_t>(k)};
          int type = k;
          // Level r (relative to the start of the period) up to level 1;
          // the split rules read only the level modulo the period and the
          // path's last two bits.
          for (int l = r; l >= 1; --l) {
            const int shift = r - l;
            const int next = ClimbOneLevel<D>(l, bits >> shift, type);
            if (next == 0) {
              s = TailStep{static_cast<uint8_t>(1u << shift), 0};
              break;
            }
            type = next;
            s.type = static_cast<uint8_t>(type);
          }
          t[r][bits][k - 1] = s;
        }
      }
    }
    return t;
  }

  static constexpr Table kTable = Derive();
};

}  // namespace simplexdb
