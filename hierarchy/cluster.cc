#include "hierarchy/cluster.h"

#include <array>
#include <cassert>

#include "hierarchy/geometry.h"
#include "hierarchy/neighbors.h"
#include "hierarchy/split_rules.h"

namespace simplexdb {

namespace {

// Walks from `code` across faces of types `first`, then the other of 3 and
// 4, alternately (Figs. 41, 43, 45), appending each tetrahedron met. Returns
// true when the walk closes on `code` (an interior edge) and false when it
// meets the boundary.
bool WalkAroundSplitEdge(TetCode code, int first, TetCluster& out) {
  TetCursor cursor(code);
  for (int type = first; cursor.Step(type); type = 7 - type) {
    const TetCode next = cursor.code();
    if (next == code) return true;
    assert(out.size() < out.capacity());
    out.push_back(next);
  }
  return false;
}

}  // namespace

TetCluster Cluster(TetCode code) {
  TetCluster out{code};
  // One way round; on the boundary the fan is open: collect the other side.
  if (!WalkAroundSplitEdge(code, 3, out)) WalkAroundSplitEdge(code, 4, out);
  return out;
}

namespace {

int PositionOf(const SimplexVertices<3>& v, const Point<3>& p) {
  for (int i = 0; i < 4; ++i) {
    if (v[i] == p) return i;
  }
  assert(false && "a neighbor across a face lacks a vertex of that face");
  return 0;
}

// Walks around the edge {p, q} from `start`, whose vertices are `sv`, first
// crossing the face that omits vertex position `omit`. Appends every
// tetrahedron met; returns true when the walk closes on `start` and false
// when it meets the boundary.
bool WalkAroundEdge(TetCode start, const SimplexVertices<3>& sv, const Point<3>& p,
                    const Point<3>& q, int omit, TetsAroundEdge& out) {
  TetCode cur = start;
  SimplexVertices<3> cv = sv;
  while (true) {
    const TetCode next = Neighbor(cur, FaceTypeOmitting<3>(omit));
    if (next.is_none()) return false;
    if (next == start) return true;
    assert(out.size() < out.capacity());
    out.push_back(next);
    // The crossed face holds p, q and one more vertex x of `cur`. In `next`
    // the two faces containing the edge are the crossed one (it omits the
    // new vertex) and the one omitting x: cross that one next.
    const int pp = PositionOf(cv, p);
    const int pq = PositionOf(cv, q);
    const int px = 0 + 1 + 2 + 3 - pp - pq - omit;
    const SimplexVertices<3> nv = Vertices(next);
    omit = PositionOf(nv, cv[px]);
    cur = next;
    cv = nv;
  }
}

}  // namespace

TetsAroundEdge EdgeNeighbors(TetCode code, int i, int j) {
  assert(i != j && i >= 0 && i < 4 && j >= 0 && j < 4);
  const SimplexVertices<3> v = Vertices(code);
  // The two vertex positions off the edge; each names a face containing it.
  int off[2];
  int n = 0;
  for (int k = 0; k < 4; ++k) {
    if (k != i && k != j) off[n++] = k;
  }
  TetsAroundEdge out{code};
  if (WalkAroundEdge(code, v, v[i], v[j], off[0], out)) return out;
  // Open fan (the edge is on the boundary): walk the other side too.
  WalkAroundEdge(code, v, v[i], v[j], off[1], out);
  return out;
}

namespace {

// The members found so far, for O(1) membership tests: open addressing over
// 128 slots (at most 48 members, so probes stay short). Keys are location
// code keys; ~0 (None's key) marks an empty slot.
class MemberSet {
 public:
  // Returns true if `c` was not in the set (and inserts it).
  bool Insert(PentaCode c) {
    uint64_t slot = (c.key() * 0x9E3779B97F4A7C15ULL) >> (64 - kBits);
    while (slots_[slot] != kEmpty) {
      if (slots_[slot] == c.key()) return false;
      slot = (slot + 1) & (kSlots - 1);
    }
    slots_[slot] = c.key();
    return true;
  }

 private:
  static constexpr int kBits = 7;
  static constexpr size_t kSlots = size_t{1} << kBits;
  static constexpr uint64_t kEmpty = ~uint64_t{0};
  static_assert(kSlots >= 2 * kMaxPentaCluster);
  std::array<uint64_t, kSlots> slots_ = [] {
    std::array<uint64_t, kSlots> a{};
    a.fill(kEmpty);
    return a;
  }();
};

}  // namespace

PentaCluster Cluster(PentaCode code) {
  PentaCluster out{code};
  MemberSet members;
  members.Insert(code);
  boost::container::static_vector<PentaCursor, kMaxPentaCluster> cursors{
      PentaCursor(code)};
  // The face type each member was reached through: a shared face has the
  // same type on both sides, so stepping back across it is known to lead to
  // a member already found.
  boost::container::static_vector<int8_t, kMaxPentaCluster> entered{0};
  for (size_t i = 0; i < out.size(); ++i) {
    const auto edge = SplitEdge(out[i]);  // every member's own split edge
    for (int omit = 0; omit < 5; ++omit) {
      const int type = FaceTypeOmitting<4>(omit);
      if (omit == edge[0] || omit == edge[1] || type == entered[i]) continue;
      PentaCursor next = cursors[i];
      if (!next.Step(type)) continue;  // boundary
      const PentaCode n = next.code();
      if (!members.Insert(n)) continue;
      assert(out.size() < out.capacity());
      out.push_back(n);
      cursors.push_back(next);
      entered.push_back(static_cast<int8_t>(type));
    }
  }
  return out;
}

}  // namespace simplexdb
