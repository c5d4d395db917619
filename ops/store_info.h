// What a store says about itself: the one description that `simplexdb info
// --json` prints and the Python package's Store.info holds, built in one
// place so the two cannot drift apart.
//
// The object's keys, in this order (values as the header stores them):
//   store, path   the store's path (both the same; "path" is the Python
//                 package's name for it); each with "<key>_hex" when the
//                 path is not valid UTF-8 (util/utf8.h, SetJsonBytes)
//   kind          "ht-dense", "hp-dense", "ht-sparse" or "hp-sparse"
//   hierarchy     "ht" or "hp";  dimension  3 or 4
//   format_version, dims, grid_points, spacing, origin (the used axes only),
//   domain_bits, domain_side, leaf_level, voxel_type, quantization, quantum,
//   field_min, field_max, error_max
//   dense:  block_records, virtual_blocks, stored_blocks, blocks_raw,
//           blocks_zstd, finest_errors, error_bytes, brick_side, bricks,
//           bricks_raw, bricks_zstd, bricks_predicted, field_bytes,
//           file_bytes, logical_bytes, compression_ratio,
//           bytes_per_grid_point
//   sparse: tolerance, value_step, block_bits, blocks, kept,
//           domain_vertices, file_bytes, bytes_per_grid_point
//   source        what the store was built from (with "source_hex" as above)
//
// Thread safety: reads the open store only (its header and index), so it may
// run while other threads query the same store.
//
// Cost: dense, O(stored blocks + bricks) index entries read (no block is
// decoded); sparse, O(1) (the header and the file's size).
//
// Errors: none; the store was validated when it opened.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "query/open_store.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"

namespace simplexdb {

// The description of a dense store opened from `path`.
nlohmann::ordered_json StoreInfoJson(const DenseStore& store, const std::string& path);
// The description of a sparse store opened from `path`.
nlohmann::ordered_json StoreInfoJson(const SparseStore& store, const std::string& path);
// The description of either kind.
nlohmann::ordered_json StoreInfoJson(const AnyStore& store);

}  // namespace simplexdb
