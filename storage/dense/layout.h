// Where a dense store keeps each node's error and each grid point's value.
// Pure arithmetic over the header's parameters; no I/O.
//
// Errors. Each root's internal nodes (levels 0 .. L-1, L = D*k the leaf
// level; leaves have error 0 and are not stored) are cut into bands of
// levels, aligned from the bottom: every band is `levels_per_block` (B)
// levels deep except the top one, which takes the remainder. A band starting
// at level s holds 2^s subtrees, one per node at level s; each subtree is one
// block, its nodes in heap order (the subtree root first, children of entry i
// at 2i+1 and 2i+2). So a depth-first walk stays in one block for up to B
// levels, and the blocks of a subtree are contiguous in the block numbering:
//
//   block(root r, band b, subtree s) = r * blocks_per_root + first[b] + s
//
// Aligning from the bottom keeps the many blocks near the leaves full
// (2^B - 1 entries); the single top band is the short one.
//
// Field. The real grid (dims, x fastest) is cut into bricks of side
// 2^brick_bits, numbered x fastest; bricks at the far edges are cut to the
// grid (only real points are stored), their points x fastest within the
// brick's own extent.
//
// Thread safety: immutable values; any number of threads may use one. No
// errors: callers validate the header first (REQUIRES lines below).
#pragma once

#include <array>
#include <cassert>
#include <algorithm>
#include <cstdint>

#include "hierarchy/simplex_code.h"

namespace simplexdb {

struct BlockSlot {
  uint64_t block;
  uint32_t entry;
};

template <int D>
class ErrorLayout {
 public:
  // REQUIRES: 1 <= leaf_level <= SimplexCode<D>::kMaxLevel, 1 <= levels_per_block <= 24.
  ErrorLayout(int leaf_level, int levels_per_block)
      : leaf_level_(leaf_level), levels_per_block_(levels_per_block) {
    assert(leaf_level >= 1 && leaf_level <= SimplexCode<D>::kMaxLevel);
    bands_ = (leaf_level + levels_per_block - 1) / levels_per_block;
    const int top = leaf_level - (bands_ - 1) * levels_per_block;
    uint64_t first = 0;
    for (int b = 0; b < bands_; ++b) {
      start_[b] = b == 0 ? 0 : top + (b - 1) * levels_per_block;
      depth_[b] = b == 0 ? top : levels_per_block;
      first_[b] = first;
      first += uint64_t{1} << start_[b];
      for (int l = start_[b]; l < start_[b] + depth_[b]; ++l) band_of_level_[l] = b;
    }
    blocks_per_root_ = first;
  }

  int leaf_level() const { return leaf_level_; }
  int levels_per_block() const { return levels_per_block_; }
  int bands() const { return bands_; }
  int band_start(int b) const { return start_[b]; }
  int band_depth(int b) const { return depth_[b]; }
  uint64_t blocks_per_root() const { return blocks_per_root_; }
  uint64_t block_count() const { return blocks_per_root_ * SimplexCode<D>::kRoots; }

  int BandOfLevel(int level) const { return band_of_level_[level]; }
  // The first block of band b within a root.
  uint64_t band_first(int b) const { return first_[b]; }
  // Entries (nodes) in a block of band b.
  uint32_t entries_in_band(int b) const { return (uint32_t{1} << depth_[b]) - 1; }

  // The block and entry of an internal node.
  // REQUIRES: code.is_valid(), code.level() < leaf_level().
  BlockSlot Locate(SimplexCode<D> code) const {
    const int l = code.level();
    assert(l < leaf_level_);
    const int b = band_of_level_[l];
    const int local = l - start_[b];
    const uint64_t path = code.path();
    const uint64_t subtree = path >> local;
    const uint64_t local_path = path & ((uint64_t{1} << local) - 1);
    return BlockSlot{static_cast<uint64_t>(code.top()) * blocks_per_root_ + first_[b] + subtree,
                     static_cast<uint32_t>(((uint64_t{1} << local) - 1) + local_path)};
  }

  // The band of a block, and the code of its subtree's root.
  int BandOfBlock(uint64_t block) const {
    const uint64_t in_root = block % blocks_per_root_;
    int b = bands_ - 1;
    while (first_[b] > in_root) --b;
    return b;
  }
  SimplexCode<D> BlockRoot(uint64_t block) const {
    const int top = static_cast<int>(block / blocks_per_root_);
    const int b = BandOfBlock(block);
    const uint64_t subtree = block % blocks_per_root_ - first_[b];
    return SimplexCode<D>::FromPath(top, subtree, start_[b]);
  }
  uint32_t EntriesInBlock(uint64_t block) const { return entries_in_band(BandOfBlock(block)); }

 private:
  int leaf_level_;
  int levels_per_block_;
  int bands_ = 0;
  uint64_t blocks_per_root_ = 0;
  std::array<int, 64> start_{};
  std::array<int, 64> depth_{};
  std::array<uint64_t, 64> first_{};
  std::array<int8_t, 64> band_of_level_{};
};

// Bricks of the real grid.
class BrickLayout {
 public:
  // REQUIRES: dimension 3 or 4; dims[i] >= 1; 1 <= brick_bits <= 8.
  BrickLayout(int dimension, std::array<uint32_t, 4> dims, int brick_bits)
      : dimension_(dimension), dims_(dims), bits_(brick_bits) {
    count_ = 1;
    for (int a = 0; a < 4; ++a) {
      per_axis_[a] = (dims[a] + (uint32_t{1} << bits_) - 1) >> bits_;
      count_ *= per_axis_[a];
    }
  }

  int dimension() const { return dimension_; }
  int brick_bits() const { return bits_; }
  uint32_t side() const { return uint32_t{1} << bits_; }
  const std::array<uint32_t, 4>& dims() const { return dims_; }
  uint64_t brick_count() const { return count_; }
  uint32_t bricks_along(int axis) const { return per_axis_[axis]; }
  // Points in a full brick.
  uint32_t max_points_per_brick() const { return uint32_t{1} << (bits_ * dimension_); }

  // The grid coordinates of a brick's first point.
  std::array<uint32_t, 4> BrickOrigin(uint64_t brick) const {
    std::array<uint32_t, 4> o = {0, 0, 0, 0};
    for (int a = 0; a < dimension_; ++a) {
      o[a] = static_cast<uint32_t>(brick % per_axis_[a]) << bits_;
      brick /= per_axis_[a];
    }
    return o;
  }

  // A brick's size along each axis (unused axes: 1).
  std::array<uint32_t, 4> BrickExtent(uint64_t brick) const {
    const std::array<uint32_t, 4> o = BrickOrigin(brick);
    std::array<uint32_t, 4> e = {1, 1, 1, 1};
    for (int a = 0; a < dimension_; ++a) e[a] = std::min(side(), dims_[a] - o[a]);
    return e;
  }
  uint32_t PointsInBrick(uint64_t brick) const {
    const std::array<uint32_t, 4> e = BrickExtent(brick);
    return e[0] * e[1] * e[2] * e[3];
  }

  // The brick and entry of a real grid point.
  // REQUIRES: p[a] < dims[a].
  BlockSlot Locate(const std::array<uint32_t, 4>& p) const {
    uint64_t brick = 0;
    for (int a = dimension_ - 1; a >= 0; --a) brick = brick * per_axis_[a] + (p[a] >> bits_);
    const uint32_t mask = side() - 1;
    uint32_t entry = 0;
    for (int a = dimension_ - 1; a >= 0; --a) {
      // The extent along a: a full side unless this is the last brick.
      const uint32_t origin = p[a] & ~mask;
      const uint32_t extent = std::min(side(), dims_[a] - origin);
      entry = entry * extent + (p[a] & mask);
    }
    return BlockSlot{brick, entry};
  }

 private:
  int dimension_;
  std::array<uint32_t, 4> dims_;
  int bits_;
  std::array<uint32_t, 4> per_axis_{1, 1, 1, 1};
  uint64_t count_ = 1;
};

// The smallest k with 2^k + 1 >= every used dimension: the hierarchy's
// domain is the cube (hypercube) of side 2^k covering the grid.
inline int DomainBitsFor(int dimension, const std::array<uint32_t, 4>& dims) {
  uint32_t largest = 2;
  for (int a = 0; a < dimension; ++a) largest = std::max(largest, dims[a]);
  int k = 0;
  while ((uint64_t{1} << k) + 1 < largest) ++k;
  return k;
}

}  // namespace simplexdb
