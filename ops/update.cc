#include "ops/update.h"

#include <cmath>

#include <fmt/format.h>

namespace simplexdb {

Result<GridBox> CheckUpdate(const std::string& store, StoreKind kind, const VolumeInfo& volume,
                            const UpdateOptions& options) {
  if (kind != StoreKind::kSparse) {
    return Status::InvalidArgument(store + " is not a sparse store: only sparse (LMDB) stores are updated in "
                                           "place; import the volume again for a dense one");
  }
  if (options.threads < 0) {
    return Status::InvalidArgument(
        fmt::format("--threads: expected a count >= 0 (0: one per core), not {}", options.threads));
  }
  const size_t d = static_cast<size_t>(volume.dimension);
  const std::vector<double>& v = options.box;
  if (v.size() != 2 * d) {
    return Status::InvalidArgument(fmt::format("--box: expected {} numbers for a {}D volume ({}), got {}",
                                               2 * d, d, d == 3 ? "x0,y0,z0,x1,y1,z1" : "x0,y0,z0,t0,x1,y1,z1,t1",
                                               v.size()));
  }
  GridBox box;
  for (size_t c = 0; c < d; ++c) {
    for (const double x : {v[c], v[d + c]}) {
      if (x != std::floor(x) || !std::isfinite(x)) {
        return Status::InvalidArgument(fmt::format("--box: {} is not a grid point coordinate (an integer)", x));
      }
    }
    box.lo[c] = static_cast<int64_t>(v[c]);
    box.hi[c] = static_cast<int64_t>(v[d + c]);
  }
  return box;
}

Result<SparseUpdateReport> UpdateStore(const std::string& store, const VolumeInfo& volume,
                                       const UpdateOptions& options) {
  SDB_ASSIGN_OR_RETURN(const GridBox box, CheckUpdate(store, ProbeStoreKind(store), volume, options));
  SparseUpdateOptions o;
  o.progress = options.progress;
  o.memory_bytes = options.memory_bytes;
  o.threads = options.threads;
  return UpdateSparseStore(store, volume, box, o);
}

}  // namespace simplexdb
