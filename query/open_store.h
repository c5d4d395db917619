// AnyStore: a store of either kind (dense .sdb or sparse LMDB) and either
// hierarchy (HT or HP) opened from its path, and the one place that turns
// "which kind, which dimension" into a concrete source type. A program that
// queries a store it did not build writes its query once, as a template over
// the dimension and the source, and hands it to Visit():
//
//   Result<AnyStore> store = AnyStore::Open(path, options);
//   if (!store.ok()) return store.status();
//   Status s = store->Visit([&]<int D, class Source>(Source& source) -> Status {
//     Refiner<D, Source> refiner(source, criteria);   // static dispatch below
//     ...
//   });
//
// or, when nothing else of the store is needed, VisitStore(path, options,
// visitor). The dispatch costs a branch per Visit() call; inside the visitor
// every error lookup is a direct (inlinable) call on the concrete source:
// no virtual call in the refinement's hot path. Each Visit() instantiates
// the visitor four times (DenseSource and SparseSource, each for D = 3 and 4).
//
// The kind is recognized from the file's first bytes (an LMDB meta page is
// the sparse store of format 2, storage/sparse/sparse_store.h; anything
// else is opened as a dense store of format 2, storage/dense/dense_store.h), so
// a file that is neither gets the dense store's InvalidArgument naming it,
// and a store of format 1 (dense: the engine's scratch format; sparse: one
// LMDB entry per node) is refused with a message that says to import the
// volume again.
//
// Thread safety: an AnyStore may be shared by threads (the stores are);
// Visit() is const and may run in several threads at once, each call with
// its own source. The source a visitor gets is its thread's alone.
//
// Lifetimes: the source passed to the visitor lives only for that call;
// the visitor must not keep a reference or pointer to it. dense() and
// sparse() point into the AnyStore and live as long as it does; moving an
// AnyStore keeps them valid (the stores are held by pointer). Sources made
// by hand over dense() or sparse() must not outlive the AnyStore.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>

#include "query/source.h"
#include "storage/common/block_cache.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"
#include "util/status.h"

namespace simplexdb {

enum class StoreKind { kDense, kSparse };

// "dense", "sparse".
const char* StoreKindName(StoreKind kind);

// How to open a store.
struct StoreOptions {
  size_t cache_bytes = size_t{256} << 20;  // decoded blocks kept
  bool in_memory = false;                  // dense: decode every block at open (in-core)
  std::shared_ptr<BlockCache> cache;       // share one cache between stores
};

// The kind of the store at `path` from its first bytes: kSparse for an LMDB
// file, kDense otherwise (whether it is a valid dense store is for
// AnyStore::Open to find out). Cost: one read of 20 bytes. Never fails: an
// unreadable file is kDense, and opening it reports why.
StoreKind ProbeStoreKind(const std::string& path);

class AnyStore {
 public:
  // Opens and validates the store at `path`. Errors: those of
  // DenseStore::Open (NotFound, InvalidArgument when the file is not a store,
  // NotSupported for format 1 and other format versions, Corruption) or of
  // SparseStore::Open (the same codes; InvalidArgument also for another
  // program's LMDB file); InvalidArgument for options.in_memory on a sparse
  // store (its blocks are decoded as read).
  static Result<AnyStore> Open(const std::string& path, const StoreOptions& options = {});

  AnyStore(AnyStore&&) noexcept = default;
  AnyStore& operator=(AnyStore&&) noexcept = default;

  StoreKind kind() const { return sparse_ ? StoreKind::kSparse : StoreKind::kDense; }
  int dimension() const { return info_.dimension; }  // 3: HT, 4: HP
  const std::string& path() const { return info_.path; }
  // What every source of this store reports as info().
  const SourceInfo& info() const { return info_; }
  // The store itself, for what only one kind has (a dense store's cache, a
  // sparse store's header); null for the other kind.
  const DenseStore* dense() const { return dense_.get(); }
  const SparseStore* sparse() const { return sparse_.get(); }

  // OK while the store's file is as it was opened (DenseStore::
  // CheckUnchanged, SparseStore::CheckUnchanged): a file truncated or
  // written in place since is IOError naming it ("open it again"). Every
  // operation that reads the store asks before it starts and after it ends,
  // so that nothing read from a changed file becomes an answer. One fstat.
  Status CheckUnchanged() const {
    return dense_ ? dense_->CheckUnchanged() : sparse_->CheckUnchanged();
  }

  // Makes a source of this store's kind and dimension and calls
  // `visitor.template operator()<D>(source)` with it: a generic lambda
  // `[&]<int D, class Source>(Source& source) { ... }` is the usual form.
  // The visitor returns Status or void (taken as OK) for every source type.
  // Returns the visitor's status, or CheckUnchanged's when the file
  // changed before or during the visit.
  template <class Visitor>
  Status Visit(Visitor&& visitor) const {
    SDB_RETURN_IF_ERROR(CheckUnchanged());
    const Status visited = VisitSource(visitor);
    SDB_RETURN_IF_ERROR(CheckUnchanged());
    return visited;
  }

 private:
  AnyStore() = default;

  template <class Visitor>
  Status VisitSource(Visitor& visitor) const {
    if (dense_) {
      if (dense_->dimension() == 3) {
        DenseSource<3> source(*dense_);
        return Call<3>(visitor, source);
      }
      DenseSource<4> source(*dense_);
      return Call<4>(visitor, source);
    }
    if (sparse_->dimension() == 3) {
      SparseSource<3> source(*sparse_);
      return Call<3>(visitor, source);
    }
    SparseSource<4> source(*sparse_);
    return Call<4>(visitor, source);
  }

  template <int D, class Visitor, class Source>
  static Status Call(Visitor& visitor, Source& source) {
    static_assert(ReadSource<Source, D>);
    using R = decltype(visitor.template operator()<D>(source));
    static_assert(std::is_void_v<R> || std::is_same_v<R, Status>,
                  "a store visitor returns Status or void");
    if constexpr (std::is_void_v<R>) {
      visitor.template operator()<D>(source);
      return Status::OK();
    } else {
      return visitor.template operator()<D>(source);
    }
  }

  // Exactly one is set.
  std::unique_ptr<DenseStore> dense_;
  std::unique_ptr<SparseStore> sparse_;
  SourceInfo info_;
};

// Opens the store at `path`, visits it once (AnyStore::Visit) and closes it.
// Errors: those of AnyStore::Open, then those of Visit.
template <class Visitor>
Status VisitStore(const std::string& path, const StoreOptions& options, Visitor&& visitor) {
  SDB_ASSIGN_OR_RETURN(const AnyStore store, AnyStore::Open(path, options));
  return store.Visit(std::forward<Visitor>(visitor));
}

}  // namespace simplexdb
