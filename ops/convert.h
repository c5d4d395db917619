// Convert: a store of one kind rebuilt as the other, `simplexdb convert`
// and the Python package's simplexdb.convert. The field is read from the
// store into memory as its voxel type (a sparse store's rebuilt values
// through RoundToVoxelType, ops/read_grid.h) and built by ImportVolume
// (ops/import.h) from that memory (MemoryVolume): no scratch file.
//
//   --to sparse  a dense store's field, kept where the diamonds' errors
//                exceed --tolerance (0: lossless). A field with missing
//                values (NaN) is refused: the sparse store holds none.
//   --to dense   a sparse store, every block verified first (a damaged one
//                is refused, not converted), its full grid rebuilt.
// The new store keeps the old one's quantization, source and placement.
//
// Memory: the field as doubles must fit --memory-mb (checked before
// anything is read); the field then sits in memory as its voxels (1 to 8
// bytes a point) while the builder runs within its own bound.
//
// Thread safety: reentrant; one conversion per output at a time. The
// progress callback is called from one thread at a time.
//
// Errors: CheckConvert's InvalidArgument (naming the option as the command
// spells it); the store's (AnyStore::Open, Verify: Corruption naming the
// block, with "; not converted"); ResourceExhausted for a field beyond
// --memory-mb; NotSupported for missing values to a sparse store; the
// builder's (ImportVolume).
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "ops/import.h"
#include "query/criteria.h"  // Amount
#include "query/open_store.h"
#include "util/status.h"

namespace simplexdb {

struct ConvertOptions {
  StoreKind to = StoreKind::kSparse;             // --to
  Amount tolerance;                              // --tolerance (--to sparse)
  Compression compression = Compression::kZstd;  // --compression (--to dense)
  size_t memory_bytes = size_t{1} << 30;         // --memory-mb
  int threads = 0;                               // --threads, >= 0; 0: one per core
  // Phases "reading" (the field), "verifying" (--to dense: blocks), then
  // the builder's.
  std::function<void(const BuildProgress&)> progress;
};

// "dense" or "sparse" (--to); InvalidArgument otherwise.
Result<StoreKind> ParseStoreKind(std::string_view text);

// The options' checks for converting `input`, a store of kind `from`. O(1).
Status CheckConvert(const std::string& input, StoreKind from, const ConvertOptions& options);

// Exactly one report is set, the builder's of the new store.
struct ConvertReport {
  std::optional<DenseBuildReport> dense;
  std::optional<SparseBuildReport> sparse;
  double seconds = 0;  // the whole conversion, verifying and reading included
};

// Converts the store at `input` into `output` (CheckConvert first). The
// output path is the caller's to check (ResolveOutput).
Result<ConvertReport> Convert(const std::string& input, const std::string& output,
                              const ConvertOptions& options);

}  // namespace simplexdb
