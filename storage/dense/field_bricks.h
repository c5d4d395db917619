// The field as bricks of every octave's lattice: how the dense store keeps
// field values (docs/format/dense-store.md, "Field").
//
// Lattice s (0 <= s <= k, for a domain of side 2^k) holds the real grid
// points whose every coordinate is a multiple of 2^s: lattice 0 is the
// grid, lattice s has (dims[a] - 1) / 2^s + 1 points along axis a. Each
// lattice is cut into bricks of 2^side_bits points per axis (partial at
// the upper faces). Bricks are numbered lattice by lattice from the
// coarsest (s = k) to the grid, so a read of every 2^s-th point is one
// contiguous range of bricks; within a lattice, x fastest.
//
// A brick is stored as its voxels (raw), one zstd frame of them, or one
// zstd frame of their Lorenzo residuals (storage/dense/brick_codec.h),
// whichever EncodeBrick finds smallest.
//
// Thread safety: BrickGrid is an immutable value. EncodeBrick and
// DecodeBrick use the caller's zstd context (one per thread).
// Lifetimes: nothing refers to its arguments after a call.
// Errors: EncodeBrick passes on ZstdCompressor's; DecodeBrick returns
// Corruption naming `what` for a frame that does not decode to the brick's
// size or an unknown coding.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "storage/io/codec.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

enum class BrickCoding : uint8_t {
  kRaw = 1,             // the voxels, little-endian
  kZstd = 2,            // one zstd frame of the voxels
  kZstdPredicted = 3,   // one zstd frame of PredictBrick's output
};

struct BrickPlace {
  int lattice = 0;                         // s: points at multiples of 2^s
  std::array<int64_t, 4> first{};          // its first point, in grid coordinates
  std::array<uint32_t, 4> extent{1, 1, 1, 1};  // points per axis (unused axes 1)
};

class BrickGrid {
 public:
  // REQUIRES: 3 <= dimension <= 4; dims[a] >= 1 and (dims[a] - 1) <= 2^k;
  // 1 <= side_bits <= 8.
  BrickGrid(int dimension, const std::array<uint32_t, 4>& dims, int k, int side_bits);

  int dimension() const { return dimension_; }
  const std::array<uint32_t, 4>& dims() const { return dims_; }
  int lattices() const { return k_ + 1; }
  uint64_t bricks() const { return first_brick_[0] + Count(0); }
  // The most voxels a brick holds: 2^(side_bits * dimension).
  size_t brick_voxels() const { return size_t{1} << (side_bits_ * dimension_); }

  // Bricks of lattice s, and the number of the first. O(1).
  uint64_t Count(int s) const;
  uint64_t FirstBrick(int s) const { return first_brick_[static_cast<size_t>(s)]; }

  // Where brick b lies. O(D). REQUIRES: b < bricks().
  BrickPlace Place(uint64_t b) const;

  // The brick of lattice s holding grid point p (every p[a] a multiple of
  // 2^s inside the real grid), and p's index within the brick's voxels.
  // O(D): shifts and multiplies.
  uint64_t BrickOf(int s, const std::array<int64_t, 4>& p, size_t* slot) const;

  // The finest-octave vertices grid brick b (lattice 0) owns: those g with
  // min(g, dims - 1) in it, per axis. The brick's points, and past the real
  // grid's last faces (when it is the last brick along an axis) the
  // vertices up to min(2^k, dims[a] + 1), whose diamonds reach real points.
  // A format-2 store records each grid brick's largest finest error over
  // this box. REQUIRES: b a brick of lattice 0.
  struct Box {
    std::array<int64_t, 4> first{}, extent{1, 1, 1, 1};
  };
  Box FinestBox(uint64_t b) const;
  // The grid brick owning finest vertex g (coordinates up to 2^k).
  uint64_t FinestOwner(const std::array<int64_t, 4>& g) const;

 private:
  int dimension_, k_, side_bits_;
  std::array<uint32_t, 4> dims_;
  // Per lattice: bricks per axis, and the first brick's number.
  std::vector<std::array<uint64_t, 4>> per_axis_;
  std::vector<uint64_t> first_brick_;
};

struct EncodedBrick {
  BrickCoding coding = BrickCoding::kRaw;
  std::vector<uint8_t> bytes;
  double min = 0, max = 0;  // over the brick's values (NaN skipped; 0, 0 when all are)
};

// Encodes brick b of `grid` from the real grid's values (`field`, x
// fastest, dims as given to the grid; V any voxel C++ type) as voxels of
// `type`, trying each coding and keeping the smallest (`only`: that coding
// alone, for measurements and tests). `zstd` null: raw. O(brick voxels).
// REQUIRES: every value IsRepresentable(type); zstd given unless only is kRaw.
template <class V>
Result<EncodedBrick> EncodeBrick(const BrickGrid& grid, uint64_t b, const V* field,
                                 VoxelType type, ZstdCompressor* zstd,
                                 std::optional<BrickCoding> only = std::nullopt);

// Part of the field, for a builder that does not hold all of it: every
// 2^shift-th point per axis from 0 (shift 0: every point), x fastest with
// `stride` (in held points), from held plane `first_plane` of the last
// axis on. A brick of lattice s >= shift whose points are held is read
// from it.
template <class V>
struct HeldField {
  const V* data = nullptr;
  std::array<int64_t, 4> stride{};
  int64_t first_plane = 0;
  int shift = 0;
};
template <class V>
Result<EncodedBrick> EncodeBrick(const BrickGrid& grid, uint64_t b, const HeldField<V>& field,
                                 VoxelType type, ZstdCompressor* zstd,
                                 std::optional<BrickCoding> only = std::nullopt);
#define SDB_ENCODE_BRICK_(V)                                                                \
  extern template Result<EncodedBrick> EncodeBrick(const BrickGrid&, uint64_t, const V*,     \
                                                   VoxelType, ZstdCompressor*,               \
                                                   std::optional<BrickCoding>);             \
  extern template Result<EncodedBrick> EncodeBrick(const BrickGrid&, uint64_t,               \
                                                   const HeldField<V>&, VoxelType,          \
                                                   ZstdCompressor*, std::optional<BrickCoding>);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_ENCODE_BRICK_)
#undef SDB_ENCODE_BRICK_

// Decodes a stored brick of `voxels` voxels into `out` (voxels *
// VoxelSize(type) bytes, little-endian voxels, x fastest within the
// brick's extent). `extent` is the brick's (BrickGrid::Place).
Status DecodeBrick(std::span<const uint8_t> stored, BrickCoding coding, VoxelType type,
                   int dimension, const std::array<uint32_t, 4>& extent,
                   ZstdDecompressor& zstd, std::span<uint8_t> out, std::string_view what);

}  // namespace simplexdb
