// The dense store's finest-octave errors (storage/dense/dense_store.h,
// FinestCodes): computed whole per grid brick (in memory at open, and by
// Verify), or out of core a vertex at a time in shared lazy boxes, from a
// window of the field each reader gathers around the box.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cstring>

#include "storage/dense/dense_store.h"
#include "storage/error/quantize.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

// Copies a short row of voxels (a brick's part of a window row: a few to
// a few dozen bytes) with fixed-size moves: no call per row.
inline void CopyRow(uint8_t* to, const uint8_t* from, size_t n) {
  if (n >= 8) {
    for (size_t i = 0; i + 8 < n; i += 8) std::memcpy(to + i, from + i, 8);
    std::memcpy(to + n - 8, from + n - 8, 8);  // the last 8, overlapping
    return;
  }
  if (n & 4) std::memcpy(to, from, 4);
  if (n & 2) std::memcpy(to + (n & 4), from + (n & 4), 2);
  if (n & 1) to[n - 1] = from[n - 1];
}

}  // namespace

Result<DenseStore::BlockHandle> DenseStore::FinestCodes(uint64_t b) const {
  if (!resident_finest_.empty()) {
    const auto& codes = resident_finest_[b - grid_->FirstBrick(0)];
    if (codes != nullptr) return BlockHandle{codes->data(), nullptr};
  }
  const BlockCache::Key key{cache_store_id_, header_.stored_blocks + header_.bricks + b};
  std::shared_ptr<const BlockCache::Block> box = cache_->Lookup(key);
  if (box == nullptr) {
    SDB_ASSIGN_OR_RETURN(auto fresh, MakeLazyFinest(b));
    box = cache_->Insert(key, std::move(fresh));
  }
  const uint8_t* data = box->data();
  return BlockHandle{data, std::move(box), /*lazy=*/true};
}

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::MakeLazyFinest(uint64_t b) const {
  const FinestTiles tiles(header_.dimension, grid_->FinestBox(b));
  const size_t bytes = error_size_ * tiles.slots + (tiles.slots + 7) / 8;
  try {
    boxes_.fetch_add(1, std::memory_order_relaxed);
    return std::shared_ptr<const BlockCache::Block>(
        std::make_shared<BlockCache::Block>(bytes));  // nothing computed
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the finest errors of " + DescribeBrick(b), bytes);
  }
}

size_t DenseStore::FinestWindowBytes() const {
  if (header_.finest_stored()) return 0;
  size_t points = 1;
  for (int a = 0; a < header_.dimension; ++a) points *= static_cast<size_t>(FinestWindowSide());
  return points * voxel_size_;
}

Status DenseStore::GatherFinestWindow(uint64_t b, std::vector<uint8_t>& window) const {
  static_assert(std::endian::native == std::endian::little, "bricks hold little-endian voxels");
  const int d = header_.dimension;
  const BrickGrid::Box box = grid_->FinestBox(b);
  const int64_t w = FinestWindowSide();
  std::array<int64_t, 4> lo{}, hi{};
  for (int a = 0; a < d; ++a) {
    // The window's real points.
    lo[a] = std::max<int64_t>(0, box.first[a] - 2);
    hi[a] = std::min<int64_t>(header_.dims[a] - 1, box.first[a] - 2 + w - 1);
  }
  try {
    window.assign(FinestWindowBytes(), 0);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the field around " + DescribeBrick(b), FinestWindowBytes());
  }
  // Brick by brick (lattice 0: every point), a row segment at a time,
  // voxels copied as they are.
  std::array<int64_t, 4> corner = lo;  // the first point of a brick's part
  while (true) {
    size_t first_slot = 0;
    const uint64_t at = grid_->BrickOf(0, corner, &first_slot);
    SDB_ASSIGN_OR_RETURN(const BlockHandle brick, Brick(at));
    const BrickPlace place = grid_->Place(at);
    std::array<int64_t, 4> end{}, stride{};  // the part's last point; the brick's strides
    int64_t n = 1;
    for (int a = 0; a < d; ++a) {
      end[a] = std::min(hi[a], place.first[a] + place.extent[a] - 1);
      stride[a] = n;
      n *= place.extent[a];
    }
    const size_t run = static_cast<size_t>(end[0] - corner[0] + 1) * voxel_size_;
    std::array<int64_t, 4> q = corner;
    while (true) {
      size_t from = 0, to = 0, scale = 1;
      for (int a = 0; a < d; ++a) {
        from += static_cast<size_t>((q[a] - place.first[a]) * stride[a]);
        to += static_cast<size_t>(q[a] - box.first[a] + 2) * scale;
        scale *= static_cast<size_t>(w);
      }
      CopyRow(window.data() + to * voxel_size_, brick.data + from * voxel_size_, run);
      int a = 1;
      for (; a < d; ++a) {
        if (++q[a] <= end[a]) break;
        q[a] = corner[a];
      }
      if (a == d) break;
    }
    // The next brick's part, x first (bricks are aligned: a row of them
    // shares its extent on the other axes).
    int a = 0;
    for (; a < d; ++a) {
      corner[a] = end[a] + 1;
      if (corner[a] <= hi[a]) break;
      corner[a] = lo[a];
    }
    if (a == d) break;
  }
  return Status::OK();
}

uint32_t DenseStore::LazyCodeRef(const BlockHandle& box, int64_t slot) const {
  uint8_t* data = const_cast<uint8_t*>(box.data);
  switch (header_.quantization) {
    case Quantization::kU8:
      return std::atomic_ref<uint8_t>(data[slot]).load(std::memory_order_relaxed);
    case Quantization::kU16:
      return std::atomic_ref<uint16_t>(reinterpret_cast<uint16_t*>(data)[slot]).load(std::memory_order_relaxed);
    case Quantization::kF32:
      break;
  }
  return std::atomic_ref<uint32_t>(reinterpret_cast<uint32_t*>(data)[slot]).load(std::memory_order_relaxed);
}

void DenseStore::SetLazyCode(const BlockHandle& box, int64_t slot, uint32_t code) const {
  uint8_t* data = const_cast<uint8_t*>(box.data);
  switch (header_.quantization) {
    case Quantization::kU8:
      std::atomic_ref<uint8_t>(data[slot]).store(static_cast<uint8_t>(code), std::memory_order_relaxed);
      return;
    case Quantization::kU16:
      std::atomic_ref<uint16_t>(reinterpret_cast<uint16_t*>(data)[slot])
          .store(static_cast<uint16_t>(code), std::memory_order_relaxed);
      return;
    case Quantization::kF32:
      std::atomic_ref<uint32_t>(reinterpret_cast<uint32_t*>(data)[slot]).store(code, std::memory_order_relaxed);
      return;
  }
}

template <size_t N>
uint32_t DenseStore::ComputeLazyCode(const BlockHandle& box, const FinestTiles& tiles,
                                     const std::array<int64_t, N>& g, int64_t slot,
                                     const uint8_t* window) const {
  constexpr int D = static_cast<int>(N);
  std::array<int64_t, D> first{}, dims{};
  for (int a = 0; a < D; ++a) {
    first[a] = tiles.first[a];
    dims[a] = header_.dims[a];
  }
  const double e = WithVoxelCppType(header_.voxel_type, [&](auto voxel) {
    using V = decltype(voxel);
    const V* values = reinterpret_cast<const V*>(window);
    if constexpr (D == 3) {
      return finest3_->ErrorAt(g, first, header_.domain_bits, dims, values);
    } else {
      return finest4_->ErrorAt(g, first, header_.domain_bits, dims, values);
    }
  });
  finest_computed_.fetch_add(1, std::memory_order_relaxed);
  // As the writer coded the builder's errors (rounded up to float first).
  const uint32_t code = quantizer_.Encode(static_cast<double>(RoundUpToFloat(e)));
  SetLazyCode(box, slot, code);
  LazyBits(box, tiles)[slot >> 3].fetch_or(static_cast<uint8_t>(1u << (slot & 7)), std::memory_order_release);
  return code;
}

template uint32_t DenseStore::ComputeLazyCode(const BlockHandle&, const FinestTiles&,
                                              const std::array<int64_t, 3>&, int64_t, const uint8_t*) const;
template uint32_t DenseStore::ComputeLazyCode(const BlockHandle&, const FinestTiles&,
                                              const std::array<int64_t, 4>&, int64_t, const uint8_t*) const;

Result<std::shared_ptr<const BlockCache::Block>> DenseStore::ComputeFinest(uint64_t b) const {
  return header_.dimension == 3 ? ComputeFinestOf<3>(b) : ComputeFinestOf<4>(b);
}

template <int D>
Result<std::shared_ptr<const BlockCache::Block>> DenseStore::ComputeFinestOf(uint64_t b) const {
  const FinestBoxErrors<D>& finest = [&]() -> const FinestBoxErrors<D>& {
    if constexpr (D == 3) {
      return *finest3_;
    } else {
      return *finest4_;
    }
  }();
  const BrickGrid::Box box = grid_->FinestBox(b);
  const FinestTiles tiles(D, box);
  const int64_t w = finest.window_side();
  std::array<int64_t, D> first{}, extent{}, dims{};
  std::array<int64_t, 4> lo{}, hi{};
  uint64_t points = 1, real_points = 1;
  for (int a = 0; a < D; ++a) {
    first[a] = box.first[a];
    extent[a] = box.extent[a];
    dims[a] = header_.dims[a];
    points *= static_cast<uint64_t>(extent[a]);
    // The window's real points.
    lo[a] = std::max<int64_t>(0, first[a] - 2);
    hi[a] = std::min<int64_t>(dims[a] - 1, first[a] - 2 + w - 1);
    real_points *= static_cast<uint64_t>(hi[a] - lo[a] + 1);
  }
  std::vector<double> window, real;
  std::shared_ptr<BlockCache::Block> codes;
  try {
    window.assign(finest.window_points(), 0.0);
    real.resize(real_points);
    codes = std::make_shared<BlockCache::Block>(error_size_ * tiles.slots);  // zeros
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path_ + ": the finest errors of " + DescribeBrick(b), 8 * finest.window_points());
  }
  // Read from the grid's bricks, then placed in the window row by row.
  SDB_RETURN_IF_ERROR(ReadLattice(*this, 0, lo, hi, real.data()));
  const int64_t row = hi[0] - lo[0] + 1;
  std::array<int64_t, 4> q = lo;
  for (const double* from = real.data();; from += row) {
    size_t at = 0, scale = 1;
    for (int a = 0; a < D; ++a) {
      at += static_cast<size_t>(q[a] - first[a] + 2) * scale;
      scale *= static_cast<size_t>(w);
    }
    std::copy(from, from + row, window.begin() + static_cast<std::ptrdiff_t>(at));
    int a = 1;
    for (; a < D; ++a) {
      if (++q[a] <= hi[a]) break;
      q[a] = lo[a];
    }
    if (a == D) break;
  }
  std::vector<double> errors(points);
  finest.Compute(first, extent, header_.domain_bits, dims, window.data(), errors.data());
  // As the writer coded the builder's errors (rounded up to float first),
  // in the width of a block's (StoredErrorAt reads them), at their tiles.
  std::array<int64_t, D> g = first;
  for (uint64_t i = 0; i < points; ++i) {
    StoreErrorCode(header_.quantization, codes->data(), static_cast<size_t>(tiles.Slot(g)),
                   quantizer_.Encode(static_cast<double>(RoundUpToFloat(errors[i]))));
    for (int a = 0; a < D; ++a) {
      if (++g[a] < first[a] + extent[a]) break;
      g[a] = first[a];
    }
  }
  boxes_.fetch_add(1, std::memory_order_relaxed);
  return std::shared_ptr<const BlockCache::Block>(std::move(codes));
}

}  // namespace simplexdb
