// Update: a box of a volume re-imported into a sparse store in one LMDB
// transaction (storage/sparse/sparse_update.h), `simplexdb update`.
// The request's checks live here with the call, so every front end that
// offers it refuses the same things.
//
// Thread safety: one update of a store at a time (LMDB's one writer).
// Lifetimes: the report is a value.
//
// Errors: CheckUpdate's InvalidArgument naming the option as the command
// spells it; then UpdateSparseStore's (the volume's, a point outside the
// box that differs from the store, the store's, ResourceExhausted).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "query/open_store.h"
#include "storage/error/progress.h"
#include "storage/sparse/sparse_update.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct UpdateOptions {
  // --box: the grid points that changed, inclusive, x0,y0,z0[,t0],x1,y1,z1[,t1]
  // (one range per axis of the volume).
  std::vector<double> box;
  uint64_t memory_bytes = uint64_t{8} << 30;  // --memory-mb: the rebuild's bound
  int threads = 0;                            // --threads, >= 0; 0: one per core
  std::function<void(const BuildProgress&)> progress;
};

// The box of `volume`'s grid the options name, for the store at `store` of
// kind `kind` (only a sparse store is updated in place). O(1).
Result<GridBox> CheckUpdate(const std::string& store, StoreKind kind, const VolumeInfo& volume,
                            const UpdateOptions& options);

// CheckUpdate, then the update.
Result<SparseUpdateReport> UpdateStore(const std::string& store, const VolumeInfo& volume,
                                       const UpdateOptions& options);

}  // namespace simplexdb
