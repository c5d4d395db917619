// An oracle of the errors a store must serve, sharing no code with any
// store: the seed's error of every node by brute force over the test
// volume, the error of every diamond, and the minimal conforming mesh under
// any test of which nodes fail, by a naive least fixed point.
//
//   Simplex(c)  the seed's error of node c: the largest |field - linear
//               interpolation of its vertices' values| over the real grid
//               points inside or on the closed simplex. Every real point of
//               the node's bounding box is tested with exact integer
//               barycentric weights (the adjugate of the edge matrix: on
//               purpose not the signed volumes of tests/util/
//               brute_force_simplex.h, whose box walk it shares, so that
//               tests/query/diamond_refine_test.cc's CheckOracle compares
//               two brute forces); a vertex in the padding takes the nearest real point's value
//               (TestVolume::ClampedAt); a node holding no real point has
//               error 0, and so has every node at or below the leaf level.
//               Exact: test values are multiples of 1/256, so 256 * det *
//               (value - interpolation) is an integer; one division at the
//               end.
//   Diamond(c)  the largest Simplex() over the nodes of c's level that share
//               its split edge (its cluster), grouped here by the edge's
//               vertex positions, not by hierarchy/cluster.h's walk.
//
// Geometry comes from hierarchy/ (codes, vertices, split edges), values from
// the TestVolume; criteria are decided by query/criteria.h's Applies, as the
// refiner decides them (tests/query/criteria_test.cc checks Applies).
//
// Cost: built once per volume, O(sum over internal nodes of their bounding
// boxes' real points): about 10^7 point tests for a 33^3 HT or a 9^4 HP,
// well under a second. Memory: three words per internal node.
//
// Thread safety: immutable once built.
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "query/criteria.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/brute_force_simplex.h"

namespace simplexdb::testing {

template <int D>
class BruteForceErrors {
 public:
  using Code = SimplexCode<D>;
  using Values = std::array<double, D + 1>;

  // REQUIRES: volume.dimension == D, its dims within the domain of side
  // 2^domain_bits, its values multiples of 1/256 (TestVolume::Random's).
  BruteForceErrors(const TestVolume& volume, int domain_bits)
      : volume_(volume), k_(domain_bits), leaf_level_(D * domain_bits) {
    const auto [lo, hi] = std::minmax_element(volume.values.begin(), volume.values.end());
    range_ = *hi - *lo;
    simplex_.resize(static_cast<size_t>(leaf_level_));
    group_.resize(static_cast<size_t>(leaf_level_));
    diamond_.resize(static_cast<size_t>(leaf_level_));
    members_.resize(static_cast<size_t>(leaf_level_));
    std::vector<std::unordered_map<std::pair<uint64_t, uint64_t>, uint32_t, EdgeHash>> by_edge(
        static_cast<size_t>(leaf_level_));
    for (int l = 0; l < leaf_level_; ++l) simplex_[l].resize(uint64_t{Code::kRoots} << l);
    for (int l = 0; l < leaf_level_; ++l) group_[l].resize(uint64_t{Code::kRoots} << l);
    // Every internal node, depth-first with its vertices.
    std::vector<std::pair<Code, SimplexVertices<D>>> stack;
    for (int t = 0; t < Code::kRoots; ++t) stack.emplace_back(Code::Root(t), RootVertices<D>(t));
    while (!stack.empty()) {
      const auto [c, v] = stack.back();
      stack.pop_back();
      const int l = c.level();
      if (l >= leaf_level_) continue;
      const uint64_t slot = Slot(c);
      simplex_[l][slot] = ErrorOf(v);
      const auto e = SplitEdge<D>(c);
      uint64_t a = internal::Pack<D>(v[e[0]]), b = internal::Pack<D>(v[e[1]]);
      if (a > b) std::swap(a, b);
      const auto [it, added] = by_edge[l].emplace(std::pair{a, b}, static_cast<uint32_t>(members_[l].size()));
      if (added) {
        members_[l].emplace_back();
        diamond_[l].push_back(0);
      }
      group_[l][slot] = it->second;
      members_[l][it->second].push_back(c);
      diamond_[l][it->second] = std::max(diamond_[l][it->second], simplex_[l][slot]);
      for (int i = 0; i < 2; ++i) stack.emplace_back(c.child(i), ChildVertices<D>(c, v, i));
    }
    for (int l = 0; l < leaf_level_; ++l) {
      for (double e : diamond_[l]) errors_.push_back(e);
    }
    std::sort(errors_.begin(), errors_.end());
    errors_.erase(std::unique(errors_.begin(), errors_.end()), errors_.end());
  }

  int domain_bits() const { return k_; }
  int leaf_level() const { return leaf_level_; }

  double Simplex(Code c) const { return c.level() >= leaf_level_ ? 0.0 : simplex_[c.level()][Slot(c)]; }
  double Diamond(Code c) const {
    return c.level() >= leaf_level_ ? 0.0 : diamond_[c.level()][group_[c.level()][Slot(c)]];
  }
  // The nodes of c's level sharing its split edge, c among them.
  // REQUIRES: c above the leaf level.
  const std::vector<Code>& Cluster(Code c) const { return members_[c.level()][group_[c.level()][Slot(c)]]; }

  // The field at the vertices `v` (the padding's nearest real values).
  Values VertexValues(const SimplexVertices<D>& v) const {
    Values out{};
    for (int i = 0; i <= D; ++i) out[i] = volume_.template ClampedAt<D>(LatticeToGrid<D>(v[i], k_));
    return out;
  }

  // Whether node c fails `criteria` with error `e` (must be split).
  bool Fails(const Criteria<D>& criteria, Code c, double e) const {
    if (c.level() >= leaf_level_ || !(e > criteria.threshold)) return false;
    if (!criteria.needs_geometry()) return true;
    const SimplexVertices<D> v = Vertices<D>(c);
    const Values values = VertexValues(v);
    return Applies<D>(criteria, v, &values, e);
  }

  // What a store with float32 errors may hold for error e at most: e moved
  // up to the next float, plus the quantizer's margin (storage/error/
  // quantize.h), with room to spare; 0 stays 0.
  double UpperBound(double e) const {
    if (e <= 0) return 0;
    return e * (1 + std::ldexp(1.0, -20)) + 1e-9 * range_;
  }

  // The internal nodes whose decision under `criteria` by diamond error
  // could change between the exact error and any bound a float32 store may
  // hold for it (UpperBound): a test comparing a store's mesh with this
  // oracle's needs none.
  uint64_t Ambiguous(const Criteria<D>& criteria) const {
    uint64_t n = 0;
    for (int l = 0; l < leaf_level_; ++l) {
      for (uint64_t s = 0; s < simplex_[l].size(); ++s) {
        const double e = diamond_[l][group_[l][s]];
        const double up = UpperBound(e);
        if ((e > criteria.threshold) != (up > criteria.threshold)) {
          ++n;
          continue;
        }
        if (!criteria.iso || !(e > criteria.threshold)) continue;
        const Code c = Code::FromPath(static_cast<int>(s >> l), s & ((uint64_t{1} << l) - 1), l);
        n += Fails(criteria, c, e) != Fails(criteria, c, up);
      }
    }
    return n;
  }

  // A threshold near `target` that no diamond error comes near: the
  // midpoint between the largest error at most `target` and the next one
  // (0 stays 0: a zero error is stored as zero). `target` itself when no
  // error exceeds it.
  double ClearThreshold(double target) const {
    if (target <= 0) return 0;
    const auto above = std::upper_bound(errors_.begin(), errors_.end(), target);
    if (above == errors_.end()) return target;
    const double below = above == errors_.begin() ? 0.0 : *(above - 1);
    return (below + *above) / 2;
  }

  // The least set of split nodes that holds the parent and the whole
  // cluster of each of its nodes and leaves no leaf (above the leaf level)
  // for which fails(leaf) holds: "split what fails among the leaves, then
  // close under parents and clusters", repeated until nothing changes.
  // fails() is asked once per node. Returns the split nodes' keys, sorted.
  std::vector<uint64_t> MinimalSplits(const std::function<bool(Code)>& fails) const {
    // Per level, by slot: split, and fails() asked already.
    std::vector<std::vector<uint8_t>> split(static_cast<size_t>(leaf_level_)), checked(split.size());
    for (int l = 0; l < leaf_level_; ++l) {
      split[l].assign(simplex_[l].size(), 0);
      checked[l].assign(simplex_[l].size(), 0);
    }
    const auto is_split = [&](Code c) { return c.level() < leaf_level_ && split[c.level()][Slot(c)]; };
    // Marks c split; true when it was not.
    const auto mark = [&](Code c) {
      uint8_t& s = split[c.level()][Slot(c)];
      return !std::exchange(s, uint8_t{1});
    };
    for (bool changed = true; changed;) {
      std::vector<Code> added, stack;
      for (int t = 0; t < Code::kRoots; ++t) stack.push_back(Code::Root(t));
      while (!stack.empty()) {
        const Code c = stack.back();
        stack.pop_back();
        if (is_split(c)) {
          stack.push_back(c.child(0));
          stack.push_back(c.child(1));
        } else if (c.level() < leaf_level_ && !std::exchange(checked[c.level()][Slot(c)], uint8_t{1}) &&
                   fails(c)) {
          added.push_back(c);
        }
      }
      for (const Code c : added) mark(c);
      changed = !added.empty();
      while (!added.empty()) {
        const Code c = added.back();
        added.pop_back();
        if (c.level() > 0 && mark(c.parent())) added.push_back(c.parent());
        for (const Code m : Cluster(c)) {
          if (mark(m)) added.push_back(m);
        }
      }
    }
    std::vector<uint64_t> keys;
    for (int l = 0; l < leaf_level_; ++l) {
      for (uint64_t s = 0; s < split[l].size(); ++s) {
        if (split[l][s]) keys.push_back(Code::FromPath(static_cast<int>(s >> l), s & ((uint64_t{1} << l) - 1), l).key());
      }
    }
    std::sort(keys.begin(), keys.end());
    return keys;
  }

  // The minimal conforming mesh under `criteria` with diamond errors.
  std::vector<uint64_t> MinimalSplits(const Criteria<D>& criteria) const {
    return MinimalSplits([&](Code c) { return Fails(criteria, c, Diamond(c)); });
  }

 private:
  struct EdgeHash {
    size_t operator()(const std::pair<uint64_t, uint64_t>& e) const {
      return std::hash<uint64_t>()(e.first * 0x9E3779B97F4A7C15ull ^ e.second);
    }
  };

  static uint64_t Slot(Code c) { return (uint64_t(c.top()) << c.level()) | c.path(); }

  static int64_t Scaled(double value) {
    const int64_t s = std::llround(value * 256);
    assert(static_cast<double>(s) == value * 256);  // a multiple of 1/256
    return s;
  }

  // The seed's error of the simplex with lattice vertices `lattice`.
  double ErrorOf(const SimplexVertices<D>& lattice) const {
    GridSimplex<D> g{};
    for (int i = 0; i <= D; ++i) g[i] = LatticeToGrid<D>(lattice[i], k_);
    // M's columns are the edges g[j+1] - g[0]: p - g[0] = M b for the
    // barycentric coordinates b[1..D]; det(M) * b = adj(M) (p - g[0]).
    std::array<std::array<int64_t, D>, D> m{};
    for (int r = 0; r < D; ++r) {
      for (int j = 0; j < D; ++j) m[r][j] = g[j + 1][r] - g[0][r];
    }
    const int64_t det = static_cast<int64_t>(Det<D>(m));
    assert(det != 0);
    std::array<std::array<int64_t, D>, D> adj{};  // adj[j][r] = cofactor(r, j)
    for (int r = 0; r < D; ++r) {
      for (int j = 0; j < D; ++j) {
        std::array<std::array<int64_t, D - 1>, D - 1> minor{};
        for (int rr = 0, mr = 0; rr < D; ++rr) {
          if (rr == r) continue;
          for (int jj = 0, mc = 0; jj < D; ++jj) {
            if (jj != j) minor[mr][mc++] = m[rr][jj];
          }
          ++mr;
        }
        const int64_t cof = static_cast<int64_t>(Det<D - 1>(minor));
        adj[j][r] = (r + j) % 2 == 0 ? cof : -cof;
      }
    }
    std::array<int64_t, D + 1> f{};
    for (int i = 0; i <= D; ++i) f[i] = Scaled(volume_.template ClampedAt<D>(g[i]));
    auto [lo, hi] = BoundingBox<D>(g);
    for (int a = 0; a < D; ++a) {
      hi[a] = std::min<int64_t>(hi[a], int64_t{volume_.dims[a]} - 1);
      if (lo[a] > hi[a]) return 0;  // wholly in the padding
    }
    Int128 worst = 0;
    ForEachBoxPoint<D>(lo, hi, [&](const IPoint<D>& p) {
      std::array<int64_t, D + 1> w{};  // det * barycentric coordinates
      w[0] = det;
      bool inside = true;
      for (int j = 0; j < D && inside; ++j) {
        int64_t s = 0;
        for (int r = 0; r < D; ++r) s += adj[j][r] * (p[r] - g[0][r]);
        w[j + 1] = s;
        w[0] -= s;
        inside = s == 0 || (s > 0) == (det > 0);
      }
      if (!inside || (w[0] != 0 && (w[0] > 0) != (det > 0))) return;
      Int128 num = static_cast<Int128>(Scaled(volume_.template ValueAt<D>(p))) * det;
      for (int i = 0; i <= D; ++i) num -= static_cast<Int128>(w[i]) * f[i];
      worst = std::max(worst, num < 0 ? -num : num);
    });
    return static_cast<double>(static_cast<long double>(worst) /
                               (static_cast<long double>(det < 0 ? -det : det) * 256));
  }

  const TestVolume& volume_;
  int k_, leaf_level_;
  double range_ = 0;  // the field's
  // Per level below the leaf level, by slot (top << level | path): the
  // node's error and its cluster's number; per cluster its error and nodes.
  std::vector<std::vector<double>> simplex_;
  std::vector<std::vector<uint32_t>> group_;
  std::vector<std::vector<double>> diamond_;
  std::vector<std::vector<std::vector<Code>>> members_;
  std::vector<double> errors_;  // every distinct diamond error, sorted
};

// The leaves of the mesh whose split nodes are `splits` (sorted keys), in
// depth-first preorder.
template <int D>
std::vector<SimplexCode<D>> LeavesOf(const std::vector<uint64_t>& splits) {
  std::vector<SimplexCode<D>> leaves, stack;
  for (int t = SimplexCode<D>::kRoots - 1; t >= 0; --t) stack.push_back(SimplexCode<D>::Root(t));
  while (!stack.empty()) {
    const SimplexCode<D> c = stack.back();
    stack.pop_back();
    if (std::binary_search(splits.begin(), splits.end(), c.key())) {
      stack.push_back(c.child(1));
      stack.push_back(c.child(0));
    } else {
      leaves.push_back(c);
    }
  }
  return leaves;
}

}  // namespace simplexdb::testing
