// ImportVolume: a volume (a file's VolumeInfo, or voxels in memory:
// storage/volume/volume.h MemoryVolume) built into a store of either kind,
// the dense .sdb (storage/dense/hz_builder.h) or the sparse LMDB store
// (storage/sparse/hz_sparse_builder.h). The one place `simplexdb import`
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

#include "storage/dense/format.h"
#include "storage/dense/hz_builder.h"
#include "storage/error/progress.h"
#include "storage/error/quantization.h"
#include "storage/sparse/hz_sparse_builder.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct ImportOptions {
  // "ht" or "hp": checked against the volume's dimension; empty: from it
  // (3D: HT, 4D: HP).
  std::string hierarchy;
  Quantization quantization = Quantization::kU16;
  Compression compression = Compression::kZstd;  // the dense store's blocks
  int zstd_level = 0;                            // 0: the store's default (dense 3, sparse 19)
  size_t memory_bytes = size_t{1} << 30;         // the builder's bound
  int threads = 0;                               // 0: one per core
  std::optional<VolumeInfo> mask;                // dense only: DenseBuildOptions::mask
  bool sparse = false;                           // the LMDB store instead of the dense one
  double tolerance = 0;                          // sparse: t in field units (0: lossless)...
  bool tolerance_percent = false;                // ...or in percent of the field's range
  std::function<void(const BuildProgress&)> progress;
};

// Exactly one is set: the dense or the sparse builder's report.
struct ImportReport {
  std::optional<HzBuildReport> dense;
  std::optional<HzSparseBuildReport> sparse;
};

// The options' checks against `input`, nothing read or written.
// InvalidArgument: "hierarchy hp needs a 4D volume; <input> is 3D (...)"
// (the message starts with the option's name, so the command can prefix
// "--"), a hierarchy other than ht/hp, a mask with a sparse store, a
// tolerance without one or one that is negative or not finite. O(1).
Status CheckImport(const VolumeInfo& input, const ImportOptions& options);

// Builds `output` from `input` (CheckImport first). The output path is the
// caller's to check (tools: CheckOutput; it must not be an input).
Result<ImportReport> ImportVolume(const VolumeInfo& input, const std::string& output,
                                  const ImportOptions& options);

// The progress line the command draws and the Python package prints:
// "OUTPUT: phase done/total (P%), S s".
std::string DescribeProgress(const std::string& output, const BuildProgress& p);

}  // namespace simplexdb
