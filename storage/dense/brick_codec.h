// Predictive coding of a brick of grid values, the step before zstd that
// makes a field compress like the peers' (HDF5, Zarr with Blosc-zstd) or
// better. The dense store keeps the field as bricks of each octave's
// lattice (docs/format/dense-store.md, "Field"); this is their coding.
//
// A brick is an extent[0] x ... x extent[D-1] box of voxels, x fastest,
// little-endian, in one voxel type. PredictBrick replaces each voxel by its
// residual against the D-dimensional Lorenzo predictor (the sum over the
// brick's 2^D - 1 lower corners of the unit cell ending at the voxel, with
// signs by inclusion-exclusion; along an edge or face of the brick, the
// same over the corners inside it). The arithmetic is on w-bit unsigned
// integers modulo 2^w (w = 8 x the voxel size): the integer types as they
// are, floats by their bit patterns mapped to integers in the order of the
// values (negative floats inverted, positive ones with the sign bit set),
// so every value, NaN and infinity included, comes back bit for bit.
// Residuals are zigzagged (small magnitudes, either sign, to small codes)
// and their bytes shuffled: all first bytes, then all second bytes, ...
//
// Computed as successive differences along each axis, the predictor costs
// D subtractions per voxel to code and D additions to decode.
//
// Thread safety: pure functions. Errors: none (REQUIREs are assertions).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "storage/volume/voxel_type.h"

namespace simplexdb {

// The number of voxels of a brick of this extent (axes past `dimension` are 1).
size_t BrickVoxels(int dimension, const std::array<uint32_t, 4>& extent);

// Codes the brick's voxels (`voxels`: BrickVoxels * VoxelSize(type) bytes,
// little-endian) into `coded`, of the same size. O(voxels * dimension).
// REQUIRES: IsValidVoxelType(type); 1 <= dimension <= 4; the spans' sizes.
void PredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                  std::span<const uint8_t> voxels, std::span<uint8_t> coded);

// The inverse: the voxels, bit for bit, from what PredictBrick wrote.
// Any bytes decode to some voxels (damage is caught by the store's
// checksums, not here). REQUIRES: as PredictBrick.
void UnpredictBrick(VoxelType type, int dimension, const std::array<uint32_t, 4>& extent,
                    std::span<const uint8_t> coded, std::span<uint8_t> voxels);

}  // namespace simplexdb
