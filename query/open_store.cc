#include "query/open_store.h"

#include "storage/io/lmdb.h"

namespace simplexdb {

const char* StoreKindName(StoreKind kind) {
  switch (kind) {
    case StoreKind::kDense:
      return "dense";
    case StoreKind::kSparse:
      return "sparse";
  }
  return "?";
}

StoreKind ProbeStoreKind(const std::string& path) {
  return lmdb::LooksLikeLmdb(path) ? StoreKind::kSparse : StoreKind::kDense;
}

Result<AnyStore> AnyStore::Open(const std::string& path, const StoreOptions& options) {
  AnyStore store;
  if (ProbeStoreKind(path) == StoreKind::kSparse) {
    if (options.in_memory) {
      return Status::InvalidArgument(path +
                                     ": in_memory applies to dense stores; a sparse store's blocks are decoded as read");
    }
    HzSparseStore::Options sparse;
    sparse.cache_bytes = options.cache_bytes;
    sparse.cache = options.cache;
    SDB_ASSIGN_OR_RETURN(store.sparse_, HzSparseStore::Open(path, sparse));
    store.info_ = InfoFromHeader(store.sparse_->header(), store.sparse_->path());
    return store;
  }
  HzStore::Options hz;
  hz.cache_bytes = options.cache_bytes;
  hz.in_memory = options.in_memory;
  hz.cache = options.cache;
  SDB_ASSIGN_OR_RETURN(store.hz_, HzStore::Open(path, hz));
  store.info_ = InfoFromHeader(store.hz_->header(), store.hz_->path());
  return store;
}

}  // namespace simplexdb
