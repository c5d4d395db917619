// ImportVolume: a volume (a file's VolumeInfo, or voxels in memory:
// storage/volume/volume.h MemoryVolume) built into a store of either kind,
// the dense .sdb (storage/dense/dense_builder.h) or the sparse LMDB store
// (storage/sparse/sparse_builder.h). The one place `simplexdb import`
// and the Python package's import_volume decide which builder runs with
// which options, so the two build the same store from the same voxels.
// Printing reports and parsing option text stay with each caller.
//
// Thread safety: reentrant; the progress callback is called from one
// thread at a time (storage/error/progress.h).
//
// Lifetimes: the input's files (or memory) are read during the call only;
// the report is a value.
//
// Errors: CheckImport's InvalidArgument (below) before anything is
// written; then the builder's: NotFound or IOError for inputs, Corruption
// for damaged input, InvalidArgument naming the voxel for values a store
// cannot hold (infinities, beyond float32), ResourceExhausted for a full
// disk or a memory bound too small (with the need).
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "query/criteria.h"  // Amount
#include "storage/dense/dense_builder.h"  // DenseBuildOptions; also declares Compression
#include "storage/error/progress.h"
#include "storage/error/quantization.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

// What `simplexdb import` takes besides its input and output; each field
// names its option.
struct ImportOptions {
  // --hierarchy: "ht" or "hp", checked against the volume's dimension;
  // empty: from it (3D: HT, 4D: HP).
  std::string hierarchy;
  Quantization quantization = Quantization::kU16;  // --quantization
  Compression compression = Compression::kZstd;    // --compression (the dense store's blocks)
  int zstd_level = 0;                     // --zstd-level, 1..22; 0: the store's default (dense 3, sparse 19)
  size_t memory_bytes = size_t{1} << 30;  // --memory-mb: the builder's bound
  int threads = 0;                        // --threads, >= 0; 0: one per core
  std::optional<VolumeInfo> mask;         // --mask (dense only): 0 marks a missing value
  bool sparse = false;                    // --sparse: the LMDB store instead of the dense one
  Amount tolerance;                       // --tolerance (sparse): 0 is lossless
  // --spacing and --origin: one number per axis of the volume, x first,
  // replacing the input's own. A negative x, y or z spacing flips that
  // axis; time's must be > 0.
  std::optional<std::vector<double>> spacing, origin;
  std::function<void(const BuildProgress&)> progress;
  // The processes building the store together (DenseBuildOptions::group:
  // the ranks of `mpirun simplexdb import`), each calling ImportVolume with
  // the same arguments; dense stores only. Null: this process alone.
  ProcessGroup* group = nullptr;
};

// Exactly one is set: the dense or the sparse builder's report.
struct ImportReport {
  std::optional<DenseBuildReport> dense;
  std::optional<SparseBuildReport> sparse;
};

// The options' checks against `input`, nothing read or written: a
// hierarchy other than ht/hp or that does not fit the volume, a mask with a
// sparse store or with a group, a tolerance without one or one that is negative or not
// finite, a negative thread count, a zstd level outside 1..22, spacing and
// origin of the wrong count or not finite (a spacing of 0, a time spacing
// <= 0). InvalidArgument naming the option as the command spells it
// ("--hierarchy hp needs a 4D volume; ..."). O(1).
Status CheckImport(const VolumeInfo& input, const ImportOptions& options);

// `input` with options.spacing and options.origin in place of its own.
// REQUIRES: CheckImport(input, options) is OK.
VolumeInfo PlacedInput(const VolumeInfo& input, const ImportOptions& options);

// Builds `output` from PlacedInput(input, options) (CheckImport first).
// The output path is the caller's to check (ResolveOutput,
// storage/io/file.h; it must not be an input).
Result<ImportReport> ImportVolume(const VolumeInfo& input, const std::string& output,
                                  const ImportOptions& options);

// The progress line the command draws and the Python package prints:
// "OUTPUT: phase done/total (P%), S s".
std::string DescribeProgress(const std::string& output, const BuildProgress& p);

}  // namespace simplexdb
