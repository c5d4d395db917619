#include "ops/verify.h"

namespace simplexdb {

namespace {

Result<VerifyReport> VerifyOf(const AnyStore& store,
                              const std::function<void(uint64_t, uint64_t)>& progress) {
  VerifyReport report;
  report.kind = store.kind();
  if (const DenseStore* dense = store.dense(); dense != nullptr) {
    SDB_RETURN_IF_ERROR(dense->Verify(progress));
    report.blocks = dense->stored_blocks();
    report.bricks = dense->bricks();
    report.finest_recomputed = !dense->header().finest_stored();
    return report;
  }
  const SparseStore& sparse = *store.sparse();
  SDB_RETURN_IF_ERROR(sparse.Verify(progress));
  report.blocks = sparse.header().blocks;
  report.kept = sparse.header().kept;
  return report;
}

}  // namespace

Result<VerifyReport> VerifyStore(const AnyStore& store,
                                 const std::function<void(uint64_t, uint64_t)>& progress) {
  // A file changed under the store is reported as such, not as damage.
  SDB_RETURN_IF_ERROR(store.CheckUnchanged());
  Result<VerifyReport> report = VerifyOf(store, progress);
  SDB_RETURN_IF_ERROR(store.CheckUnchanged());
  return report;
}

}  // namespace simplexdb
