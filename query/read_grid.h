// ReadGridBox: the field at the grid points of a box, every step-th along
// each axis, as `simplexdb export` writes it and the Python package's
// Store.export returns it. One reader for both, so the two give the same
// values.
//
// Thread safety: reentrant over const stores (each call makes its own
// readers). Lifetimes: the values are returned by value.
//
// Errors: InvalidArgument for a box outside the grid or a step < 1 (the
// command checks its options first and words them its own way); the store's
// Corruption or IOError for a block that cannot be read.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "query/open_store.h"
#include "storage/dense/hz_store.h"
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

// The values at the box's points, x fastest (then y, z, t), as the dense
// store holds them. A power-of-two step from a multiple of it reads one
// lattice's bricks (a coarse read decodes only them); otherwise point by
// point. O(points + voxels of the bricks met).
Result<std::vector<double>> ReadGridBox(const HzStore& store, const ExportBox& box);

// The same for a store of either kind: a sparse store's value at a dropped
// vertex is its rebuilt one (within the store's tolerance; exact at 0).
// O(points) lookups for a sparse store.
Result<std::vector<double>> ReadGridBox(const AnyStore& store, const ExportBox& box);

}  // namespace simplexdb
