// Builds a format-2 store (storage/dense/hz_store.h): per grid vertex, the
// error of its diamond (the largest of the seed's errors over the nodes
// whose split creates it: one cluster) and its field value.
//
// This first builder takes the per-node errors from format 1's streaming
// error engine: ConvertToHz reads them from a format-1 store (float32
// errors keep them exact up to rounding up), BuildHzStore first builds such
// a store as a scratch file beside the output. It is correct and bounded,
// not fast: it visits every node that holds a real grid point (6 per grid
// point in 3D, 24 in 4D), one thread. The level-by-level diamond builder of
// DESIGN.md replaces it.
//
// Memory: one float per vertex of the real grid grown by two points along
// each axis (where diamonds of the finest levels lie), a map for the few
// coarser diamonds beyond it, and the writer's blocks per thread; checked
// against memory_bytes before anything is allocated.
//
// Thread safety: may run in several threads at once for different outputs.
// Lifetimes: ConvertToHz reads `f1` during the call only.
// Errors: those of the format-1 builder (input, mask, memory, output) and
// of WriteHzStore; ResourceExhausted naming the figures when the diamond
// table does not fit in memory_bytes.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "storage/dense/dense_store.h"
#include "storage/dense/format.h"
#include "storage/dense/hz_format.h"
#include "storage/error/progress.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct HzBuildOptions {
  Quantization quantization = Quantization::kU16;
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
  int block_bits = kHzDefaultBlockBits;
  size_t memory_bytes = size_t{1} << 30;
  int threads = 0;  // 0: one per core
  std::optional<VolumeInfo> mask;  // as DenseBuildOptions::mask
  std::function<void(const BuildProgress&)> progress;  // "field", "errors", "diamonds", "blocks"
};

struct HzBuildReport {
  HzHeader header;
  double seconds = 0;
  uint64_t grid_points = 0;  // real grid points
  uint64_t nodes = 0;        // nodes whose error was read
};

// Makes `out_path` from a format-1 store. Exact when `f1` holds float32
// errors: each diamond stores the largest of its nodes' stored bounds.
Result<HzBuildReport> ConvertToHz(const DenseStore& f1, const std::string& out_path,
                                  const HzBuildOptions& options);

// Builds `out_path` from `input` (3D: HT, 4D: HP).
Result<HzBuildReport> BuildHzStore(const VolumeInfo& input, const std::string& out_path,
                                   const HzBuildOptions& options);

}  // namespace simplexdb
