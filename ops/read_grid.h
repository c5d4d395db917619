// ReadGridBox: the field at the grid points of a box, every step-th along
// each axis, as `simplexdb export` writes it, `simplexdb convert` rebuilds
// a store from it and the Python package's Store.export returns it. One
// reader for all three, so they give the same values.
//
// Thread safety: reentrant over const stores (each call makes its own
// readers). Lifetimes: the values are returned by value.
//
// Errors: InvalidArgument for a box outside the grid or a step < 1 (the
// operations check their options first and word them their own way); the
// store's Corruption or IOError for a block that cannot be read.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "query/open_store.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// A box of the grid, inclusive, and the step between the points read.
// Axes past the store's dimension are 0..0.
struct ExportBox {
  std::array<int64_t, 4> lo = {0, 0, 0, 0}, hi = {0, 0, 0, 0};
  int step = 1;
};

// The whole grid of `info` with `step`.
ExportBox WholeGrid(const SourceInfo& info, int step = 1);

// The box's points per axis, (hi - lo) / step + 1 (1 past the dimension).
std::array<uint32_t, 4> ExportDims(const ExportBox& box, int dimension);

// The type of the store's voxels (its input's, or float32 for a scaled or
// masked integer input).
VoxelType StoreVoxelType(const AnyStore& store);

// Brings values rebuilt in double precision into `type`: for an integer
// type each is rounded to the nearest integer and clamped to the type's
// range (a lossy sparse store rebuilds a dropped vertex within its
// tolerance of the input, so a 0 of uint8 may come back as -0.6; the input
// was in range, so clamping only brings it nearer); float types and NaN
// are left as they are. The one place this is done: export, convert and
// the Python package's Store.export all read through ReadGridBox below.
// O(values).
void RoundToVoxelType(VoxelType type, std::span<double> values);

// The values at the box's points, x fastest (then y, z, t), as the dense
// store holds them. A power-of-two step from a multiple of it reads one
// lattice's bricks (a coarse read decodes only them); otherwise point by
// point. O(points + voxels of the bricks met).
Result<std::vector<double>> ReadGridBox(const DenseStore& store, const ExportBox& box);

// The same for a store of either kind, every value one its voxel type
// holds: a dense store's are its input's own; a sparse store's value at a
// dropped vertex is its rebuilt one (within the store's tolerance; exact at
// 0), through RoundToVoxelType. O(points) lookups for a sparse store.
Result<std::vector<double>> ReadGridBox(const AnyStore& store, const ExportBox& box);

}  // namespace simplexdb
