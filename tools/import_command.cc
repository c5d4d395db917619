// `simplexdb import`: a volume into a dense or a sparse store, through
// ImportVolume (ops/import.h), which the Python package's import_volume
// calls too. Here: the options parsed, the report printed.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ops/import.h"
#include "ops/process_memory.h"
#include "storage/volume/generate.h"
#include "tools/build_reports.h"
#include "tools/cli_util.h"
#include "tools/commands.h"
#include "parallel/mpi_session.h"

namespace simplexdb::tools {

namespace {

using json = nlohmann::ordered_json;

// Domain vertices: (2^k + 1)^D.
double DomainVertices(const SparseHeader& h) {
  return std::pow(std::ldexp(1.0, h.domain_bits) + 1, h.dimension);
}

}  // namespace

void PrintDenseBuild(const DenseBuildReport& built, const VolumeInfo& input, const std::string& output,
                     const std::string& compression, bool as_json, bool quiet,
                     const std::vector<std::string>& ranks) {
  std::vector<json> per_rank;
  for (const std::string& text : ranks) per_rank.push_back(json::parse(text));
  const DenseHeader& h = built.header;
  const double points_per_second = built.grid_points / std::max(built.seconds, 1e-9);
  const uint64_t peak = PeakResidentBytes();
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["hierarchy"] = h.dimension == 3 ? "ht" : "hp";
    j["format_version"] = h.version;
    j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
    j["domain_bits"] = h.domain_bits;
    j["leaf_level"] = h.leaf_level();
    j["grid_points"] = built.grid_points;
    j["seconds"] = built.seconds;
    j["grid_points_per_second"] = points_per_second;
    j["peak_memory_bytes"] = peak;
    j["file_bytes"] = h.file_size;
    j["stored_blocks"] = h.stored_blocks;
    j["error_method"] = built.method;
    j["windows"] = built.windows;
    j["window_planes"] = built.window_planes;
    if (!per_rank.empty()) j["ranks"] = per_rank;
    if (input.scaled()) j["scaling"] = {{"slope", input.scale}, {"intercept", input.shift}};
    std::cout << j.dump() << "\n";
    return;
  }
  if (quiet) return;
  fmt::print("{}: {} over {} {} (domain 2^{} + 1 per axis, {} levels), {} errors, {}\n", output,
             h.dimension == 3 ? "HT" : "HP", FormatDims(h.dimension, h.dims), VoxelTypeName(h.voxel_type),
             h.domain_bits, h.leaf_level(), QuantizationName(h.quantization), compression);
  if (input.scaled()) {
    fmt::print("  scaled: {} -> {}\n", FormatScaling(input), VoxelTypeName(h.voxel_type));
  }
  fmt::print("  built in {:.2f} s: {:.3g} grid points/s, peak memory {}\n", built.seconds,
             points_per_second, HumanBytes(peak));
  if (built.windows > 1) {
    fmt::print("  the field read in {} windows of {} planes (the whole field exceeds --memory-mb)\n",
               built.windows, built.window_planes);
  }
  fmt::print("  {} on disk ({:.2f} bytes per grid point, {} error blocks of the {} written (those of zeros "
             "not kept), {} bricks)\n",
             HumanBytes(h.file_size), static_cast<double>(h.file_size) / built.grid_points,
             h.stored_blocks, built.candidate_blocks, h.bricks);
  for (const json& r : per_rank) {
    fmt::print("  rank {}: {} of the {} slabs, {:.2f} s, peak memory {}, {} sent in {} exchanges\n",
               r["rank"].get<int>(), r["slabs"].get<int>(), built.windows, r["seconds"].get<double>(),
               HumanBytes(r["peak_memory_bytes"].get<uint64_t>()), HumanBytes(r["payload_bytes_sent"].get<uint64_t>()),
               r["collectives"].get<uint64_t>());
  }
}

void PrintSparseBuild(const SparseBuildReport& r, const std::string& output, bool as_json, bool quiet) {
  const SparseHeader& h = r.header;
  const double points = static_cast<double>(h.points());
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["kind"] = h.dimension == 3 ? "ht-sparse" : "hp-sparse";
    j["format_version"] = h.version;
    j["tolerance"] = h.tolerance;
    j["kept"] = h.kept;
    j["blocks"] = h.blocks;
    j["rounds"] = r.rounds;
    j["kept_by_check"] = r.kept_by_check;
    j["seconds"] = r.seconds;
    j["grid_points_per_second"] = points / std::max(r.seconds, 1e-9);
    j["file_bytes"] = r.file_bytes;
    j["bytes_per_grid_point"] = static_cast<double>(r.file_bytes) / points;
    j["peak_memory_bytes"] = PeakResidentBytes();
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: sparse {} store, tolerance {:.6g}: {} of {:.4g} vertices kept ({:.3g}%) in {} "
               "blocks\n",
               output, h.dimension == 3 ? "HT" : "HP", h.tolerance, h.kept, DomainVertices(h),
               100.0 * static_cast<double>(h.kept) / DomainVertices(h), h.blocks);
    fmt::print("  built in {:.2f} s ({:.3g} grid points/s); {} on disk ({:.2f} bytes per grid "
               "point), peak memory {}\n",
               r.seconds, points / std::max(r.seconds, 1e-9), HumanBytes(r.file_bytes),
               static_cast<double>(r.file_bytes) / points, HumanBytes(PeakResidentBytes()));
  }
}

namespace {

struct ImportArgs {
  std::vector<std::string> inputs;
  std::string output;
  std::string hierarchy;
  RawInputOptions raw;
  std::string spacing, origin;
  std::string quantization = "u16";
  std::string compression = "zstd";
  bool sparse = false;
  std::string tolerance = "0";
  std::string mask;
  size_t memory_mb = 1024;
  int threads = 0;
  int zstd_level = 0;  // 0: the store's default
  bool json = false;
  bool quiet = false;
  bool force = false;
  // --field: a generated field instead of a file (GeneratedVolume); none
  // unless given.
  FieldArgs f = {.field = ""};
};

// The volume to build: the input files, or with --field the field that
// `simplexdb generate` would write with the same options, computed as read.
VolumeInfo ImportInput(const ImportArgs& a) {
  if (a.f.field.empty()) {
    if (a.inputs.empty()) throw CommandError("give a volume file to import, or --field to generate one", 2);
    return OpenInputs(a.inputs, a.raw);
  }
  if (!a.inputs.empty()) {
    throw CommandError("--field generates the volume: give no input file with it (" + a.inputs[0] + ")", 2);
  }
  if (a.raw.dims.empty()) throw CommandError("--field needs --dims X,Y,Z or X,Y,Z,T", 2);
  if (a.raw.offset != 0 || a.raw.endian != "little") {
    throw CommandError("--offset and --endian describe raw files, not a generated field", 2);
  }
  const GenerateOptions g = ParseFieldOptions(a.f, a.raw.dims);
  Result<VoxelType> type = ParseVoxelType(a.raw.type.empty() ? "float32" : a.raw.type);
  if (!type.ok()) throw CommandError("--type: " + std::string(type.status().message()), 2);
  Result<VolumeInfo> v = GeneratedVolume(g, *type);
  if (!v.ok()) throw CommandError(std::string(v.status().message()), 2);
  return *std::move(v);
}

// The options parsed and checked against `input`, a.output resolved.
ImportOptions PrepareImport(ImportArgs& a, const VolumeInfo& input) {
  ImportOptions options;
  options.hierarchy = a.hierarchy;
  Result<Quantization> q = ParseQuantization(a.quantization);
  if (!q.ok()) throw CommandError("--quantization: " + std::string(q.status().message()), 2);
  options.quantization = *q;
  Result<Compression> c = ParseCompression(a.compression);
  if (!c.ok()) throw CommandError("--compression: " + std::string(c.status().message()), 2);
  options.compression = *c;
  options.memory_bytes = MebibytesOption(a.memory_mb);
  options.threads = a.threads;
  options.zstd_level = a.zstd_level;
  options.sparse = a.sparse;
  options.tolerance = ParseAmountOption(a.tolerance, "--tolerance");
  if (!a.spacing.empty()) options.spacing = ParseNumberList(a.spacing, "--spacing", 1, 4);
  if (!a.origin.empty()) options.origin = ParseNumberList(a.origin, "--origin", 1, 4);
  if (!a.mask.empty()) {
    Result<VolumeInfo> mask = OpenVolume(a.mask);
    if (!mask.ok()) Fail(mask.status());
    options.mask = *std::move(mask);
  }
  CheckUsage(CheckImport(input, options));
  // Before anything is written: the output is none of the files read, the
  // data files a detached header names included.
  std::vector<std::string> inputs = a.inputs;
  inputs.insert(inputs.end(), input.files.begin(), input.files.end());
  if (options.mask) {
    inputs.push_back(a.mask);
    inputs.insert(inputs.end(), options.mask->files.begin(), options.mask->files.end());
  }
  a.output = CheckOutput(a.output, inputs, a.force);
  return options;
}

// Under mpirun with several ranks: one store, built by every rank from its
// own slabs of the input (DenseBuildOptions::group); rank 0 prints the
// report, with each rank's slabs, time, memory and exchanges.
void RunImportTogether(ImportArgs a, MpiSession& mpi) {
  std::optional<VolumeInfo> input;
  ImportOptions options;
  Together(mpi, [&]() -> Status {
    input.emplace(ImportInput(a));
    options = PrepareImport(a, *input);
    options.group = &mpi;
    // The machine's cores shared among its ranks, unless --threads says.
    if (options.threads == 0) {
      options.threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / mpi.local_size());
    }
    return CheckImport(*input, options);  // --sparse refused
  });
  ProgressLine line(mpi.rank() == 0 && !a.quiet && !a.json);
  options.progress = ProgressTo(line, a.output);
  const Result<ImportReport> imported = ImportVolume(*input, a.output, options);
  line.Finish();
  if (!imported.ok()) Fail(imported.status());  // the same on every rank: the build agrees on it
  const DenseBuildReport& built = *imported->dense;
  json mine;
  mine["rank"] = mpi.rank();
  mine["slabs"] = built.slabs_built;
  mine["seconds"] = built.seconds;
  mine["peak_memory_bytes"] = PeakResidentBytes();
  mine["collectives"] = mpi.collective_calls();
  mine["payload_bytes_sent"] = mpi.payload_bytes();
  Result<std::vector<std::string>> all = mpi.Gather(mine.dump());
  if (!all.ok()) Fail(all.status());
  if (mpi.rank() == 0) PrintDenseBuild(built, *input, a.output, a.compression, a.json, a.quiet, *all);
}

void RunImport(ImportArgs a) {
  if (MpiSession* mpi = MpiSession::Current(); mpi != nullptr && mpi->size() > 1) {
    RunImportTogether(std::move(a), *mpi);
    return;
  }
  const VolumeInfo input = ImportInput(a);
  ImportOptions options = PrepareImport(a, input);
  ProgressLine line(!a.quiet && !(a.sparse && a.json));
  options.progress = ProgressTo(line, a.output);
  const Result<ImportReport> imported = ImportVolume(input, a.output, options);
  line.Finish();
  if (!imported.ok()) Fail(imported.status());
  if (imported->dense) {
    PrintDenseBuild(*imported->dense, input, a.output, a.compression, a.json, a.quiet);
    return;
  }
  PrintSparseBuild(*imported->sparse, a.output, a.json, a.quiet);
  if (input.scaled() && !a.quiet && !a.json) {
    fmt::print("  scaled: {} -> {}\n", FormatScaling(input), VoxelTypeName(imported->sparse->header.voxel_type));
  }
}

// `simplexdb import --help`.
constexpr const char* kImportHelp = R"(Build a store from a volume (dense; or sparse with --sparse): NRRD (.nrrd, .nhdr) and NIfTI-1 (.nii)
files describe themselves; raw files need --dims and --type. A 3D volume
builds a Hierarchy of Tetrahedra, a 4D one (or several 3D volumes, a time
series) a Hierarchy of Pentatopes. Any grid size: the domain is the
smallest cube of side 2^k + 1 points covering it (docs/features.md: padding).
NIfTI scl_slope/scl_inter are applied (a scaled integer volume is stored as
float32). NaN marks a missing value; Inf or a value beyond float32's range
(+-3.4e38) is an error naming the voxel, and nothing is written.
Under mpirun -np N the ranks build one dense store together, each reading
only its slabs of planes (and a halo) within --memory-mb: the same file,
byte for byte, as one process builds; rank 0 prints the report.
With --field no file is read: the generated field (as `simplexdb generate`) is computed as it is built.
Example: simplexdb import tooth.raw --dims 103,94,161 --type uint8 -o tooth.sdb
         mpirun -np 4 simplexdb import --field perlin --dims 2049,2049,2049 --type uint8 -o p2049.sdb)";

}  // namespace

void RegisterImportCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<ImportArgs>(app, "import", kImportHelp, RunImport);
  cmd->add_option("input", a->inputs, "volume file(s); several 3D files form a time series");
  AddOutputOptions(cmd, &a->output, &a->force, "the store to write");
  cmd->add_option("--hierarchy", a->hierarchy, "ht or hp (checked against the volume)")
      ->check(CLI::IsMember({"ht", "hp"}));
  AddRawInputOptions(cmd, &a->raw, "raw input: X,Y,Z or X,Y,Z,T (x fastest)");
  cmd->add_option("--spacing", a->spacing,
                  "grid spacing X,Y,Z[,T]; a negative X, Y or Z flips that axis, as "
                  "--spacing=-2,2,2.2 (stored in the header; replaces the file's)");
  cmd->add_option("--origin", a->origin,
                  "position of grid point 0, X,Y,Z[,T] (stored in the header; replaces the file's)");
  cmd->add_option("--quantization", a->quantization,
                  "errors as u16 (the seed's 14n bytes), u8 (7n) or f32; always rounded up")
      ->capture_default_str();
  cmd->add_option("--compression", a->compression, "blocks as zstd frames or none (raw)")->capture_default_str();
  cmd->add_flag("--sparse", a->sparse,
                "build the variable-resolution LMDB store instead (in memory: 8 bytes "
                "per grid point and 23 per vertex near the grid)");
  cmd->add_option("--tolerance", a->tolerance,
                  "--sparse: drop the diamonds whose errors are within this, and keep the "
                  "rest's values to within it (7.3, or 1% of the field range; 0: lossless)")
      ->capture_default_str();
  cmd->add_option("--mask", a->mask,
                  "a volume of the same grid, 0 where the field is not available: those points "
                  "become missing values (NaN; integer fields are then stored as float32). NaN "
                  "in a float input is missing too")
      ->check(CLI::ExistingFile);
  AddMemoryOption(cmd, &a->memory_mb,
                  "the builder's memory bound, block index included; a volume larger than it is read a "
                  "window of planes at a time; too small fails at once with the need");
  AddThreadsOption(cmd, &a->threads);
  cmd->add_option("--zstd-level", a->zstd_level,
                  "zstd compression level (default 3; 19 with --sparse, whose blocks are few "
                  "and built for size)")
      ->check(CLI::Range(1, 22));
  AddReportFlags(cmd, &a->json, &a->quiet, "print the build report as JSON");
  cmd->add_option("--field", a->f.field,
                  "no input file: build the field `simplexdb generate --field NAME` writes with the same "
                  "--dims, --type (default float32), --seed, --octaves, --frequency and --constant, computed "
                  "as it is read (under mpirun each rank computes its own planes)");
  cmd->add_option("--seed", a->f.seed, "--field: random seed")->capture_default_str();
  cmd->add_option("--octaves", a->f.octaves, "--field: Perlin octaves")->capture_default_str();
  cmd->add_option("--frequency", a->f.frequency, "--field: periods across the domain")
      ->capture_default_str()->check(DecimalNumber());
  cmd->add_option("--constant", a->f.constant, "--field constant: its value")->check(DecimalNumber());
}

}  // namespace simplexdb::tools
