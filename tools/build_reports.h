// What `simplexdb import` and `convert` print about a store they built:
// the builder's report as text or JSON (import_command.cc).
#pragma once

#include <string>
#include <vector>

#include "storage/dense/dense_builder.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/volume/volume.h"

namespace simplexdb::tools {

// A dense store built from `input` (the scaling it applied is said).
// `compression` as the option gave it.
void PrintDenseBuild(const DenseBuildReport& built, const VolumeInfo& input, const std::string& output,
                     const std::string& compression, bool as_json, bool quiet,
                     const std::vector<std::string>& ranks = {});

// A sparse store built at `output`.
void PrintSparseBuild(const SparseBuildReport& built, const std::string& output, bool as_json,
                      bool quiet);

}  // namespace simplexdb::tools
