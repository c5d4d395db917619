#include "tools/sparse_commands.h"

#include <unistd.h>

#include <algorithm>
#include <iostream>
#include <limits>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "query/open_store.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_lattice.h"
#include "storage/dense/hz_store.h"
#include "storage/io/file.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/sparse/sparse_update.h"
#include "storage/volume/nrrd_writer.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

std::unique_ptr<SparseStore> OpenSparse(const std::string& path) {
  Result<std::unique_ptr<SparseStore>> s = SparseStore::Open(path);
  if (!s.ok()) Fail(s.status());
  return *std::move(s);
}

// Internal nodes of the complete hierarchy: what a dense store holds.
double CompleteNodes(int dimension, int leaf_level) {
  return (dimension == 3 ? 6.0 : 24.0) * (std::ldexp(1.0, leaf_level) - 1);
}

uint64_t GridPoints(int dimension, const std::array<uint32_t, 4>& dims) {
  uint64_t n = 1;
  for (int c = 0; c < dimension; ++c) n *= dims[c];
  return n;
}

SparseBuildReport Convert(const DenseStore& dense, const std::string& output,
                          const std::string& tolerance, bool quiet, uint64_t memory_bytes = 0) {
  SparseBuildOptions options;
  options.memory_bytes = memory_bytes;
  options.tolerance = ParseAmount(tolerance, "--tolerance",
                                  dense.header().field_max - dense.header().field_min);
  ProgressLine line(!quiet);
  options.progress = ProgressTo(line, output);
  Result<SparseBuildReport> report = ConvertDenseToSparse(dense, output, options);
  line.Finish();
  if (!report.ok()) Fail(report.status());
  return *std::move(report);
}

void PrintSparseReport(const SparseBuildReport& r, const std::string& output, bool as_json,
                       bool quiet) {
  const SparseHeader& h = r.header;
  const uint64_t points = GridPoints(h.dimension, h.dims);
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["kind"] = h.dimension == 3 ? "ht-sparse" : "hp-sparse";
    j["nodes"] = h.nodes;
    j["vertices"] = h.vertices;
    j["tolerance"] = h.tolerance;
    j["seconds"] = r.seconds;
    j["nodes_visited"] = r.nodes_visited;
    j["map_growths"] = r.map_growths;
    j["file_bytes"] = r.file_bytes;
    j["bytes_per_grid_point"] = static_cast<double>(r.file_bytes) / static_cast<double>(points);
    j["peak_memory_bytes"] = PeakResidentBytes();
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: sparse {} store, tolerance {:.6g}: {} of {:.4g} nodes kept ({:.3g}%), {} "
               "vertices\n",
               output, h.dimension == 3 ? "HT" : "HP", h.tolerance, h.nodes,
               CompleteNodes(h.dimension, h.leaf_level()),
               100.0 * static_cast<double>(h.nodes) / CompleteNodes(h.dimension, h.leaf_level()),
               h.vertices);
    fmt::print("  converted in {:.2f} s; {} on disk ({:.2f} bytes per grid point), peak memory "
               "{}\n",
               r.seconds, HumanBytes(r.file_bytes),
               static_cast<double>(r.file_bytes) / static_cast<double>(points),
               HumanBytes(PeakResidentBytes()));
  }
}

// The dense store's field, written losslessly to a scratch NRRD beside the
// output, imported as a sparse store (as import --sparse does): the sparse
// store keeps each node's own error, which the dense store does not.
void ConvertDenseToSparse(const std::string& input, const std::string& output,
                          const std::string& tolerance, uint64_t memory_bytes, bool as_json,
                          bool quiet) {
  const auto opened = OpenHzStore(input);
  const HzStore& dense = *opened;
  const HzHeader& h = dense.header();
  std::array<int64_t, 4> lo = {0, 0, 0, 0}, hi = {0, 0, 0, 0};
  uint64_t n = 1;
  for (int a = 0; a < h.dimension; ++a) {
    hi[a] = h.dims[a] - 1;
    n *= h.dims[a];
  }
  if (memory_bytes != 0 && n * sizeof(double) > memory_bytes) {
    Fail(Status::ResourceExhausted(fmt::format(
        "{}: converting to a sparse store reads the field into memory, {}, more than the bound of "
        "{} (--memory-mb)",
        input, HumanBytes(n * sizeof(double)), HumanBytes(memory_bytes))));
  }
  if (Status s = PrepareOutput(output); !s.ok()) Fail(s);
  const TemporaryFile field(output, "field.nrrd");
  {
    std::vector<double> values(n);
    if (Status s = ReadLattice(dense, 0, lo, hi, values.data()); !s.ok()) Fail(s);
    if (Status s = WriteNrrd(field.path(), h.dimension, h.dims, h.voxel_type, values, h.spacing);
        !s.ok()) {
      Fail(s);
    }
  }
  Result<VolumeInfo> volume = OpenVolume(field.path());
  if (!volume.ok()) Fail(volume.status());
  volume->description = h.source;  // the dense store's source, not the scratch file
  DenseBuildOptions options;
  options.memory_bytes = memory_bytes;
  options.quantization = h.quantization;
  ImportSparse(*volume, output, options, tolerance, as_json, quiet);
}

void RunConvert(const std::string& input, const std::string& output, const std::string& to,
                const std::string& tolerance, const std::string& compression, size_t memory_mb,
                bool as_json, bool quiet) {
  if (memory_mb > (std::numeric_limits<size_t>::max() >> 20)) {  // << 20 would wrap
    throw CommandError(fmt::format("--memory-mb {} is beyond this machine's address space",
                                   memory_mb),
                       2);
  }
  if (to == "sparse") {
    if (ProbeStoreKind(input) == StoreKind::kSparse) {
      throw CommandError(input + " is already a sparse store; convert it --to dense first", 2);
    }
    ConvertDenseToSparse(input, output, tolerance, memory_mb << 20, as_json, quiet);
    return;
  }
  if (tolerance != "0") throw CommandError("--tolerance applies to --to sparse", 2);
  if (ProbeStoreKind(input) != StoreKind::kSparse) {
    throw CommandError(input + " is not a sparse store; only sparse stores convert --to dense", 2);
  }
  const auto sparse = OpenSparse(input);
  Result<Compression> c = ParseCompression(compression);
  if (!c.ok()) throw CommandError("--compression: " + std::string(c.status().message()), 2);
  // Through the sparse store's own dense form (one error per node, as it
  // keeps them, no compression) in a scratch file beside the output, whose
  // errors the dense store takes per diamond (the largest of its nodes').
  if (Status s = PrepareOutput(output); !s.ok()) Fail(s);
  const TemporaryFile scratch(output, "nodes");
  DenseBuildOptions nodes;
  nodes.compression = Compression::kNone;
  nodes.memory_bytes = memory_mb << 20;
  ProgressLine line(!quiet);
  nodes.progress = ProgressTo(line, output);
  const Result<DenseBuildReport> built = ConvertSparseToDense(*sparse, scratch.path(), nodes);
  if (!built.ok()) {
    line.Finish();
    Fail(built.status());
  }
  const auto per_node = OpenDenseStore(scratch.path());
  HzBuildOptions options;
  options.quantization = per_node->header().quantization;
  options.compression = *c;
  options.memory_bytes = memory_mb << 20;
  options.progress = nodes.progress;
  const Result<HzBuildReport> converted = ConvertToHz(*per_node, output, options);
  line.Finish();
  if (!converted.ok()) Fail(converted.status());
  const double seconds = built->seconds + converted->seconds;
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["kind"] = sparse->dimension() == 3 ? "ht-dense" : "hp-dense";
    j["nodes"] = built->nodes;
    j["seconds"] = seconds;
    j["file_bytes"] = converted->header.file_size;
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: dense store from {} ({} nodes) in {:.2f} s, {} on disk\n", output, input,
               built->nodes, seconds, HumanBytes(converted->header.file_size));
  }
}

}  // namespace


void RunSparseInfo(const std::string& path, bool as_json) {
  const auto store = OpenSparse(path);
  const SparseHeader& h = store->header();
  const uint64_t points = GridPoints(h.dimension, h.dims);
  const uint64_t bytes = store->file_bytes();
  const double complete = CompleteNodes(h.dimension, h.leaf_level());
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", path);
    j["kind"] = h.dimension == 3 ? "ht-sparse" : "hp-sparse";
    j["hierarchy"] = h.dimension == 3 ? "ht" : "hp";
    j["format_version"] = h.version;
    j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
    j["grid_points"] = points;
    j["domain_bits"] = h.domain_bits;
    j["domain_side"] = h.domain_side();
    j["leaf_level"] = h.leaf_level();
    j["voxel_type"] = VoxelTypeName(h.voxel_type);
    j["quantization"] = QuantizationName(h.quantization);
    j["quantum"] = h.quantum;
    j["field_min"] = h.field_min;
    j["field_max"] = h.field_max;
    j["error_max"] = h.error_max;
    j["tolerance"] = h.tolerance;
    j["nodes"] = h.nodes;
    j["complete_nodes"] = complete;
    j["vertices"] = h.vertices;
    j["content_sum"] = h.content_sum;
    j["file_bytes"] = bytes;
    j["bytes_per_grid_point"] = static_cast<double>(bytes) / static_cast<double>(points);
    SetJsonBytes(j, "source", h.source);
    std::cout << j.dump() << "\n";
    return;
  }
  fmt::print("{}: sparse {} store (LMDB, format {})\n", path, h.dimension == 3 ? "HT" : "HP",
             h.version);
  fmt::print("  grid        {} {} ({} points), from {}\n", FormatDims(h.dimension, h.dims),
             VoxelTypeName(h.voxel_type), points, h.source);
  fmt::print("  domain      side 2^{} + 1 = {}, {} levels ({} roots)\n", h.domain_bits,
             h.domain_side(), h.leaf_level(), h.dimension == 3 ? 6 : 24);
  fmt::print("  field       {} .. {}; {} vertices stored\n", h.field_min, h.field_max, h.vertices);
  fmt::print("  errors      {} (quantum {:.6g}), largest {:.6g}; subtrees within {:.6g} "
             "dropped\n",
             QuantizationName(h.quantization), h.quantum, h.error_max, h.tolerance);
  fmt::print("  nodes       {} of {:.4g} ({:.3g}%)\n", h.nodes, complete,
             100.0 * static_cast<double>(h.nodes) / complete);
  fmt::print("  size        {} on disk, {:.2f} bytes per grid point\n", HumanBytes(bytes),
             static_cast<double>(bytes) / static_cast<double>(points));
}

void RunSparseVerify(const std::string& path, bool quiet) {
  const auto store = OpenSparse(path);
  ProgressLine line(!quiet);
  const Status s = store->Verify([&](uint64_t done, uint64_t total) {
    line.Update(fmt::format("{}: verifying entry {}/{}", path, done, total));
  });
  line.Finish();
  if (!s.ok()) Fail(s);
  if (!quiet) {
    fmt::print("{}: ok ({} nodes, {} vertices: keys, values, tree, vertices and checksum)\n",
               path, store->header().nodes, store->header().vertices);
  }
}

void ImportSparse(const VolumeInfo& input, const std::string& output, DenseBuildOptions options,
                  const std::string& tolerance, bool as_json, bool quiet) {
  // The dense store is the sparse one's source: a scratch file of the
  // output (`<output>.tmp.<pid>.dense`), removed on every path out of this
  // function, and by the next run of the same output if this one is killed.
  if (Status s = PrepareOutput(output); !s.ok()) Fail(s);
  if (Status s = CheckSparseImportMemory(input, options.levels_per_block, options.memory_bytes);
      !s.ok()) {
    Fail(s);
  }
  const TemporaryFile temp(output, "dense");
  ProgressLine line(!quiet);
  options.progress = ProgressTo(line, output);
  const Result<DenseBuildReport> built = BuildDenseStore(input, temp.path(), options);
  line.Finish();
  if (!built.ok()) Fail(built.status());
  const auto dense = OpenDenseStore(temp.path());
  SparseBuildReport report =
      Convert(*dense, output, tolerance, quiet || as_json, options.memory_bytes);
  report.seconds += built->seconds;
  PrintSparseReport(report, output, as_json, quiet);
  if (input.scaled() && !quiet && !as_json) {
    fmt::print("  scaled: {} -> {}\n", FormatScaling(input),
               VoxelTypeName(dense->header().voxel_type));
  }
}

void RegisterConvertCommand(CLI::App& app) {
  struct Args {
    std::string input, output, to, tolerance = "0", compression = "zstd";
    size_t memory_mb = 1024;
    bool json = false, quiet = false, force = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "convert",
      "Convert between the dense store and the sparse (LMDB, variable-resolution)\n"
      "store. --to sparse keeps a node only when some error in its subtree exceeds\n"
      "--tolerance (0: lossless, only where the field is not linear); --to dense\n"
      "rebuilds the full grid, interpolating over the dropped subtrees.\n"
      "Example: simplexdb convert tooth.sdb --to sparse --tolerance 1% -o tooth.lmdb");
  cmd->add_option("store", a->input, "the store to read")->required();
  cmd->add_option("-o,--output", a->output, "the store to write")->required();
  cmd->add_option("--to", a->to, "dense or sparse")->required()->check(CLI::IsMember({"dense", "sparse"}));
  cmd->add_option("--tolerance", a->tolerance,
                  "--to sparse: drop subtrees whose errors are all within this (7.3, or 1% of "
                  "the field range)")
      ->capture_default_str();
  cmd->add_option("--compression", a->compression, "--to dense: blocks as zstd or none")
      ->capture_default_str();
  cmd->add_option("--memory-mb", a->memory_mb,
                  "memory bound of the conversion (as import's), block index and vertex set "
                  "included; too small fails at once with the need")
      ->capture_default_str();
  cmd->add_flag("--json", a->json, "print the report as JSON");
  cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
  AddForceOption(cmd, &a->force);
  cmd->callback([a] {
    a->output = CheckOutput(a->output, {a->input}, a->force);
    RunConvert(a->input, a->output, a->to, a->tolerance, a->compression, a->memory_mb, a->json,
               a->quiet);
  });
}

void RunUpdate(const std::string& store, const std::string& input, const std::string& box_text,
               const std::string& mask, bool as_json, bool quiet) {
  if (ProbeStoreKind(store) != StoreKind::kSparse) {
    throw CommandError(store + " is not a sparse store: only sparse (LMDB) stores are updated in "
                                   "place; import the volume again for a dense one",
                       2);
  }
  Result<VolumeInfo> volume = OpenVolume(input);
  if (!volume.ok()) Fail(volume.status());
  const int d = volume->dimension;
  const std::vector<double> v = ParseNumberList(box_text, "--box", 2 * d, 2 * d);
  GridBox box;
  for (int c = 0; c < d; ++c) {
    for (const double x : {v[c], v[d + c]}) {
      if (x != std::floor(x)) {
        throw CommandError(fmt::format("--box: {} is not a grid point coordinate (an integer)", x), 2);
      }
    }
    box.lo[c] = static_cast<int64_t>(v[c]);
    box.hi[c] = static_cast<int64_t>(v[d + c]);
  }
  ProgressLine line(!quiet && !as_json);
  SparseUpdateOptions options;
  options.progress = ProgressTo(line, store);
  if (!mask.empty()) {
    Result<VolumeInfo> m = OpenVolume(mask);
    if (!m.ok()) Fail(m.status());
    options.mask = *std::move(m);
  }
  const Result<SparseUpdateReport> r = UpdateSparseStore(store, *volume, box, options);
  line.Finish();
  if (!r.ok()) Fail(r.status());
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", store);
    j["nodes_recomputed"] = r->nodes_recomputed;
    j["nodes_written"] = r->nodes_written;
    j["nodes_deleted"] = r->nodes_deleted;
    j["vertices_written"] = r->vertices_written;
    j["vertices_deleted"] = r->vertices_deleted;
    j["nodes"] = r->header.nodes;
    j["vertices"] = r->header.vertices;
    j["map_growths"] = r->map_growths;
    j["seconds"] = r->seconds;
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: box {} of {} re-imported in one transaction: {} nodes recomputed, {} written, "
               "{} deleted; {} vertices written, {} deleted; now {} nodes, {} vertices ({:.2f} s)\n",
               store, box_text, input, r->nodes_recomputed, r->nodes_written, r->nodes_deleted,
               r->vertices_written, r->vertices_deleted, r->header.nodes, r->header.vertices,
               r->seconds);
  }
}

void RegisterUpdateCommand(CLI::App& app) {
  struct Args {
    std::string store, input, box, mask;
    bool json = false, quiet = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "update",
      "Re-import a box of a volume into a sparse store, in one LMDB transaction: readers\n"
      "see the old store or the new one, never a mix. Every node whose simplex meets the\n"
      "box is recomputed from VOLUME (a whole simplex, so the top levels read all of it),\n"
      "nodes appear or vanish by the store's tolerance, vertex values in the box follow.\n"
      "VOLUME must have the store's grid and voxel type (or, with --mask or NIfTI scaling,\n"
      "the integer type the store was imported from), and its values in the box must lie\n"
      "in the store's field range (it fixes the error quantum).\n"
      "Example: simplexdb update tooth.lmdb tooth-fixed.nrrd --box 10,10,10,40,40,40");
  cmd->add_option("store", a->store, "the sparse store to update")->required();
  cmd->add_option("volume", a->input, "the new volume (NRRD or NIfTI-1)")->required();
  cmd->add_option("--box", a->box,
                  "the grid points that changed, inclusive: x0,y0,z0,x1,y1,z1 (4D: "
                  "x0,y0,z0,t0,x1,y1,z1,t1)")
      ->required();
  cmd->add_option("--mask", a->mask,
                  "the mask the store was imported with, updated: 0 where the field is missing")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--json", a->json, "print the report as JSON");
  cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
  cmd->callback([a] { RunUpdate(a->store, a->input, a->box, a->mask, a->json, a->quiet); });
}

}  // namespace simplexdb::tools
