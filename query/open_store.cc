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
    SparseStore::Options sparse;
    sparse.cache_bytes = options.cache_bytes;
    sparse.cache = options.cache;
    SDB_ASSIGN_OR_RETURN(store.sparse_, SparseStore::Open(path, sparse));
    store.info_ = InfoFromHeader(store.sparse_->header(), store.sparse_->path());
    return store;
  }
  DenseStore::Options dense;
  dense.cache_bytes = options.cache_bytes;
  dense.in_memory = options.in_memory;
  dense.cache = options.cache;
  SDB_ASSIGN_OR_RETURN(store.dense_, DenseStore::Open(path, dense));
  store.info_ = InfoFromHeader(store.dense_->header(), store.dense_->path());
  return store;
}

}  // namespace simplexdb
