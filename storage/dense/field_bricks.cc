#include "storage/dense/field_bricks.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "storage/dense/brick_codec.h"

namespace simplexdb {
namespace {

int64_t LatticePoints(uint32_t dim, int s) { return ((int64_t{dim} - 1) >> s) + 1; }

}  // namespace

BrickGrid::BrickGrid(int dimension, const std::array<uint32_t, 4>& dims, int k, int side_bits)
    : dimension_(dimension), k_(k), side_bits_(side_bits), dims_(dims) {
  assert(dimension >= 3 && dimension <= 4 && side_bits >= 1 && side_bits <= 8);
  per_axis_.resize(static_cast<size_t>(k + 1));
  first_brick_.resize(static_cast<size_t>(k + 1));
  const int64_t side = int64_t{1} << side_bits;
  for (int s = 0; s <= k; ++s) {
    for (int a = 0; a < 4; ++a) {
      const int64_t n = a < dimension ? LatticePoints(dims[a], s) : 1;
      per_axis_[static_cast<size_t>(s)][a] = static_cast<uint64_t>((n + side - 1) / side);
    }
  }
  uint64_t next = 0;
  for (int s = k; s >= 0; --s) {
    first_brick_[static_cast<size_t>(s)] = next;
    next += Count(s);
  }
}

uint64_t BrickGrid::Count(int s) const {
  const auto& n = per_axis_[static_cast<size_t>(s)];
  return n[0] * n[1] * n[2] * n[3];
}

BrickPlace BrickGrid::Place(uint64_t b) const {
  assert(b < bricks());
  BrickPlace place;
  int s = k_;
  while (s > 0 && b >= first_brick_[static_cast<size_t>(s)] + Count(s)) --s;
  place.lattice = s;
  uint64_t local = b - first_brick_[static_cast<size_t>(s)];
  const int64_t side = int64_t{1} << side_bits_;
  for (int a = 0; a < 4; ++a) {
    const uint64_t n = per_axis_[static_cast<size_t>(s)][a];
    const int64_t c = static_cast<int64_t>(local % n);
    local /= n;
    place.first[a] = (c * side) << s;
    if (a < dimension_) {
      place.extent[a] = static_cast<uint32_t>(std::min(side, LatticePoints(dims_[a], s) - c * side));
    }
  }
  return place;
}

uint64_t BrickGrid::BrickOf(int s, const std::array<int64_t, 4>& p, size_t* slot) const {
  const auto& n = per_axis_[static_cast<size_t>(s)];
  const int64_t side = int64_t{1} << side_bits_;
  uint64_t brick = 0, scale = 1;
  size_t within = 0, within_scale = 1;
  for (int a = 0; a < dimension_; ++a) {
    const int64_t q = p[a] >> s;
    const int64_t c = q >> side_bits_;
    brick += static_cast<uint64_t>(c) * scale;
    scale *= n[a];
    const int64_t extent = std::min(side, LatticePoints(dims_[a], s) - c * side);
    within += static_cast<size_t>(q - c * side) * within_scale;
    within_scale *= static_cast<size_t>(extent);
  }
  *slot = within;
  return first_brick_[static_cast<size_t>(s)] + brick;
}

BrickGrid::Box BrickGrid::FinestBox(uint64_t b) const {
  const BrickPlace place = Place(b);
  assert(place.lattice == 0);
  const int64_t side = int64_t{1} << k_;
  Box box;
  for (int a = 0; a < dimension_; ++a) {
    box.first[a] = place.first[a];
    box.extent[a] = place.extent[a];
    const int64_t dim = dims_[a];
    if (place.first[a] + place.extent[a] == dim) box.extent[a] = std::min(side, dim + 1) + 1 - place.first[a];
  }
  return box;
}

uint64_t BrickGrid::FinestOwner(const std::array<int64_t, 4>& g) const {
  std::array<int64_t, 4> q{};
  for (int a = 0; a < dimension_; ++a) q[a] = std::min<int64_t>(g[a], int64_t{dims_[a]} - 1);
  size_t unused = 0;
  return BrickOf(0, q, &unused);
}

template <class V>
Result<EncodedBrick> EncodeBrick(const BrickGrid& grid, uint64_t b, const V* field,
                                 VoxelType type, ZstdCompressor* zstd,
                                 std::optional<BrickCoding> only) {
  HeldField<V> whole{field, {1, 1, 1, 1}, 0, 0};  // x fastest
  for (int a = 1; a < 4; ++a) whole.stride[a] = whole.stride[a - 1] * grid.dims()[a - 1];
  return EncodeBrick(grid, b, whole, type, zstd, only);
}

template <class V>
Result<EncodedBrick> EncodeBrick(const BrickGrid& grid, uint64_t b, const HeldField<V>& held,
                                 VoxelType type, ZstdCompressor* zstd,
                                 std::optional<BrickCoding> only) {
  const BrickPlace place = grid.Place(b);
  const int D = grid.dimension();
  assert(place.lattice >= held.shift);
  const std::array<uint32_t, 4>& e = place.extent;
  const std::array<int64_t, 4>& stride = held.stride;
  // In held points: the brick's first point, its step, the window's start.
  std::array<int64_t, 4> first{};
  for (int a = 0; a < 4; ++a) first[a] = int64_t{place.first[a]} >> held.shift;
  first[static_cast<size_t>(D - 1)] -= held.first_plane;
  const V* field = held.data;
  const int64_t step = int64_t{1} << (place.lattice - held.shift);
  const size_t n = BrickVoxels(D, e);
  std::vector<double> values;
  values.reserve(n);
  EncodedBrick out;
  bool any = false;
  for (uint32_t i3 = 0; i3 < e[3]; ++i3) {
    for (uint32_t i2 = 0; i2 < e[2]; ++i2) {
      for (uint32_t i1 = 0; i1 < e[1]; ++i1) {
        int64_t index = (first[1] + i1 * step) * stride[1] + (first[2] + i2 * step) * stride[2] +
                        (first[3] + i3 * step) * stride[3] + first[0];
        for (uint32_t i0 = 0; i0 < e[0]; ++i0, index += step) {
          const double v = static_cast<double>(field[index]);
          values.push_back(v);
          if (std::isnan(v)) continue;
          out.min = any ? std::min(out.min, v) : v;
          out.max = any ? std::max(out.max, v) : v;
          any = true;
        }
      }
    }
  }
  std::vector<uint8_t> voxels(n * VoxelSize(type));
  EncodeVoxels(type, ByteOrder::kLittle, values.data(), n, reinterpret_cast<std::byte*>(voxels.data()));
  const auto tries = [&](BrickCoding c) { return !only || *only == c; };
  // Each coding tried replaces the one kept when smaller (the first always).
  const auto keep = [&](BrickCoding c, std::vector<uint8_t> bytes) {
    if (out.bytes.empty() || bytes.size() < out.bytes.size()) {
      out.coding = c;
      out.bytes = std::move(bytes);
    }
  };
  if (tries(BrickCoding::kRaw) || zstd == nullptr) keep(BrickCoding::kRaw, voxels);
  if (zstd == nullptr) return out;
  if (tries(BrickCoding::kZstd)) {
    SDB_ASSIGN_OR_RETURN(std::vector<uint8_t> plain, zstd->Compress(voxels));
    keep(BrickCoding::kZstd, std::move(plain));
  }
  if (tries(BrickCoding::kZstdPredicted)) {
    std::vector<uint8_t> residuals(voxels.size());
    PredictBrick(type, D, e, voxels, residuals);
    SDB_ASSIGN_OR_RETURN(std::vector<uint8_t> predicted, zstd->Compress(residuals));
    keep(BrickCoding::kZstdPredicted, std::move(predicted));
  }
  return out;
}

#define SDB_ENCODE_BRICK_(V)                                                                 \
  template Result<EncodedBrick> EncodeBrick(const BrickGrid&, uint64_t, const V*, VoxelType, \
                                            ZstdCompressor*, std::optional<BrickCoding>);    \
  template Result<EncodedBrick> EncodeBrick(const BrickGrid&, uint64_t, const HeldField<V>&, \
                                            VoxelType, ZstdCompressor*,                      \
                                            std::optional<BrickCoding>);
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_ENCODE_BRICK_)
#undef SDB_ENCODE_BRICK_

Status DecodeBrick(std::span<const uint8_t> stored, BrickCoding coding, VoxelType type,
                   int dimension, const std::array<uint32_t, 4>& extent, ZstdDecompressor& zstd,
                   std::span<uint8_t> out, std::string_view what) {
  switch (coding) {
    case BrickCoding::kRaw:
      if (stored.size() != out.size()) {
        return Status::Corruption(std::string(what) + ": a raw brick of " +
                                  std::to_string(stored.size()) + " bytes, expected " +
                                  std::to_string(out.size()));
      }
      std::copy(stored.begin(), stored.end(), out.begin());
      return Status::OK();
    case BrickCoding::kZstd:
      return zstd.Decompress(stored, out, what);
    case BrickCoding::kZstdPredicted: {
      std::vector<uint8_t> residuals(out.size());
      SDB_RETURN_IF_ERROR(zstd.Decompress(stored, residuals, what));
      UnpredictBrick(type, dimension, extent, residuals, out);
      return Status::OK();
    }
  }
  return Status::Corruption(std::string(what) + ": unknown brick coding " +
                            std::to_string(static_cast<int>(coding)));
}

}  // namespace simplexdb
