// Coarse reads of a format-2 store: every 2^s-th grid point of a box, read
// from lattice s's bricks alone (storage/dense/field_bricks.h), so a read
// at a quarter of the resolution decodes 1/64 of the field's voxels (1/256
// in the HP) instead of asking for each point in turn.
//
// Thread safety: as HzStore (any number of threads at once).
// Lifetimes: nothing is kept after the call.
// Errors: those of HzStore::Brick (Corruption naming the brick,
// ResourceExhausted); InvalidArgument for a box or lattice out of range.
#pragma once

#include <array>
#include <cstdint>

#include "storage/dense/hz_store.h"
#include "util/status.h"

namespace simplexdb {

// Writes the field at the points lo + i * 2^s (per axis, up to hi
// inclusive) to out, x fastest: ((hi[a] - lo[a]) >> s) + 1 points per axis.
// REQUIRES: `out` holds that many doubles; lo[a] a multiple of 2^s,
// 0 <= lo[a] <= hi[a] < dims[a] on the used axes (checked: InvalidArgument).
// O(points + the voxels of the bricks the box meets).
Status ReadLattice(const HzStore& store, int s, const std::array<int64_t, 4>& lo,
                   const std::array<int64_t, 4>& hi, double* out);

}  // namespace simplexdb
