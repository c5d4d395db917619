// Clusters and edge neighbors (seed sections 3.4, 3.5 and 4.5).
//
// A cluster is the set of same-level simplices that share a simplex's split
// edge: they must all be split together to keep a mesh conforming. In the HT
// it has 4 members around a 1/2 pyramid's edge (plane-aligned), 8 around a
// 1/4 pyramid's (axis-aligned) and 6 around a 1/8 pyramid's (non-aligned; the
// six roots too). In the HP: 24 around an h-pentatope's edge (a hypercube's
// diagonal; the 24 roots too), 12 around a c-, 16 around an s- and 48 around
// an e-pentatope's. Fewer on the boundary (SEED-ERRATA item 10).
//
// Thread safety: pure functions.
#pragma once

#include <boost/container/static_vector.hpp>

#include "hierarchy/simplex_code.h"

namespace simplexdb {

// Upper bounds on the number of same-level simplices around an edge.
inline constexpr int kMaxTetCluster = 8;
inline constexpr int kMaxTetsAroundEdge = 8;
inline constexpr int kMaxPentaCluster = 48;

using TetCluster = boost::container::static_vector<TetCode, kMaxTetCluster>;
using TetsAroundEdge = boost::container::static_vector<TetCode, kMaxTetsAroundEdge>;
using PentaCluster = boost::container::static_vector<PentaCode, kMaxPentaCluster>;

// The cluster of `code`: every tetrahedron at its level that shares its split
// edge v3v4. Found by alternating the face neighbors of types 3 and 4 (the
// two faces that contain v3v4), as in Figs. 41, 43 and 45. Order: `code`
// first, then around the edge; on the boundary the fan is open, and the
// walk goes out one side from `code` and then out the other.
// O(cluster size), constant-time steps.
// REQUIRES: code.is_valid().
TetCluster Cluster(TetCode code);

// Every tetrahedron at the level of `code` that contains the edge between
// its vertex positions `i` and `j` (0-based: 0 is v1) (section 3.4), in the
// order Cluster() uses: `code` first, then around the edge (out one side
// and then the other when the edge is on the boundary).
//
// The walk follows vertex identity, not a fixed sequence of face types:
// SEED-ERRATA items 4 and 5 (the shared face of two siblings of a 1/8 pyramid
// lists its vertices in another order, so Fig. 39's sequences fail for 1/4
// pyramids around v2v3 and v2v4). O(count * level): each step computes the
// neighbor's vertices.
// REQUIRES: code.is_valid(), 0 <= i, j <= 3, i != j.
TetsAroundEdge EdgeNeighbors(TetCode code, int i, int j);

// The cluster of a pentatope (4.5): every pentatope at its level sharing its
// split edge, `code` first. In 4D the pentatopes around an edge form a
// triangulated 2-sphere, not a ring, so this is a breadth-first search
// across the three faces of each member that contain the edge (the faces
// omitting a vertex off the edge), with constant-time steps, `code` first.
// O(cluster size): at most two new steps per member, a hash set of members.
// REQUIRES: code.is_valid().
PentaCluster Cluster(PentaCode code);

}  // namespace simplexdb
