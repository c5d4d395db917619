// A 4D volume made from a 3D one the way the seed's section 4.7 made its 4D
// Buckyball: "the field values inside each 4x4x4 subgrid" become "the
// different values in the fourth dimension for the point corresponding to
// the subgrid".
//
// With subgrid side s, output point (i, j, k) stands for the subgrid whose
// first corner is input point (s i, s j, s k), and time step t reads the
// subgrid's point t in x-fastest order:
//
//   out(i, j, k, t) = in(s i + t % s, s j + (t / s) % s, s k + t / s^2),
//
// each coordinate clamped to the input grid (a subgrid running past the far
// faces repeats the last plane). Axis a of the output has (n_a - 1) / s + 1
// points (rounded down), so 129^3 with s = 4 gives 33^3, and the time axis
// has `steps` points, at most s^3: the seed's 33^4 from a 129^3 Buckyball is
// s = 4, steps = 33.
//
// Errors: SubgridsToTime's, listed at the function (InvalidArgument for bad
// parameters, the VolumeReader's errors for the input).
//
// Thread safety: reentrant; SubgridsToTime opens its own reader.
//
// Lifetimes: the result owns its values (a plain value); nothing refers to
// `in` after the call.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

struct SubgridTimeVolume {
  std::array<uint32_t, 4> dims{};  // x, y, z, t
  std::vector<double> values;      // x fastest, then y, z, t
};

// The output's spatial axis for an input axis of n points.
constexpr uint32_t SubgridAxis(uint32_t n, uint32_t s) { return (n - 1) / s + 1; }

// Reads all of `in` (a 3D volume) and builds the 4D volume above. Memory:
// 8 bytes per input point plus 8 per output point.
// Errors: InvalidArgument if `in` is not 3D, s is not in [2, 64], or steps
// is not in [2, s^3]; ResourceExhausted "not enough memory for ..." when
// either volume does not fit; the reader's errors (naming the file) otherwise.
Result<SubgridTimeVolume> SubgridsToTime(const VolumeInfo& in, uint32_t s, uint32_t steps);

}  // namespace simplexdb
