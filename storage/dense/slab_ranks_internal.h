// How the ranks of a group building one dense store together
// (DenseBuildOptions::group, storage/dense/dense_builder.h) split the
// windowed build's slabs of planes, and what they share: each rank builds
// a contiguous run of slabs, about as many each (a last slab holding only
// the last vertex plane goes with the one before), reading their real
// planes and a halo; the range, the corner lattice, the coarse lattices'
// points and the scanned scales' maxima cross the ranks here, and the
// local tables' chunks that span a boundary between two ranks' slabs.
//
// Thread safety: one caller (the collectives are the group's).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "storage/dense/sub_lattice_internal.h"
#include "util/process_group.h"
#include "util/status.h"

namespace simplexdb::dense_build {

class SlabRanks {
 public:
  // `slabs` of `slab` planes over `real_planes` planes of the last axis,
  // the last vertex plane `last_vertex_plane`; a group of one, or a
  // single slab, is this process alone.
  SlabRanks(ProcessGroup* group, int64_t slabs, int64_t slab, int64_t last_vertex_plane, int64_t real_planes)
      : slabs_(slabs), slab_(slab), last_vertex_plane_(last_vertex_plane), real_planes_(real_planes) {
    if (group != nullptr && group->size() > 1 && slabs > 1) {
      group_ = group;
      rank_ = group->rank();
      ranks_ = group->size();
    }
  }

  // The group, when the slabs are split (else null).
  ProcessGroup* group() const { return group_; }
  int rank() const { return rank_; }
  int ranks() const { return ranks_; }
  // This rank's slabs: [first_slab(), end_slab()).
  int64_t first_slab() const { return FirstSlabOf(rank_); }
  int64_t end_slab() const { return FirstSlabOf(rank_ + 1); }
  // The rank that builds slab i.
  int OwnerOf(int64_t i) const {
    const int64_t full = std::max<int64_t>(1, last_vertex_plane_ % slab_ == 0 ? slabs_ - 1 : slabs_);
    return static_cast<int>(std::min<int64_t>(ranks_ - 1, i * ranks_ / full));
  }
  // The chunks of `chunk` planes (a multiple of the slab) that two or more
  // ranks build parts of, ascending.
  std::vector<int64_t> SplitChunks(int64_t chunk) const {
    std::vector<int64_t> split;
    for (int r = 1; r < ranks_; ++r) {
      const int64_t b = FirstSlabOf(r) * slab_;
      if (b % chunk != 0 && b < slabs_ * slab_ && (split.empty() || split.back() != b / chunk)) {
        split.push_back(b / chunk);
      }
    }
    return split;
  }
  // Each chunk of `chunk` planes that several ranks built parts of (a
  // local table, `table`, holds one): the table set to this rank's part
  // (part_of(c): null when it has none, then zeros), combined (every
  // vertex is one rank's), and write(c) by the rank that built the
  // chunk's first slab. A rank that failed goes on combining, and returns
  // its failure at the end.
  template <class PartOf, class Write>
  Status CombineSplit(int64_t chunk, std::span<float> table, PartOf part_of, Write write) const {
    Status status;
    for (const int64_t c : SplitChunks(chunk)) {
      const std::vector<float>* part = part_of(c);
      std::fill(table.begin(), table.end(), 0.0f);
      if (part != nullptr) std::copy(part->begin(), part->end(), table.begin());
      SDB_RETURN_IF_ERROR(group_->Max(table));
      if (status.ok() && OwnerOf(c * chunk / slab_) == rank_) status = write(c);
    }
    return status;
  }
  // The real planes [first, end) of rank r's slabs.
  std::pair<int64_t, int64_t> RealPlanesOf(int r) const {
    const int64_t lo = std::min(FirstSlabOf(r) * slab_, real_planes_);
    return {lo, std::max(lo, std::min(FirstSlabOf(r + 1) * slab_, real_planes_))};
  }

  // Every rank's outcome (ProcessGroup::Agree); alone, `mine`.
  Status Together(const Status& mine) const { return group_ != nullptr ? group_->Agree(mine) : mine; }

  // The range of the values present on any rank (0, 0 when none is) and
  // whether any is missing, to every rank.
  Status ShareRange(double& min, double& max, bool& present, bool& missing) const {
    constexpr double kNone = -std::numeric_limits<double>::infinity();
    std::array<double, 3> m{present ? -min : kNone, present ? max : kNone, missing ? 1.0 : 0.0};
    SDB_RETURN_IF_ERROR(group_->Max(m));
    present = m[1] > kNone;
    min = present ? -m[0] : 0;
    max = present ? m[1] : 0;
    missing = m[2] > 0;
    return Status::OK();
  }

  // Each rank's planes of `lattice` (those of its real planes) to every
  // rank.
  template <int D, class T>
  Status SharePlanes(SubLattice<D, T>& lattice) const {
    constexpr int L = D - 1;
    if (lattice.size() == 0) return Status::OK();
    const size_t plane = static_cast<size_t>(lattice.stride(L)) * sizeof(T);
    for (int r = 0; r < ranks_; ++r) {
      const auto [lo, hi] = RealPlanesOf(r);
      int64_t first = -1, last = -1;
      for (int64_t z = lo; z < hi; ++z) {
        const int64_t j = lattice.Index(L, z);
        if (j < 0) continue;
        if (first < 0) first = j;
        last = j;
      }
      if (first < 0) continue;
      uint8_t* at = reinterpret_cast<uint8_t*>(lattice.mutable_data()) + static_cast<size_t>(first) * plane;
      SDB_RETURN_IF_ERROR(group_->Broadcast({at, static_cast<size_t>(last - first + 1) * plane}, r));
    }
    return Status::OK();
  }

 private:
  int64_t FirstSlabOf(int r) const {
    if (r >= ranks_) return slabs_;
    int64_t i = 0;
    while (i < slabs_ && OwnerOf(i) < r) ++i;
    return i;
  }

  ProcessGroup* group_ = nullptr;
  int rank_ = 0, ranks_ = 1;
  int64_t slabs_, slab_, last_vertex_plane_, real_planes_;
};

}  // namespace simplexdb::dense_build
