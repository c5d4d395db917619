// The sparse (LMDB) store in the `simplexdb` command: `import --sparse`,
// `convert`, and the sparse side of `info` and `verify`.
#pragma once

#include <string>

#include "storage/dense/dense_builder.h"
#include "storage/volume/volume.h"

namespace simplexdb::tools {

void RunSparseInfo(const std::string& path, bool as_json);
void RunSparseVerify(const std::string& path, bool quiet);

// Builds a dense store from `input` as a scratch file of `output`
// (`<output>.tmp.<pid>.dense`, storage/io/file.h), converts it with
// `tolerance` ("7.3" absolute or "1%" of the field range), removes the
// scratch file.
void ImportSparse(const VolumeInfo& input, const std::string& output, DenseBuildOptions options,
                  const std::string& tolerance, bool as_json, bool quiet);

}  // namespace simplexdb::tools
