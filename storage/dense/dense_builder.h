// Builds a format-2 store (storage/dense/dense_store.h): per grid vertex, the
// error of its diamond (the largest of the seed's errors over the nodes
// whose split creates it: one cluster), and the field as bricks.
//
// BuildDenseStore computes every diamond's error octave by octave on every
// core (storage/error/diamond_errors.h) from a window of planes of the
// field's last axis, then writes the store, leaving the finest octave's
// errors to the reader (it computes them from the field the same way). A
// volume with missing values (NaN, or points a mask removes) takes the
// same path with every diamond scanned and every octave's errors stored,
// since the reader's stencils assume values everywhere.
//
// One pipeline, one window as wide as the memory bound allows
// (storage/dense/dense_windowed_build.cc):
//   - the whole field when it fits in memory_bytes (or the grid is too
//     small to cut): the input read once, every block then every brick
//     written at the end;
//   - else the widest window of slabs of 2^j planes (with a halo of 32
//     planes on each side in the HT, 8 in the HP) that fits, down to the
//     narrowest (64 planes in the HT, 32 in the HP, with the default
//     blocks): the input read twice, a first pass for the range, the
//     checks and the corner lattice, and each slab's blocks and bricks
//     spooled as soon as they are complete, put in order at the end.
// Any window gives the same bytes: every stored block in index order, then
// every brick (several windows make them out of that order and spool them,
// DenseWriteOptions::spool), at any thread count and any number of ranks.
//
// Memory, checked against memory_bytes before anything is allocated: the
// window as the field's stored voxels (a byte a point for uint8, four for
// float32, scaled and masked volumes), a float per vertex of the scales
// whose diamonds stay near their vertex (scales 1-4 in the HT, 1-2 in the
// HP: a seventh of the grid's points in the HT, for the window's planes
// plus one block's reach), a float per coarser vertex of the domain (with
// missing values, where their simplices have values), a double per point
// of the corner lattice (every 32nd per axis in the HT, 8th in the HP) and
// per grid brick, with several windows every 8th point per axis, and the
// readers' buffers and the writer's blocks per thread. Not counted: what
// the process holds besides (code, libraries, each worker's codec contexts
// and scratch; measured building 513^3: 23 MiB and 2.7 MiB per worker). A
// window narrower than the field is planned leaving 20 MiB and 4 MiB per
// worker for it, and the narrowest is taken when it alone fits.
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
#include "util/process_group.h"
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
  // Take the narrowest window even when a wider one fits in memory_bytes
  // (for tests; a grid too small to cut is built in one window).
  bool stream = false;
  // Phases "field" (a pass over the input), "errors", "blocks", "bricks"
  // with one window; "field", then "slabs" with several.
  std::function<void(const BuildProgress&)> progress;
  // The processes building this store together (the ranks of `mpirun -np
  // N simplexdb import`; util/process_group.h), each calling
  // BuildDenseStore with the same arguments; null: this one alone. Each
  // reads its own slabs of planes (and a halo), within memory_bytes; the
  // ranks combine the range, the corner lattice, the scanned scales'
  // maxima and the coarse lattices' points, and write one file (rank 0
  // the header and indexes). The store is the one this process would
  // build alone, byte for byte. A grid too small to cut into slabs is
  // built by rank 0 alone. Any rank's failure fails every rank with one
  // message naming it, and leaves no store.
  ProcessGroup* group = nullptr;
};

struct DenseBuildReport {
  DenseHeader header;
  double seconds = 0;
  uint64_t grid_points = 0;  // real grid points
  // How the field was held: "diamonds" (one window, the whole field in
  // memory) or "streamed" (several windows of window_planes planes).
  const char* method = "diamonds";
  int windows = 1;
  int64_t window_planes = 0;  // the window's planes of the last axis, halo included
  // With a group: the processes, and the slabs this one built (of windows).
  int ranks = 1;
  int slabs_built = 1;
  // The error blocks that may hold errors, by geometry (the "blocks"
  // progress counts them); those holding only zeros are not stored.
  uint64_t candidate_blocks = 0;
};

// How BuildDenseStore would hold the field: its windows and their need.
struct DenseBuildPlan {
  int windows = 1;             // 1: the whole field
  int64_t slab_planes = 0;     // planes of the last axis each window advances by
  int64_t window_planes = 0;   // planes a window holds, halo included
  uint64_t bytes = 0;          // the build's arrays (the bound's measure)
};
// The plan for `input` under options.memory_bytes, without reading it.
// Errors: BuildDenseStore's before it reads (InvalidArgument,
// ResourceExhausted with the need).
Result<DenseBuildPlan> PlanDenseBuild(const VolumeInfo& input, const std::string& out_path,
                                      const DenseBuildOptions& options);

// Builds `out_path` from `input` (3D: HT, 4D: HP).
Result<DenseBuildReport> BuildDenseStore(const VolumeInfo& input, const std::string& out_path,
                                         const DenseBuildOptions& options);

}  // namespace simplexdb
