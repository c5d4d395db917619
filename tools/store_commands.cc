// `simplexdb import`, `info`, `verify` and `export`: building stores from
// volumes and looking at them (the sparse store's side is in
// sparse_commands.cc).
#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "query/import_volume.h"
#include "query/open_store.h"
#include "query/pvd_writer.h"
#include "query/read_grid.h"
#include "query/store_info.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/brick_codec.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_store.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "storage/volume/vti_writer.h"
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

// The dense store (format 2, storage/dense/hz_builder.h), built by
// ImportVolume (query/import_volume.h, shared with the Python package).
// `common`: the options import sets for either store.
void ImportDense(const VolumeInfo& input, const ImportArgs& a, const DenseBuildOptions& common) {
  ImportOptions options;
  options.quantization = common.quantization;
  options.compression = common.compression;
  options.zstd_level = common.zstd_level;
  options.memory_bytes = common.memory_bytes;
  options.threads = common.threads;
  options.mask = common.mask;
  ProgressLine line(!a.quiet);
  options.progress = ProgressTo(line, a.output);
  const Result<ImportReport> imported = ImportVolume(input, a.output, options);
  line.Finish();
  if (!imported.ok()) Fail(imported.status());
  const HzBuildReport* built = &*imported->dense;
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
  {
    ImportOptions hierarchy;  // CheckImport's message starts with the option's name
    hierarchy.hierarchy = a.hierarchy;
    if (const Status s = CheckImport(input, hierarchy); !s.ok()) {
      throw CommandError("--" + std::string(s.message()), 2);
    }
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
  // The counts are the library's (query/store_info.h), so the text and the
  // JSON (and the Python package's Store.info) say the same.
  const json j = StoreInfoJson(store, path);
  if (as_json) {
    std::cout << j.dump() << "\n";
    return;
  }
  const auto n = [&](const char* key) { return j[key].get<uint64_t>(); };
  const uint64_t points = n("grid_points"), error_bytes = n("error_bytes"), field_bytes = n("field_bytes");
  const uint64_t raw = n("blocks_raw"), zstd = n("blocks_zstd");
  const uint64_t codings[4] = {0, n("bricks_raw"), n("bricks_zstd"), n("bricks_predicted")};
  const uint64_t logical = n("logical_bytes");
  const double per_point = j["bytes_per_grid_point"].get<double>();
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
  std::string time;  // empty: not given
  int step = 1;
  bool force = false;
};

bool EndsWith(const std::string& s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The box --roi, --time and --step ask for. With --time (a 4D store only)
// the box is the one time step T and --roi has the three space axes;
// without it --roi has every axis of the store.
template <int D>
ExportBox ResolveExportBox(const HzStore& store, const ExportArgs& a) {
  const HzHeader& h = store.header();
  ExportBox box;
  for (int c = 0; c < D; ++c) box.hi[c] = h.dims[c] - 1;
  if (a.step < 1) throw CommandError("--step must be at least 1", 2);
  box.step = a.step;
  int roi_axes = D;
  if (!a.time.empty()) {
    if (D != 4) {
      throw CommandError(fmt::format("--time: {} is a 3D (HT) store; it has no time axis (leave "
                                     "--time out)",
                                     a.store),
                         2);
    }
    const double t = ParseNumberList(a.time, "--time", 1, 1)[0];
    if (t != std::floor(t) || t < 0 || t > h.dims[3] - 1) {
      throw CommandError(fmt::format("--time {}: not a time step of {}: expected a whole number "
                                     "in 0..{} (grid units)",
                                     a.time, a.store, h.dims[3] - 1),
                         2);
    }
    box.lo[3] = box.hi[3] = static_cast<int64_t>(t);
    roi_axes = 3;
  }
  if (!a.roi.empty()) {
    const size_t n = 2 * static_cast<size_t>(roi_axes);
    if (D == 4 && roi_axes == 3 && ParseNumberList(a.roi, "--roi", 1, 8).size() == 8) {
      throw CommandError("--roi with --time is x0,y0,z0,x1,y1,z1: --time gives the time", 2);
    }
    const std::vector<double> v = ParseNumberList(a.roi, "--roi", n, n);
    for (int c = 0; c < roi_axes; ++c) {
      const double from = v[static_cast<size_t>(c)], to = v[static_cast<size_t>(roi_axes + c)];
      box.lo[c] = static_cast<int64_t>(from);
      box.hi[c] = static_cast<int64_t>(to);
      if (from != std::floor(from) || to != std::floor(to) || box.lo[c] < 0 ||
          box.hi[c] >= h.dims[c] || box.lo[c] > box.hi[c]) {
        throw CommandError(fmt::format("--roi: axis {} range {}..{} is not within 0..{}", c, from,
                                       to, h.dims[c] - 1),
                           2);
      }
    }
  }
  return box;
}

// The points of `box` (every box.step-th, x fastest; along t too, unless
// the box is one time step) as read from the store (ReadGridBox,
// query/read_grid.h, which Store.export in Python reads through too);
// `dims` gets the count per axis.
template <int D>
std::vector<double> ReadExportBox(const HzStore& store, const ExportBox& box,
                                  std::array<uint32_t, 4>* dims) {
  *dims = ExportDims(box, D);
  Result<std::vector<double>> values = ReadGridBox(store, box);
  if (!values.ok()) Fail(values.status());
  return *std::move(values);
}

// The physical placement of a box: voxel size (the store's spacing times the
// step) and the position of its first point, origin + lo * spacing.
struct ExportGeometry {
  std::array<double, 4> spacing = {1, 1, 1, 1};
  std::array<double, 4> origin = {0, 0, 0, 0};
};

ExportGeometry GeometryOf(const HzHeader& h, const ExportBox& box, int dimension) {
  ExportGeometry g;
  for (int c = 0; c < dimension; ++c) {
    g.spacing[c] = h.spacing[c] * box.step;
    g.origin[c] = h.origin[c] + static_cast<double>(box.lo[c]) * h.spacing[c];
  }
  return g;
}

// An image of a store with flipped axes (negative spacing), written so that
// every reader places it right: VTK's NRRD reader, and so ParaView, keeps a
// space direction's length and drops its sign. Each flipped axis of
// `values` (x fastest, `dims`) is reversed and `g` moved to its last sample
// with a positive spacing: the same voxels at the same places. O(values).
void WriteFlippedAxesForwards(std::vector<double>& values, const std::array<uint32_t, 4>& dims,
                              ExportGeometry& g) {
  const size_t nx = dims[0], ny = dims[1];
  for (size_t c = 0; c < 3; ++c) {
    if (!(g.spacing[c] < 0)) continue;
    g.origin[c] += static_cast<double>(dims[c] - 1) * g.spacing[c];
    g.spacing[c] = -g.spacing[c];
    const size_t stride = c == 0 ? 1 : c == 1 ? nx : nx * ny;
    const size_t n = dims[c];
    for (size_t start = 0; start < values.size(); ++start) {
      // Each line along axis c starts where its index on c is 0.
      if ((start / stride) % n != 0) continue;
      for (size_t i = 0, j = n - 1; i < j; ++i, --j) {
        std::swap(values[start + i * stride], values[start + j * stride]);
      }
    }
  }
}

// A 4D store without --time, to OUT.nrrd or OUT.pvd: one 3D image per time
// step, OUT_t<t>.nrrd (VTK's NRRD reader, Slicer, ITK) or OUT_t<t>.vti
// (ParaView's .pvd reader opens VTK XML files only), t the grid time (four
// digits or more), and OUT.pvd listing them with their times, origin[3] +
// t * spacing[3]. All files are written to their temporaries first and
// renamed after the last is complete, the .pvd last: a failure while
// writing leaves none of them, and a .pvd never names a missing file (a
// rename failing part-way leaves the steps renamed before it, complete).
// Cost: one open file per step until the renames, so a series longer than
// the descriptor limit (ulimit -n) fails, ResourceExhausted, before any
// file appears; memory for one step's values at a time.
void ExportTimeSeries(const HzStore& store, const ExportArgs& a, const ExportBox& box) {
  const HzHeader& h = store.header();
  const bool vti = EndsWith(a.output, ".pvd");
  const std::string stem = a.output.substr(0, a.output.size() - (vti ? 4 : 5));
  const char* ext = vti ? "vti" : "nrrd";
  const size_t slash = stem.find_last_of('/');
  const int width = std::max<int>(4, static_cast<int>(std::to_string(h.dims[3] - 1).size()));
  std::vector<std::unique_ptr<AtomicFileWriter>> files;
  std::vector<PvdDataSet> steps;  // time, file name without folder
  uint64_t count = 0;
  std::array<uint32_t, 4> dims{};
  for (int64_t t = box.lo[3]; t <= box.hi[3]; t += box.step) {
    ExportBox one = box;
    one.lo[3] = one.hi[3] = t;
    std::vector<double> values = ReadExportBox<4>(store, one, &dims);
    ExportGeometry g = GeometryOf(h, one, 4);
    WriteFlippedAxesForwards(values, dims, g);
    const std::string name = fmt::format("{}_t{:0{}}.{}", stem, t, width, ext);
    const std::string path = CheckOutput(name, {a.store}, a.force);
    const std::array<double, 3> origin = {g.origin[0], g.origin[1], g.origin[2]};
    Result<std::unique_ptr<AtomicFileWriter>> file =
        vti ? PrepareVti(path, {dims[0], dims[1], dims[2]}, h.voxel_type, values,
                         {g.spacing[0], g.spacing[1], g.spacing[2]}, origin)
            : PrepareNrrd(path, 3, {dims[0], dims[1], dims[2], 1}, h.voxel_type, values,
                          g.spacing, origin);
    if (!file.ok()) Fail(file.status());
    files.push_back(*std::move(file));
    steps.push_back({g.origin[3], slash == std::string::npos ? name : name.substr(slash + 1)});
    count += values.size();
  }
  for (auto& f : files) {
    if (const Status st = f->Commit(); !st.ok()) Fail(st);
  }
  files.clear();
  const std::string pvd_path = CheckOutput(stem + ".pvd", {a.store}, a.force);
  if (const Status st = WritePvd(steps, pvd_path); !st.ok()) Fail(st);
  fmt::print("{}: {} {} values ({} in {} time steps) written to {}_t*.{} and {}.pvd\n", a.store,
             count, VoxelTypeName(h.voxel_type), FormatDims(3, dims), steps.size(), stem, ext, stem);
}

template <int D>
void ExportField(const HzStore& store, const ExportArgs& a) {
  const HzHeader& h = store.header();
  const ExportBox box = ResolveExportBox<D>(store, a);
  const bool nrrd = EndsWith(a.output, ".nrrd");
  if (EndsWith(a.output, ".pvd") && (D != 4 || !a.time.empty())) {
    throw CommandError(fmt::format("-o {}: a .pvd is the time series of a 4D (HP) store without "
                                   "--time; write this image as OUT.nrrd",
                                   a.output),
                       2);
  }
  if (D == 4 && a.time.empty() && (nrrd || EndsWith(a.output, ".pvd"))) {
    ExportTimeSeries(store, a, box);
    return;
  }
  std::array<uint32_t, 4> dims{};
  std::vector<double> values = ReadExportBox<D>(store, box, &dims);
  // One time step of an HP is a 3D image; a 4D raw export stays 4D.
  const int dimension = D == 4 && !a.time.empty() ? 3 : D;
  ExportGeometry g = GeometryOf(h, box, D);
  WriteFlippedAxesForwards(values, dims, g);
  const NrrdOrigin origin = std::array<double, 3>{g.origin[0], g.origin[1], g.origin[2]};
  std::array<double, 4> spacing = g.spacing;
  if (dimension == 3) spacing[3] = 1;
  Status s;
  std::string written = a.output;
  if (nrrd) {
    s = WriteNrrd(a.output, dimension, dims, h.voxel_type, values, spacing, origin);
  } else {
    const std::string base = EndsWith(a.output, ".raw") ? a.output.substr(0, a.output.size() - 4) : a.output;
    written = a.output + " and " + base + ".nhdr";
    const std::string nhdr = CheckOutput(base + ".nhdr", {a.store, a.output}, false);
    s = WriteRawWithNhdr(a.output, nhdr, dimension, dims, h.voxel_type, values, spacing, origin);
  }
  if (!s.ok()) Fail(s);
  fmt::print("{}: {} {} values ({}{}) written to {}\n", a.store, values.size(),
             VoxelTypeName(h.voxel_type), FormatDims(dimension, dims),
             dimension < D ? fmt::format(", time step {}", box.lo[3]) : "", written);
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
        "are the store's own, losslessly. A 3D image says where it is: \"space\n"
        "directions\" and \"space origin\" from the store's spacing and origin.\n"
        "A 4D (HP) store is written as one 3D image per time step (VTK's NRRD\n"
        "reader, and so ParaView, reads no 4D NRRD as 4D: it takes the first axis\n"
        "for vector components):\n"
        "  -o OUT.pvd   OUT_t0000.vti, OUT_t0001.vti, ... (VTK XML image data) and\n"
        "               OUT.pvd listing them with their times (origin_t + t *\n"
        "               spacing_t): ParaView opens OUT.pvd as a time series.\n"
        "  -o OUT.nrrd  OUT_t0000.nrrd, ... (for VTK, Slicer, ITK) and OUT.pvd\n"
        "               listing them (for scripts: ParaView's .pvd reader opens\n"
        "               VTK XML files only).\n"
        "  --time T     the one 3D time step T as OUT.nrrd (or OUT.raw).\n"
        "Files are named by the grid time t. To OUT.raw a 4D store stays one 4D\n"
        "file (x fastest, t slowest) for teem, ITK and Slicer. VTK also takes an\n"
        "x axis of 9 points or fewer for vector components, whatever the header.\n"
        "Every file is complete before the first is renamed into place: a failure\n"
        "while writing leaves none of them.\n"
        "Example: simplexdb export tooth.sdb --roi 0,0,0,50,50,80 --step 2 -o part.nrrd\n"
        "         simplexdb export flow.sdb -o flow.pvd\n"
        "         simplexdb export flow.sdb --time 3 -o flow_t3.nrrd");
    cmd->add_option("store", a->store, "a store file")->required();
    cmd->add_option("-o,--output", a->output,
                    "OUT.nrrd (a 4D store: OUT_t<t>.nrrd per step + OUT.pvd), OUT.pvd (a 4D "
                    "store: OUT_t<t>.vti per step), or OUT.raw (+ OUT.nhdr)")
        ->required();
    cmd->add_option("--roi", a->roi,
                    "x0,y0,z0[,t0],x1,y1,z1[,t1]: a box of the grid, inclusive, one range per "
                    "axis of the store; with --time the three space axes only");
    cmd->add_option("--time", a->time,
                    "a 4D store: only time step T (grid units, 0..T-1) as a 3D image");
    cmd->add_option("--step", a->step,
                    "every step-th point along each axis (a coarser resolution); in a 4D "
                    "export without --time, every step-th time step too")
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
