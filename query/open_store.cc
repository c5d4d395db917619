#include "query/open_store.h"

#include <algorithm>
#include <cstddef>

#include "storage/io/read_only_file.h"
#include "util/little_endian.h"

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
  return LooksLikeLmdb(path) ? StoreKind::kSparse : StoreKind::kDense;
}

bool LooksLikeFormat2(const std::string& path) {
  // ReadOnlyFile: a FIFO or a device is refused at once, not waited on.
  Result<ReadOnlyFile> file = ReadOnlyFile::Open(path);
  if (!file.ok()) return false;
  uint8_t head[12] = {};
  const Result<size_t> got = file->ReadUpTo(0, sizeof head, reinterpret_cast<std::byte*>(head));
  if (!got.ok() || *got != sizeof head) return false;
  return std::equal(kDenseMagic.begin(), kDenseMagic.end(), head) &&
         LoadLittle<uint32_t>(head + 8) >= 2;  // format 2, any version: HzStore names it
}

Result<AnyStore> AnyStore::Open(const std::string& path, const StoreOptions& options) {
  AnyStore store;
  if (ProbeStoreKind(path) == StoreKind::kSparse) {
    if (options.in_memory) {
      return Status::InvalidArgument(path +
                                     ": in_memory applies to dense stores; the LMDB store is read in place");
    }
    SDB_ASSIGN_OR_RETURN(store.sparse_, SparseStore::Open(path));
    store.info_ = InfoFromHeader(store.sparse_->header(), store.sparse_->path());
    return store;
  }
  if (LooksLikeFormat2(path)) {
    HzStore::Options hz;
    hz.cache_bytes = options.cache_bytes;
    hz.in_memory = options.in_memory;
    hz.cache = options.cache;
    SDB_ASSIGN_OR_RETURN(store.hz_, HzStore::Open(path, hz));
    store.info_ = InfoFromHeader(store.hz_->header(), store.hz_->path());
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
