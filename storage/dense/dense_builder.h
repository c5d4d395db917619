// Builds a dense store from a volume: the field in bricks, then the error of
// every internal node of the hierarchy (HT for 3D volumes, HP for 4D).
//
// The domain is the smallest cube (hypercube) of side 2^k that covers the
// grid. Grid points outside the real grid (the padding) take the value of
// the nearest real point, and a node's error is the maximum over the REAL
// grid points inside or on it of |field - interpolation at its vertices|:
// nodes lying wholly in the padding have error 0 and are never refined, and
// nodes across the edge of the data are judged on the data alone.
//
// Streaming, bounded memory: pass 1 reads the volume a row of bricks at a
// time; pass 2 computes errors one unit (a block of the deepest band, with
// the bounding box of its root's field values) at a time, on every core, and
// gets the errors of the levels above the units from the same points as
// partial maxima (the units tile every ancestor), both by the error engine
// (storage/error/unit_errors.h). Memory is the brick cache (half of
// `memory_bytes`) and what the grid sets: the block index (80 bytes per
// block and brick), each thread's row of bricks and unit, and the error
// partials of the nodes above the units. These are estimated before
// anything is allocated, and a build whose estimate exceeds the other half
// fails at once (ResourceExhausted naming each figure).
//
// Crash safety: the store is written under a temporary name, flushed and
// renamed; a build that fails or is killed leaves nothing under the final
// name (a killed build's temporary is removed by the next build of that
// name).
//
// Thread safety: BuildDenseStore may run in several threads at once for
// different outputs; it starts its own workers (`threads`) and calls
// `progress` from the thread that called it. Errors: listed at the function.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "storage/dense/format.h"
#include "storage/error/progress.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct DenseBuildOptions {
  Quantization quantization = Quantization::kU16;
  Compression compression = Compression::kZstd;
  int zstd_level = 3;
  size_t memory_bytes = size_t{1} << 30;  // the builder's memory bound
  int threads = 0;  // 0: one per core, or fewer if memory_bytes holds fewer
  int levels_per_block = 14;               // B
  int brick_bits = 0;                      // 0: 5 (32^3) in 3D, 4 (16^4) in 4D
  // Where the field is available: a volume of the input's grid, 0 (or NaN)
  // where it is not. Masked points become missing values (NaN; see
  // docs/format/dense-store.md), so an integer input is stored as float32
  // (exact for every 8- and 16-bit value). Without a mask, NaN in a float
  // input marks missing values.
  std::optional<VolumeInfo> mask;
  // Called from the building thread a few times a second.
  std::function<void(const BuildProgress&)> progress;  // phases "field", "errors"
};

struct DenseBuildReport {
  DenseHeader header;
  double seconds = 0;
  uint64_t grid_points = 0;  // real grid points read
  uint64_t nodes = 0;        // internal nodes whose error was stored
};

// Builds `out_path` from `input` (3D: HT, 4D: HP). Fails with a message
// naming the input or the output: infinite values or values beyond
// float32's range (storage/error/field_values.h), a mask of another grid,
// unreadable or truncated input, a full disk (ResourceExhausted), a volume
// too large for the 64-bit location code, a grid whose block index, rows
// and units need more than half of `memory_bytes` (ResourceExhausted, with
// the figures; nothing is created), an allocation the system refuses even
// so (ResourceExhausted "not enough memory for ...").
Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options);

}  // namespace simplexdb
