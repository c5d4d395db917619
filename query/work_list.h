// Work lists of the refinement's walks (query/refine.h) that group their
// candidates by where in the store they read: GroupByKey sorts a batch by
// key (the level-order walk's blocks), RegionWorkList keeps a LIFO list per
// region (the depth-first walk out of core, DepthFirstByRegion).
//
// Thread safety: one thread's at a time. Lifetimes: values only.
// Errors: none. Cost: see each.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <set>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "query/source.h"

namespace simplexdb {

// `sorted`: `batch` in increasing order of key >> shift, entries equal there
// in their order in `batch` when the keys span a range not much larger than
// the batch (a counting sort: a level's blocks, a walk's regions), in any
// order otherwise (a comparison sort). O(batch + range) or O(batch log batch).
template <class T>
void GroupByKey(const std::vector<std::pair<uint64_t, T>>& batch, int shift,
                std::vector<std::pair<uint64_t, T>>& sorted) {
  sorted.resize(batch.size());
  if (batch.empty()) return;
  uint64_t lo = batch[0].first >> shift, hi = lo;
  for (const auto& e : batch) lo = std::min(lo, e.first >> shift), hi = std::max(hi, e.first >> shift);
  const uint64_t range = hi - lo + 1;
  if (range > 4 * batch.size() + 4096) {
    sorted = batch;
    std::sort(sorted.begin(), sorted.end(),
              [shift](const auto& a, const auto& b) { return (a.first >> shift) < (b.first >> shift); });
    return;
  }
  std::vector<uint32_t> start(range + 1, 0);
  for (const auto& e : batch) ++start[(e.first >> shift) - lo + 1];
  for (uint64_t i = 1; i <= range; ++i) start[i] += start[i - 1];
  for (const auto& e : batch) sorted[start[(e.first >> shift) - lo]++] = e;
}

// Candidates by region: a LIFO list for the region being walked (and for
// candidates of none, kAnyRegion), the others waiting on their region's
// list. NextRegion() takes up the next waiting region in Morton order after
// the one left (from the first after the last), so a walk sweeps the store
// once and comes back to a region only for what forced splits queue behind
// the sweep. Candidates of other regions go first to a spill list (no hash
// lookup per candidate), filed in one counting sort when the region's list
// runs out.
template <class Code>
class RegionWorkList {
 public:
  explicit RegionWorkList(std::vector<Code> first) : work_(std::move(first)) {}

  // O(1).
  void Push(Code c, uint64_t region) {
    if (region == kAnyRegion || region == region_) {
      work_.push_back(c);
    } else {
      spill_.emplace_back(region, c);
    }
  }
  // The last candidate pushed of the region being walked (or of none);
  // false when its list is empty. O(1).
  bool Pop(Code& c) {
    if (work_.empty()) return false;
    c = work_.back();
    work_.pop_back();
    return true;
  }
  // Takes up the next waiting region; false when no candidate waits.
  // O(spilled + log regions).
  bool NextRegion() {
    if (!spill_.empty()) {
      GroupByKey(spill_, 0, sorted_);
      for (size_t i = 0; i < sorted_.size();) {
        const uint64_t r = sorted_[i].first;
        const auto [it, fresh] = waiting_.try_emplace(r);
        if (fresh) order_.insert(r);
        for (; i < sorted_.size() && sorted_[i].first == r; ++i) it->second.push_back(sorted_[i].second);
      }
      spill_.clear();
    }
    if (order_.empty()) return false;
    const auto next = Following();
    region_ = *next;
    order_.erase(next);
    const auto it = waiting_.find(region_);
    work_.swap(it->second);
    waiting_.erase(it);
    return true;
  }
  // The region NextRegion() would take up next and its candidates as they
  // wait (filed so far; a LIFO list: the last is taken first); nullopt when
  // none waits. The span lives until the next call on the list.
  std::optional<std::pair<uint64_t, std::span<const Code>>> After() {
    if (order_.empty()) return std::nullopt;
    const uint64_t r = *Following();
    return std::pair<uint64_t, std::span<const Code>>(r, waiting_.find(r)->second);
  }

 private:
  std::set<uint64_t>::iterator Following() {
    auto next = order_.upper_bound(region_);
    return next == order_.end() ? order_.begin() : next;
  }

  std::vector<Code> work_;  // the region being walked
  uint64_t region_ = kAnyRegion;
  std::vector<std::pair<uint64_t, Code>> spill_, sorted_;
  std::unordered_map<uint64_t, std::vector<Code>> waiting_;
  std::set<uint64_t> order_;  // the regions with waiting candidates
};

}  // namespace simplexdb
