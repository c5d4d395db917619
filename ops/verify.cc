#include "ops/verify.h"

namespace simplexdb {

Result<VerifyReport> VerifyStore(const AnyStore& store,
                                 const std::function<void(uint64_t, uint64_t)>& progress) {
  VerifyReport report;
  report.kind = store.kind();
  if (const HzStore* hz = store.hz(); hz != nullptr) {
    SDB_RETURN_IF_ERROR(hz->Verify(progress));
    report.blocks = hz->stored_blocks();
    report.bricks = hz->bricks();
    report.finest_recomputed = !hz->header().finest_stored();
    return report;
  }
  const HzSparseStore& sparse = *store.sparse();
  SDB_RETURN_IF_ERROR(sparse.Verify(progress));
  report.blocks = sparse.header().blocks;
  report.kept = sparse.header().kept;
  return report;
}

}  // namespace simplexdb
