// Verify: every checksum and invariant of a store, `simplexdb verify` (and
// the Python package's Store.verify). One function for both kinds: a dense
// store's blocks, bricks and finest errors (DenseStore::Verify), a sparse
// store's pages, blocks, counts and values (SparseStore::Verify).
//
// Thread safety: reentrant over a const store; `progress` is called from
// the calling thread. Lifetimes: the report is a value.
//
// Errors: the store's Verify's: Corruption naming the first bad block or
// brick, IOError.
#pragma once

#include <cstdint>
#include <functional>

#include "query/open_store.h"
#include "util/status.h"

namespace simplexdb {

// What was checked.
struct VerifyReport {
  StoreKind kind = StoreKind::kDense;
  uint64_t blocks = 0;   // dense: error blocks stored; sparse: blocks
  uint64_t bricks = 0;   // dense: field bricks
  bool finest_recomputed = false;  // dense: the finest octave's errors recomputed from the field
  uint64_t kept = 0;     // sparse: kept vertices
};

// progress(done, total): blocks (then bricks) checked so far.
Result<VerifyReport> VerifyStore(const AnyStore& store,
                                 const std::function<void(uint64_t, uint64_t)>& progress = {});

}  // namespace simplexdb
