// Mesh<D>: an extracted mesh, the leaves of a cut through the forest of an
// HT (D = 3) or HP (D = 4), held as the set of split nodes.
//
// Invariants (every refinement algorithm keeps them; CheckConformity checks
// the geometry independently):
//   - the parent of a split node is split (the mesh is a cut of the forest);
//   - the cluster of a split node is split whole (the mesh is conforming:
//     section 3.5, all simplices sharing a split edge are split together).
// The leaves are the roots and the children of split nodes that are not
// split themselves: there are kRoots + (number of split nodes) of them.
//
// Thread safety: none; a mesh belongs to one query at a time (const methods
// write nothing, so readers may share a mesh no one changes).
//
// Lifetimes: Leaves() returns a new vector; split_set() is a reference into
// the mesh, valid as long as the mesh.
//
// Errors: none; std::bad_alloc when memory runs out.
#pragma once

#include <cstdint>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "query/split_set.h"

namespace simplexdb {

template <int D>
class Mesh {
 public:
  using Code = SimplexCode<D>;

  // The coarsest mesh: the kRoots root simplices.
  Mesh() = default;

  bool is_split(Code c) const { return split_.contains(c); }
  // A node is in the mesh (a leaf) when it exists and is not split.
  bool is_leaf(Code c) const {
    return !is_split(c) && (c.level() == 0 || is_split(c.parent()));
  }
  uint64_t leaf_count() const { return Code::kRoots + split_.size(); }
  uint64_t split_count() const { return split_.size(); }

  // The leaves in depth-first preorder (ascending keys). O(leaves).
  std::vector<Code> Leaves() const {
    std::vector<Code> out;
    out.reserve(leaf_count());
    std::vector<Code> stack;
    for (int r = Code::kRoots - 1; r >= 0; --r) stack.push_back(Code::Root(r));
    while (!stack.empty()) {
      const Code c = stack.back();
      stack.pop_back();
      if (is_split(c)) {
        stack.push_back(c.child(1));
        stack.push_back(c.child(0));
      } else {
        out.push_back(c);
      }
    }
    return out;
  }

  // Refinement algorithms edit the set directly; they keep the invariants.
  SplitSet<D>& split_set() { return split_; }
  const SplitSet<D>& split_set() const { return split_; }

 private:
  SplitSet<D> split_;
};

}  // namespace simplexdb
