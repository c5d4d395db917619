// Sources: the one read interface the query layer sees, over every store,
// written as the concept ReadSource<S, D> below with its contract. The
// refinement templates (query/refine.h, mesh_io.h, slice.h) take any type
// that models it; DenseSource<D> (the dense store, mapped, through a bounded
// cache or decoded in memory) and SparseSource<D> (the LMDB store) are
// the ones over stores, and query/open_store.h makes the right one for a
// store path.
//
// Refinement is a template over the source (static dispatch): an error lookup
// is a few nanoseconds in core and a virtual call would show.
//
// The in-memory (in-core) case is an DenseStore opened with
// Options::in_memory; it reads through the same DenseSource.
//
// Thread safety: a source is one thread's at a time (no locks inside; it
// keeps the blocks, snapshot and counters of one walk). Make one source per
// thread over a shared store: every store may be shared by any number of
// threads, each with its own sources. A source may move to
// another thread between calls (the LMDB environment is opened with
// MDB_NOTLS).
//
// Lifetimes: a source must not outlive the store it reads (it keeps a
// reference to it). Everything a source hands back is a value (Result<double>,
// SourceStats, ...) except info(), a reference that lives as long as the
// source; no span or pointer into a block or the LMDB map escapes a source.
// An SparseSource reads one LMDB snapshot for its whole life (a read
// transaction, begun at its first lookup): it sees no commit made after it was created, and while it
// lives LMDB keeps that snapshot's pages from reuse, so a writer's file can
// grow; make a source per query rather than one for the program's life.
// A Refiner (query/refine.h) holds a reference to its source: the source
// outlives the refiner.
//
// Errors: lookups return the store reader's Status (Corruption naming the
// file and block for damaged data, IOError for a failed read: the contract
// below); making a source cannot fail (an SparseSource's first lookup
// reports a read transaction that cannot begin).
#pragma once

#include <array>
#include <concepts>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <type_traits>

#include "hierarchy/simplex_code.h"
#include "storage/dense/dense_prefetch.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"
#include "util/status.h"

namespace simplexdb {

// What a query needs to know of a store.
struct SourceInfo {
  int dimension = 3;                             // 3: HT, 4: HP
  int domain_bits = 0;                           // the domain has side 2^k
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};   // the real grid (unused axes 1)
  // The field's range over the real grid, skipping missing values (NaN);
  // min == max == 0 when every value is missing.
  double field_min = 0, field_max = 0;
  double error_max = 0;  // the largest node error, before quantization
  // Physical placement of grid point i on axis a: origin[a] + i * spacing[a]
  // (axis 3 is time for HP). Unit spacing and zero origin when the input
  // gave none.
  std::array<double, 4> spacing = {1, 1, 1, 1};
  std::array<double, 4> origin = {0, 0, 0, 0};
  std::string path;      // the store's file, for messages

  int leaf_level() const { return dimension * domain_bits; }
  double field_range() const { return field_max - field_min; }
};

// The SourceInfo of a store whose header has the usual fields (DenseHeader,
// SparseHeader).
template <class Header>
SourceInfo InfoFromHeader(const Header& h, const std::string& path) {
  SourceInfo info;
  info.dimension = h.dimension;
  info.domain_bits = h.domain_bits;
  info.dims = h.dims;
  info.field_min = h.field_min;
  info.field_max = h.field_max;
  info.error_max = h.error_max;
  info.spacing = h.spacing;
  if constexpr (requires { h.origin; }) info.origin = h.origin;
  info.path = path;
  return info;
}

// Work a source did, for the statistics of a query. Counters only grow over
// a source's life; a query reports the difference of two snapshots.
struct SourceStats {
  uint64_t error_lookups = 0;
  uint64_t field_lookups = 0;
  uint64_t blocks_read = 0;  // dense: block fetches; LMDB: B-tree searches and range scans
  uint64_t blocks_skipped = 0;  // dense: blocks whose indexed maximum answered a threshold test
};

// ReadSource<S, D>: S reads a store of an HT (D = 3) or HP (D = 4) for one
// thread. The contract, for s of type S over a store whose SourceInfo is
// `info` (k = info.domain_bits, L = info.leaf_level()):
//
//   Result<double> s.Error(code)
//       REQUIRES: code.is_valid() and code is a node of this hierarchy
//       (code.level() may exceed L).
//       The node's stored error bound: finite, >= 0 and <= about
//       info.error_max (quantization may add one step). It is never below
//       the node's true error (the seed's maximum over the real grid points
//       in the simplex of |field - linear interpolation|): quantized errors
//       (u16, u8) round up to the next code, f32 errors to the next float
//       (storage/error/quantize.h). Exactly 0 for nodes at or below the
//       leaf level (level >= L), for nodes holding no real grid point with a
//       value (the padding, missing regions), and for a sparse store's
//       absent nodes (a store built with a tolerance dropped subtrees whose
//       errors were within it: for them 0 is the bound against the
//       interpolated field that store serves, not against the volume).
//       A node partly in a missing region reports the field range.
//       The same code gives the same value for the source's whole life.
//       Errors: those of the store's reader: Corruption for a damaged block
//       or entry (naming the file and the block), IOError when reading
//       fails.
//
//   Result<double> s.ErrorForThreshold(code, t)     OPTIONAL (see
//       ThresholdReadSource): for a caller that only asks "does the bound
//       exceed t?". Returns v with v > t exactly when Error(code) > t; then
//       v == Error(code). Otherwise Error(code) <= v <= t (the dense source
//       answers from its block index's per-block maxima without reading or
//       decoding the block). REQUIRES and errors as Error().
//
//   Result<std::optional<double>> s.Field(p)
//       REQUIRES: p is a point of the domain grid, 0 <= p[a] <= 2^k.
//       The field at p: every grid point has a value (the sparse store
//       rebuilds those it dropped). Points beyond the real grid (the
//       padding) take the value of the nearest real point. A value may be
//       NaN where the volume had no field (a missing value). Never nullopt
//       from the stores' sources; a source of a program's own may return
//       nullopt for a point it has no value at, and a query that needs that
//       value fails with Corruption (query/refine.h). Errors as Error().
//
//   const SourceInfo& s.info() const     the store's metadata; the same
//       values for the source's life; the reference lives as long as s.
//   SourceStats s.stats() const           the work done so far, by value.
//
// The query layer takes sources by reference and never copies or moves one.
template <class S, int D>
concept ReadSource =
    (D == 3 || D == 4) &&
    requires(S& s, const S& cs, SimplexCode<D> code, const std::array<int64_t, D>& p) {
      { s.Error(code) } -> std::same_as<Result<double>>;
      { s.Field(p) } -> std::same_as<Result<std::optional<double>>>;
      { cs.info() } -> std::same_as<const SourceInfo&>;
      { cs.stats() } -> std::convertible_to<SourceStats>;
    };

// A ReadSource that also answers ErrorForThreshold (the dense source): the
// refiners use it where they only compare the bound with the threshold.
template <class S, int D>
concept ThresholdReadSource =
    ReadSource<S, D> && requires(S& s, SimplexCode<D> code, double t) {
      { s.ErrorForThreshold(code, t) } -> std::same_as<Result<double>>;
    };

// A source whose records have a storage order: StorageOrder(code) sorts
// nodes so that those whose errors share a block are adjacent (format 2:
// the HZ position of the node's split vertex). The level-order refinement
// visits each level's candidates in this order.
// StorageBlockBits(): nodes whose orders agree above these low bits share a
// block; their order within it does not matter.
// ErrorForThresholdAt(code, order, threshold): ErrorForThreshold with the
// order computed already.
template <class S, int D>
concept OrderedReadSource =
    ReadSource<S, D> && requires(S& s, SimplexCode<D> code, uint64_t order, double t) {
      { s.StorageOrder(code) } -> std::same_as<uint64_t>;
      { s.StorageBlockBits() } -> std::same_as<int>;
      { s.ErrorForThresholdAt(code, order, t) } -> std::same_as<Result<double>>;
    };

// A source that names, for the nodes whose reads cost to come back to out of
// core, the region of the store they read: Region(code) (kAnyRegion for
// nodes whose reads are cheap anywhere), and ChildrenRegion(parent) the
// region of both children of `parent` when they share one it knows cheaply
// (kPerChild: ask Region for each); regions() is false when the source
// names none (a store in memory, a cache that holds much of it). The
// depth-first refinement then finishes a region's nodes before it takes up
// the next region's (query/refine.h). Any answer gives the same mesh:
// regions order the walk, nothing else.
inline constexpr uint64_t kAnyRegion = ~uint64_t{0};
inline constexpr uint64_t kPerChild = kAnyRegion - 1;
template <class S, int D>
concept RegionReadSource = ReadSource<S, D> && requires(S& s, const S& cs, SimplexCode<D> code) {
  { s.Region(code) } -> std::same_as<uint64_t>;
  { s.ChildrenRegion(code) } -> std::same_as<uint64_t>;
  { cs.regions() } -> std::same_as<bool>;
};

// What the stores' sources share: the store's reader, its SourceInfo, the
// lookup counters, the error bound and the field (a value at every grid
// point).
template <int D, class Reader>
class StoreSource {
 public:
  const SourceInfo& info() const { return info_; }
  Result<double> Error(SimplexCode<D> code) {
    ++stats_.error_lookups;
    return reader_.ErrorBound(code);
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>& p) {
    ++stats_.field_lookups;
    SDB_ASSIGN_OR_RETURN(const double v, reader_.Field(p));
    return std::optional<double>(v);
  }

 protected:
  template <class Store>
  explicit StoreSource(const Store& store) : reader_(store), info_(InfoFromHeader(store.header(), store.path())) {}

  Reader reader_;
  SourceInfo info_;
  SourceStats stats_;
};

// A format-2 store's source (storage/dense/dense_store.h: one record per
// diamond in hierarchical Z-order): a node's error is its diamond's. Models
// ThresholdReadSource<DenseSource<D>, D>; making one reads nothing.
template <int D>
class DenseSource : public StoreSource<D, DenseStore::Reader<D>> {
  using Base = StoreSource<D, DenseStore::Reader<D>>;
  using Base::info_, Base::reader_, Base::stats_;

 public:
  // REQUIRES: store.dimension() == D; the store outlives the source.
  explicit DenseSource(const DenseStore& store) : Base(store), block_bits_(store.header().block_bits) {}

  // OrderedReadSource: the HZ position of the node's split vertex; for
  // leaf-level nodes (no split vertex, error 0) the largest order.
  uint64_t StorageOrder(SimplexCode<D> code) {
    return code.level() < info_.leaf_level() ? reader_.Position(code) : ~uint64_t{0};
  }
  int StorageBlockBits() const { return block_bits_; }
  Result<double> ErrorForThresholdAt(SimplexCode<D> code, uint64_t order, double threshold) {
    ++stats_.error_lookups;
    if (code.level() >= info_.leaf_level()) return 0.0;
    return reader_.ErrorBoundForThresholdAt(code, order, threshold);
  }

  SourceStats stats() const {
    SourceStats s = stats_;
    s.blocks_read = reader_.block_fetches();
    s.blocks_skipped = reader_.blocks_skipped();
    return s;
  }

  Result<double> ErrorForThreshold(SimplexCode<D> code, double threshold) {
    ++stats_.error_lookups;
    return reader_.ErrorBoundForThreshold(code, threshold);
  }

  // RegionReadSource: out of core, the grid brick of the split vertex of a
  // node of the last octave (DenseStore::Reader::Region).
  bool regions() const { return reader_.has_regions(); }
  uint64_t Region(SimplexCode<D> code) { return reader_.Region(code); }
  uint64_t ChildrenRegion(SimplexCode<D> parent) { return reader_.ChildrenRegion(parent); }
  // The region a walk takes up next and its waiting nodes (a LIFO list: the
  // last taken first): walked ahead on another thread
  // (storage/dense/dense_prefetch.h), started at the first call; none when
  // the machine has one core.
  void Ahead(uint64_t region, std::span<const SimplexCode<D>> codes, double threshold) {
    if (prefetcher_ == nullptr) {
      if (std::thread::hardware_concurrency() < 2) return;
      prefetcher_ = std::make_unique<RegionPrefetcher<D>>(reader_.store());
    }
    prefetcher_->Ahead(region, codes, threshold);
  }

 private:
  int block_bits_;
  std::unique_ptr<RegionPrefetcher<D>> prefetcher_;
};

// A sparse store of format 2's source (storage/sparse/sparse_store.h):
// every grid point has a value (the kept ones stored, the dropped ones
// rebuilt), a dropped diamond's bound is 0. Models ReadSource<SparseSource<D>, D>;
// making one reads nothing.
template <int D>
class SparseSource : public StoreSource<D, SparseStore::Reader<D>> {
  using Base = StoreSource<D, SparseStore::Reader<D>>;
  using Base::reader_, Base::stats_;

 public:
  // REQUIRES: store.dimension() == D; the store outlives the source.
  explicit SparseSource(const SparseStore& store) : Base(store) {}

  SourceStats stats() const { return stats_; }
  Result<double> ErrorForThreshold(SimplexCode<D> code, double) { return this->Error(code); }
};

static_assert(ThresholdReadSource<DenseSource<3>, 3> && ThresholdReadSource<DenseSource<4>, 4>);
static_assert(RegionReadSource<DenseSource<3>, 3> && RegionReadSource<DenseSource<4>, 4>);

}  // namespace simplexdb
