#include "ops/import.h"

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "ops/amount.h"

namespace simplexdb {
namespace {

// --spacing or --origin: one finite number per axis; a spacing is not 0
// (negative x, y, z: a flipped axis) and time's is > 0.
Status CheckPlacement(const VolumeInfo& input, const std::vector<double>& v, bool spacing) {
  const char* option = spacing ? "--spacing" : "--origin";
  if (static_cast<int>(v.size()) != input.dimension) {
    return Status::InvalidArgument(fmt::format("{}: {} numbers for a {}D volume ({}); give {}, x first",
                                               option, v.size(), input.dimension,
                                               FormatDims(input.dimension, input.dims),
                                               input.dimension));
  }
  for (size_t a = 0; a < v.size(); ++a) {
    if (!std::isfinite(v[a]) || (spacing && (a < 3 ? v[a] == 0 : !(v[a] > 0)))) {
      return Status::InvalidArgument(fmt::format(
          "{}: {} on axis {} is not {}", option, v[a], a,
          !spacing ? "a finite number"
          : a < 3  ? "a finite non-zero number (negative: a flipped axis)"
                   : "a finite number > 0 (time runs forwards)"));
    }
  }
  return Status::OK();
}

}  // namespace

VolumeInfo PlacedInput(const VolumeInfo& input, const ImportOptions& options) {
  VolumeInfo placed = input;
  for (size_t a = 0; options.spacing && a < options.spacing->size(); ++a) {
    placed.spacing[a] = (*options.spacing)[a];
  }
  for (size_t a = 0; options.origin && a < options.origin->size(); ++a) {
    placed.origin[a] = (*options.origin)[a];
  }
  return placed;
}

Status CheckImport(const VolumeInfo& input, const ImportOptions& options) {
  const std::string expected = input.dimension == 3 ? "ht" : "hp";
  if (!options.hierarchy.empty()) {
    if (options.hierarchy != "ht" && options.hierarchy != "hp") {
      return Status::InvalidArgument("--hierarchy: expected ht or hp, not '" + options.hierarchy + "'");
    }
    if (options.hierarchy != expected) {
      return Status::InvalidArgument(fmt::format(
          "--hierarchy {} needs a {}D volume; {} is {}D ({})", options.hierarchy,
          options.hierarchy == "ht" ? 3 : 4, input.description, input.dimension,
          FormatDims(input.dimension, input.dims)));
    }
  }
  if (options.sparse && options.mask) {
    return Status::InvalidArgument(
        "--mask with --sparse: the sparse store does not take missing values yet; import a "
        "dense store");
  }
  if (options.sparse && options.group != nullptr && options.group->size() > 1) {
    return Status::InvalidArgument(fmt::format(
        "--sparse with {} processes: the sparse store is built by one; run the import in one process, or "
        "build a dense store", options.group->size()));
  }
  SDB_RETURN_IF_ERROR(CheckAmount(options.tolerance, "--tolerance"));
  if (!options.sparse && options.tolerance.value != 0) {
    return Status::InvalidArgument("--tolerance needs --sparse (the dense store is lossless)");
  }
  if (options.threads < 0) {
    return Status::InvalidArgument(
        fmt::format("--threads: expected a count >= 0 (0: one per core), not {}", options.threads));
  }
  if (options.zstd_level != 0 && (options.zstd_level < 1 || options.zstd_level > 22)) {
    return Status::InvalidArgument(
        fmt::format("--zstd-level: expected 1 to 22, not {}", options.zstd_level));
  }
  if (options.spacing) SDB_RETURN_IF_ERROR(CheckPlacement(input, *options.spacing, true));
  if (options.origin) SDB_RETURN_IF_ERROR(CheckPlacement(input, *options.origin, false));
  // Every grid point has a finite place: the last one of each axis too.
  const VolumeInfo placed = PlacedInput(input, options);
  for (int a = 0; a < placed.dimension; ++a) {
    const double last = placed.origin[a] + static_cast<double>(placed.dims[a] - 1) * placed.spacing[a];
    if (!std::isfinite(last)) {
      return Status::InvalidArgument(fmt::format(
          "{}: grid point {} of axis {} would lie at {} (origin {}, spacing {}): the grid's extent must be a "
          "finite number; give a smaller spacing or origin",
          options.spacing ? "--spacing" : (options.origin ? "--origin" : input.description), placed.dims[a] - 1,
          a, last, placed.origin[a], placed.spacing[a]));
    }
  }
  return Status::OK();
}

Result<ImportReport> ImportVolume(const VolumeInfo& input, const std::string& output,
                                  const ImportOptions& options) {
  SDB_RETURN_IF_ERROR(CheckImport(input, options));
  const VolumeInfo placed = PlacedInput(input, options);
  ImportReport report;
  if (options.sparse) {
    SparseBuildOptions o;
    o.quantization = options.quantization;
    if (options.zstd_level > 0) o.zstd_level = options.zstd_level;
    o.memory_bytes = options.memory_bytes;
    o.threads = options.threads;
    o.tolerance = options.tolerance.value;  // a percentage is applied to the range the builder finds
    o.tolerance_percent = options.tolerance.percent;
    o.progress = options.progress;
    SDB_ASSIGN_OR_RETURN(report.sparse, BuildSparseStore(placed, output, o));
    return report;
  }
  DenseBuildOptions o;
  o.quantization = options.quantization;
  o.compression = options.compression;
  if (options.zstd_level > 0) o.zstd_level = options.zstd_level;
  o.memory_bytes = options.memory_bytes;
  o.threads = options.threads;
  o.mask = options.mask;
  o.progress = options.progress;
  o.group = options.group;
  SDB_ASSIGN_OR_RETURN(report.dense, BuildDenseStore(placed, output, o));
  return report;
}

std::string DescribeProgress(const std::string& output, const BuildProgress& p) {
  return fmt::format("{}: {} {}/{} ({:.0f}%), {:.1f} s", output, p.phase, p.done, p.total,
                     p.total ? 100.0 * static_cast<double>(p.done) / static_cast<double>(p.total) : 100.0,
                     p.seconds);
}

}  // namespace simplexdb
