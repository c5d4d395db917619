// The vertex-geometry checks the HT and HP tests share
// (tests/hierarchy/ht_geometry_test.cc, hp_geometry_test.cc), as templates
// over the dimension, against the literal split rules of
// tests/hierarchy/simplex_reference.h.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "tests/hierarchy/simplex_reference.h"

namespace simplexdb::testing {

// Vertices() equals the recursive bisection for every code to max_level
// (all of them visited: kRoots * (2^(max_level+1) - 1)).
template <int D>
void CheckVerticesEqualLiteral(int max_level) {
  size_t count = 0;
  ForEachLiteral<D>(max_level, [&](SimplexCode<D> c, const SimplexVertices<D>& t) {
    ++count;
    ASSERT_EQ(Vertices(c), t) << c.ToString();
  });
  EXPECT_EQ(count, SimplexCode<D>::kRoots * ((size_t{2} << max_level) - 1));
}

// ChildVertices (one split, for descents) agrees with Vertices for every
// code above max_level.
template <int D>
void CheckChildVertices(int max_level) {
  ForEachLiteral<D>(max_level, [&](SimplexCode<D> c, const SimplexVertices<D>& t) {
    if (c.level() == max_level) return;
    for (int i = 0; i < 2; ++i) ASSERT_EQ(ChildVertices(c, t, i), Vertices(c.child(i)));
  });
}

// Shapes repeat every D levels at half the size: the code at `level` + D on
// the first path of root `top` is congruent to the one at `level`, scaled by
// 1/2, for every level to max_level.
template <int D>
void CheckShapesCycle(int top, int max_level) {
  for (int level = 0; level <= max_level; ++level) {
    const SimplexVertices<D> a = Vertices(SimplexCode<D>::FromPath(top, 0, level));
    const SimplexVertices<D> b = Vertices(SimplexCode<D>::FromPath(top, 0, level + D));
    for (int i = 0; i <= D; ++i) {
      for (int j = i + 1; j <= D; ++j) ASSERT_EQ(Dist2(a[i], a[j]), 4 * Dist2(b[i], b[j])) << level;
    }
  }
}

}  // namespace simplexdb::testing
