// Builds a format-2 store (storage/dense/dense_store.h): per grid vertex, the
// error of its diamond (the largest of the seed's errors over the nodes
// whose split creates it: one cluster), and the field as bricks.
//
// BuildDenseStore reads the field into memory (or a window of it at a time)
// and computes every diamond's error octave by octave on every core
// (storage/error/diamond_errors.h), then writes the store, leaving the
// finest octave's errors to the reader (it computes them from the field
// the same way). A volume with missing values (NaN, or points a mask
// removes) takes the same path with every diamond scanned and every
// octave's errors stored, since the reader's stencils assume values
// everywhere.
//
// Memory: the direct path holds the field as its stored voxels (a byte a
// point for uint8, four for float32, scaled and masked volumes), a float per
// even vertex (every coordinate even: an eighth of the grid in the HT, a
// sixteenth in the HP; the finest octave's errors are reduced to each grid
// brick's largest as they are computed, or computed again as the blocks
// are written), a chunk of the input (and of the mask) per reader and the
// writer's blocks per thread. When that exceeds memory_bytes (or
// DenseBuildOptions::stream), the build streams: it reads the input twice, a
// plane at a time, and holds a window of planes of the last axis (64 + 2 x
// 32 in the HT, 32 + 2 x 8 in the HP), tables for one run of blocks per
// local scale, every scanned diamond's maximum (and, with missing values,
// where its simplices have values), every 8th point per axis and a double
// per corner-lattice point (every 32nd in the HT, 8th in the HP) and a
// plane of doubles per reader: the same store as the direct path's, its
// blocks in another order. Each is checked against memory_bytes before
// anything is allocated.
//
// Thread safety: may run in several threads at once for different outputs.
// Lifetimes: the input (and mask) is read during the call only.
// Errors: those of reading the input and the mask (storage/volume/volume.h)
// and of storable values (storage/error/field_values.h), of WriteDenseStore;
// InvalidArgument for a volume that is not 3D or 4D, a mask of another grid
// (storage/error/mask.h) or a grid beyond the deepest level a location code
// holds; ResourceExhausted naming the figures when the field and the
// diamond table do not fit in memory_bytes, or when the padded domain's
// block bitmap would exceed 2^30 blocks or memory_bytes (a grid far longer
// on one axis than the others), before anything is computed.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "storage/dense/dense_format.h"
#include "storage/error/progress.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct DenseBuildOptions {
  Quantization quantization = Quantization::kU16;
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
  int block_bits = kDenseDefaultBlockBits;
  size_t memory_bytes = size_t{1} << 30;
  int threads = 0;  // 0: one per core
  // Where the field is available: 0 (or NaN) marks a missing point
  // (storage/error/mask.h). Of the input's grid.
  std::optional<VolumeInfo> mask;
  // Read the field a window of planes at a time even when it fits in
  // memory_bytes (a grid too small to stream is built in memory).
  bool stream = false;
  std::function<void(const BuildProgress&)> progress;  // "field", "errors", "diamonds", "blocks", "bricks"
};

struct DenseBuildReport {
  DenseHeader header;
  double seconds = 0;
  uint64_t grid_points = 0;  // real grid points
  // How the errors were computed: "diamonds" (the field in memory, octave
  // by octave) or "streamed" (the same a window of planes at a time).
  const char* method = "diamonds";
};

// Builds `out_path` from `input` (3D: HT, 4D: HP).
Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options);

}  // namespace simplexdb
