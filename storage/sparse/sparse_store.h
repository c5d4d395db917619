// SparseStore: the variable-resolution store of the seed's conclusions, in
// LMDB (docs/format/sparse-store-1.md). Only the part of the hierarchy that
// carries information is stored:
//
//   "errors"  packed location code (8 bytes, big-endian: LMDB's key order is
//             the code's depth-first preorder, a subtree one key range) ->
//             the quantized error bound, as the dense store stores it.
//   "field"   vertex (its index in the (2^k + 1)^D domain grid, x fastest,
//             8 bytes big-endian) -> the field value in the volume's type.
//   "meta"    "header" -> the store's parameters as JSON.
//
// A node that is absent is a leaf: it is not refined further. A subtree is
// dropped whole when every error in it is within the tolerance it was built
// with (0: only where the field is exactly linear), so the nodes present
// form a tree: every present node's parent is present, and absent nodes have
// error 0 as far as this store knows. The field is stored at the vertices
// the present nodes create: the corners of the domain and the midpoint of
// every present node's split edge. A vertex deeper in a dropped subtree is
// not stored; its value is the linear interpolation over the dropped node
// (exact when lossless, within the tolerance otherwise).
//
// Thread safety: a SparseStore may be shared by threads; many processes may
// open the same file (LMDB's lock file, STORE-lock, coordinates them).
// Lookups go through a Reader, one per thread: it reads one consistent
// snapshot (an LMDB read transaction) until Refresh().
//
// Lifetimes: the store must outlive its Readers; a Reader's snapshot lives
// until Refresh() or its destruction (a long-lived snapshot keeps LMDB from
// reusing the pages later writers free). header() and path() live as long
// as the store.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hierarchy/simplex_code.h"
#include "storage/error/quantize.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

namespace lmdb {  // storage/io/lmdb.h, which embedders need not include
class Env;
class Txn;
}  // namespace lmdb

inline constexpr uint32_t kSparseFormatVersion = 1;
inline constexpr const char* kSparseFormatName = "simplexdb-sparse";

struct SparseHeader {
  uint32_t version = kSparseFormatVersion;
  int dimension = 3;  // 3: HT, 4: HP
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  int domain_bits = 0;  // the domain is a cube of side 2^k
  VoxelType voxel_type = VoxelType::kU8;
  Quantization quantization = Quantization::kU16;
  double quantum = 0;
  double field_min = 0, field_max = 0;
  double error_max = 0;
  double tolerance = 0;  // subtrees within it were dropped
  uint64_t nodes = 0;     // entries in "errors"
  uint64_t vertices = 0;  // entries in "field"
  // The sum (mod 2^64) of XXH3-64 over every entry's key and value: any
  // change to the data shows, and an update adjusts it entry by entry.
  uint64_t content_sum = 0;
  std::string source;

  int leaf_level() const { return dimension * domain_bits; }
  uint64_t domain_side() const { return (uint64_t{1} << domain_bits) + 1; }
};

std::string SerializeSparseHeader(const SparseHeader& h);
Result<SparseHeader> ParseSparseHeader(std::string_view json, const std::string& file);

// The XXH3-64 term one entry adds to SparseHeader::content_sum.
uint64_t SparseEntryHash(int db, std::span<const uint8_t> key, std::span<const uint8_t> value);
inline constexpr int kErrorsDb = 0;
inline constexpr int kFieldDb = 1;

// True when `path` begins like an LMDB data file (so a store of this kind,
// or another program's LMDB file).
bool LooksLikeLmdb(const std::string& path);

class SparseStore {
 public:
  // Opens a store read-only and checks its header. Errors: NotFound,
  // InvalidArgument (not LMDB, or LMDB without SimplexDB's databases: the
  // message says which), NotSupported (another format version), Corruption.
  static Result<std::unique_ptr<SparseStore>> Open(const std::string& path);
  ~SparseStore();

  const SparseHeader& header() const { return header_; }
  int dimension() const { return header_.dimension; }
  const std::string& path() const { return path_; }
  const ErrorQuantizer& quantizer() const { return quantizer_; }
  // The LMDB environment and database handles (MDB_dbi), for the sparse
  // wing's own writers and tests; they live as long as the store.
  lmdb::Env& env() const;
  unsigned int errors_db() const { return errors_; }
  unsigned int field_db() const { return field_; }
  uint64_t file_bytes() const;

  // Reads every entry: keys are valid codes of this hierarchy above the leaf
  // level (resp. domain vertices), values have the right size and range,
  // every present node's parent is present, every vertex a present node
  // needs is stored and nothing else is, the counts and the content sum match
  // the header. Returns the first failure, naming the entry.
  Status Verify(const std::function<void(uint64_t, uint64_t)>& progress = {}) const;

  template <int D>
  static uint64_t VertexKey(const std::array<int64_t, D>& p, int domain_bits) {
    const uint64_t side = (uint64_t{1} << domain_bits) + 1;
    uint64_t key = 0;
    for (int c = D - 1; c >= 0; --c) key = key * side + static_cast<uint64_t>(p[c]);
    return key;
  }

  // Lookups for one thread, in one snapshot.
  template <int D>
  class Reader {
   public:
    // REQUIRES: store.dimension() == D; the store outlives the reader.
    static Result<Reader> Create(const SparseStore& store);
    Reader(Reader&&) noexcept;
    Reader& operator=(Reader&&) noexcept;
    ~Reader();

    // The stored error bound of a present node; nullopt for an absent one
    // (a leaf: error 0 for this store).
    Result<std::optional<double>> Find(SimplexCode<D> code);
    // The bound, 0 for absent nodes and for nodes at or below the leaf level.
    Result<double> ErrorBound(SimplexCode<D> code);
    // The stored quantized value (as the dense store's entries hold it).
    Result<std::optional<uint32_t>> FindStored(SimplexCode<D> code);

    // The field at domain point p if it is stored (see the header comment).
    Result<std::optional<double>> Field(const std::array<int64_t, D>& p);

    // Reads the errors of `code`'s subtree with one cursor range scan (at
    // most `max_entries` of them, from the front of the range), so later
    // lookups in it need no B-tree search.
    Status Prefetch(SimplexCode<D> code, size_t max_entries = size_t{1} << 16);

    // Moves to the newest committed snapshot.
    Status Refresh();

    struct Stats {
      uint64_t btree_lookups = 0;
      uint64_t prefetched = 0;
      uint64_t prefetch_hits = 0;
    };
    const Stats& stats() const { return stats_; }

   private:
    Reader(const SparseStore& store, std::unique_ptr<lmdb::Txn> txn);
    Result<std::optional<uint32_t>> DecodeStored(uint64_t key, std::span<const uint8_t> value);

    const SparseStore* store_;
    std::unique_ptr<lmdb::Txn> txn_;  // never null
    // Prefetched entries: keys [prefetch_lo_, prefetch_hi_] are all here.
    std::vector<std::pair<uint64_t, uint32_t>> prefetch_;
    uint64_t prefetch_lo_ = 1, prefetch_hi_ = 0;
    Stats stats_;
  };

 private:
  SparseStore() = default;

  std::string path_;
  std::unique_ptr<lmdb::Env> env_;
  unsigned int errors_ = 0, field_ = 0, meta_ = 0;  // MDB_dbi
  SparseHeader header_;
  ErrorQuantizer quantizer_{Quantization::kU16, 1, 0};
};

// Decodes a stored error value of `q` from its bytes; nullopt when the size
// is wrong.
std::optional<uint32_t> DecodeStoredError(Quantization q, std::span<const uint8_t> bytes);
// The bytes of a stored error value of `q` (1, 2 or 4, little-endian).
size_t EncodeStoredError(Quantization q, uint32_t stored, uint8_t* out);

}  // namespace simplexdb
