// The reference face-neighbor algorithm: the nearest-common-ancestor scan of
// sections 3.2 and 4.3, one level at a time, driven only by the split rules
// (FaceTransitions<D>, derived from hierarchy/split_rules.h).
//
// It walks from the code towards the root while the sought face lies inside
// a face of the ancestor, and flips the one bit of the level where the face
// is shared by two siblings; at the root it crosses to another root by table
// or reports the boundary. It is the slow, obviously-right algorithm the
// grouped scans (Figs. 38 and 53) and the constant-time algorithms are tested
// against. O(level).
#pragma once

#include <cassert>
#include <cstdint>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "hierarchy/split_rules.h"

namespace simplexdb {

// The same-level simplex sharing the face of type `type` with `code`, or
// SimplexCode<D>::None() when that face lies on the domain boundary.
// REQUIRES: code.is_valid(), 1 <= type <= D + 1.
template <int D>
constexpr SimplexCode<D> NeighborByLevelScan(SimplexCode<D> code, int type) {
  assert(code.is_valid() && type >= 1 && type <= D + 1);
  const int level = code.level();
  const uint64_t path = code.path();
  int k = type;
  for (int l = level; l >= 1; --l) {
    const int shift = level - l;
    const int next = ClimbOneLevel<D>(l, path >> shift, k);
    if (next == 0) return code.with_path(path ^ (uint64_t{1} << shift));
    k = next;
  }
  const int root = kRootFaceToRoot<D>[code.top()][k - 1];
  return root < 0 ? SimplexCode<D>::None() : code.with_top(root);
}

}  // namespace simplexdb
