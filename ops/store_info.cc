#include "ops/store_info.h"

#include <cmath>
#include <cstdint>
#include <vector>

#include "storage/dense/brick_codec.h"
#include "storage/dense/dense_format.h"  // BlockEncoding
#include "storage/error/quantization.h"
#include "storage/volume/voxel_type.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

using json = nlohmann::ordered_json;

// The keys every store has, up to "dims" (the sparse and dense stores then
// order grid_points and the placement differently, as `info --json` always
// has: kept so scripts that print the object see no change).
template <class Header>
json Opening(const Header& h, const std::string& path, const char* kind_suffix) {
  json j;
  SetJsonBytes(j, "store", path);
  SetJsonBytes(j, "path", path);
  j["kind"] = std::string(h.dimension == 3 ? "ht-" : "hp-") + kind_suffix;
  j["hierarchy"] = h.dimension == 3 ? "ht" : "hp";
  j["dimension"] = h.dimension;
  j["format_version"] = h.version;
  j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
  return j;
}

template <class Header>
void Placement(const Header& h, json& j) {
  j["spacing"] = std::vector<double>(h.spacing.begin(), h.spacing.begin() + h.dimension);
  j["origin"] = std::vector<double>(h.origin.begin(), h.origin.begin() + h.dimension);
}

template <class Header>
void Field(const Header& h, json& j) {
  j["voxel_type"] = VoxelTypeName(h.voxel_type);
  j["quantization"] = QuantizationName(h.quantization);
  j["quantum"] = h.quantum;
  j["field_min"] = h.field_min;
  j["field_max"] = h.field_max;
  j["error_max"] = h.error_max;
}

}  // namespace

json StoreInfoJson(const DenseStore& store, const std::string& path) {
  const DenseHeader& h = store.header();
  uint64_t points = 1;
  for (int a = 0; a < h.dimension; ++a) points *= h.dims[a];
  uint64_t raw = 0, zstd = 0;
  for (uint64_t i = 0; i < h.stored_blocks; ++i) {
    ++(store.entry(i).encoding == static_cast<uint8_t>(BlockEncoding::kRaw) ? raw : zstd);
  }
  // Bricks by coding (1 raw, 2 zstd, 3 zstd of Lorenzo residuals), and the
  // bytes of each kind stored.
  uint64_t codings[4] = {0, 0, 0, 0}, error_bytes = 0, field_bytes = 0, brick_voxels = 0;
  for (uint64_t i = 0; i < h.stored_blocks; ++i) error_bytes += store.entry(i).stored_size;
  for (uint64_t b = 0; b < h.bricks; ++b) {
    const DenseIndexEntry e = store.brick_entry(b);
    ++codings[e.encoding & 3];
    field_bytes += e.stored_size;
    brick_voxels += BrickVoxels(h.dimension, store.grid().Place(b).extent);
  }
  const uint64_t logical = h.stored_blocks * store.block_bytes() + brick_voxels * VoxelSize(h.voxel_type);
  json j = Opening(h, path, "dense");
  j["grid_points"] = points;
  Placement(h, j);
  j["domain_bits"] = h.domain_bits;
  j["domain_side"] = (uint64_t{1} << h.domain_bits) + 1;
  j["leaf_level"] = h.leaf_level();
  Field(h, j);
  j["block_records"] = h.block_records();
  j["virtual_blocks"] = h.virtual_blocks;
  j["stored_blocks"] = h.stored_blocks;
  j["blocks_raw"] = raw;
  j["blocks_zstd"] = zstd;
  j["finest_errors"] = h.finest_stored() ? "stored" : "computed";
  j["error_bytes"] = error_bytes;
  j["brick_side"] = uint64_t{1} << h.brick_bits;
  j["bricks"] = h.bricks;
  j["bricks_raw"] = codings[1];
  j["bricks_zstd"] = codings[2];
  j["bricks_predicted"] = codings[3];
  j["field_bytes"] = field_bytes;
  j["file_bytes"] = h.file_size;
  j["logical_bytes"] = logical;
  j["compression_ratio"] = static_cast<double>(logical) / static_cast<double>(h.file_size);
  j["bytes_per_grid_point"] = static_cast<double>(h.file_size) / static_cast<double>(points);
  SetJsonBytes(j, "source", h.source);
  return j;
}

json StoreInfoJson(const SparseStore& store, const std::string& path) {
  const SparseHeader& h = store.header();
  const uint64_t points = h.points();
  const uint64_t bytes = store.file_bytes();
  json j = Opening(h, path, "sparse");
  Placement(h, j);
  j["grid_points"] = points;
  j["domain_bits"] = h.domain_bits;
  j["domain_side"] = (uint64_t{1} << h.domain_bits) + 1;
  j["leaf_level"] = h.dimension * h.domain_bits;
  Field(h, j);
  j["tolerance"] = h.tolerance;
  j["value_step"] = h.value_step;
  j["block_bits"] = h.block_bits;
  j["blocks"] = h.blocks;
  j["kept"] = h.kept;
  j["domain_vertices"] = std::pow(std::ldexp(1.0, h.domain_bits) + 1, h.dimension);  // (2^k + 1)^D
  j["file_bytes"] = bytes;
  j["bytes_per_grid_point"] = static_cast<double>(bytes) / static_cast<double>(points);
  SetJsonBytes(j, "source", h.source);
  return j;
}

json StoreInfoJson(const AnyStore& store) {
  if (store.dense() != nullptr) return StoreInfoJson(*store.dense(), store.path());
  return StoreInfoJson(*store.sparse(), store.path());
}

}  // namespace simplexdb
