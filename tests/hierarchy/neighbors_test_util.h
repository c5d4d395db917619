// The face-neighbor checks the HT and HP tests share
// (tests/hierarchy/ht_neighbors_test.cc, hp_neighbors_test.cc), as templates
// over the dimension: geometry as the judge (faces matched by coordinates,
// tests/hierarchy/simplex_reference.h), and the cursor's mask along walks.
#pragma once

#include <gtest/gtest.h>

#include <random>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "hierarchy/level_scan.h"
#include "hierarchy/neighbors.h"
#include "hierarchy/simplex_code.h"
#include "tests/hierarchy/simplex_reference.h"

namespace simplexdb::testing {

// An algorithm under test, by name, so failures say which one broke.
template <int D>
struct NamedNeighbor {
  const char* name;
  SimplexCode<D> (*fn)(SimplexCode<D>, int);
};

// The neighbor across face `type` by one step of a cursor.
template <int D>
SimplexCode<D> ByCursor(SimplexCode<D> c, int type) {
  NeighborCursor<D> cursor(c);
  return cursor.Step(type) ? cursor.code() : SimplexCode<D>::None();
}

// For each level to max_level: every face of every simplex, matched with the
// other simplex (if any) of that level with the same D vertices; each
// algorithm names it, across a face of the same type there, and is an
// involution. With `same_positions`, the shared face also keeps its vertex
// positions on both sides (true in the HP).
template <int D>
void CheckNeighborsByGeometry(int max_level, std::span<const NamedNeighbor<D>> algorithms, bool same_positions) {
  for (int level = 0; level <= max_level; ++level) {
    const auto simplices = AllAtLevel<D>(level);
    std::unordered_map<Face<D>, std::vector<std::pair<SimplexCode<D>, int>>, PointsHash> faces;
    for (const auto& [code, t] : simplices) {
      for (int k = 1; k <= D + 1; ++k) faces[FaceOf(t, k)].emplace_back(code, k);
    }
    std::unordered_map<uint64_t, SimplexVertices<D>> vertices;
    for (const auto& [code, t] : simplices) vertices.emplace(code.key(), t);
    for (const auto& [code, t] : simplices) {
      for (int k = 1; k <= D + 1; ++k) {
        const Face<D> f = FaceOf(t, k);
        const auto& holders = faces[f];
        ASSERT_LE(holders.size(), 2u) << "a face shared by three simplices";
        for (const NamedNeighbor<D>& alg : algorithms) {
          SCOPED_TRACE(::testing::Message() << alg.name << ": " << code.ToString() << " type " << k);
          const SimplexCode<D> n = alg.fn(code, k);
          if (holders.size() == 1) {
            ASSERT_TRUE(OnDomainBoundary(f)) << "an unmatched inner face";
            ASSERT_TRUE(n.is_none()) << "got " << n.ToString();
            continue;
          }
          ASSERT_FALSE(OnDomainBoundary(f));
          const auto& other = holders[0].first == code ? holders[1] : holders[0];
          ASSERT_EQ(n, other.first);
          ASSERT_EQ(other.second, k) << "the shared face has another type there";
          ASSERT_EQ(n.level(), code.level());
          if (same_positions) {
            ASSERT_EQ(FaceOf(vertices.at(n.key()), k, false), FaceOf(t, k, false));
          }
          ASSERT_EQ(alg.fn(n, k), code) << "not an involution";
        }
      }
    }
  }
}

// Deep codes, random, to the maximum level: the neighbor computed from the
// code shares the face geometrically (the same D vertices, in the same
// positions with `same_positions`, and another apex), and is an involution.
template <int D>
void CheckRandomNeighborsGeometrically(uint64_t seed, int count, bool same_positions) {
  using Code = SimplexCode<D>;
  std::mt19937_64 rng(seed);
  for (int i = 0; i < count; ++i) {
    const int level = static_cast<int>(rng() % (Code::kMaxLevel + 1));
    const Code c = Code::FromPath(static_cast<int>(rng() % Code::kRoots), level ? rng() >> (64 - level) : 0, level);
    const SimplexVertices<D> t = Vertices(c);
    for (int k = 1; k <= D + 1; ++k) {
      SCOPED_TRACE(::testing::Message() << c.ToString() << " type " << k);
      const Code n = Neighbor(c, k);
      if (n.is_none()) {
        ASSERT_TRUE(OnDomainBoundary(FaceOf(t, k)));
        continue;
      }
      const SimplexVertices<D> u = Vertices(n);
      ASSERT_EQ(FaceOf(u, k, !same_positions), FaceOf(t, k, !same_positions));
      ASSERT_NE(u[D + 1 - k], t[D + 1 - k]) << "the apex must differ";
      ASSERT_EQ(Neighbor(n, k), c);
    }
  }
}

// The mask a cursor maintains in O(1) per step stays equal to the mask
// derived from scratch, along 2000 random walks of 500 steps from codes
// start(rng, level).
template <int D, class Start>
void CheckCursorMaskAlongWalks(uint64_t seed, Start&& start) {
  using Code = SimplexCode<D>;
  std::mt19937_64 rng(seed);
  for (int walk = 0; walk < 2000; ++walk) {
    const int level = static_cast<int>(rng() % (Code::kMaxLevel + 1));
    NeighborCursor<D> cursor(start(rng, level));
    for (int step = 0; step < 500; ++step) {
      const Code before = cursor.code();
      const int k = 1 + static_cast<int>(rng() % (D + 1));
      const Code expected = NeighborScan(before, k);
      const bool moved = cursor.Step(k);
      ASSERT_EQ(moved, !expected.is_none());
      ASSERT_EQ(cursor.code(), moved ? expected : before);
      ASSERT_EQ(cursor.mask(), NeighborMask(cursor.code())) << before.ToString() << " type " << k;
    }
  }
}

// The scan against the per-level reference on a million deep codes
// code(rng, level).
template <int D, class MakeCode>
void CheckScanEqualsLevelScan(uint64_t seed, MakeCode&& code) {
  std::mt19937_64 rng(seed);
  for (int i = 0; i < 1'000'000; ++i) {
    const int level = static_cast<int>(rng() % (SimplexCode<D>::kMaxLevel + 1));
    const SimplexCode<D> c = code(rng, level);
    for (int k = 1; k <= D + 1; ++k) {
      ASSERT_EQ(NeighborScan(c, k), NeighborByLevelScan<D>(c, k)) << c.ToString() << " type " << k;
    }
  }
}

// Root faces of types 1 and 2 lie on the domain's boundary; the others are
// shared with another root, across a face of the same type.
template <int D>
void CheckRootTable() {
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    EXPECT_EQ(kRootFaceToRoot<D>[top][0], -1);
    EXPECT_EQ(kRootFaceToRoot<D>[top][1], -1);
    for (int k = 3; k <= D + 1; ++k) {
      const int other = kRootFaceToRoot<D>[top][k - 1];
      ASSERT_GE(other, 0);
      EXPECT_EQ(kRootFaceToRoot<D>[other][k - 1], top);
    }
  }
}

}  // namespace simplexdb::testing
