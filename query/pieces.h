// One mesh in pieces (issue 42, ../shared/DESIGN.md "Beyond one machine"):
// the partition that says which piece of n a simplex belongs to, and the
// walk that extracts one piece exactly, exchanging forced splits with the
// others in rounds, so that the union of the pieces is the one-process
// depth-first mesh cell for cell (query/refine.h: the least conforming mesh
// meeting the criteria, whatever the order of the work).
//
// Partition: piece r is a contiguous range of the simplices of one coarse
// level L in depth-first order (key order: a node's descendants at level L
// are contiguous there). A node at level L or finer belongs to the piece of
// its level-L ancestor; a coarser node is *relevant* to every piece its
// level-L descendants meet and *owned* (output) by the piece of its first
// one. Ranges are weighted by work (PlanPieces): the leaves of the same
// query cut off some octaves below L, cheap coarse refinements that every
// caller runs alike, so every caller (MPI ranks, ParaView's pieces,
// Python) gets the same parts.
//
// PieceWalk: the depth-first walk over the nodes relevant to its piece. A
// split whose node is relevant to other pieces (cluster members across the
// boundary, coarse nodes) is sent to them; a piece applies what it receives
// as a forced split (with its conformity closure), which may queue more
// candidates and send more splits. Rounds end when no piece sends anything.
// Why the union is the one-process mesh: every split a piece makes is in the
// least mesh (made for a failing leaf or for conformity), each piece's set
// is closed under parents and clusters, and every leaf of the union is a
// relevant candidate of its owner, checked there against the criteria; so
// the union is a conforming mesh meeting the criteria inside the least one,
// hence equal to it.
//
// Thread safety: a PieceWalk is one thread's (it uses its source, which is
// one thread's: query/source.h); walks of different pieces share nothing
// but the store. Partition is a value.
// Lifetimes: a PieceWalk keeps references to its source, criteria and
// partition: they outlive it. Results are values.
// Errors: Round() and PlanPieces return the source's errors (Corruption,
// IOError); the walk is left unfinished then.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "query/mesh.h"
#include "query/refine.h"
#include "query/source.h"
#include "query/split_set.h"
#include "util/status.h"

namespace simplexdb {

template <int D>
class Partition {
 public:
  using Code = SimplexCode<D>;

  // The whole hierarchy as one piece.
  Partition() : Partition(0, {0, uint64_t{Code::kRoots}}) {}
  // Pieces of about equal weight: `weights` has one entry per simplex of
  // `level` (kRoots << level of them) in key order; piece r gets a
  // contiguous range, none empty while pieces <= simplices.
  // REQUIRES: pieces >= 1, weights.size() == kRoots << level.
  static Partition Weighted(int level, std::span<const uint64_t> weights, int pieces) {
    const uint64_t n = weights.size(), k = static_cast<uint64_t>(pieces);
    // Each weight in units of n, plus one unit: no range is of nothing,
    // and all the units together weigh no more than one of `weights`.
    std::vector<uint64_t> prefix{0};
    for (const uint64_t w : weights) prefix.push_back(prefix.back() + w * n + 1);
    std::vector<uint64_t> bounds{0};
    for (uint64_t r = 1; r < k; ++r) {
      // The first index whose running sum reaches r/pieces of the total,
      // leaving a simplex for this piece and each after it.
      const uint64_t goal = prefix.back() / k * r + prefix.back() % k * r / k;
      const uint64_t at = static_cast<uint64_t>(std::lower_bound(prefix.begin(), prefix.end(), goal) - prefix.begin());
      bounds.push_back(std::clamp<uint64_t>(at, bounds.back() + 1, n - (k - r)));
    }
    bounds.push_back(n);
    return Partition(level, std::move(bounds));
  }

  int pieces() const { return static_cast<int>(bounds_.size()) - 1; }
  int level() const { return level_; }
  // The level-L range [first, last] of a node's descendants (its own
  // ancestor's index twice when it is at level L or finer). O(1).
  std::pair<uint64_t, uint64_t> Range(Code c) const {
    const uint64_t first = c.key() >> (Code::kLevelBits + Code::kMaxLevel - level_);
    const int below = level_ - c.level();
    return {first, below > 0 ? first + (uint64_t{1} << below) - 1 : first};
  }
  // The piece that outputs c when it is a leaf. O(log pieces).
  int Owner(Code c) const { return PieceOf(Range(c).first); }
  // Pieces [lo, hi] whose ranges meet c's. O(log pieces).
  std::pair<int, int> Relevant(Code c) const {
    const auto [first, last] = Range(c);
    return {PieceOf(first), PieceOf(last)};
  }
  bool IsRelevant(Code c, int piece) const {
    const auto [first, last] = Range(c);
    return first < bounds_[static_cast<size_t>(piece) + 1] && last >= bounds_[static_cast<size_t>(piece)];
  }
  // The level-L simplices of piece r: [begin, end).
  std::pair<uint64_t, uint64_t> Simplices(int piece) const {
    return {bounds_[static_cast<size_t>(piece)], bounds_[static_cast<size_t>(piece) + 1]};
  }

 private:
  Partition(int level, std::vector<uint64_t> bounds) : level_(level), bounds_(std::move(bounds)) {}
  int PieceOf(uint64_t index) const {
    return static_cast<int>(std::upper_bound(bounds_.begin() + 1, bounds_.end() - 1, index) - bounds_.begin() - 1);
  }

  int level_;
  std::vector<uint64_t> bounds_;  // pieces + 1 increasing indices, 0 first
};

// A source that answers 0 for every node at `cap` or finer (they pass): the
// coarse refinement PlanPieces weighs the pieces with.
template <int D, ReadSource<D> Source>
class CappedSource {
 public:
  CappedSource(Source& source, int cap) : source_(source), cap_(cap) {}
  Result<double> Error(SimplexCode<D> code) { return code.level() >= cap_ ? 0.0 : source_.Error(code); }
  Result<double> ErrorForThreshold(SimplexCode<D> code, double threshold) {
    if (code.level() >= cap_) return 0.0;
    if constexpr (ThresholdReadSource<Source, D>) return source_.ErrorForThreshold(code, threshold);
    return source_.Error(code);
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>& p) { return source_.Field(p); }
  const SourceInfo& info() const { return source_.info(); }
  SourceStats stats() const { return source_.stats(); }

 private:
  Source& source_;
  int cap_;
};

// The weighing refinement's size: it goes an octave deeper while its mesh
// stays under this many leaves (an octave multiplies them by up to 2^D).
inline constexpr uint64_t kWeightLeaves = uint64_t{1} << 22;

// The partition of a query's mesh into `pieces`: level L the first with at
// least 512 simplices per piece (granularity: one heavy simplex must not
// be a piece's whole share), weights from the same query cut off whole
// octaves below L, the deepest whose mesh has at most about kWeightLeaves
// leaves (its leaves under each level-L simplex). Deterministic: the same
// store, criteria and count give the same partition. Cost: a few
// refinements of at most kWeightLeaves leaves each (tens of ms).
template <int D, ReadSource<D> Source>
Result<Partition<D>> PlanPieces(Source& source, const Criteria<D>& criteria, int pieces) {
  using Code = SimplexCode<D>;
  if (pieces <= 1) return Partition<D>();
  int level = 0;
  while ((uint64_t{Code::kRoots} << level) < 512 * static_cast<uint64_t>(pieces)) ++level;
  Mesh<D> mesh;
  for (int cap = level + D;; cap += D) {
    CappedSource<D, Source> capped(source, cap);
    Refiner<D, CappedSource<D, Source>> coarse(capped, criteria);
    QueryStats stats;
    SDB_RETURN_IF_ERROR(coarse.Run({Algorithm::kDepthFirst}, mesh, stats));
    if (cap + D > source.info().leaf_level() || (mesh.leaf_count() << D) > kWeightLeaves) break;
  }
  std::vector<uint64_t> weights(uint64_t{Code::kRoots} << level, 0);
  for (const Code leaf : mesh.Leaves()) {
    const uint64_t first = leaf.key() >> (Code::kLevelBits + Code::kMaxLevel - level);
    ++weights[first];
  }
  return Partition<D>::Weighted(level, weights, pieces);
}

// What a round of a PieceWalk did.
struct PieceRoundStats {
  uint64_t sent = 0;  // splits sent to other pieces (one per piece sent to)
};

template <int D, class Source>
class PieceWalk {
  static_assert(ReadSource<Source, D>);

 public:
  using Code = SimplexCode<D>;

  PieceWalk(Source& source, const Criteria<D>& criteria, const Partition<D>& partition, int piece)
      : refiner_(source, criteria), partition_(partition), piece_(piece) {
    refiner_.mesh_ = &mesh_;
    refiner_.stats_ = &stats_;
    for (int t = Code::kRoots - 1; t >= 0; --t) Push(Code::Root(t));
  }
  // Not moved: its refiner points at its own mesh and statistics.
  PieceWalk(const PieceWalk&) = delete;
  PieceWalk& operator=(const PieceWalk&) = delete;

  // Applies `received` (splits other pieces sent; any order, repeats and
  // nodes not relevant here are ignored), then walks until no candidate is
  // left. Appends to outbox[s] what piece s must hear of (outbox has one
  // list per piece; its own stays empty). The first round takes nothing.
  Status Round(std::span<const Code> received, std::vector<std::vector<Code>>& outbox, PieceRoundStats& round) {
    round = PieceRoundStats{};
    outbox_ = &outbox;
    round_ = &round;
    SplitSet<D>& split = mesh_.split_set();
    for (const Code m : received) {
      if (split.contains(m) || !partition_.IsRelevant(m, piece_)) continue;
      // A forced split: the members of its closure (m among them) queue
      // their children if they were visited; the others wait on the list.
      // None is sent on: the sender's set is closed, so it holds them all,
      // and it told every other piece they are relevant to.
      refiner_.SplitClosure(m, [&](Code x) {
        if (visited_.contains(x)) PushChildren(x);
      });
    }
    while (!work_.empty()) {
      const Code c = work_.back();
      work_.pop_back();
      visited_.insert(c);
      if (split.contains(c)) {  // split for conformity while it waited
        PushChildren(c);
        continue;
      }
      SDB_ASSIGN_OR_RETURN(const bool fails, refiner_.Fails(c));
      if (!fails) continue;
      refiner_.SplitClosure(c, [&](Code x) { OnSplit(x, c); });
      PushChildren(c);
    }
    return Status::OK();
  }

  // Whether an output walk over mesh() (query/mesh_io.h ForEachLeaf's
  // `keep`) goes into c: a node relevant here, split, or a leaf owned here.
  bool Keeps(Code c) const {
    return partition_.IsRelevant(c, piece_) && (mesh_.is_split(c) || partition_.Owner(c) == piece_);
  }

  // The leaves this piece owns (Partition::Owner), in depth-first order:
  // after the last round, its part of the mesh. O(nodes relevant here).
  std::vector<Code> Leaves() const {
    std::vector<Code> out, stack;
    for (int t = Code::kRoots - 1; t >= 0; --t) stack.push_back(Code::Root(t));
    while (!stack.empty()) {
      const Code c = stack.back();
      stack.pop_back();
      if (!Keeps(c)) continue;
      if (!mesh_.is_split(c)) {
        out.push_back(c);
        continue;
      }
      stack.push_back(c.child(1));
      stack.push_back(c.child(0));
    }
    return out;
  }

  // The split set: this piece's nodes and whatever else it learned.
  const Mesh<D>& mesh() const { return mesh_; }
  const QueryStats& stats() const { return stats_; }

 private:
  void Push(Code c) {
    if (partition_.IsRelevant(c, piece_)) work_.push_back(c);
  }
  void PushChildren(Code c) {
    Push(c.child(1));
    Push(c.child(0));
  }
  // x was split (new in this piece's set) in the closure of candidate
  // `cause`: tell the other pieces it is relevant to; queue its children
  // if it was visited already (the candidate's own are queued after the
  // closure).
  void OnSplit(Code x, Code cause) {
    const auto [lo, hi] = partition_.Relevant(x);
    for (int s = lo; s <= hi; ++s) {
      if (s == piece_ || !partition_.IsRelevant(x, s)) continue;
      (*outbox_)[static_cast<size_t>(s)].push_back(x);
      ++round_->sent;
    }
    if (x != cause && visited_.contains(x)) PushChildren(x);
  }

  Refiner<D, Source> refiner_;
  const Partition<D>& partition_;
  int piece_;
  Mesh<D> mesh_;
  QueryStats stats_;
  SplitSet<D> visited_;
  std::vector<Code> work_;
  std::vector<std::vector<Code>>* outbox_ = nullptr;
  PieceRoundStats* round_ = nullptr;
};

// What ExtractPieces did.
struct PiecesStats {
  int rounds = 0;                     // of exchange, the last sending nothing
  uint64_t splits_sent = 0;           // between pieces, one per piece told
  std::vector<double> piece_seconds;  // each piece's walk, all rounds
};

// One piece's walk to the end where each piece has its own process (MPI):
// exchange(outbox, failed, &quiet) hands a round's crossing splits to the
// others (outbox[s] for piece s) and returns what they sent this piece,
// with quiet set when no piece sent anything (every process sees the same;
// the walk stops then). Every process calls it once per round, the same
// number of rounds: a walk that fails still calls it once, with `failed`,
// so that the others stop too (the exchange returns an error to them).
// Returns this piece's figures (piece_seconds: its walk's alone).
template <int D, class Source, class Exchange>
Result<PiecesStats> WalkPiece(PieceWalk<D, Source>& walk, int pieces, Exchange&& exchange) {
  using Code = SimplexCode<D>;
  PiecesStats stats;
  stats.piece_seconds.assign(1, 0.0);
  std::vector<Code> inbox;
  while (true) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::vector<Code>> outbox(static_cast<size_t>(pieces));
    PieceRoundStats round;
    const Status walked = walk.Round(inbox, outbox, round);
    stats.piece_seconds[0] += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats.splits_sent += round.sent;
    ++stats.rounds;
    bool quiet = false;
    Result<std::vector<Code>> received = exchange(outbox, !walked.ok(), &quiet);
    SDB_RETURN_IF_ERROR(walked);
    SDB_ASSIGN_OR_RETURN(inbox, std::move(received));
    if (quiet) break;
  }
  return stats;
}

// All pieces in one process, round by round (for tests, and for a caller
// without MPI that wants a piece exact: it needs the others' splits):
// `walks` gets one walk per piece, run to the end (Leaves() and mesh() of
// each are its piece). `sources` has one source per piece (they may be the
// same object: the walks run one after the other).
template <int D, class Source>
Result<PiecesStats> ExtractPieces(std::span<Source* const> sources, const Criteria<D>& criteria,
                                  const Partition<D>& partition,
                                  std::vector<std::unique_ptr<PieceWalk<D, Source>>>& walks) {
  using Code = SimplexCode<D>;
  const size_t n = static_cast<size_t>(partition.pieces());
  walks.clear();
  for (size_t r = 0; r < n; ++r) {
    walks.push_back(std::make_unique<PieceWalk<D, Source>>(*sources[r], criteria, partition, static_cast<int>(r)));
  }
  PiecesStats stats;
  stats.piece_seconds.assign(n, 0.0);
  std::vector<std::vector<Code>> inbox(n);
  while (true) {
    std::vector<std::vector<Code>> next(n);
    uint64_t sent = 0;
    for (size_t r = 0; r < n; ++r) {
      const auto start = std::chrono::steady_clock::now();
      std::vector<std::vector<Code>> outbox(n);
      PieceRoundStats round;
      SDB_RETURN_IF_ERROR(walks[r]->Round(inbox[r], outbox, round));
      sent += round.sent;
      for (size_t s = 0; s < n; ++s) next[s].insert(next[s].end(), outbox[s].begin(), outbox[s].end());
      stats.piece_seconds[r] += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    ++stats.rounds;
    stats.splits_sent += sent;
    inbox.swap(next);
    if (sent == 0) break;
  }
  return stats;
}

}  // namespace simplexdb
