// DenseStore's Reader (one thread's lookups) and Verify (storage/dense/
// dense_store.h); the store's opening, blocks and bricks are in
// dense_store.cc, its finest boxes in dense_finest.cc.
#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "storage/dense/brick_codec.h"
#include "storage/dense/dense_store.h"
#include "storage/error/quantize.h"
#include "storage/io/checksum.h"

namespace simplexdb {

Status DenseStore::Verify(const std::function<void(uint64_t, uint64_t)>& progress) const {
  const uint64_t blocks = header_.stored_blocks, total = blocks + header_.bricks;
  const uint32_t n = static_cast<uint32_t>(header_.block_records());
  // Entry `e`'s stored bytes match its checksum (read from the file even
  // when the block or brick is cached or resident).
  const auto stored_ok = [this](const DenseIndexEntry& e) {
    const Result<std::span<const uint8_t>> bytes = StoredBytes(e, "an entry");
    return bytes.ok() && Checksum(*bytes) == e.checksum;
  };
  const auto corrupt = [this](const std::string& what, const std::string& why) {
    return Status::Corruption(path_ + ": " + what + ": " + why);
  };
  for (uint64_t i = 0; i < blocks; ++i) {
    if (progress && i % 256 == 0) progress(i, total);
    const DenseIndexEntry e = entry(i);
    const auto bad = [&](const std::string& why) { return corrupt(Describe(i), why); };
    if (!stored_ok(e)) return bad("checksum mismatch");
    SDB_ASSIGN_OR_RETURN(const BlockHandle h, Block(i));
    uint32_t largest = 0;
    for (uint32_t slot = 0; slot < n; ++slot) {
      const uint32_t code = StoredErrorAt(h.data, slot);
      const double v = quantizer_.Decode(code);
      if (!std::isfinite(v) || v < 0) {
        return bad("error entry " + std::to_string(slot) + " is " + std::to_string(v));
      }
      largest = std::max(largest, code);  // f32 bits of non-negative floats order as the floats
    }
    if (largest > e.error_max) {
      return bad("holds an error of " + std::to_string(quantizer_.Decode(largest)) +
                 " above its recorded maximum " + std::to_string(quantizer_.Decode(e.error_max)));
    }
  }
  for (uint64_t b = 0; b < header_.bricks; ++b) {
    if (progress && (blocks + b) % 256 == 0) progress(blocks + b, total);
    const DenseIndexEntry e = brick_entry(b);
    const auto bad = [&](const std::string& why) { return corrupt(DescribeBrick(b), why); };
    if (!stored_ok(e)) return bad("checksum mismatch");
    SDB_ASSIGN_OR_RETURN(const BlockHandle h, Brick(b));
    const BrickPlace place = grid_->Place(b);
    const size_t voxels = BrickVoxels(header_.dimension, place.extent);
    for (size_t slot = 0; slot < voxels; ++slot) {
      const double f = VoxelAt(h.data, slot);
      if (std::isnan(f)) continue;  // a missing value
      if (!(f >= e.field_min && f <= e.field_max && f >= header_.field_min &&
            f <= header_.field_max)) {
        return bad("field entry " + std::to_string(slot) + " is " + std::to_string(f) +
                   ", outside the recorded range");
      }
    }
    if (place.lattice != 0 || header_.finest_stored()) continue;
    // The finest errors the reader computes, against the builder's maximum.
    SDB_ASSIGN_OR_RETURN(const auto codes, ComputeFinest(b));
    uint32_t largest = 0;
    for (size_t i = 0; i < codes->size() / error_size_; ++i) {
      largest = std::max(largest, StoredErrorAt(codes->data(), static_cast<uint32_t>(i)));
    }
    if (largest != e.error_max) {
      return bad("its finest errors, computed from the field, reach " +
                 std::to_string(quantizer_.Decode(largest)) + "; the builder recorded " +
                 std::to_string(quantizer_.Decode(e.error_max)));
    }
  }
  if (progress) progress(total, total);
  return Status::OK();
}

template <int D>
DenseStore::Reader<D>::Reader(const DenseStore& store)
    : store_(store),
      order_(store.header().domain_bits),
      finest_level_(store.header().finest_stored() ? order_.levels() : order_.levels() - D),
      region_level_(store.RegionWalkPays(D) ? std::max(0, order_.levels() - D) : order_.levels()),
      held_bricks_(static_cast<size_t>(store.header().domain_bits) + 1) {
  const size_t bytes = store.FinestWindowBytes();
  if (bytes > 0) windows_.resize(std::clamp<size_t>((size_t{1} << 20) / bytes, 2, 16));
}

template <int D>
Status DenseStore::Reader<D>::Hold(Held& held, uint64_t vblock) {
  const std::optional<uint64_t> stored = store_.StoredIndex(vblock);
  held.vblock = vblock;
  held.stored = stored.has_value();
  held.handle = BlockHandle{};
  held.skipped = false;
  if (!stored) return Status::OK();
  ++block_fetches_;
  Result<BlockHandle> h = store_.Block(*stored);
  if (!h.ok()) {
    held.vblock = ~uint64_t{0};
    return h.status();
  }
  held.handle = *std::move(h);
  return Status::OK();
}

template <int D>
Result<uint32_t> DenseStore::Reader<D>::FinestCode(uint64_t p, const double* threshold, bool* skipped) {
  std::array<int64_t, D> g = last_vertex_;
  if (p != last_position_ && !order_.Decode(p, g)) return 0u;  // no vertex there
  return FinestCodeAt(g, threshold, skipped);
}

template <int D>
Result<uint32_t> DenseStore::Reader<D>::FinestCodeAt(const std::array<int64_t, D>& g,
                                                     const double* threshold, bool* skipped) {
  // A walk asks for the vertices of one box many times in a row.
  if (last_box_ >= 0) {
    const HeldBrick& last = held_boxes_[static_cast<size_t>(last_box_)];
    if (const int64_t slot = last.tiles.Slot(g); slot >= 0) {
      return BoxCode(last, g, slot);
    }
  }
  std::array<int64_t, 4> g4{};
  for (int a = 0; a < D; ++a) g4[a] = g[a];
  const uint64_t b = store_.grid().FinestOwner(g4);
  const int index = static_cast<int>(b & 7);
  HeldBrick& held = held_boxes_[static_cast<size_t>(index)];
  if (held.brick != b) {
    const uint32_t recorded = store_.brick_entry(b).error_max;
    if (recorded == 0) return 0u;  // every finest error of the brick is 0
    if (threshold != nullptr && store_.quantizer().Decode(recorded) <= *threshold) {
      ++blocks_skipped_;
      *skipped = true;
      return recorded;
    }
    ++block_fetches_;
    if (index == last_box_) last_box_ = -1;
    SDB_ASSIGN_OR_RETURN(held.handle, store_.FinestCodes(b));
    held.brick = b;
    held.tiles = FinestTiles(D, store_.grid().FinestBox(b));
  }
  const int64_t slot = held.tiles.Slot(g);
  if (slot < 0) return 0u;  // past the box: no real point in its diamond
  last_box_ = index;
  return BoxCode(held, g, slot);
}

template <int D>
Result<uint32_t> DenseStore::Reader<D>::BoxCode(const HeldBrick& box, const std::array<int64_t, D>& g,
                                                int64_t slot) {
  if (!box.handle.lazy) return store_.StoredErrorAt(box.handle.data, static_cast<uint32_t>(slot));
  uint32_t code = 0;
  if (store_.LazyCode(box.handle, box.tiles, slot, &code)) return code;
  Window* window = nullptr;
  Window* oldest = &windows_[0];
  for (Window& w : windows_) {
    if (w.brick == box.brick) window = &w;
    if (w.used < oldest->used) oldest = &w;
  }
  if (window == nullptr) {
    window = oldest;
    window->brick = ~uint64_t{0};
    SDB_RETURN_IF_ERROR(store_.GatherFinestWindow(box.brick, window->bytes));
    window->brick = box.brick;
  }
  window->used = ++windows_tick_;
  return store_.ComputeLazyCode(box.handle, box.tiles, g, slot, window->bytes.data());
}

template <int D>
Result<uint32_t> DenseStore::Reader<D>::StoredError(SimplexCode<D> code) {
  if (code.level() >= order_.levels()) return 0u;
  const uint64_t p = PositionOf(code);
  if (p >= store_.header().error_positions()) {
    bool skipped = false;
    return FinestCode(p, nullptr, &skipped);
  }
  const uint64_t vblock = p >> store_.header().block_bits;
  Held& held = HeldFor(p);
  if (vblock != held.vblock || held.skipped) SDB_RETURN_IF_ERROR(Hold(held, vblock));
  if (!held.stored) return 0u;
  return store_.StoredErrorAt(held.handle.data,
                              static_cast<uint32_t>(p & (store_.header().block_records() - 1)));
}

template <int D>
Result<double> DenseStore::Reader<D>::ErrorBound(SimplexCode<D> code) {
  SDB_ASSIGN_OR_RETURN(const uint32_t stored, StoredError(code));
  return store_.quantizer().Decode(stored);
}

template <int D>
Result<double> DenseStore::Reader<D>::ErrorBoundForThresholdAt(SimplexCode<D> code, uint64_t p,
                                                               double threshold) {
  if (code.level() >= order_.levels()) return 0.0;
  if (p >= store_.header().error_positions()) {
    bool skipped = false;
    SDB_ASSIGN_OR_RETURN(const uint32_t c, FinestCode(p, &threshold, &skipped));
    return store_.quantizer().Decode(c);
  }
  const uint64_t vblock = p >> store_.header().block_bits;
  Held& held = HeldFor(p);
  if (vblock == held.vblock && held.skipped) {
    if (held.skipped_max <= threshold) return held.skipped_max;
    SDB_RETURN_IF_ERROR(Hold(held, vblock));
  } else if (vblock != held.vblock) {
    const std::optional<uint64_t> stored = store_.StoredIndex(vblock);
    if (!stored) {
      SDB_RETURN_IF_ERROR(Hold(held, vblock));  // nothing to read: remember that
      return 0.0;
    }
    const double block_max = store_.quantizer().Decode(store_.entry(*stored).error_max);
    if (block_max <= threshold) {
      ++blocks_skipped_;
      held.vblock = vblock;
      held.stored = true;
      held.handle = BlockHandle{};
      held.skipped = true;
      held.skipped_max = block_max;
      return block_max;
    }
    SDB_RETURN_IF_ERROR(Hold(held, vblock));
  }
  if (!held.stored) return 0.0;
  return store_.quantizer().Decode(store_.StoredErrorAt(
      held.handle.data, static_cast<uint32_t>(p & (store_.header().block_records() - 1))));
}

template <int D>
Result<double> DenseStore::Reader<D>::Field(const std::array<int64_t, D>& p) {
  // From the coarsest lattice holding the point: a coarse mesh reads
  // coarse bricks only.
  std::array<int64_t, 4> q{};
  uint64_t bits = 0;
  const auto& dims = store_.header().dims;
  for (int a = 0; a < D; ++a) {
    q[a] = std::clamp<int64_t>(p[a], 0, int64_t{dims[a]} - 1);
    bits |= static_cast<uint64_t>(q[a]);
  }
  const int k = store_.header().domain_bits;
  const int s = bits == 0 ? k : std::min(k, std::countr_zero(bits));
  size_t slot = 0;
  const uint64_t b = store_.grid().BrickOf(s, q, &slot);
  HeldBrick& held = held_bricks_[static_cast<size_t>(s)];
  if (held.brick != b) {
    SDB_ASSIGN_OR_RETURN(held.handle, store_.Brick(b));
    held.brick = b;
  }
  return store_.VoxelAt(held.handle.data, slot);
}

template class DenseStore::Reader<3>;
template class DenseStore::Reader<4>;

}  // namespace simplexdb
