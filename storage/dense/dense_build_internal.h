// The dense builder's internals (storage/dense/dense_builder.h): its entry
// and checks (dense_builder.cc) and its pipeline (dense_windowed_build.cc).
// Not part of the installed headers.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_format.h"
#include "storage/dense/dense_writer.h"
#include "storage/error/diamond_errors.h"
#include "storage/volume/volume.h"
#include "util/big_array.h"
#include "util/status.h"

namespace simplexdb::dense_build {

using Clock = std::chrono::steady_clock;

// The windowed build's tables of diamond errors (dense_windowed_build_internal.h).
template <int D>
struct LocalTable {  // a local scale's: one chunk of planes
  int64_t chunk = 0;  // planes per chunk (a multiple of the slab)
  std::array<int64_t, D> extent{};
  std::array<uint64_t, D> stride{};
  uint64_t size = 0;
  BigArray<float> table;
  std::vector<std::vector<uint64_t>> blocks;  // candidates by chunk
};
template <int D>
struct ScannedTable {  // a scanned scale's maxima: every vertex of the domain
  std::array<uint64_t, D> stride{};
  uint64_t size = 0;
  std::vector<float> table;
  std::vector<DiamondAvailability> availability;  // with missing values
  void Release() {
    std::vector<float>().swap(table);
    std::vector<DiamondAvailability>().swap(availability);
  }
};

// "12 MiB", rounded up.
std::string MiB(uint64_t bytes);

// The store's block bitmap covers the padded domain: a bit per block of
// 2^block_bits positions (2^(D k) of them, 2^(D (k + 1)) when the finest
// octave is stored), which the writer walks and a reader holds. Padding
// costs nothing else, but a grid far longer on one axis than the others
// (a domain of side 2^18 for 200000x2x2) would make the bitmap itself
// terabytes: ResourceExhausted, with the figures, before anything is
// computed. `what` names the input.
Status CheckBlockBitmap(int dimension, const std::array<uint32_t, 4>& dims, int k,
                        const DenseBuildOptions& options, bool finest_stored,
                        const std::string& out, const std::string& what);

// The store's parameters for a build from `input` (the writer sets the rest).
DenseHeader ParamsFor(int dimension, const VolumeInfo& input, const DenseBuildOptions& options,
                      VoxelType stored, int k, double fmin, double fmax);

// The writer's options (no progress: the caller reports its own phases).
DenseWriteOptions WriteOptionsFor(const DenseBuildOptions& options, int threads);

// The build (dense_windowed_build.cc), V the stored voxel type's C++ type,
// k the domain bits: the field a window of planes at a time, the window as
// wide as options.memory_bytes allows (the whole field when it fits), as
// PlanWindows plans it (PlanDenseBuild); ResourceExhausted, with the need,
// when even the narrowest does not fit.
// REQUIRES: input.dimension == D; threads >= 1.
template <int D, class V>
Result<DenseBuildPlan> PlanWindows(const VolumeInfo& input, const std::string& out,
                                   const DenseBuildOptions& options, int k, int threads);
template <int D, class V>
Result<DenseBuildReport> BuildWindowed(const VolumeInfo& input, const std::string& out,
                                       const DenseBuildOptions& options, Clock::time_point start, int k,
                                       int threads);

}  // namespace simplexdb::dense_build
