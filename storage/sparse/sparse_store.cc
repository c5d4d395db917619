#include "storage/sparse/sparse_store.h"

#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <limits>
#include <vector>

#include "storage/error/finest_box_errors.h"
#include "storage/io/file.h"
#include "storage/io/lmdb.h"

namespace simplexdb {
namespace {

template <int D>
std::array<int64_t, D> WindowStrides() {
  std::array<int64_t, D> s{};
  int64_t stride = 1;
  for (int a = 0; a < D; ++a) {
    s[a] = stride;
    stride *= 5;
  }
  return s;
}

}  // namespace

Result<std::unique_ptr<SparseStore>> SparseStore::Open(const std::string& path, const Options& options) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return StatusFromErrno(errno, path, "open");
  if (!S_ISREG(st.st_mode)) return Status::InvalidArgument(path + ": not a regular file");
  if (!lmdb::LooksLikeLmdb(path)) return Status::InvalidArgument(path + ": not a sparse store (not an LMDB file)");
  std::unique_ptr<SparseStore> store(new SparseStore());
  store->path_ = path;
  lmdb::Env::Options env_options;
  env_options.read_only = true;
  SDB_ASSIGN_OR_RETURN(store->env_, lmdb::Env::Open(path, env_options));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*store->env_, /*read_only=*/true));
  SDB_ASSIGN_OR_RETURN(store->db_, txn.OpenDb(nullptr, false));
  bool found = false;
  SDB_ASSIGN_OR_RETURN(std::span<const uint8_t> value, txn.Get(store->db_, kSparseHeaderKey, &found));
  if (!found) {
    // Earlier layouts kept named databases.
    if (txn.OpenDb("errors", false).ok()) {
      return Status::NotSupported(path + ": a sparse store of format 1; this build reads format 2 "
                                         "(import the volume again)");
    }
    if (txn.OpenDb("meta", false).ok()) {
      return Status::NotSupported(path + ": a sparse store of format 2 with header version 2 or 3; this build "
                                         "reads version " + std::to_string(kSparseFormatVersion) +
                                  " (import the volume again)");
    }
    return Status::InvalidArgument(path + ": an LMDB file, but not a SimplexDB sparse store (no header)");
  }
  SDB_ASSIGN_OR_RETURN(store->header_, DecodeSparseHeader(value, path));
  // Committing a read-only transaction keeps its database handles open.
  SDB_RETURN_IF_ERROR(txn.Commit());
  const SparseHeader& h = store->header_;
  store->errors_ = std::make_unique<SparseErrorCoder>(h);
  // Few shards: a decoded block is 16 bytes per kept vertex and a bit per
  // position (up to 4.03 MiB at the HT's default 2^18 positions), and a
  // shard must hold several.
  store->cache_ = options.cache ? options.cache : std::make_shared<BlockCache>(options.cache_bytes, 4);
  store->cache_id_ = BlockCache::NewStoreId();
  return store;
}

SparseStore::~SparseStore() {
  if (cache_) cache_->EraseStore(cache_id_);
}

uint64_t SparseStore::file_bytes() const {
  struct stat st;
  return stat(path_.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0;
}

SparseStore::Stats SparseStore::stats() const {
  return Stats{decoded_.load(std::memory_order_relaxed), rebuilt_.load(std::memory_order_relaxed)};
}

Result<bool> ReadSparseBlockValue(lmdb::Txn& txn, MDB_dbi dbi, uint64_t b, const std::string& path,
                                  std::vector<uint8_t>* out) {
  out->clear();
  SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, dbi));
  auto first = SparseKey(b, 0);
  MDB_val k = lmdb::Val(first.data(), first.size()), v;
  uint32_t next = 0;
  for (int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_SET_RANGE);; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    if (rc == MDB_NOTFOUND) break;
    if (rc != MDB_SUCCESS) return lmdb::FromCode(rc, path, "read block " + std::to_string(b));
    const std::span<const uint8_t> key(static_cast<const uint8_t*>(k.mv_data), k.mv_size);
    if (IsSparseHeaderKey(key)) break;
    uint64_t block = 0;
    uint32_t part = 0;
    if (!ParseSparseKey(key, &block, &part)) {
      return Status::Corruption(path + ": a block key of " + std::to_string(k.mv_size) + " bytes");
    }
    if (block != b) break;
    if (part != next) {
      return Status::Corruption(path + ": block " + std::to_string(b) + " has part " + std::to_string(part) +
                                " where part " + std::to_string(next) + " belongs");
    }
    ++next;
    const auto* data = static_cast<const uint8_t*>(v.mv_data);
    out->insert(out->end(), data, data + v.mv_size);
  }
  return next > 0;
}

template <int D>
SparseStore::Reader<D>::Reader(const SparseStore& store)
    : store_(store),
      order_(store.header().domain_bits),
      stencils_(FinestDiamonds<D>::Get(), WindowStrides<D>()),
      window_memo_(size_t{1} << kWindowMemoBits) {
  for (int a = 0; a < D; ++a) dims_[a] = store.header().dims[a];
}

template <int D>
SparseStore::Reader<D>::~Reader() = default;

template <int D>
Result<uint64_t> SparseStore::Reader<D>::Rebuild(uint64_t b) {
  SDB_ASSIGN_OR_RETURN(const View v, Materialize(b));
  return static_cast<uint64_t>(v.kept);
}

template <int D>
Result<const typename SparseStore::Reader<D>::View*> SparseStore::Reader<D>::Get(uint64_t p) {
  const int bb = store_.header().block_bits;
  const uint64_t b = p >> bb;
  size_t slot = 0;
  if (b != 0) {
    const int top = 63 - std::countl_zero(p);
    const int octave = top / D - 1;
    slot = static_cast<size_t>(octave) * (size_t{1} << D) + static_cast<size_t>(p >> (D * (octave + 1)));
  }
  View& held = held_[slot];
  if (held.b != b) {
    SDB_ASSIGN_OR_RETURN(held, Fetch(b));
  }
  return &held;
}

namespace {

// A compact decoded block of `kept` vertices of a block of 2^block_bits
// positions: values, then offsets, then states, then a bit per position,
// set when kept (doubles first, for their alignment). A block without an
// entry: no bytes.
size_t BitWords(int block_bits) { return ((size_t{1} << block_bits) + 63) / 64; }
size_t CompactBytes(size_t kept, int block_bits) {
  return kept * (sizeof(double) + 2 * sizeof(uint32_t)) + BitWords(block_bits) * sizeof(uint64_t);
}

}  // namespace

template <int D>
Result<typename SparseStore::Reader<D>::View> SparseStore::Reader<D>::Fetch(uint64_t b) {
  const BlockCache::Key key{store_.cache_id_, b};
  std::shared_ptr<const BlockCache::Block> block = store_.cache_->Lookup(key);
  if (block == nullptr) {
    if (const auto it = failed_.find(b); it != failed_.end()) return it->second;
    Result<View> made = Materialize(b);
    if (!made.ok()) {
      failed_.emplace(b, made.status());
      return made.status();
    }
    block = store_.cache_->Insert(key, made->block);
  }
  View v;
  v.b = b;
  if (!block->empty()) {
    const int bb = store_.header().block_bits;
    v.kept = (block->size() - CompactBytes(0, bb)) / (CompactBytes(1, bb) - CompactBytes(0, bb));
    v.values = reinterpret_cast<const double*>(block->data());
    v.offsets = reinterpret_cast<const uint32_t*>(block->data() + v.kept * sizeof(double));
    v.states = v.offsets + v.kept;
    v.bits = reinterpret_cast<const uint64_t*>(v.states + v.kept);
  }
  v.block = std::move(block);
  return v;
}

template <int D>
template <class ValueOf>
Result<double> SparseStore::Reader<D>::RebuiltValue(const std::array<int64_t, D>& g, uint64_t p,
                                                    ValueOf&& value) {
  if (const auto it = rebuilt_values_.find(p); it != rebuilt_values_.end()) return it->second;
  // The ends are coarser, so the recursion ends within the levels.
  Status failed = Status::OK();
  const double v = HzPredict<D>(g, dims_, true, [&](const std::array<int64_t, D>& q) -> double {
    Result<double> end = value(q);
    if (!end.ok()) {
      failed = end.status();
      return 0.0;
    }
    return *end;
  });
  SDB_RETURN_IF_ERROR(failed);
  if (rebuilt_values_.size() >= kRebuiltValuesHeld) rebuilt_values_.clear();
  rebuilt_values_.emplace(p, v);
  return v;
}

template <int D>
Result<typename SparseStore::Reader<D>::View> SparseStore::Reader<D>::Materialize(uint64_t b) {
  const SparseHeader& h = store_.header();
  const int bb = h.block_bits;
  const uint64_t n = uint64_t{1} << bb, first = b << bb;
  if (txn_ == nullptr) {
    SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*store_.env_, /*read_only=*/true));
    txn_ = std::make_unique<lmdb::Txn>(std::move(txn));
  }
  std::vector<uint8_t> value;
  SDB_ASSIGN_OR_RETURN(const bool found, ReadSparseBlockValue(*txn_, store_.db_, b, store_.path(), &value));
  View out;
  out.b = b;
  if (!found) {
    if (b == 0) return Status::Corruption(store_.path() + ": block 0 (the domain's corners) is missing");
    store_.rebuilt_.fetch_add(1, std::memory_order_relaxed);
    out.block = std::make_shared<BlockCache::Block>();
    return out;
  }
  // The kept vertices, by the bitmap over the block's domain vertices.
  struct Vertex {
    uint32_t offset;
    std::array<int64_t, D> g;
  };
  std::vector<Vertex> kept;
  // Count first (the decoder checks the count against the value), then
  // decode, then pick the kept ones.
  uint32_t vertices = 0;
  if (HzBlockMayHoldVertices<D>(bb, b)) {
    ForEachHzVertex<D>(order_, first, n, [&](uint64_t, const std::array<int64_t, D>&) { ++vertices; });
  }
  SDB_ASSIGN_OR_RETURN(SparseBlock decoded,
                       DecodeSparseBlock(b, value, vertices, SparseErrorWidth(h.quantization),
                                         SparseResidualWidth(h), zstd_, store_.path()));
  store_.decoded_.fetch_add(1, std::memory_order_relaxed);
  kept.reserve(decoded.residuals.size());
  if (vertices != 0) {
    // The bitmap has a bit per candidate (SparseMayBeKept): a vertex
    // whose ancestors are kept, in this block (earlier positions: coarser)
    // or in others (read through the cache).
    std::vector<uint64_t> here((n + 63) / 64, 0);
    Status failed = Status::OK();
    const auto kept_at = [&](const std::array<int64_t, D>& q) {
      const uint64_t p = order_.Position(q);
      if ((p >> bb) == b) return (here[(p - first) >> 6] >> ((p - first) & 63) & 1) != 0;
      Result<bool> k = Kept(q);
      if (!k.ok()) failed = k.status();
      return k.ok() && *k;
    };
    // A bit for every vertex: no candidate to find.
    const bool every = decoded.candidates == vertices;
    uint32_t c = 0;
    ForEachHzVertex<D>(order_, first, n, [&](uint64_t p, const std::array<int64_t, D>& g) {
      if (!every && (!failed.ok() || !SparseMayBeKept<D>(g, h.domain_bits, kept_at))) return;
      if (c < decoded.candidates && decoded.IsKept(c)) {
        kept.push_back(Vertex{static_cast<uint32_t>(p - first), g});
        here[(p - first) >> 6] |= uint64_t{1} << ((p - first) & 63);
      }
      ++c;
    });
    SDB_RETURN_IF_ERROR(failed);
    if (c != decoded.candidates) {
      return Status::Corruption(store_.path() + ": block " + std::to_string(b) + " has " + std::to_string(c) +
                                " vertices that may be kept; its bitmap codes " +
                                std::to_string(decoded.candidates));
    }
  }
  if (kept.size() != decoded.residuals.size()) {
    return Status::Corruption(store_.path() + ": block " + std::to_string(b) + " keeps " +
                              std::to_string(kept.size()) + " vertices and holds " +
                              std::to_string(decoded.residuals.size()) + " values");
  }
  auto block = std::make_shared<BlockCache::Block>(CompactBytes(kept.size(), bb));
  auto* values = reinterpret_cast<double*>(block->data());
  auto* offsets = reinterpret_cast<uint32_t*>(block->data() + kept.size() * sizeof(double));
  uint32_t* states = offsets + kept.size();
  auto* bits = reinterpret_cast<uint64_t*>(states + kept.size());
  std::fill(bits, bits + BitWords(bb), 0);
  for (size_t i = 0; i < kept.size(); ++i) {
    offsets[i] = kept[i].offset;
    bits[kept[i].offset >> 6] |= uint64_t{1} << (kept[i].offset & 63);
  }
  out.kept = kept.size();
  out.values = values;
  out.offsets = offsets;
  out.states = states;
  out.bits = bits;
  // Values at coarser vertices: this block's (kept ones are filled in
  // position order, so coarser first; dropped ones rebuilt from their ends)
  // or another's.
  Status failed = Status::OK();
  std::function<Result<double>(const std::array<int64_t, D>&)> value_of;
  value_of = [&](const std::array<int64_t, D>& q) -> Result<double> {
    const uint64_t p = order_.Position(q);
    if ((p >> bb) != b) return Value(q);
    const size_t i = out.Find(static_cast<uint32_t>(p - first));
    if (i != out.kept) return values[i];
    return RebuiltValue(q, p, value_of);
  };
  const auto value_at = [&](const std::array<int64_t, D>& q) -> double {
    Result<double> v = value_of(q);
    if (!v.ok()) {
      failed = v.status();
      return 0.0;
    }
    return *v;
  };
  const int finest_first = D * (h.domain_bits - 1);
  size_t e = 0;
  for (size_t i = 0; i < kept.size(); ++i) {
    const Vertex& v = kept[i];
    const int level = order_.LevelAt(first + v.offset);
    if (level < 0) {  // a domain corner: predicted 0
      values[i] = KeptValue(decoded.residuals[i], 0.0);
      states[i] = 0;
      continue;
    }
    const double p = HzPredict<D>(v.g, dims_, false, value_at);
    SDB_RETURN_IF_ERROR(failed);
    values[i] = KeptValue(decoded.residuals[i], p);
    if (level < finest_first) {
      if (e >= decoded.errors.size()) {
        return Status::Corruption(store_.path() + ": block " + std::to_string(b) + " holds too few errors");
      }
      states[i] = decoded.errors[e++];
    } else {
      states[i] = kFinestKept;
    }
  }
  if (b == 0) {  // every domain corner kept
    size_t corners = 0;
    for (size_t i = 0; i < kept.size(); ++i) corners += order_.LevelAt(first + kept[i].offset) < 0;
    if (corners != (size_t{1} << D)) {
      return Status::Corruption(store_.path() + ": block 0 drops a domain corner");
    }
  }
  if (e != decoded.errors.size()) {
    return Status::Corruption(store_.path() + ": block " + std::to_string(b) + " holds " +
                              std::to_string(decoded.errors.size()) + " errors; its kept diamonds need " +
                              std::to_string(e));
  }
  out.block = std::move(block);
  return out;
}

template <int D>
Result<double> SparseStore::Reader<D>::Value(const std::array<int64_t, D>& g) {
  const uint64_t p = order_.Position(g);
  SDB_ASSIGN_OR_RETURN(const View* v, Get(p));
  const size_t i = v->Find(static_cast<uint32_t>(p & ((uint64_t{1} << store_.header().block_bits) - 1)));
  if (i != v->kept) return v->values[i];
  return RebuiltValue(g, p, [this](const std::array<int64_t, D>& q) { return Value(q); });
}

template <int D>
Result<double> SparseStore::Reader<D>::Field(const std::array<int64_t, D>& p) {
  // Past the real grid, the nearest real point's value: a kept vertex there
  // holds it exactly (the builder stored it), a dropped one takes it from
  // that point, rebuilt.
  std::array<int64_t, D> q{};
  bool real = true;
  for (int a = 0; a < D; ++a) {
    q[a] = std::clamp<int64_t>(p[a], 0, dims_[a] - 1);
    real = real && q[a] == p[a];
  }
  if (!real) {
    SDB_ASSIGN_OR_RETURN(const bool kept, Kept(p));
    if (kept) return Value(p);
  }
  return Value(q);
}

template <int D>
Result<bool> SparseStore::Reader<D>::Kept(const std::array<int64_t, D>& g) {
  const uint64_t p = order_.Position(g);
  SDB_ASSIGN_OR_RETURN(const View* v, Get(p));
  return v->Has(static_cast<uint32_t>(p & ((uint64_t{1} << store_.header().block_bits) - 1)));
}

template <int D>
Result<uint32_t> SparseStore::Reader<D>::FinestCode(const std::array<int64_t, D>& g) {
  // The rebuilt values of the real points of [g - 2, g + 2], in a window of
  // side 5 that the stencils are laid out for.
  int64_t center = 0, stride = 1;
  for (int a = 0; a < D; ++a) {
    center += 2 * stride;
    stride *= 5;
  }
  for (int64_t w = 0; w < stride; ++w) {
    std::array<int64_t, D> q{};
    bool real = true;
    int64_t rest = w;
    for (int a = 0; a < D; ++a) {
      q[a] = g[a] + rest % 5 - 2;
      rest /= 5;
      real = real && q[a] >= 0 && q[a] < dims_[a];
    }
    if (!real) {
      window_[static_cast<size_t>(w)] = 0;
      continue;
    }
    // Neighboring diamonds' windows overlap: their values are remembered by
    // grid point (each coordinate below 2^21 in 3D, 2^16 in 4D).
    uint64_t key = 0;
    for (int a = D - 1; a >= 0; --a) key = key << (D == 3 ? 21 : 16) | static_cast<uint64_t>(q[a]);
    WindowMemo& m = window_memo_[(key * 0x9E3779B97F4A7C15ull) >> (64 - kWindowMemoBits)];
    if (m.key != key) {
      SDB_ASSIGN_OR_RETURN(m.value, Value(q));
      m.key = key;
    }
    window_[static_cast<size_t>(w)] = m.value;
  }
  const auto field = [&](const std::array<int64_t, D>& p) {
    int64_t i = 0, s = 1;
    for (int a = 0; a < D; ++a) {
      i += (p[a] - g[a] + 2) * s;
      s *= 5;
    }
    return window_[static_cast<size_t>(i)];
  };
  const double e = FinestDiamondError<D>(stencils_, window_.data() + center, g, store_.header().domain_bits,
                                         dims_, field);
  // The input differs from the rebuilt field by at most the value bound at
  // any point, and its interpolant between the diamond's (kept) vertices by
  // at most s / 2.
  const SparseHeader& h = store_.header();
  return store_.errors().Encode(e + SparseValueBound(h) + h.value_step / 2);
}

template <int D>
Result<double> SparseStore::Reader<D>::ErrorBound(SimplexCode<D> code) {
  const int k = store_.header().domain_bits;
  if (code.level() >= D * k) return 0.0;
  const std::array<int64_t, D> g = LatticeToGrid<D>(cursor_.Of(code), k);
  const uint64_t p = order_.PositionAtLevel(g, code.level());
  SDB_ASSIGN_OR_RETURN(const View* v, Get(p));
  const size_t i = v->Find(static_cast<uint32_t>(p & ((uint64_t{1} << store_.header().block_bits) - 1)));
  if (i == v->kept) return 0.0;  // dropped
  // The block was made (non-const) by Materialize and published through
  // the cache's lock; finest codes are filled in with atomic stores.
  std::atomic_ref<uint32_t> state(const_cast<uint32_t*>(v->states)[i]);
  const uint32_t s = state.load(std::memory_order_relaxed);
  if (s != kFinestKept) return store_.errors().Decode(s);
  const std::shared_ptr<const BlockCache::Block> keep = v->block;  // FinestCode may move the held views
  SDB_ASSIGN_OR_RETURN(const uint32_t c, FinestCode(g));
  state.store(c, std::memory_order_relaxed);
  return store_.errors().Decode(c);
}

namespace {

template <int D>
Status VerifyTyped(const SparseStore& store, lmdb::Env& env, unsigned int dbi,
                   const std::function<void(uint64_t, uint64_t)>& progress) {
  const SparseHeader& h = store.header();
  const std::string& path = store.path();
  const HzOrder<D> order(h.domain_bits);
  const int bb = h.block_bits;
  const uint64_t nblocks = (order.size() + (uint64_t{1} << bb) - 1) >> bb;
  typename SparseStore::template Reader<D> reader(store);
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(env, /*read_only=*/true));
  SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, dbi));
  MDB_val k, v;
  uint64_t entries = 0, kept = 0, last = 0;
  int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST);
  for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    const std::span<const uint8_t> key(static_cast<const uint8_t*>(k.mv_data), k.mv_size);
    uint64_t b = 0;
    uint32_t part = 0;
    if (IsSparseHeaderKey(key)) continue;  // read at the open
    if (!ParseSparseKey(key, &b, &part)) {
      return Status::Corruption(path + ": a key of " + std::to_string(k.mv_size) + " bytes");
    }
    if (b >= nblocks || !HzBlockMayHoldVertices<D>(bb, b)) {
      return Status::Corruption(path + ": block " + std::to_string(b) + " lies past the domain");
    }
    // A block's later parts: read with its first (ReadBlockValue checks
    // their sequence); a later part without a first is refused there too.
    if (part != 0 && entries > 0 && b == last) continue;
    last = b;
    SDB_ASSIGN_OR_RETURN(const uint64_t block_kept, reader.Rebuild(b));
    kept += block_kept;
    ++entries;
    if (progress) progress(entries, h.blocks);
  }
  if (rc != MDB_NOTFOUND) return env.FromCode(rc, "read the blocks");
  if (entries != h.blocks || kept != h.kept) {
    return Status::Corruption(path + ": " + std::to_string(entries) + " blocks holding " + std::to_string(kept) +
                              " kept vertices; the header says " + std::to_string(h.blocks) + " and " +
                              std::to_string(h.kept));
  }
  return Status::OK();
}

}  // namespace

Status SparseStore::Verify(const std::function<void(uint64_t, uint64_t)>& progress) const {
  return header_.dimension == 3 ? VerifyTyped<3>(*this, *env_, db_, progress)
                                : VerifyTyped<4>(*this, *env_, db_, progress);
}

template class SparseStore::Reader<3>;
template class SparseStore::Reader<4>;

Status SparseStore::CheckUnchanged() const { return env_->CheckUnchanged(); }

}  // namespace simplexdb
