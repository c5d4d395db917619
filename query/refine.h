// Selective refinement (seed sections 3.6 and 4.6): extract from a store the
// mesh that meets LOD criteria, over any source (query/source.h).
//
// The result of depth-first and of priority run to completion is the unique
// minimal conforming mesh meeting the criteria: the least set of split nodes
// that (a) holds the parent of every split node, (b) holds the cluster of
// every split node whole (conformity), and (c) leaves no leaf that fails the
// criteria. Such sets are closed under intersection, so the least one exists
// and both orders reach it. The seed's CHECK_SPLIT only re-checks children
// of simplices that failed themselves; children of simplices split for
// conformity can fail too (errors are not monotone), so here every new leaf
// goes on the work list and is checked (SEED-ERRATA item 11), and a walk
// that reaches a node already split moves on to its children, which were
// queued when it was split.
//
//   kDepthFirst   SPLIT_CLUSTER / CHECK_SPLIT (3.6.1) with a LIFO work list.
//                 Over a source that names regions (out of core, a small
//                 cache) a region at a time, walked ahead on another core.
//   kPriority     3.6.2: the failing leaf with the largest error first;
//                 interruptible by a simplex budget (a split whose closure
//                 would pass it is not made) or a time limit, leaving the
//                 best conforming mesh so far.
//   kIncremental  3.6.3: from a previous mesh, split what fails, then merge
//                 clusters whose children are all leaves and whose members
//                 all pass (CHECK_MERGE). Meets the criteria and conforms; as
//                 the seed says it can keep more than the minimum when
//                 errors are not monotone (a failing node may keep a cluster
//                 alive whose own parent would not be needed).
//   kLevelOrder   the same work list taken level by level, coarse first,
//                 and within a level in the source's storage order when it
//                 has one (OrderedReadSource: format 2's HZ order), so an
//                 out-of-core query reads each level's blocks in one sweep
//                 instead of returning to them as a depth-first walk does.
//                 Same mesh as depth-first; costs a grouping of each
//                 level's candidates by block and a work list per level
//                 (slower than depth-first in memory).
//   kSaturated    3.7's comparison method: a node is split iff some node
//                 whose split needs it fails (the cluster shares one value;
//                 a parent is at least its children), then a plain top-down
//                 traversal. The seed stored saturated errors; this baseline
//                 computes them per query, visiting every internal node: its
//                 mesh sizes compare with the seed's, its time does not.
//
// Cost: depth-first does one error lookup per new leaf, one cluster
// computation per cluster split and one hash lookup per cluster member;
// nothing is proportional to the hierarchy's size except for kSaturated.
//
// Sources: any type modeling ReadSource<Source, D> (query/source.h), the
// dense and sparse sources or a program's own; query/open_store.h picks the
// right one for a store path. The templates below are instantiated for the
// concrete source: error lookups are direct calls.
//
// Thread safety: a Refiner uses its source and mesh without locks; one per
// thread (with its own source over a shared store). VertexValues likewise.
//
// Lifetimes: a Refiner and a VertexValues keep a reference to their source:
// the source outlives them. Run() uses the mesh it is given only during the
// call. Everything else is returned by value or written to the caller's
// QueryStats.
//
// Errors: Refiner::Run returns the source's errors (Corruption, IOError:
// query/source.h), Corruption when a source of a program's own has no value
// at a vertex a query needs, and for kSaturated ResourceExhausted when the
// hierarchy has more internal nodes than RefineOptions::max_saturated_nodes.
// ParseAlgorithm returns InvalidArgument naming the text. On any error the
// mesh is left conforming but unfinished.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>
#include <queue>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "query/code_set.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/source.h"
#include "query/vertex_values.h"
#include "query/work_list.h"
#include "util/status.h"

namespace simplexdb {

enum class Algorithm { kDepthFirst, kPriority, kIncremental, kSaturated, kLevelOrder };

const char* AlgorithmName(Algorithm a);
// "depth-first", "priority", "incremental", "saturated", "level-order".
Result<Algorithm> ParseAlgorithm(std::string_view text);

struct RefineOptions {
  Algorithm algorithm = Algorithm::kDepthFirst;
  uint64_t max_simplices = 0;  // kPriority: the budget; 0 for none
  double max_seconds = 0;      // kPriority: the time limit; 0 for none
  // kSaturated visits every internal node and keeps two bits for each; it
  // refuses hierarchies with more (memory and time are the reason).
  uint64_t max_saturated_nodes = uint64_t{1} << 32;
};

struct QueryStats {
  uint64_t simplices = 0;             // leaves of the result
  uint64_t splits = 0;                // simplices split
  uint64_t merges = 0;                // simplices merged (kIncremental)
  uint64_t cluster_computations = 0;  // Cluster() calls
  uint64_t candidates = 0;            // leaves checked against the criteria
  uint64_t error_lookups = 0;
  uint64_t field_lookups = 0;
  uint64_t blocks_read = 0;
  uint64_t blocks_skipped = 0;        // answered from per-block maxima, not read
  double seconds = 0;                 // the whole run
  double saturation_seconds = 0;      // kSaturated: computing the saturation
  bool interrupted = false;           // kPriority stopped at its budget or time
};

template <int D, ReadSource<D> Source>
class Refiner {
 public:
  using Code = SimplexCode<D>;

  // The source outlives the refiner.
  Refiner(Source& source, const Criteria<D>& criteria)
      : source_(source), criteria_(criteria), values_(source) {}

  // Runs the algorithm. kIncremental starts from `mesh` as it is (a previous
  // result, or the roots); the others from the roots (they clear `mesh`).
  // On an error from the source `mesh` is left conforming but unfinished.
  Status Run(const RefineOptions& options, Mesh<D>& mesh, QueryStats& stats) {
    const auto start = std::chrono::steady_clock::now();
    const SourceStats before = source_.stats();
    mesh_ = &mesh;
    stats_ = &stats;
    stats = QueryStats{};
    Status status;
    switch (options.algorithm) {
      case Algorithm::kDepthFirst:
        mesh.split_set().clear();
        if constexpr (RegionReadSource<Source, D>) {
          if (source_.regions()) {
            status = DepthFirstByRegion(Roots());
            break;
          }
        }
        status = DepthFirst(Roots());
        break;
      case Algorithm::kPriority:
        mesh.split_set().clear();
        status = Priority(options, start);
        break;
      case Algorithm::kLevelOrder:
        mesh.split_set().clear();
        status = LevelOrder(Roots());
        break;
      case Algorithm::kIncremental:
        status = Incremental();
        break;
      case Algorithm::kSaturated:
        mesh.split_set().clear();
        status = Saturated(options);
        break;
    }
    const SourceStats after = source_.stats();
    stats.error_lookups = after.error_lookups - before.error_lookups;
    stats.field_lookups = after.field_lookups - before.field_lookups;
    stats.blocks_read = after.blocks_read - before.blocks_read;
    stats.blocks_skipped = after.blocks_skipped - before.blocks_skipped;
    stats.simplices = mesh.leaf_count();
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return status;
  }

  // Whether the leaf `code` fails the criteria (must be split).
  Result<bool> Fails(Code code) {
    SDB_ASSIGN_OR_RETURN(const double error, ErrorForThreshold(code));
    return FailsWithError(code, error);
  }

 private:
  // The bound where it exceeds the threshold; a store with per-block maxima
  // may answer a smaller value without reading the block (the node passes
  // either way, and FailsWithError only compares a passing value).
  Result<double> ErrorForThreshold(Code code) {
    if constexpr (ThresholdReadSource<Source, D>) {
      return source_.ErrorForThreshold(code, criteria_.threshold);
    } else {
      return source_.Error(code);
    }
  }

  std::vector<Code> Roots() const {
    std::vector<Code> r;
    for (int t = Code::kRoots - 1; t >= 0; --t) r.push_back(Code::Root(t));
    return r;
  }

  Result<bool> FailsWithError(Code code, double error) {
    ++stats_->candidates;
    if (!(error > criteria_.threshold)) return false;
    if (!criteria_.needs_geometry()) return true;
    const SimplexVertices<D> v = Vertices<D>(code);
    std::array<double, D + 1> values{};
    if (criteria_.needs_values()) SDB_RETURN_IF_ERROR(values_.Get(code, v, values));
    return Applies<D>(criteria_, v, &values, error);
  }

  // Splits `code` with everything conformity needs first: the parents of its
  // cluster members (recursively, coarser levels only) and then the whole
  // cluster. Calls on_split(member) for each node split, deepest cluster
  // last. REQUIRES: code is not split.
  template <class OnSplit>
  void SplitClosure(Code code, OnSplit&& on_split) {
    const auto cluster = Cluster(code);
    ++stats_->cluster_computations;
    SplitSet<D>& split = mesh_->split_set();
    for (const Code m : cluster) {
      if (m.level() > 0 && !split.contains(m.parent())) SplitClosure(m.parent(), on_split);
    }
    for (const Code m : cluster) {
      split.insert(m);
      ++stats_->splits;
      on_split(m);
    }
  }

  // The nodes SplitClosure(code) would split, without splitting them.
  void PlanClosure(Code code, CodeSet& planned, std::vector<Code>& plan) {
    const auto cluster = Cluster(code);
    ++stats_->cluster_computations;
    const SplitSet<D>& split = mesh_->split_set();
    for (const Code m : cluster) {
      if (m.level() == 0) continue;
      const Code p = m.parent();
      if (!split.contains(p) && !planned.contains(p.key())) PlanClosure(p, planned, plan);
    }
    for (const Code m : cluster) {
      planned.insert(m.key());
      plan.push_back(m);
    }
  }

  // The work list in LIFO order: candidates are checked depth-first, each new
  // leaf once. Every node goes on the list once: its children go on when it
  // is split, if it was visited already, or else when it is visited (a node
  // split for conformity while it waited on the list). Queuing the children
  // of every forced split at once left most entries stale: on a uniform 1%
  // query of 129^3 Perlin noise the list held 4.5 M entries, two thirds of
  // them split since, for a mesh of 4.7 M tetrahedra.
  Status DepthFirst(std::vector<Code> work) {
    SplitSet<D> visited;
    const auto push_children = [&](Code m) {
      work.push_back(m.child(1));
      work.push_back(m.child(0));
    };
    while (!work.empty()) {
      const Code c = work.back();
      work.pop_back();
      SDB_RETURN_IF_ERROR(TakeCandidate(c, visited, push_children, [&](Code m) {
        return [&push_children, m] { push_children(m); };
      }));
    }
    return Status::OK();
  }

  // A depth-first walk's candidate: its children go on if it was split while
  // it waited, or if it fails, after those of its closure's visited members
  // (`children_of(c)`, run before the closure, returns what puts them on).
  template <class PushChildren, class ChildrenOf>
  Status TakeCandidate(Code c, SplitSet<D>& visited, PushChildren& push_children, ChildrenOf&& children_of) {
    visited.insert(c);
    if (mesh_->split_set().contains(c)) {  // split for conformity while it waited
      push_children(c);
      return Status::OK();
    }
    SDB_ASSIGN_OR_RETURN(const bool fails, Fails(c));
    if (!fails) return Status::OK();
    const auto push_own = children_of(c);
    SplitClosure(c, [&](Code m) {
      if (m != c && visited.contains(m)) push_children(m);
    });
    push_own();
    return Status::OK();
  }

  // DepthFirst's walk a region at a time, for a source that names regions
  // (RegionReadSource: out of core, the grid brick a node of the last octave
  // reads around). The work list is the same multiset of candidates taken
  // in another order, so the mesh is the same (see the top of this file): a
  // candidate of the region being walked, or of none, goes on its LIFO list;
  // one of another region waits on that region's list. When the list is
  // empty the walk takes up the next waiting region in Morton order after
  // the one it left (from the first after the last), so it sweeps the store
  // once, coming back to a region only for the few candidates that forced
  // splits queue behind the sweep. A plain depth-first walk returns to a
  // brick many times as its subtrees cross it: with a small cache each
  // return decodes the brick again.
  Status DepthFirstByRegion(std::vector<Code> roots) {
    SplitSet<D> visited;
    RegionWorkList<Code> work(std::move(roots));
    // `r`: the children's region if the source knew it (ChildrenRegion).
    const auto push_children_of = [&](Code m, uint64_t r) {
      if (r != kPerChild) {
        work.Push(m.child(1), r);
        work.Push(m.child(0), r);
      } else {
        work.Push(m.child(1), source_.Region(m.child(1)));
        work.Push(m.child(0), source_.Region(m.child(0)));  // taken next, mostly: the source keeps its vertex
      }
    };
    const auto push_children = [&](Code m) { push_children_of(m, source_.ChildrenRegion(m)); };
    Code c;
    while (true) {
      if (!work.Pop(c)) {
        if (!work.NextRegion()) break;
        // A source that can work ahead walks the region after this one
        // while the walk is here.
        if constexpr (requires(std::span<const Code> s) { source_.Ahead(0, s, criteria_.threshold); }) {
          if (const auto after = work.After(); after.has_value()) {
            source_.Ahead(after->first, after->second, criteria_.threshold);
          }
        }
        continue;
      }
      SDB_RETURN_IF_ERROR(TakeCandidate(c, visited, push_children, [&](Code m) {
        const uint64_t r = source_.ChildrenRegion(m);  // while the source holds m's vertex
        return [&push_children_of, m, r] { push_children_of(m, r); };
      }));
    }
    return Status::OK();
  }

  // The work list by level: the lowest level with candidates first, its
  // candidates grouped by storage block (GroupByKey). Forced splits of coarser nodes put
  // their children on coarser levels, taken up again next.
  Status LevelOrder(std::vector<Code> roots) {
    SplitSet<D>& split = mesh_->split_set();
    std::vector<std::vector<Code>> bucket;
    int lowest = 0;
    const auto push = [&](Code m) {
      const int l = m.level();
      if (static_cast<size_t>(l) >= bucket.size()) bucket.resize(static_cast<size_t>(l) + 1);
      bucket[static_cast<size_t>(l)].push_back(m);
      lowest = std::min(lowest, l);
    };
    const auto push_children = [&](Code m) {
      push(m.child(0));
      push(m.child(1));
    };
    for (const Code r : roots) push(r);
    std::vector<std::pair<uint64_t, Code>> batch, sorted;
    while (true) {
      while (static_cast<size_t>(lowest) < bucket.size() && bucket[static_cast<size_t>(lowest)].empty()) {
        ++lowest;
      }
      if (static_cast<size_t>(lowest) >= bucket.size()) break;
      std::vector<Code>& level = bucket[static_cast<size_t>(lowest)];
      batch.clear();
      int block_bits = 0;
      if constexpr (OrderedReadSource<Source, D>) {
        block_bits = source_.StorageBlockBits();
        for (const Code c : level) batch.emplace_back(source_.StorageOrder(c), c);
      } else {
        for (const Code c : level) batch.emplace_back(c.key(), c);
      }
      level.clear();
      GroupByKey(batch, block_bits, sorted);
      for (const auto& [order, c] : sorted) {
        if (split.contains(c)) continue;  // split for conformity; children queued then
        bool fails;
        if constexpr (OrderedReadSource<Source, D>) {
          SDB_ASSIGN_OR_RETURN(const double error,
                               source_.ErrorForThresholdAt(c, order, criteria_.threshold));
          SDB_ASSIGN_OR_RETURN(fails, FailsWithError(c, error));
        } else {
          SDB_ASSIGN_OR_RETURN(fails, Fails(c));
        }
        if (!fails) continue;
        SplitClosure(c, [&](Code m) { push_children(m); });
      }
    }
    return Status::OK();
  }

  Status Priority(const RefineOptions& options, std::chrono::steady_clock::time_point start) {
    struct Entry {
      double error;
      uint64_t key;
      bool operator<(const Entry& o) const {
        return error < o.error || (error == o.error && key > o.key);
      }
    };
    std::priority_queue<Entry> heap;
    const auto push = [&](Code c) -> Status {
      SDB_ASSIGN_OR_RETURN(const double e, ErrorForThreshold(c));
      if (e > criteria_.threshold) heap.push(Entry{e, c.key()});  // others never fail
      return Status::OK();
    };
    for (const Code r : Roots()) SDB_RETURN_IF_ERROR(push(r));
    SplitSet<D>& split = mesh_->split_set();
    CodeSet planned;
    std::vector<Code> plan;
    uint64_t steps = 0;
    while (!heap.empty()) {
      if (options.max_seconds > 0 && (++steps & 255) == 0 &&
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >
              options.max_seconds) {
        stats_->interrupted = true;
        break;
      }
      const Entry top = heap.top();
      heap.pop();
      const Code c = Code::FromKey(top.key);
      if (split.contains(c)) continue;
      SDB_ASSIGN_OR_RETURN(const bool fails, FailsWithError(c, top.error));
      if (!fails) continue;
      plan.clear();
      planned.clear();
      PlanClosure(c, planned, plan);
      if (options.max_simplices > 0 && mesh_->leaf_count() + plan.size() > options.max_simplices) {
        stats_->interrupted = true;
        break;
      }
      for (const Code m : plan) {
        split.insert(m);
        ++stats_->splits;
      }
      for (const Code m : plan) {
        for (int i = 0; i < 2; ++i) {
          if (!split.contains(m.child(i))) SDB_RETURN_IF_ERROR(push(m.child(i)));
        }
      }
    }
    return Status::OK();
  }

  Status Incremental() {
    // Split: every leaf of the previous mesh is a candidate.
    std::vector<Code> leaves = mesh_->Leaves();
    std::reverse(leaves.begin(), leaves.end());
    SDB_RETURN_IF_ERROR(DepthFirst(leaves));
    // Merge (CHECK_MERGE, bottom-up from each leaf). Never forced: a cluster
    // merges only when all its members are split into two leaves each and
    // all of them pass as leaves.
    leaves = mesh_->Leaves();
    for (const Code t : leaves) {
      Code c = t;
      // A split sibling rules the merge out without a cluster computation.
      while (c.level() > 0 && mesh_->is_leaf(c) && !mesh_->is_split(c.sibling())) {
        SDB_ASSIGN_OR_RETURN(const bool merged, TryMerge(c.parent()));
        if (!merged) break;
        c = c.parent();
      }
    }
    return Status::OK();
  }

  // Merges the cluster of the split node `p` if it may: true when merged.
  Result<bool> TryMerge(Code p) {
    // `p` itself failing rules the merge out without a cluster computation
    // (an HP cluster is up to 48 members): the common case right after a
    // refinement.
    SDB_ASSIGN_OR_RETURN(const bool p_fails, Fails(p));
    if (p_fails) return false;
    const auto cluster = Cluster(p);
    ++stats_->cluster_computations;
    SplitSet<D>& split = mesh_->split_set();
    for (const Code n : cluster) {
      if (split.contains(n.child(0)) || split.contains(n.child(1))) return false;
    }
    for (const Code n : cluster) {
      if (n == p) continue;
      SDB_ASSIGN_OR_RETURN(const bool fails, Fails(n));
      if (fails) return false;
    }
    for (const Code n : cluster) {
      split.erase(n);
      ++stats_->merges;
    }
    return true;
  }

  // Bits per level of the hierarchy, indexed by (top << level) | path.
  class LevelBits {
   public:
    void Resize(int levels) { bits_.resize(levels); }
    void Allocate(int level, uint64_t n) { bits_[level].assign((n + 63) / 64, 0); }
    bool Get(int level, uint64_t i) const { return bits_[level][i >> 6] >> (i & 63) & 1; }
    void Set(int level, uint64_t i) { bits_[level][i >> 6] |= uint64_t{1} << (i & 63); }

   private:
    std::vector<std::vector<uint64_t>> bits_;
  };
  static uint64_t Slot(Code c) { return (uint64_t(c.top()) << c.level()) | c.path(); }

  Status Saturated(const RefineOptions& options) {
    const auto start = std::chrono::steady_clock::now();
    const int leaf_level = source_.info().leaf_level();
    const uint64_t internal = uint64_t{Code::kRoots} * ((uint64_t{1} << leaf_level) - 1);
    if (leaf_level >= 62 || internal > options.max_saturated_nodes) {
      return Status::ResourceExhausted(
          source_.info().path + ": the saturated baseline visits every internal node and this hierarchy has " +
          std::to_string(internal) + " (limit " + std::to_string(options.max_saturated_nodes) +
          "); use depth-first or priority");
    }
    // need(N) at level l: some node whose split needs N's fails. Computed
    // bottom-up: raw(N) = fails(N) or need(child); need is raw shared over
    // the cluster (the seed: "all tetrahedra in the same cluster are
    // assigned the maximum", "saturated to be >= its children").
    LevelBits raw, need;
    raw.Resize(leaf_level + 1);
    need.Resize(leaf_level + 1);
    for (int l = 0; l <= leaf_level; ++l) {
      const uint64_t n = l < leaf_level ? uint64_t{Code::kRoots} << l : 0;
      raw.Allocate(l, n);
      need.Allocate(l, n);
    }
    // fails(N) for every internal node, walking each root depth-first
    // (vertices carried down when the criteria need them).
    struct Frame {
      Code code;
      SimplexVertices<D> v;
      std::array<double, D + 1> values;
    };
    const bool geometry = criteria_.needs_geometry(), with_values = criteria_.needs_values();
    std::vector<Frame> stack;
    for (int t = Code::kRoots - 1; t >= 0; --t) {
      Frame f{Code::Root(t), RootVertices<D>(t), {}};
      if (with_values) SDB_RETURN_IF_ERROR(values_.RootValues(t, f.v, f.values));
      stack.push_back(f);
    }
    while (!stack.empty()) {
      const Frame f = stack.back();
      stack.pop_back();
      const Code c = f.code;
      if (c.level() >= leaf_level) continue;
      SDB_ASSIGN_OR_RETURN(const double error, ErrorForThreshold(c));
      ++stats_->candidates;
      bool fails = error > criteria_.threshold;
      if (fails && geometry) fails = Applies<D>(criteria_, f.v, &f.values, error);
      if (fails) raw.Set(c.level(), Slot(c));
      if (c.level() + 1 >= leaf_level) continue;
      double mid = 0;
      if (with_values) {
        SDB_ASSIGN_OR_RETURN(mid, values_.Midpoint(c, f.v));
      }
      for (int i = 1; i >= 0; --i) {
        Frame child{c.child(i), {}, {}};
        if (geometry) child.v = ChildVertices<D>(c, f.v, i);
        if (with_values) {
          internal::Split<D>(f.values, SplitRules<D>::CaseOf(c.level(), c.path()), i, child.values,
                             [&](double, double) { return mid; });
        }
        stack.push_back(child);
      }
    }
    for (int l = leaf_level - 1; l >= 0; --l) {
      const uint64_t n = uint64_t{Code::kRoots} << l;
      for (uint64_t s = 0; s < n; ++s) {
        const Code c = Code::FromPath(static_cast<int>(s >> l), s & ((uint64_t{1} << l) - 1), l);
        bool r = raw.Get(l, s);
        if (!r && l + 1 < leaf_level) {
          r = need.Get(l + 1, Slot(c.child(0))) || need.Get(l + 1, Slot(c.child(1)));
        }
        if (!r || need.Get(l, s)) continue;
        const auto cluster = Cluster(c);
        ++stats_->cluster_computations;
        for (const Code m : cluster) need.Set(l, Slot(m));
      }
    }
    stats_->saturation_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // The top-down traversal: no neighbor finding.
    SplitSet<D>& split = mesh_->split_set();
    std::vector<Code> work = Roots();
    while (!work.empty()) {
      const Code c = work.back();
      work.pop_back();
      if (c.level() >= leaf_level || !need.Get(c.level(), Slot(c))) continue;
      split.insert(c);
      ++stats_->splits;
      work.push_back(c.child(1));
      work.push_back(c.child(0));
    }
    return Status::OK();
  }

  template <int, class> friend class PieceWalk;  // query/pieces.h: a piece of the walk, these steps
  Source& source_;
  Criteria<D> criteria_;
  VertexValues<D, Source> values_;
  Mesh<D>* mesh_ = nullptr;
  QueryStats* stats_ = nullptr;
};

}  // namespace simplexdb
