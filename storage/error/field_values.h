// What values a store can hold: finite numbers within float32's range (its
// block statistics and error ranges are float32), or NaN for a missing
// value. Every path that builds or updates a store (the dense builder, so
// import and import --sparse, and the sparse store's update) checks the
// values it reads with CheckStorableValues before it writes anything, so a
// volume with +-Inf or a float64 such as 1e39 fails naming the file, the
// value and the voxel instead of making a store no reader can open.
// VolumeReader itself returns any double: other readers (extract, the NRRD
// writer's tests) want them as they are.
//
// Thread safety: pure functions; reentrant.
// Lifetimes: nothing is kept.
// Errors: InvalidArgument (below).
#pragma once

#include <cstddef>
#include <cstdint>

#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

// OK when every values[i], i < count, is NaN or finite with |v| <= FLT_MAX.
// Otherwise InvalidArgument for the first that is not: "<file>: value V at
// voxel (x, y, z[, t]) is infinite | beyond float32's range (+-3.40282e+38);
// a store holds finite float32 values (NaN marks a missing one)", where
// values[i] is voxel first + i of `volume` (x fastest) and <file> is its
// description, with the data file holding the voxel when there are several;
// a scaled volume's message also gives its scaling.
// REQUIRES: values holds `count` doubles.
Status CheckStorableValues(const VolumeInfo& volume, uint64_t first, const double* values,
                           size_t count);

// OK when the field's range, max - min (of storable values), is itself
// within float32's range: errors are bounded by the range and stored as
// float32 (or in steps of it), so a field spanning more (3e38 and -3e38)
// would have errors no store can hold. Otherwise InvalidArgument: "<file>:
// the values run from MIN to MAX, a range of R, beyond float32's (+-3.40282e+38),
// in which a store keeps its errors; scale the values down (a NRRD or NIfTI
// scaling, or fewer units)". Every builder asks before it writes anything.
Status CheckFieldRange(const VolumeInfo& volume, double min, double max);

}  // namespace simplexdb
