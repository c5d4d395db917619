// The sparse store (LMDB, format 2: storage/sparse/hz_sparse_store.h) in
// the `simplexdb` command: `import --sparse`, `convert`, `update`, and the
// sparse side of `info` and `verify`.
#pragma once

#include <string>

#include "storage/dense/dense_builder.h"
#include "storage/volume/volume.h"

namespace simplexdb::tools {

void RunSparseInfo(const std::string& path, bool as_json);
void RunSparseVerify(const std::string& path, bool quiet);

// Builds the sparse store `output` from `input` in memory with `tolerance`
// ("7.3" absolute or "1%" of the field range); `common` gives the
// quantization, zstd level, threads and memory bound import takes. A mask
// (missing values) is refused: the sparse store does not hold them yet.
void ImportSparse(const VolumeInfo& input, const std::string& output,
                  const DenseBuildOptions& common, const std::string& tolerance, bool as_json,
                  bool quiet);

}  // namespace simplexdb::tools
