#include "query/import_volume.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

namespace simplexdb {

Status CheckImport(const VolumeInfo& input, const ImportOptions& options) {
  const std::string expected = input.dimension == 3 ? "ht" : "hp";
  if (!options.hierarchy.empty()) {
    if (options.hierarchy != "ht" && options.hierarchy != "hp") {
      return Status::InvalidArgument("hierarchy: expected ht or hp, not '" + options.hierarchy + "'");
    }
    if (options.hierarchy != expected) {
      return Status::InvalidArgument(fmt::format(
          "hierarchy {} needs a {}D volume; {} is {}D ({})", options.hierarchy,
          options.hierarchy == "ht" ? 3 : 4, input.description, input.dimension,
          FormatDims(input.dimension, input.dims)));
    }
  }
  if (options.sparse && options.mask) {
    return Status::InvalidArgument(
        "mask with a sparse store: the sparse store does not take missing values yet; import a "
        "dense store");
  }
  if (!options.sparse && options.tolerance != 0) {
    return Status::InvalidArgument("tolerance needs a sparse store (the dense store is lossless)");
  }
  if (!(options.tolerance >= 0) || !std::isfinite(options.tolerance)) {
    return Status::InvalidArgument(
        fmt::format("tolerance: expected a number >= 0, not {}", options.tolerance));
  }
  return Status::OK();
}

Result<ImportReport> ImportVolume(const VolumeInfo& input, const std::string& output,
                                  const ImportOptions& options) {
  SDB_RETURN_IF_ERROR(CheckImport(input, options));
  ImportReport report;
  if (options.sparse) {
    HzSparseBuildOptions o;
    o.quantization = options.quantization;
    if (options.zstd_level > 0) o.zstd_level = options.zstd_level;
    o.memory_bytes = options.memory_bytes;
    o.threads = options.threads;
    o.tolerance = options.tolerance;
    o.tolerance_percent = options.tolerance_percent;
    o.progress = options.progress;
    SDB_ASSIGN_OR_RETURN(report.sparse, BuildHzSparseStore(input, output, o));
    return report;
  }
  HzBuildOptions o;
  o.quantization = options.quantization;
  o.compression = options.compression;
  if (options.zstd_level > 0) o.zstd_level = options.zstd_level;
  o.memory_bytes = options.memory_bytes;
  o.threads = options.threads;
  o.mask = options.mask;
  o.progress = options.progress;
  SDB_ASSIGN_OR_RETURN(report.dense, BuildHzStore(input, output, o));
  return report;
}

std::string DescribeProgress(const std::string& output, const BuildProgress& p) {
  return fmt::format("{}: {} {}/{} ({:.0f}%), {:.1f} s", output, p.phase, p.done, p.total,
                     p.total ? 100.0 * static_cast<double>(p.done) / static_cast<double>(p.total) : 100.0,
                     p.seconds);
}

}  // namespace simplexdb
