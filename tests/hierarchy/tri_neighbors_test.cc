// Triangle quadtree neighbors. Geometry is the judge: every code to level 8
// on each solid is checked against the exact vertices of the triangle the
// algorithms name; the constant-time algorithm (2.4, 2.5) against the scan
// (2.2, 2.3) on millions of random codes to the maximum level; neighbors of
// greater or equal size (2.6) against the geometry of random
// variable-resolution leaf sets.
#include "hierarchy/tri_neighbors.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <vector>

#include "tests/hierarchy/tri_reference.h"

namespace simplexdb {
namespace {

using testing::AllCodesAtLevel;
using testing::AllPolyhedra;
using testing::DirectionName;
using testing::EdgeOf;
using testing::OnSegment;
using testing::RandomCode;
using testing::SameEdge;
using testing::SolidVertices;

constexpr TriDirection kLeft = TriDirection::kLeft;
constexpr TriDirection kRight = TriDirection::kRight;
constexpr TriDirection kVertical = TriDirection::kVertical;

template <class Tag>
class TriNeighborsTest : public testing::TriFixture<Tag> {};
TYPED_TEST_SUITE(TriNeighborsTest, AllPolyhedra);

IcosaCode I(const char* text) { return IcosaCode::Parse(text).value(); }

// The worked examples of the text, on a face of the icosahedron's middle
// band where the examples' paths stay inside the face.
TEST(TriNeighborsSeed, WorkedExamples) {
  for (auto fn : {&TriNeighbor<Polyhedron::kIcosahedron>,
                  &TriNeighborScan<Polyhedron::kIcosahedron>}) {
    // 2.2.1-2.2.3: EXCODE's right neighbor.
    EXPECT_EQ(fn(I("7:010010110000"), kRight), I("7:010011000101"));
    // 2.3: EXCODE2's left neighbor crosses from face 2 to face 1 (REFLTOP).
    EXPECT_EQ(fn(I("2:010001010001"), kLeft), I("1:110011110011"));
    // 2.4.2, Fig. 13a: RCODE 00011100 -> 00100001.
    EXPECT_EQ(fn(I("7:00011100"), kRight), I("7:00100001"));
    // 2.4.3, Fig. 13b: LCODE 01110001 -> 01101100.
    EXPECT_EQ(fn(I("7:01110001"), kLeft), I("7:01101100"));
    // 2.4.4, Fig. 13c: VCODE 10100111 -> 10000111.
    EXPECT_EQ(fn(I("7:10100111"), kVertical), I("7:10000111"));
    // 2.4.5: 0011110011 carries out of the path ("10100000100" with the
    // overflow bit): on band face 5 the result holds, on face 10.
    EXPECT_EQ(fn(I("5:0011110011"), kRight), I("10:0100000100"));
    // ... on a polar face the input is reflected instead (11 -> 01).
    EXPECT_EQ(fn(I("3:0011110011"), kRight), I("4:0001010001"));
  }
}

// Every code to level 8: for each direction the named triangle is at the
// same level, shares exactly the edge of that direction (and no other
// vertex), names the shared edge as TriNeighborEdge says, and leads back.
// The scan and the constant-time algorithm give the same answer.
TYPED_TEST(TriNeighborsTest, EveryCodeToLevel8SharesExactlyTheNamedEdge) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  for (int level = 0; level <= 8; ++level) {
    for (const Code c : AllCodesAtLevel<P>(level)) {
      const auto v = SolidVertices(c);
      for (int d = 0; d < 3; ++d) {
        const auto dir = static_cast<TriDirection>(d);
        const Code n = TriNeighbor(c, dir);
        const Code scan = TriNeighborScan(c, dir);
        if (n != scan || !n.is_valid() || n.level() != level) {
          FAIL() << c << " " << DirectionName(d) << ": constant " << n << ", scan " << scan;
        }
        const auto w = SolidVertices(n);
        const auto edge = EdgeOf(v, d);
        const TriDirection back = TriNeighborEdge(c, dir);
        if (!SameEdge(edge, EdgeOf(w, static_cast<int>(back)))) {
          FAIL() << c << " " << DirectionName(d) << " -> " << n << " does not share the edge as "
                 << DirectionName(static_cast<int>(back));
        }
        // Exactly one edge: the third vertices differ and are not shared.
        int shared = 0;
        for (const auto& a : v) {
          for (const auto& b : w) shared += a == b;
        }
        if (shared != 2) FAIL() << c << " and " << n << " share " << shared << " vertices";
        if (TriNeighbor(n, back) != c) {
          FAIL() << c << " " << DirectionName(d) << " -> " << n << " -> " << TriNeighbor(n, back);
        }
      }
    }
  }
}

// The two algorithms agree on a million random codes per solid and
// direction, at every level to the maximum (fixed seed).
TYPED_TEST(TriNeighborsTest, ConstantTimeEqualsTheScanOnRandomCodes) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  std::mt19937_64 rng(17 + static_cast<int>(P));
  for (int i = 0; i < 1'000'000; ++i) {
    const Code c = RandomCode<P>(rng, 1 + static_cast<int>(rng() % Code::kMaxLevel));
    for (int d = 0; d < 3; ++d) {
      const auto dir = static_cast<TriDirection>(d);
      const Code n = TriNeighbor(c, dir);
      if (n != TriNeighborScan(c, dir)) {
        FAIL() << c << " " << DirectionName(d) << ": constant " << n << ", scan "
               << TriNeighborScan(c, dir);
      }
      if (TriNeighbor(n, TriNeighborEdge(c, dir)) != c) FAIL() << c << " " << DirectionName(d);
    }
  }
}

// Random codes are mostly inside a face; codes along the base faces' edges
// (paths of two child types) cross faces at every level: check those
// against the geometry to the maximum level.
TYPED_TEST(TriNeighborsTest, DeepCodesOnBaseEdgesCrossFacesCorrectly) {
  using Code = typename TestFixture::CodeType;
  std::mt19937_64 rng(23);
  for (int i = 0; i < 20000; ++i) {
    const int level = 1 + static_cast<int>(rng() % Code::kMaxLevel);
    const int d = static_cast<int>(rng() % 3);
    const auto ends = tri::kEdgeEndChild[d];
    uint64_t path = 0;
    for (int l = 0; l < level; ++l) path = path << 2 | ends[rng() & 1];
    // Now and then a different last pair or two: just inside the face.
    if (rng() % 4 == 0) path ^= rng() & 15 & ((uint64_t{1} << (2 * level)) - 1);
    const Code c = Code::FromPath(static_cast<int>(rng() % Code::kFaces), path, level);
    const auto dir = static_cast<TriDirection>(d);
    const Code n = TriNeighbor(c, dir);
    ASSERT_EQ(n, TriNeighborScan(c, dir)) << c;
    ASSERT_TRUE(SameEdge(EdgeOf(SolidVertices(c), d),
                         EdgeOf(SolidVertices(n), static_cast<int>(TriNeighborEdge(c, dir)))))
        << c << " " << DirectionName(d) << " -> " << n;
  }
}

// A random variable-resolution set of leaves tiling the solid: faces split
// with a probability falling with depth, plus a few chains down to the
// maximum level.
template <Polyhedron P>
std::vector<TriCode<P>> RandomLeaves(std::mt19937_64& rng) {
  using Code = TriCode<P>;
  std::vector<Code> leaves, work;
  std::set<Code> deep;  // ancestors of the deep chains: always split
  for (int i = 0; i < 3; ++i) {
    Code c = RandomCode<P>(rng, Code::kMaxLevel);
    for (int l = 0; l < Code::kMaxLevel; ++l) deep.insert(c.ancestor(l));
  }
  for (int f = 0; f < Code::kFaces; ++f) work.push_back(Code::Face(f));
  while (!work.empty()) {
    const Code c = work.back();
    work.pop_back();
    const bool split = deep.count(c) > 0 ||
                       (c.level() < 7 && static_cast<int>(rng() % 100) < 70 - 8 * c.level());
    if (split) {
      for (int t = 0; t < 4; ++t) work.push_back(c.child(t));
    } else {
      leaves.push_back(c);
    }
  }
  std::sort(leaves.begin(), leaves.end());
  return leaves;
}

// 2.6 against the geometry: an equal or larger leaf has an edge holding the
// sought edge; a smaller answer is the subdivided equal-size triangle across
// the edge.
TYPED_TEST(TriNeighborsTest, GreaterOrEqualSizeNeighborsMatchTheGeometry) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  std::mt19937_64 rng(29);
  size_t counts[3] = {0, 0, 0};
  for (int round = 0; round < 8; ++round) {
    const std::vector<Code> leaves = RandomLeaves<P>(rng);
    const std::set<Code> leaf_set(leaves.begin(), leaves.end());
    for (const Code c : leaves) {
      const auto v = SolidVertices(c);
      for (int d = 0; d < 3; ++d) {
        const auto dir = static_cast<TriDirection>(d);
        const auto edge = EdgeOf(v, d);
        const TriSizedNeighbor<P> r =
            TriNeighborOfGreaterOrEqualSize<P>(std::span<const Code>(leaves), c, dir);
        ++counts[static_cast<int>(r.size)];
        SCOPED_TRACE(::testing::Message() << c << " " << DirectionName(d) << " -> " << r.code);
        const Code same_size = TriNeighbor(c, dir);
        if (r.size == TriNeighborSize::kSmaller) {
          ASSERT_EQ(r.code, same_size);
          ASSERT_EQ(leaf_set.count(r.code), 0u);
          const auto it = leaf_set.upper_bound(r.code);
          ASSERT_TRUE(it != leaf_set.end() && r.code.is_ancestor_of(*it)) << "not subdivided";
          continue;
        }
        ASSERT_EQ(leaf_set.count(r.code), 1u) << "not a leaf";
        ASSERT_LE(r.code.level(), c.level());
        ASSERT_EQ(r.size == TriNeighborSize::kEqual, r.code.level() == c.level());
        ASSERT_NE(r.code, c);
        const auto w = SolidVertices(r.code);
        bool holds = false;
        for (int e = 0; e < 3; ++e) {
          const auto re = EdgeOf(w, e);
          holds = holds || (OnSegment(edge[0], re[0], re[1]) && OnSegment(edge[1], re[0], re[1]));
        }
        ASSERT_TRUE(holds) << "the leaf's edges do not hold the sought edge";
      }
    }
  }
  EXPECT_GT(counts[0], 0u);
  EXPECT_GT(counts[1], 0u);
  EXPECT_GT(counts[2], 0u);
}

}  // namespace
}  // namespace simplexdb
