// Helpers for the query tests: stores built from small volumes, a source
// that refines everywhere, and the minimal conforming mesh by brute force.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "hierarchy/geometry.h"
#include "query/refine.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb::testing {

// Builds a dense store of `volume` at `path` (zstd unless `raw`).
inline std::unique_ptr<DenseStore> BuildDense(const TestVolume& volume, const std::string& dir,
                                              const std::string& name, bool raw = false,
                                              bool in_memory = false) {
  const std::string nrrd = dir + "/" + name + ".nrrd";
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  DenseBuildOptions options;
  options.compression = raw ? Compression::kNone : Compression::kZstd;
  options.levels_per_block = 6;  // several bands even on small grids
  const std::string path = dir + "/" + name + ".sdb";
  auto built = BuildDenseStore(*OpenVolume(nrrd), path, options);
  EXPECT_TRUE(built.ok()) << built.status().message();
  DenseStore::Options open;
  open.in_memory = in_memory;
  auto store = DenseStore::Open(path, open);
  EXPECT_TRUE(store.ok()) << store.status().message();
  return std::move(store).value();
}

// A source over no store: every node above the leaf level of a domain of
// side 2^k has error 1, so any threshold below 1 refines to full resolution.
template <int D>
class FullSource {
 public:
  static constexpr bool kFieldComplete = true;
  explicit FullSource(int k) {
    info_.dimension = D;
    info_.domain_bits = k;
    info_.field_max = 1;
    info_.path = "full";
  }
  const SourceInfo& info() const { return info_; }
  SourceStats stats() const { return stats_; }
  Result<double> Error(SimplexCode<D> c) {
    ++stats_.error_lookups;
    return c.level() < info_.leaf_level() ? 1.0 : 0.0;
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>&) { return std::optional<double>(0.0); }
  void Descend(SimplexCode<D>) {}

 private:
  SourceInfo info_;
  SourceStats stats_;
};

template <int D>
std::vector<uint64_t> Keys(const std::vector<SimplexCode<D>>& codes) {
  std::vector<uint64_t> k;
  for (auto c : codes) k.push_back(c.key());
  return k;
}

// The minimal conforming mesh by brute force, sharing nothing with the
// refiners but the geometry: clusters are found by grouping every node of a
// level by its split edge (vertex positions), and the least fixed point of
// "split what fails, then close under parents and clusters" is iterated
// naively until nothing changes. Returns the split nodes' keys.
template <int D>
std::set<uint64_t> BruteForceMinimalSplits(int leaf_level, const std::function<bool(SimplexCode<D>)>& fails) {
  using Code = SimplexCode<D>;
  // Cluster of each internal node: the nodes of its level with the same
  // split edge.
  std::vector<std::vector<uint64_t>> clusters;
  std::unordered_map<uint64_t, size_t> cluster_of;
  for (int l = 0; l < leaf_level; ++l) {
    std::map<std::pair<uint64_t, uint64_t>, std::vector<uint64_t>> by_edge;
    for (int top = 0; top < Code::kRoots; ++top) {
      for (uint64_t path = 0; path < (uint64_t{1} << l); ++path) {
        const Code c = Code::FromPath(top, path, l);
        const auto v = Vertices<D>(c);
        const auto e = SplitEdge<D>(c);
        uint64_t a = internal::Pack<D>(v[e[0]]), b = internal::Pack<D>(v[e[1]]);
        if (a > b) std::swap(a, b);
        by_edge[{a, b}].push_back(c.key());
      }
    }
    for (auto& [edge, members] : by_edge) {
      for (uint64_t m : members) cluster_of[m] = clusters.size();
      clusters.push_back(std::move(members));
    }
  }
  std::set<uint64_t> split;
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<Code> leaves;
    std::vector<Code> stack;
    for (int t = 0; t < Code::kRoots; ++t) stack.push_back(Code::Root(t));
    while (!stack.empty()) {
      const Code c = stack.back();
      stack.pop_back();
      if (split.count(c.key())) {
        stack.push_back(c.child(0));
        stack.push_back(c.child(1));
      } else {
        leaves.push_back(c);
      }
    }
    // Split what fails, then close under "parent" and "cluster" (a work
    // list: every node added is expanded once).
    std::vector<uint64_t> added;
    for (const Code c : leaves) {
      if (c.level() < leaf_level && fails(c) && split.insert(c.key()).second) added.push_back(c.key());
    }
    changed = !added.empty();
    while (!added.empty()) {
      const Code c = Code::FromKey(added.back());
      added.pop_back();
      if (c.level() > 0 && split.insert(c.parent().key()).second) added.push_back(c.parent().key());
      for (uint64_t m : clusters[cluster_of.at(c.key())]) {
        if (split.insert(m).second) added.push_back(m);
      }
    }
  }
  return split;
}

template <int D>
std::set<uint64_t> SplitKeys(const Mesh<D>& mesh) {
  std::set<uint64_t> s;
  mesh.split_set().ForEach([&](SimplexCode<D> c) { s.insert(c.key()); });
  return s;
}

}  // namespace simplexdb::testing
