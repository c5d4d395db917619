// `simplexdb import`, `info`, `verify` and `export`: building stores from
// volumes and looking at them (the sparse store's side is in
// sparse_commands.cc).
#include <bit>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "query/open_store.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/brick_codec.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_lattice.h"
#include "storage/dense/hz_store.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tools/cli_util.h"
#include "tools/commands.h"
#include "tools/sparse_commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

std::string HierarchyName(int dimension) { return dimension == 3 ? "ht" : "hp"; }


// --- import ----------------------------------------------------------------

struct ImportArgs {
  std::vector<std::string> inputs;
  std::string output;
  std::string hierarchy;
  RawInputOptions raw;
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
};

// The dense store (format 2, storage/dense/hz_builder.h).
// `common`: the options import sets for either store.
void ImportDense(const VolumeInfo& input, const ImportArgs& a, const DenseBuildOptions& common) {
  HzBuildOptions options;
  options.quantization = common.quantization;
  options.compression = common.compression;
  if (common.zstd_level > 0) options.zstd_level = common.zstd_level;
  options.memory_bytes = common.memory_bytes;
  options.threads = common.threads;
  options.mask = common.mask;
  ProgressLine line(!a.quiet);
  options.progress = ProgressTo(line, a.output);
  const Result<HzBuildReport> built = BuildHzStore(input, a.output, options);
  line.Finish();
  if (!built.ok()) Fail(built.status());
  const HzHeader& h = built->header;
  const double points_per_second = built->grid_points / std::max(built->seconds, 1e-9);
  const uint64_t peak = PeakResidentBytes();
  if (a.json) {
    json j;
    SetJsonBytes(j, "store", a.output);
    j["hierarchy"] = HierarchyName(h.dimension);
    j["format_version"] = h.version;
    j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
    j["domain_bits"] = h.domain_bits;
    j["leaf_level"] = h.leaf_level();
    j["grid_points"] = built->grid_points;
    j["seconds"] = built->seconds;
    j["grid_points_per_second"] = points_per_second;
    j["peak_memory_bytes"] = peak;
    j["file_bytes"] = h.file_size;
    j["stored_blocks"] = h.stored_blocks;
    j["error_method"] = built->method;
    if (input.scaled()) j["scaling"] = {{"slope", input.scale}, {"intercept", input.shift}};
    std::cout << j.dump() << "\n";
  } else if (!a.quiet) {
    fmt::print("{}: {} over {} {} (domain 2^{} + 1 per axis, {} levels), {} errors, {}\n",
               a.output, h.dimension == 3 ? "HT" : "HP", FormatDims(h.dimension, h.dims),
               VoxelTypeName(h.voxel_type), h.domain_bits, h.leaf_level(),
               QuantizationName(h.quantization), a.compression);
    if (input.scaled()) {
      fmt::print("  scaled: {} -> {}\n", FormatScaling(input), VoxelTypeName(h.voxel_type));
    }
    fmt::print("  built in {:.2f} s: {:.3g} grid points/s, peak memory {}\n", built->seconds,
               points_per_second, HumanBytes(peak));
    if (std::string(built->method) == "engine") {
      fmt::print("  errors per node through format 1 (a mask or missing values), all stored\n");
    } else if (std::string(built->method) == "streamed") {
      fmt::print("  the field read a window of planes at a time (larger than --memory-mb)\n");
    }
    fmt::print("  {} on disk ({:.2f} bytes per grid point, {} error blocks, {} bricks)\n",
               HumanBytes(h.file_size), static_cast<double>(h.file_size) / built->grid_points,
               h.stored_blocks, h.bricks);
  }
}

void RunImport(ImportArgs a) {
  if (!a.sparse && a.tolerance != "0") throw CommandError("--tolerance needs --sparse", 2);
  const VolumeInfo input = OpenInputs(a.inputs, a.raw);
  const std::string expected = HierarchyName(input.dimension);
  if (!a.hierarchy.empty() && a.hierarchy != expected) {
    throw CommandError(fmt::format("--hierarchy {} needs a {}D volume; {} is {}D ({})", a.hierarchy,
                                   a.hierarchy == "ht" ? 3 : 4, input.description,
                                   input.dimension, FormatDims(input.dimension, input.dims)),
                       2);
  }
  DenseBuildOptions options;
  Result<Quantization> q = ParseQuantization(a.quantization);
  if (!q.ok()) throw CommandError("--quantization: " + std::string(q.status().message()), 2);
  options.quantization = *q;
  Result<Compression> c = ParseCompression(a.compression);
  if (!c.ok()) throw CommandError("--compression: " + std::string(c.status().message()), 2);
  options.compression = *c;
  if (a.memory_mb > (std::numeric_limits<size_t>::max() >> 20)) {  // << 20 would wrap
    throw CommandError(fmt::format("--memory-mb {} is beyond this machine's address space",
                                   a.memory_mb),
                       2);
  }
  options.memory_bytes = a.memory_mb << 20;
  options.threads = a.threads;
  options.zstd_level = a.zstd_level;
  if (!a.mask.empty()) {
    Result<VolumeInfo> mask = OpenVolume(a.mask);
    if (!mask.ok()) Fail(mask.status());
    options.mask = *std::move(mask);
  }
  // Before anything is written: the output is none of the files read, the
  // data files a detached header names included.
  std::vector<std::string> inputs = a.inputs;
  inputs.insert(inputs.end(), input.files.begin(), input.files.end());
  if (options.mask) {
    inputs.push_back(a.mask);
    inputs.insert(inputs.end(), options.mask->files.begin(), options.mask->files.end());
  }
  a.output = CheckOutput(a.output, inputs, a.force);
  if (a.sparse) {
    ImportSparse(input, a.output, options, a.tolerance, a.json, a.quiet);
    return;
  }
  ImportDense(input, a, options);
}

// --- info ------------------------------------------------------------------

void RunHzInfo(const std::string& path, bool as_json) {
  const auto opened = OpenHzStore(path);
  const HzStore& store = *opened;
  const HzHeader& h = store.header();
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
    const HzIndexEntry e = store.brick_entry(b);
    ++codings[e.encoding & 3];
    field_bytes += e.stored_size;
    brick_voxels += BrickVoxels(h.dimension, store.grid().Place(b).extent);
  }
  const uint64_t logical =
      h.stored_blocks * store.block_bytes() + brick_voxels * VoxelSize(h.voxel_type);
  const double per_point = static_cast<double>(h.file_size) / static_cast<double>(points);
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", path);
    j["kind"] = h.dimension == 3 ? "ht-dense" : "hp-dense";
    j["hierarchy"] = HierarchyName(h.dimension);
    j["format_version"] = h.version;
    j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
    j["grid_points"] = points;
    j["spacing"] = std::vector<double>(h.spacing.begin(), h.spacing.begin() + h.dimension);
    j["origin"] = std::vector<double>(h.origin.begin(), h.origin.begin() + h.dimension);
    j["domain_bits"] = h.domain_bits;
    j["domain_side"] = (uint64_t{1} << h.domain_bits) + 1;
    j["leaf_level"] = h.leaf_level();
    j["voxel_type"] = VoxelTypeName(h.voxel_type);
    j["quantization"] = QuantizationName(h.quantization);
    j["quantum"] = h.quantum;
    j["field_min"] = h.field_min;
    j["field_max"] = h.field_max;
    j["error_max"] = h.error_max;
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
    j["bytes_per_grid_point"] = per_point;
    SetJsonBytes(j, "source", h.source);
    std::cout << j.dump() << "\n";
    return;
  }
  fmt::print("{}: dense {} store (format 2, version {}: diamond errors in hierarchical Z-order, "
             "the field in octave bricks)\n",
             path, h.dimension == 3 ? "HT" : "HP", h.version);
  fmt::print("  grid        {} {} ({} points), from {}\n", FormatDims(h.dimension, h.dims),
             VoxelTypeName(h.voxel_type), points, h.source.empty() ? "?" : h.source);
  fmt::print("  placement   {}\n", FormatPlacement(h.dimension, h.spacing, h.origin));
  fmt::print("  domain      side 2^{} + 1 = {}, {} levels ({} roots)\n", h.domain_bits,
             (uint64_t{1} << h.domain_bits) + 1, h.leaf_level(), h.dimension == 3 ? 6 : 24);
  fmt::print("  field       {} .. {}\n", h.field_min, h.field_max);
  fmt::print("  errors      {} (quantum {:.6g}), largest {:.6g} ({:.3g}% of the range)\n",
             QuantizationName(h.quantization), h.quantum, h.error_max,
             h.field_max > h.field_min ? 100 * h.error_max / (h.field_max - h.field_min) : 0.0);
  fmt::print("  blocks      {} blocks of {} errors stored ({} raw, {} zstd) of {} in the padded "
             "domain, {}; the finest octave's {}\n",
             h.stored_blocks, h.block_records(), raw, zstd, h.virtual_blocks, HumanBytes(error_bytes),
             h.finest_stored() ? "stored" : "computed from the field");
  fmt::print("  bricks      {} of {}^{} points ({} raw, {} zstd, {} zstd with prediction), {}\n",
             h.bricks, uint64_t{1} << h.brick_bits, h.dimension, codings[1], codings[2], codings[3],
             HumanBytes(field_bytes));
  fmt::print("  size        {} on disk, {} logical: {:.2f}x, {:.2f} bytes per grid point\n",
             HumanBytes(h.file_size), HumanBytes(logical),
             static_cast<double>(logical) / static_cast<double>(h.file_size), per_point);
}


void RunInfo(const std::string& path, bool as_json) {
  if (ProbeStoreKind(path) == StoreKind::kSparse) {
    RunSparseInfo(path, as_json);
    return;
  }
  RunHzInfo(path, as_json);
}

// --- verify ----------------------------------------------------------------

// Verify reports progress by block, then by brick. `what`: "12 blocks and 40 bricks".
void VerifyStore(const HzStore& store, const std::string& path, const std::string& what, bool quiet) {
  ProgressLine line(!quiet);
  const Status s = store.Verify([&](uint64_t done, uint64_t total) {
    line.Update(fmt::format("{}: verifying {}/{}", path, done, total));
  });
  line.Finish();
  if (!s.ok()) Fail(s);
  if (!quiet) fmt::print("{}: ok ({}, every checksum and value range)\n", path, what);
}

void RunVerify(const std::string& path, bool quiet) {
  if (ProbeStoreKind(path) == StoreKind::kSparse) {
    RunSparseVerify(path, quiet);
    return;
  }
  const auto hz = OpenHzStore(path);  // header, bitmap, index
  VerifyStore(*hz, path,
              fmt::format("{} blocks and {} bricks{}", hz->stored_blocks(), hz->bricks(),
                          hz->header().finest_stored() ? "" : ", the finest errors recomputed"),
              quiet);
}

// --- export ----------------------------------------------------------------

struct ExportArgs {
  std::string store;
  std::string output;
  std::string roi;
  int step = 1;
  bool force = false;
};

template <int D>
void ExportField(const HzStore& store, const ExportArgs& a) {
  const auto& h = store.header();
  std::array<int64_t, 4> lo = {0, 0, 0, 0}, hi = {0, 0, 0, 0};
  for (int c = 0; c < D; ++c) hi[c] = h.dims[c] - 1;
  if (!a.roi.empty()) {
    const std::vector<double> v = ParseNumberList(a.roi, "--roi", 2 * D, 2 * D);
    for (int c = 0; c < D; ++c) {
      lo[c] = static_cast<int64_t>(v[c]);
      hi[c] = static_cast<int64_t>(v[D + c]);
      if (v[c] != std::floor(v[c]) || v[D + c] != std::floor(v[D + c]) || lo[c] < 0 ||
          hi[c] >= h.dims[c] || lo[c] > hi[c]) {
        throw CommandError(fmt::format("--roi: axis {} range {}..{} is not within 0..{}", c,
                                       v[c], v[D + c], h.dims[c] - 1),
                           2);
      }
    }
  }
  if (a.step < 1) throw CommandError("--step must be at least 1", 2);
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  for (int c = 0; c < D; ++c) dims[c] = static_cast<uint32_t>((hi[c] - lo[c]) / a.step + 1);
  uint64_t count = 1;
  for (uint32_t d : dims) count *= d;
  std::vector<double> values(count);
  // A power-of-two step from a multiple of it: one lattice's bricks (a
  // coarse read decodes only them); otherwise point by point.
  const int lattice = std::countr_zero(static_cast<uint64_t>(a.step));
  bool read = (a.step & (a.step - 1)) == 0 && lattice <= h.domain_bits;
  for (int c = 0; c < D; ++c) read = read && lo[c] % a.step == 0;
  if (read) {
    const Status st = ReadLattice(store, lattice, lo, hi, values.data());
    if (!st.ok()) Fail(st);
  }
  HzStore::Reader<D> reader(store);
  std::array<int64_t, D> p{};
  for (uint64_t i = 0; i < count && !read; ++i) {
    uint64_t rest = i;
    for (int c = 0; c < D; ++c) {
      p[c] = lo[c] + static_cast<int64_t>(rest % dims[c]) * a.step;
      rest /= dims[c];
    }
    const Result<double> v = reader.Field(p);
    if (!v.ok()) Fail(v.status());
    values[i] = *v;
  }
  std::array<double, 4> spacing = h.spacing;
  for (int c = 0; c < D; ++c) spacing[c] *= a.step;
  const auto ends_with = [&](std::string_view suffix) {
    return a.output.size() >= suffix.size() &&
           a.output.compare(a.output.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  Status s;
  std::string written = a.output;
  if (ends_with(".nrrd")) {
    s = WriteNrrd(a.output, D, dims, h.voxel_type, values, spacing);
  } else {
    const std::string base = ends_with(".raw") ? a.output.substr(0, a.output.size() - 4) : a.output;
    written = a.output + " and " + base + ".nhdr";
    const std::string nhdr = CheckOutput(base + ".nhdr", {a.store, a.output}, false);
    s = WriteRawWithNhdr(a.output, nhdr, D, dims, h.voxel_type, values, spacing);
  }
  if (!s.ok()) Fail(s);
  fmt::print("{}: {} {} values ({}) written to {}\n", a.store, count, VoxelTypeName(h.voxel_type),
             FormatDims(D, dims), written);
}

}  // namespace

void RegisterStoreCommands(CLI::App& app) {
  {
    auto a = std::make_shared<ImportArgs>();
    auto* cmd = app.add_subcommand(
        "import",
        "Build a store from a volume (dense; or sparse with --sparse): NRRD (.nrrd, .nhdr) and NIfTI-1 (.nii)\n"
        "files describe themselves; raw files need --dims and --type. A 3D volume\n"
        "builds a Hierarchy of Tetrahedra, a 4D one (or several 3D volumes, a time\n"
        "series) a Hierarchy of Pentatopes. Any grid size: the domain is the\n"
        "smallest cube of side 2^k + 1 points covering it (see README: padding).\n"
        "NIfTI scl_slope/scl_inter are applied (a scaled integer volume is stored as\n"
        "float32). NaN marks a missing value; Inf or a value beyond float32's range\n"
        "(+-3.4e38) is an error naming the voxel, and nothing is written.\n"
        "Example: simplexdb import tooth.raw --dims 103,94,161 --type uint8 -o tooth.sdb");
    cmd->add_option("input", a->inputs, "volume file(s); several 3D files form a time series")
        ->required();
    cmd->add_option("-o,--output", a->output, "the store to write")->required();
    cmd->add_option("--hierarchy", a->hierarchy, "ht or hp (checked against the volume)")
        ->check(CLI::IsMember({"ht", "hp"}));
    AddRawInputOptions(cmd, &a->raw, "raw input: X,Y,Z or X,Y,Z,T (x fastest)");
    cmd->add_option("--quantization", a->quantization,
                    "errors as u16 (the seed's 14n bytes), u8 (7n) or f32; always rounded up")
        ->capture_default_str();
    cmd->add_option("--compression", a->compression, "blocks as zstd frames or none (raw)")
        ->capture_default_str();
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
    cmd->add_option("--memory-mb", a->memory_mb, "the builder's memory bound, block index included; a volume larger than it is read a window of planes "
                    "at a time; too small fails at once with the need")
        ->capture_default_str();
    cmd->add_option("--threads", a->threads, "worker threads (0: one per core)")
        ->capture_default_str();
    cmd->add_option("--zstd-level", a->zstd_level,
                    "zstd compression level (default 3; 19 with --sparse, whose blocks are few "
                    "and built for size)")
        ->check(CLI::Range(1, 22));
    cmd->add_flag("--json", a->json, "print the build report as JSON");
    cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
    AddForceOption(cmd, &a->force);
    cmd->callback([a] { RunImport(*a); });
  }
  {
    auto path = std::make_shared<std::string>();
    auto as_json = std::make_shared<bool>(false);
    auto* cmd = app.add_subcommand(
        "info", "Describe a store: kind, grid, levels, value ranges, quantization, sizes on\n"
                "disk against logical, compression ratio.");
    cmd->add_option("store", *path, "a store file")->required();
    cmd->add_flag("--json", *as_json, "as one JSON object");
    cmd->callback([path, as_json] { RunInfo(*path, *as_json); });
  }
  {
    auto path = std::make_shared<std::string>();
    auto quiet = std::make_shared<bool>(false);
    auto* cmd = app.add_subcommand(
        "verify", "Check every checksum and invariant of a store; exit 0 only if all hold,\n"
                  "otherwise 1 with the first bad block named.");
    cmd->add_option("store", *path, "a store file")->required();
    cmd->add_flag("-q,--quiet", *quiet, "no progress or summary");
    cmd->callback([path, quiet] { RunVerify(*path, *quiet); });
  }
  {
    auto a = std::make_shared<ExportArgs>();
    auto* cmd = app.add_subcommand(
        "export",
        "Write a store's field back out: OUT.nrrd as one NRRD file, anything else\n"
        "as raw with a detached NRRD header beside it (OUT.raw + OUT.nhdr). Values\n"
        "are the store's own, losslessly.\n"
        "Example: simplexdb export tooth.sdb --roi 0,0,0,50,50,80 --step 2 -o part.nrrd");
    cmd->add_option("store", a->store, "a store file")->required();
    cmd->add_option("-o,--output", a->output, "OUT.nrrd, or OUT.raw (+ OUT.nhdr)")->required();
    cmd->add_option("--roi", a->roi, "x0,y0,z0[,t0],x1,y1,z1[,t1]: a box of the grid, inclusive");
    cmd->add_option("--step", a->step, "every step-th point along each axis (a coarser resolution)")
        ->capture_default_str();
    AddForceOption(cmd, &a->force);
    cmd->callback([a] {
      a->output = CheckOutput(a->output, {a->store}, a->force);
      if (ProbeStoreKind(a->store) == StoreKind::kSparse) {
        throw CommandError(a->store + " is a sparse store: convert it --to dense to export", 2);
      }
      const auto hz = OpenHzStore(a->store);
      if (hz->dimension() == 3) {
        ExportField<3>(*hz, *a);
      } else {
        ExportField<4>(*hz, *a);
      }
    });
  }
}

}  // namespace simplexdb::tools
