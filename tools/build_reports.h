// What `simplexdb import` and `convert` print about a store they built:
// the builder's report as text or JSON (import_command.cc).
#pragma once

#include <string>

#include "storage/dense/hz_builder.h"
#include "storage/sparse/hz_sparse_builder.h"
#include "storage/volume/volume.h"

namespace simplexdb::tools {

// A dense store built from `input` (the scaling it applied is said).
// `compression` as the option gave it.
void PrintDenseBuild(const HzBuildReport& built, const VolumeInfo& input, const std::string& output,
                     const std::string& compression, bool as_json, bool quiet);

// A sparse store built at `output`.
void PrintSparseBuild(const HzSparseBuildReport& built, const std::string& output, bool as_json,
                      bool quiet);

}  // namespace simplexdb::tools
