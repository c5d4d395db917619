// Sources: the one read interface the query layer sees, over every store.
//
// A source answers, for one thread:
//
//   Result<double> Error(SimplexCode<D>)        the stored error bound (0 at
//                                               and below the leaf level,
//                                               and for a sparse store's
//                                               absent nodes);
//   Result<double> ErrorForThreshold(code, t)   optional: a value that is
//                                               the bound when either
//                                               exceeds t (the dense source
//                                               answers from its block
//                                               index's per-block maxima
//                                               without decoding a block);
//   Result<std::optional<double>> Field(point)  the field at a point of the
//                                               domain grid [0, 2^k]^D, or
//                                               nullopt where the store has
//                                               no value (a sparse store
//                                               keeps only the vertices its
//                                               present nodes create);
//   void Descend(SimplexCode<D>)                a hint that a walk goes into
//                                               this subtree (the LMDB source
//                                               prefetches it);
//   const SourceInfo& info(), SourceStats stats().
//
// Refinement is a template over the source (static dispatch): an error lookup
// is a few nanoseconds in core and a virtual call would show.
//
// The in-memory (in-core) case is a DenseStore opened with
// Options::in_memory; it reads through the same DenseSource.
//
// Thread safety: a source is one thread's; make one per thread over a shared
// store.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "hierarchy/simplex_code.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"
#include "util/status.h"

namespace simplexdb {

// What a query needs to know of a store.
struct SourceInfo {
  int dimension = 3;
  int domain_bits = 0;                           // the domain has side 2^k
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};   // the real grid
  double field_min = 0, field_max = 0;
  double error_max = 0;
  std::string path;

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
  info.path = path;
  return info;
}

// Work a source did, for the statistics of a query.
struct SourceStats {
  uint64_t error_lookups = 0;
  uint64_t field_lookups = 0;
  uint64_t blocks_read = 0;  // dense: block fetches; LMDB: B-tree searches and range scans
  uint64_t blocks_skipped = 0;  // dense: blocks whose indexed maximum answered a threshold test
};

template <int D>
class DenseSource {
 public:
  static constexpr bool kFieldComplete = true;  // Field() never returns nullopt

  // REQUIRES: store.dimension() == D; the store outlives the source.
  explicit DenseSource(const DenseStore& store)
      : reader_(store), info_(InfoFromHeader(store.header(), store.path())) {}

  const SourceInfo& info() const { return info_; }
  SourceStats stats() const {
    SourceStats s = stats_;
    s.blocks_read = reader_.block_fetches();
    s.blocks_skipped = reader_.blocks_skipped();
    return s;
  }

  Result<double> Error(SimplexCode<D> code) {
    ++stats_.error_lookups;
    return reader_.ErrorBound(code);
  }
  Result<double> ErrorForThreshold(SimplexCode<D> code, double threshold) {
    ++stats_.error_lookups;
    return reader_.ErrorBoundForThreshold(code, threshold);
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>& p) {
    ++stats_.field_lookups;
    SDB_ASSIGN_OR_RETURN(const double v, reader_.Field(p));
    return std::optional<double>(v);
  }
  void Descend(SimplexCode<D>) {}

 private:
  DenseStore::Reader<D> reader_;
  SourceInfo info_;
  SourceStats stats_;
};

template <int D>
class SparseSource {
 public:
  static constexpr bool kFieldComplete = false;
  // Descend() prefetches subtrees rooted every kPrefetchLevels levels, at
  // most kPrefetchEntries errors each: a depth-first walk then reads a subtree
  // with one cursor scan instead of a B-tree search per node, and a walk that
  // only touches a subtree's top reads a bounded amount.
  static constexpr int kPrefetchLevels = 8;
  static constexpr size_t kPrefetchEntries = 4096;

  // The store outlives the source. Errors: those of SparseStore::Reader::Create.
  static Result<SparseSource> Create(const SparseStore& store) {
    SDB_ASSIGN_OR_RETURN(auto reader, SparseStore::Reader<D>::Create(store));
    return SparseSource(store, std::move(reader));
  }

  const SourceInfo& info() const { return info_; }
  SourceStats stats() const {
    SourceStats s = stats_;
    s.blocks_read = reader_.stats().btree_lookups + prefetches_;
    return s;
  }

  Result<double> Error(SimplexCode<D> code) {
    ++stats_.error_lookups;
    return reader_.ErrorBound(code);
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>& p) {
    ++stats_.field_lookups;
    return reader_.Field(p);
  }
  // A prefetch that fails is only a lost optimization: lookups fall back to
  // B-tree searches, which report the failure themselves.
  void Descend(SimplexCode<D> code) {
    if (code.level() % kPrefetchLevels != 0) return;
    ++prefetches_;
    (void)reader_.Prefetch(code, kPrefetchEntries);
  }

 private:
  SparseSource(const SparseStore& store, typename SparseStore::Reader<D> reader)
      : reader_(std::move(reader)), info_(InfoFromHeader(store.header(), store.path())) {}

  typename SparseStore::Reader<D> reader_;
  SourceInfo info_;
  SourceStats stats_;
  uint64_t prefetches_ = 0;
};

}  // namespace simplexdb
