#include "storage/sparse/sparse_store.h"

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <nlohmann/json.hpp>

#include "hierarchy/geometry.h"
#include "storage/io/checksum.h"
#include "storage/io/file.h"
#include "storage/io/lmdb.h"
#include "storage/io/read_only_file.h"
#include "storage/sparse/vertex_set.h"
#include "util/little_endian.h"
#include "util/utf8.h"

namespace simplexdb {

std::string SerializeSparseHeader(const SparseHeader& h) {
  nlohmann::json j;
  j["format"] = kSparseFormatName;
  j["version"] = h.version;
  j["hierarchy"] = h.dimension == 3 ? "ht" : "hp";
  j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
  j["domain_bits"] = h.domain_bits;
  j["voxel_type"] = std::string(VoxelTypeName(h.voxel_type));
  j["quantization"] = std::string(QuantizationName(h.quantization));
  j["quantum"] = h.quantum;
  j["field_min"] = h.field_min;
  j["field_max"] = h.field_max;
  j["error_max"] = h.error_max;
  j["tolerance"] = h.tolerance;
  j["nodes"] = h.nodes;
  j["vertices"] = h.vertices;
  j["content_sum"] = h.content_sum;
  // A path is bytes, JSON text is UTF-8: without this dump() throws.
  j["source"] = ToValidUtf8(h.source);
  return j.dump();
}

Result<SparseHeader> ParseSparseHeader(std::string_view text, const std::string& file) {
  const auto bad = [&](const std::string& why) {
    return Status::Corruption(file + ": sparse store header: " + why);
  };
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return bad("not a JSON object");
  if (j.value("format", "") != kSparseFormatName) {
    return Status::InvalidArgument(file + ": an LMDB file, but not a SimplexDB sparse store");
  }
  SparseHeader h;
  try {
    h.version = j.at("version").get<uint32_t>();
    if (h.version != kSparseFormatVersion) {
      return Status::NotSupported(file + ": sparse store format version " +
                                  std::to_string(h.version) + "; this build reads version " +
                                  std::to_string(kSparseFormatVersion));
    }
    const std::string hierarchy = j.at("hierarchy").get<std::string>();
    if (hierarchy != "ht" && hierarchy != "hp") return bad("hierarchy '" + hierarchy + "'");
    h.dimension = hierarchy == "ht" ? 3 : 4;
    const auto dims = j.at("dims").get<std::vector<uint32_t>>();
    if (static_cast<int>(dims.size()) != h.dimension) return bad("dims do not match the hierarchy");
    for (int c = 0; c < h.dimension; ++c) h.dims[c] = dims[c];
    h.domain_bits = j.at("domain_bits").get<int>();
    const int max_bits = h.dimension == 3 ? SimplexCode<3>::kMaxLevel / 3
                                          : SimplexCode<4>::kMaxLevel / 4;
    if (h.domain_bits < 1 || h.domain_bits > max_bits) return bad("domain_bits out of range");
    for (int c = 0; c < h.dimension; ++c) {
      if (h.dims[c] < 1 || h.dims[c] > (uint64_t{1} << h.domain_bits) + 1) {
        return bad("dims exceed the domain");
      }
    }
    auto type = ParseVoxelType(j.at("voxel_type").get<std::string>());
    if (!type.ok()) return bad(std::string(type.status().message()));
    h.voxel_type = *type;
    auto q = ParseQuantization(j.at("quantization").get<std::string>());
    if (!q.ok()) return bad(std::string(q.status().message()));
    h.quantization = *q;
    h.quantum = j.at("quantum").get<double>();
    h.field_min = j.at("field_min").get<double>();
    h.field_max = j.at("field_max").get<double>();
    h.error_max = j.at("error_max").get<double>();
    h.tolerance = j.at("tolerance").get<double>();
    h.nodes = j.at("nodes").get<uint64_t>();
    h.vertices = j.at("vertices").get<uint64_t>();
    h.content_sum = j.at("content_sum").get<uint64_t>();
    h.source = j.at("source").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    return bad(e.what());
  }
  if (!(std::isfinite(h.field_min) && std::isfinite(h.field_max) && h.field_min <= h.field_max)) {
    return bad("field range");
  }
  if (!(std::isfinite(h.error_max) && h.error_max >= 0 && std::isfinite(h.tolerance) &&
        h.tolerance >= 0 && std::isfinite(h.quantum) && h.quantum >= 0)) {
    return bad("error range, tolerance or quantum");
  }
  return h;
}

uint64_t SparseEntryHash(int db, std::span<const uint8_t> key, std::span<const uint8_t> value) {
  // Keys are 8 bytes and values at most 8: one short buffer.
  uint8_t buffer[32];
  const size_t n = std::min(key.size(), size_t{16});
  const size_t m = std::min(value.size(), size_t{16});
  std::copy_n(key.data(), n, buffer);
  std::copy_n(value.data(), m, buffer + n);
  return Checksum(std::span<const uint8_t>(buffer, n + m), static_cast<uint64_t>(db + 1));
}

bool LooksLikeLmdb(const std::string& path) {
  // LMDB's first page is a meta page: a 16-byte page header, then the meta
  // record, whose first field is the magic 0xBEEFC0DE (native order).
  // ReadOnlyFile: a FIFO or a device is refused at once, not waited on.
  Result<ReadOnlyFile> file = ReadOnlyFile::Open(path);
  if (!file.ok()) return false;
  uint8_t head[20] = {};
  const Result<size_t> got = file->ReadUpTo(0, sizeof head, reinterpret_cast<std::byte*>(head));
  if (!got.ok() || *got != sizeof head) return false;
  const uint32_t magic = LoadLittle<uint32_t>(head + 16);
  return magic == 0xBEEFC0DEu;
}

std::optional<uint32_t> DecodeStoredError(Quantization q, std::span<const uint8_t> bytes) {
  if (bytes.size() != QuantizedSize(q)) return std::nullopt;
  switch (q) {
    case Quantization::kU8:
      return bytes[0];
    case Quantization::kU16:
      return LoadLittle<uint16_t>(bytes.data());
    case Quantization::kF32:
      return LoadLittle<uint32_t>(bytes.data());
  }
  return std::nullopt;
}

size_t EncodeStoredError(Quantization q, uint32_t stored, uint8_t* out) {
  switch (q) {
    case Quantization::kU8:
      out[0] = static_cast<uint8_t>(stored);
      return 1;
    case Quantization::kU16:
      StoreLittle<uint16_t>(out, static_cast<uint16_t>(stored));
      return 2;
    case Quantization::kF32:
      StoreLittle<uint32_t>(out, stored);
      return 4;
  }
  return 0;
}

Result<std::unique_ptr<SparseStore>> SparseStore::Open(const std::string& path) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return StatusFromErrno(errno, path, "open");
  if (!S_ISREG(st.st_mode)) return Status::InvalidArgument(path + ": not a regular file");
  if (!LooksLikeLmdb(path)) {
    return Status::InvalidArgument(path + ": not a sparse store (not an LMDB file)");
  }
  std::unique_ptr<SparseStore> store(new SparseStore());
  store->path_ = path;
  lmdb::Env::Options options;
  options.read_only = true;
  SDB_ASSIGN_OR_RETURN(store->env_, lmdb::Env::Open(path, options));
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(*store->env_, /*read_only=*/true));
  auto meta = txn.OpenDb("meta", false);
  if (!meta.ok()) {
    return Status::InvalidArgument(path + ": an LMDB file, but not a SimplexDB sparse store (" +
                                   std::string(meta.status().message()) + ")");
  }
  store->meta_ = *meta;
  SDB_ASSIGN_OR_RETURN(store->errors_, txn.OpenDb("errors", false));
  SDB_ASSIGN_OR_RETURN(store->field_, txn.OpenDb("field", false));
  static constexpr uint8_t kHeaderKey[] = {'h', 'e', 'a', 'd', 'e', 'r'};
  bool found = false;
  SDB_ASSIGN_OR_RETURN(std::span<const uint8_t> text, txn.Get(store->meta_, kHeaderKey, &found));
  if (!found) return Status::Corruption(path + ": sparse store without a header");
  SDB_ASSIGN_OR_RETURN(
      store->header_,
      ParseSparseHeader(std::string_view(reinterpret_cast<const char*>(text.data()), text.size()),
                        path));
  // Committing a read-only transaction keeps its database handles open for
  // the environment (aborting would close them).
  SDB_RETURN_IF_ERROR(txn.Commit());
  const SparseHeader& h = store->header_;
  store->quantizer_ = ErrorQuantizer(h.quantization, h.quantum, h.field_max - h.field_min);
  return store;
}

uint64_t SparseStore::file_bytes() const {
  struct stat st;
  return stat(path_.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0;
}

namespace {

template <int D>
Status VerifyTyped(const SparseStore& store,
                   const std::function<void(uint64_t, uint64_t)>& progress) {
  const SparseHeader& h = store.header();
  const std::string& path = store.path();
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(store.env(), /*read_only=*/true));
  const uint64_t total = h.nodes + h.vertices;
  uint64_t done = 0, sum = 0;
  VertexSet needed(D, h.domain_bits);
  for (const std::array<int64_t, D>& corner : DomainCorners<D>(h.domain_bits)) {
    needed.Insert(SparseStore::VertexKey<D>(corner, h.domain_bits));
  }
  // Errors, in preorder: a stack of the present ancestors (with vertices).
  struct Open {
    SimplexCode<D> code;
    SimplexVertices<D> vertices;
  };
  std::vector<Open> stack;
  // No stored error may exceed the code the largest error was stored as.
  const double limit = store.quantizer().Decode(store.quantizer().Encode(h.error_max));
  uint64_t nodes = 0;
  {
    SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, store.errors_db()));
    MDB_val k, v;
    int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST);
    for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
      if (k.mv_size != 8) return Status::Corruption(path + ": an error key of " + std::to_string(k.mv_size) + " bytes");
      const uint64_t key = lmdb::KeyValue(k);
      const SimplexCode<D> code = SimplexCode<D>::FromKey(key);
      const std::string name = path + ": node " + (code.is_valid() ? code.ToString() : "(invalid key)");
      if (!code.is_valid()) return Status::Corruption(name + " " + std::to_string(key));
      if (code.level() >= h.leaf_level()) return Status::Corruption(name + ": at or below the leaf level");
      const std::span<const uint8_t> value(static_cast<const uint8_t*>(v.mv_data), v.mv_size);
      const std::optional<uint32_t> stored = DecodeStoredError(h.quantization, value);
      if (!stored) return Status::Corruption(name + ": a value of " + std::to_string(v.mv_size) + " bytes");
      const double e = store.quantizer().Decode(*stored);
      if (!(std::isfinite(e) && e >= 0 && e <= limit)) {
        return Status::Corruption(name + ": error " + std::to_string(e) + " out of range");
      }
      while (!stack.empty() && !stack.back().code.is_ancestor_of(code)) stack.pop_back();
      SimplexVertices<D> vertices;
      if (code.level() == 0) {
        vertices = RootVertices<D>(code.top());
      } else {
        if (stack.empty() || stack.back().code != code.parent()) {
          return Status::Corruption(name + ": present, but its parent is not");
        }
        vertices = ChildVertices<D>(stack.back().code, stack.back().vertices, code.child_index());
      }
      needed.Insert(SparseStore::VertexKey<D>(
          LatticeToGrid<D>(SplitMidpoint<D>(code, vertices), h.domain_bits),
          h.domain_bits));
      stack.push_back(Open{code, vertices});
      sum += SparseEntryHash(kErrorsDb, {static_cast<const uint8_t*>(k.mv_data), 8}, value);
      ++nodes;
      if (progress && (++done & 0xfffff) == 0) progress(done, total);
    }
    if (rc != MDB_NOTFOUND) return store.env().FromCode(rc, "read the errors");
  }
  if (nodes != h.nodes) {
    return Status::Corruption(path + ": " + std::to_string(nodes) + " nodes; the header says " +
                              std::to_string(h.nodes));
  }
  uint64_t vertices = 0;
  {
    SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(txn, store.field_db()));
    MDB_val k, v;
    int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST);
    const size_t voxel = VoxelSize(h.voxel_type);
    for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
      if (k.mv_size != 8) return Status::Corruption(path + ": a vertex key of " + std::to_string(k.mv_size) + " bytes");
      const uint64_t key = lmdb::KeyValue(k);
      const std::string name = path + ": vertex " + std::to_string(key);
      if (!needed.Contains(key)) return Status::Corruption(name + ": stored, but no present node has it");
      if (v.mv_size != voxel) return Status::Corruption(name + ": a value of " + std::to_string(v.mv_size) + " bytes");
      double value;
      DecodeVoxels(h.voxel_type, ByteOrder::kLittle, static_cast<const std::byte*>(v.mv_data), 1, &value);
      if (!std::isnan(value) && !(value >= h.field_min && value <= h.field_max)) {  // NaN: missing
        return Status::Corruption(name + ": value " + std::to_string(value) + " outside the field range");
      }
      sum += SparseEntryHash(kFieldDb, {static_cast<const uint8_t*>(k.mv_data), 8},
                             {static_cast<const uint8_t*>(v.mv_data), v.mv_size});
      ++vertices;
      if (progress && (++done & 0xfffff) == 0) progress(done, total);
    }
    if (rc != MDB_NOTFOUND) return store.env().FromCode(rc, "read the field");
  }
  if (vertices != needed.size()) {
    return Status::Corruption(path + ": " + std::to_string(needed.size() - vertices) +
                              " vertices of present nodes are missing from the field");
  }
  if (vertices != h.vertices) {
    return Status::Corruption(path + ": " + std::to_string(vertices) +
                              " vertices; the header says " + std::to_string(h.vertices));
  }
  if (sum != h.content_sum) {
    return Status::Corruption(path + ": the content does not match the header's checksum");
  }
  if (progress) progress(total, total);
  return Status::OK();
}

}  // namespace

Status SparseStore::Verify(const std::function<void(uint64_t, uint64_t)>& progress) const {
  return dimension() == 3 ? VerifyTyped<3>(*this, progress) : VerifyTyped<4>(*this, progress);
}

static_assert(std::is_same_v<MDB_dbi, unsigned int>, "sparse_store.h keeps MDB_dbi values");

SparseStore::~SparseStore() = default;

lmdb::Env& SparseStore::env() const { return *env_; }

template <int D>
SparseStore::Reader<D>::Reader(const SparseStore& store, std::unique_ptr<lmdb::Txn> txn)
    : store_(&store), txn_(std::move(txn)) {}
template <int D>
SparseStore::Reader<D>::Reader(Reader&&) noexcept = default;
template <int D>
SparseStore::Reader<D>& SparseStore::Reader<D>::operator=(Reader&&) noexcept = default;
// Named through the injected class name: after `Reader<D>::~` the name is
// looked up where `Reader` was, which finds the template (clang's -Wdtor-name).
template <int D>
SparseStore::Reader<D>::Reader::~Reader() = default;

template <int D>
Result<SparseStore::Reader<D>> SparseStore::Reader<D>::Create(const SparseStore& store) {
  SDB_ASSIGN_OR_RETURN(lmdb::Txn txn, lmdb::Txn::Begin(store.env(), /*read_only=*/true));
  return Reader(store, std::make_unique<lmdb::Txn>(std::move(txn)));
}

template <int D>
Status SparseStore::Reader<D>::Refresh() {
  txn_->Abort();
  prefetch_.clear();
  prefetch_lo_ = 1;
  prefetch_hi_ = 0;
  SDB_ASSIGN_OR_RETURN(*txn_, lmdb::Txn::Begin(store_->env(), /*read_only=*/true));
  return Status::OK();
}

template <int D>
Result<std::optional<uint32_t>> SparseStore::Reader<D>::DecodeStored(
    uint64_t key, std::span<const uint8_t> value) {
  const std::optional<uint32_t> stored = DecodeStoredError(store_->header().quantization, value);
  if (!stored) {
    return Status::Corruption(store_->path() + ": node " + SimplexCode<D>::FromKey(key).ToString() +
                              ": a value of " + std::to_string(value.size()) + " bytes");
  }
  return stored;
}

template <int D>
Result<std::optional<uint32_t>> SparseStore::Reader<D>::FindStored(SimplexCode<D> code) {
  const uint64_t key = code.key();
  if (key >= prefetch_lo_ && key <= prefetch_hi_) {
    ++stats_.prefetch_hits;
    const auto it = std::lower_bound(prefetch_.begin(), prefetch_.end(),
                                     std::pair<uint64_t, uint32_t>(key, 0));
    if (it != prefetch_.end() && it->first == key) return std::optional<uint32_t>(it->second);
    return std::optional<uint32_t>();
  }
  ++stats_.btree_lookups;
  const auto k = lmdb::KeyBytes(key);
  bool found = false;
  SDB_ASSIGN_OR_RETURN(std::span<const uint8_t> value, txn_->Get(store_->errors_db(), k, &found));
  if (!found) return std::optional<uint32_t>();
  return DecodeStored(key, value);
}

template <int D>
Result<std::optional<double>> SparseStore::Reader<D>::Find(SimplexCode<D> code) {
  SDB_ASSIGN_OR_RETURN(std::optional<uint32_t> stored, FindStored(code));
  if (!stored) return std::optional<double>();
  return std::optional<double>(store_->quantizer().Decode(*stored));
}

template <int D>
Result<double> SparseStore::Reader<D>::ErrorBound(SimplexCode<D> code) {
  if (code.level() >= store_->header().leaf_level()) return 0.0;
  SDB_ASSIGN_OR_RETURN(std::optional<double> e, Find(code));
  return e.value_or(0.0);
}

template <int D>
Result<std::optional<double>> SparseStore::Reader<D>::Field(const std::array<int64_t, D>& p) {
  const SparseHeader& h = store_->header();
  const auto k = lmdb::KeyBytes(VertexKey<D>(p, h.domain_bits));
  bool found = false;
  SDB_ASSIGN_OR_RETURN(std::span<const uint8_t> value, txn_->Get(store_->field_db(), k, &found));
  if (!found) return std::optional<double>();
  if (value.size() != VoxelSize(h.voxel_type)) {
    return Status::Corruption(store_->path() + ": vertex " + std::to_string(VertexKey<D>(p, h.domain_bits)) +
                              ": a value of " + std::to_string(value.size()) + " bytes");
  }
  double v;
  DecodeVoxels(h.voxel_type, ByteOrder::kLittle, reinterpret_cast<const std::byte*>(value.data()), 1, &v);
  return std::optional<double>(v);
}

template <int D>
Status SparseStore::Reader<D>::Prefetch(SimplexCode<D> code, size_t max_entries) {
  prefetch_.clear();
  prefetch_lo_ = 1;
  prefetch_hi_ = 0;
  SDB_ASSIGN_OR_RETURN(lmdb::Cursor cursor, lmdb::Cursor::Open(*txn_, store_->errors_db()));
  const uint64_t lo = code.range_min(), hi = code.range_max();
  auto first = lmdb::KeyBytes(lo);
  MDB_val k = lmdb::Val(first.data(), 8), v;
  int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_SET_RANGE);
  uint64_t covered = hi;  // the range is complete unless cut short
  for (; rc == MDB_SUCCESS; rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    if (k.mv_size != 8) return Status::Corruption(store_->path() + ": an error key of " + std::to_string(k.mv_size) + " bytes");
    const uint64_t key = lmdb::KeyValue(k);
    if (key > hi) break;
    if (prefetch_.size() == max_entries) {
      covered = key - 1;
      break;
    }
    SDB_ASSIGN_OR_RETURN(std::optional<uint32_t> stored,
                         DecodeStored(key, {static_cast<const uint8_t*>(v.mv_data), v.mv_size}));
    prefetch_.emplace_back(key, *stored);
  }
  if (rc != MDB_SUCCESS && rc != MDB_NOTFOUND) return store_->env().FromCode(rc, "prefetch");
  prefetch_lo_ = lo;
  prefetch_hi_ = covered;
  stats_.prefetched += prefetch_.size();
  return Status::OK();
}

template class SparseStore::Reader<3>;
template class SparseStore::Reader<4>;

}  // namespace simplexdb
