// TriLeafStore<P>: a variable-resolution triangle quadtree over the sphere,
// kept on disk as the seed's sorted list of leaves (section 2.6: "the nodes
// are usually kept in a list L that is sorted ... maintaining L using an
// index such as a B-tree"). The B-tree is LMDB; the format is
// docs/format/tri-leaf-store.md.
//
// Invariant: the leaves tile the sphere (every point of the solid lies in
// exactly one leaf). A new store holds the base faces. Every write keeps the
// invariant and is one LMDB transaction, so a crash leaves the state before
// or after it, never half of it:
//
//   Refine(c)   makes c a leaf: the leaf holding c is replaced by c and the
//               three siblings of c and of each of its ancestors below that
//               leaf (3 per level). O(levels * log n).
//   Coarsen(c)  makes c a leaf: every leaf below c is removed. O(k log n)
//               for k leaves removed.
//
// Reads: LeafContaining(code) and LeafAt(lat/lng) find the leaf holding a
// triangle or a point with one B-tree search (the largest key at most the
// code's: with preorder keys, its leaf ancestor when it has one);
// Neighbor(leaf, dir) is 2.6's neighbor of greater or equal size, through
// the same search. Each read is one read transaction (a snapshot).
//
// Errors: NotFound when the file is missing (Open) or a code lies in no
// leaf (it is subdivided); InvalidArgument for a file that is not a leaf
// store of this solid, or a write that would break the invariant (refining
// a subdivided triangle, coarsening inside a leaf), or any write to a store
// opened read-only; Corruption when Verify() finds the leaves do not tile
// the sphere; LMDB's errors as lmdb::FromCode translates them.
//
// Thread safety: all methods may be called from several threads (LMDB
// serializes the writers; MDB_NOTLS lets each read run its own snapshot).
// Lifetimes: the vectors and codes returned are copies; nothing refers
// into the store after a call returns.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hierarchy/tri_code.h"
#include "hierarchy/tri_geometry.h"
#include "hierarchy/tri_neighbors.h"
#include "util/status.h"

namespace simplexdb {

namespace lmdb {
class Env;  // storage/io/lmdb.h, which embedders need not include
}  // namespace lmdb

template <Polyhedron P>
class TriLeafStore {
 public:
  using Code = TriCode<P>;

  // Creates a store at `path` whose leaves are the solid's base faces.
  // REQUIRES: nothing at `path` (InvalidArgument otherwise).
  static Result<std::unique_ptr<TriLeafStore>> Create(const std::string& path);
  // Opens an existing store; writes fail when `read_only`.
  static Result<std::unique_ptr<TriLeafStore>> Open(const std::string& path, bool read_only);
  ~TriLeafStore();

  Status Refine(Code code);
  Status Coarsen(Code code);

  // The leaf that is `code` or an ancestor of it; NotFound when `code` is
  // subdivided (leaves below it).
  Result<Code> LeafContaining(Code code) const;
  // The leaf holding the point (on an edge: one of the leaves sharing it).
  Result<Code> LeafAt(LatLng point) const;
  // 2.6 through the B-tree: the leaf across the edge of `dir` of `leaf`
  // that is as large or larger, or the subdivided equal-size triangle.
  // REQUIRES: leaf is a leaf of the store (checked: InvalidArgument).
  Result<TriSizedNeighbor<P>> Neighbor(Code leaf, TriDirection dir) const;

  // The leaves in key order (all of them, or those below `under`).
  Result<std::vector<Code>> Leaves() const;
  Result<std::vector<Code>> LeavesUnder(Code under) const;
  Result<uint64_t> LeafCount() const;

  // Checks that the leaves are valid codes of this solid tiling the sphere.
  // O(n).
  Status Verify() const;

  const std::string& path() const;

 private:
  TriLeafStore(std::unique_ptr<lmdb::Env> env, unsigned int leaves, bool read_only);

  // Runs `edit` in a write transaction and commits; when the map is full,
  // aborts, doubles the map and runs it again.
  template <class Edit>
  Status Write(const char* what, Edit edit);

  std::unique_ptr<lmdb::Env> env_;
  unsigned int leaves_;  // the MDB_dbi of the leaves
  bool read_only_;
};

extern template class TriLeafStore<Polyhedron::kIcosahedron>;
extern template class TriLeafStore<Polyhedron::kOctahedron>;
extern template class TriLeafStore<Polyhedron::kTetrahedron>;

}  // namespace simplexdb
