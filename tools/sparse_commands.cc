#include "tools/sparse_commands.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "query/import_volume.h"
#include "query/open_store.h"
#include "query/store_info.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_store.h"
#include "storage/io/file.h"
#include "storage/sparse/hz_sparse_builder.h"
#include "storage/sparse/hz_sparse_store.h"
#include "storage/sparse/hz_sparse_update.h"
#include "storage/volume/nrrd_writer.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

std::unique_ptr<HzSparseStore> OpenSparse(const std::string& path) {
  Result<std::unique_ptr<HzSparseStore>> s = HzSparseStore::Open(path, {});
  if (!s.ok()) Fail(s.status());
  return *std::move(s);
}

const char* SparseKind(int dimension) { return dimension == 3 ? "ht-sparse" : "hp-sparse"; }

// Domain vertices: (2^k + 1)^D.
double DomainVertices(const HzSparseHeader& h) {
  return std::pow(std::ldexp(1.0, h.domain_bits) + 1, h.dimension);
}

void PrintSparseReport(const HzSparseBuildReport& r, const std::string& output, bool as_json,
                       bool quiet) {
  const HzSparseHeader& h = r.header;
  const double points = static_cast<double>(h.points());
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["kind"] = SparseKind(h.dimension);
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

// The dense store's field, written losslessly to a scratch NRRD beside the
// output, imported as a sparse store (as import --sparse does).
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
    if (std::any_of(values.begin(), values.end(), [](double v) { return std::isnan(v); })) {
      Fail(Status::NotSupported(input + ": the field has missing values (NaN); the sparse store "
                                        "does not take them yet (keep the dense store)"));
    }
    if (Status s = WriteNrrd(field.path(), h.dimension, h.dims, h.voxel_type, values); !s.ok()) {
      Fail(s);
    }
  }
  Result<VolumeInfo> volume = OpenVolume(field.path());
  if (!volume.ok()) Fail(volume.status());
  volume->description = h.source;  // the dense store's source, not the scratch file
  volume->spacing = h.spacing;     // and its placement (the scratch NRRD has none)
  volume->origin = h.origin;
  DenseBuildOptions options;
  options.memory_bytes = memory_bytes;
  options.quantization = h.quantization;
  options.zstd_level = 0;  // the sparse store's default
  ImportSparse(*volume, output, options, tolerance, as_json, quiet);
}

// The sparse store's rebuilt field (the input's values at t = 0; within t,
// or t + 0.5 for an integer type, at a tolerance t), checked whole first,
// written to a scratch NRRD beside the output and imported as a dense store.
template <int D>
void ReadSparseField(const HzSparseStore& store, std::vector<double>& values, ProgressLine& line,
                     const std::string& output) {
  const HzSparseHeader& h = store.header();
  HzSparseStore::Reader<D> reader(store);
  std::array<int64_t, D> p{};
  for (uint64_t i = 0; i < values.size(); ++i) {
    uint64_t rest = i;
    for (int a = 0; a < D; ++a) {
      p[a] = static_cast<int64_t>(rest % h.dims[a]);
      rest /= h.dims[a];
    }
    Result<double> v = reader.Field(p);
    if (!v.ok()) Fail(v.status());
    // A dropped vertex of an integer field is rebuilt from its neighbours,
    // within t of the input: rounded to the type and clamped to its range
    // (a rebuilt 0 of uint8 may come out as -1; the input was in range, so
    // clamping only brings the value nearer to it).
    values[i] = IsFloatType(h.voxel_type) ? *v : WithVoxelCppType(h.voxel_type, [&](auto zero) {
      using T = decltype(zero);
      return std::clamp(std::round(*v), static_cast<double>(std::numeric_limits<T>::lowest()),
                        static_cast<double>(std::numeric_limits<T>::max()));
    });
    if ((i & 0xFFFFF) == 0) {
      line.Update(fmt::format("{}: field {}/{}", output, i, values.size()));
    }
  }
}

void ConvertSparseToDense(const std::string& input, const std::string& output,
                          const std::string& compression, uint64_t memory_bytes, bool as_json,
                          bool quiet) {
  const Clock::time_point start = Clock::now();
  const auto sparse = OpenSparse(input);
  const HzSparseHeader& h = sparse->header();
  Result<Compression> c = ParseCompression(compression);
  if (!c.ok()) throw CommandError("--compression: " + std::string(c.status().message()), 2);
  const uint64_t n = h.points();
  if (memory_bytes != 0 && n * sizeof(double) > memory_bytes) {
    Fail(Status::ResourceExhausted(fmt::format(
        "{}: converting to a dense store reads the field into memory, {}, more than the bound of "
        "{} (--memory-mb)",
        input, HumanBytes(n * sizeof(double)), HumanBytes(memory_bytes))));
  }
  if (Status s = PrepareOutput(output); !s.ok()) Fail(s);
  ProgressLine line(!quiet && !as_json);
  // A store that fails its checksums is not converted (a damaged block the
  // field never reads would otherwise pass unseen).
  if (Status s = sparse->Verify([&](uint64_t done, uint64_t total) {
        line.Update(fmt::format("{}: verifying block {}/{}", input, done, total));
      });
      !s.ok()) {
    line.Finish();
    throw CommandError(std::string(s.message()) + "; not converted", 1);
  }
  const TemporaryFile field(output, "field.nrrd");
  {
    std::vector<double> values(n);
    if (h.dimension == 3) {
      ReadSparseField<3>(*sparse, values, line, output);
    } else {
      ReadSparseField<4>(*sparse, values, line, output);
    }
    if (Status s = WriteNrrd(field.path(), h.dimension, h.dims, h.voxel_type, values); !s.ok()) {
      line.Finish();
      Fail(s);
    }
  }
  Result<VolumeInfo> volume = OpenVolume(field.path());
  if (!volume.ok()) Fail(volume.status());
  volume->description = h.source;
  volume->spacing = h.spacing;  // the store's placement (the scratch NRRD has none)
  volume->origin = h.origin;
  HzBuildOptions options;
  options.quantization = h.quantization;
  options.compression = *c;
  options.memory_bytes = memory_bytes;
  options.progress = ProgressTo(line, output);
  const Result<HzBuildReport> built = BuildHzStore(*volume, output, options);
  line.Finish();
  if (!built.ok()) Fail(built.status());
  const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", output);
    j["kind"] = h.dimension == 3 ? "ht-dense" : "hp-dense";
    j["seconds"] = seconds;
    j["file_bytes"] = built->header.file_size;
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: dense store from {} in {:.2f} s, {} on disk\n", output, input, seconds,
               HumanBytes(built->header.file_size));
  }
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
  ConvertSparseToDense(input, output, compression, memory_mb << 20, as_json, quiet);
}

}  // namespace


void RunSparseInfo(const std::string& path, bool as_json) {
  const auto store = OpenSparse(path);
  const HzSparseHeader& h = store->header();
  const uint64_t points = h.points();
  const uint64_t bytes = store->file_bytes();
  const double domain_vertices = DomainVertices(h);
  if (as_json) {
    // The library's description (query/store_info.h), which the Python
    // package's Store.info is too.
    std::cout << StoreInfoJson(*store, path).dump() << "\n";
    return;
  }
  fmt::print("{}: sparse {} store (LMDB, format {})\n", path, h.dimension == 3 ? "HT" : "HP",
             h.version);
  fmt::print("  grid        {} {} ({} points), from {}\n", FormatDims(h.dimension, h.dims),
             VoxelTypeName(h.voxel_type), points, h.source);
  fmt::print("  placement   {}\n", FormatPlacement(h.dimension, h.spacing, h.origin));
  fmt::print("  domain      side 2^{} + 1 = {}, {} levels\n", h.domain_bits,
             (uint64_t{1} << h.domain_bits) + 1, h.dimension * h.domain_bits);
  fmt::print("  field       {} .. {}; the values of {} kept vertices of {:.4g} ({:.3g}%), {}\n",
             h.field_min, h.field_max, h.kept, domain_vertices,
             100.0 * static_cast<double>(h.kept) / domain_vertices,
             h.value_step > 0 ? fmt::format("to within {:.6g}", h.value_step / 2) : "exact");
  fmt::print("  errors      {} (quantum {:.6g}), largest {:.6g}; diamonds within {:.6g} "
             "dropped\n",
             QuantizationName(h.quantization), h.quantum, h.error_max, h.tolerance);
  fmt::print("  blocks      {} of 2^{} positions\n", h.blocks, h.block_bits);
  fmt::print("  size        {} on disk, {:.2f} bytes per grid point\n", HumanBytes(bytes),
             static_cast<double>(bytes) / static_cast<double>(points));
}

void RunSparseVerify(const std::string& path, bool quiet) {
  const auto store = OpenSparse(path);
  ProgressLine line(!quiet);
  const Status s = store->Verify([&](uint64_t done, uint64_t total) {
    line.Update(fmt::format("{}: verifying block {}/{}", path, done, total));
  });
  line.Finish();
  if (!s.ok()) Fail(s);
  if (!quiet) {
    fmt::print("{}: ok ({} blocks, {} kept vertices: pages, checksums, counts and values)\n", path,
               store->header().blocks, store->header().kept);
  }
}

void ImportSparse(const VolumeInfo& input, const std::string& output, const DenseBuildOptions& common,
                  const std::string& tolerance, bool as_json, bool quiet) {
  if (common.mask) {
    throw CommandError("--mask with --sparse: the sparse store does not take missing values yet; "
                       "import a dense store",
                       2);
  }
  ImportOptions options;  // the builder ImportVolume runs (query/import_volume.h)
  options.sparse = true;
  options.quantization = common.quantization;
  options.zstd_level = common.zstd_level;
  options.memory_bytes = common.memory_bytes;
  options.threads = common.threads;
  options.tolerance_percent = !tolerance.empty() && tolerance.back() == '%';
  // "1%" -> 1 (a percentage, applied to the range the builder finds).
  options.tolerance = ParseAmount(tolerance, "--tolerance", 100.0);
  ProgressLine line(!quiet && !as_json);
  options.progress = ProgressTo(line, output);
  const Result<ImportReport> imported = ImportVolume(input, output, options);
  line.Finish();
  if (!imported.ok()) Fail(imported.status());
  const HzSparseBuildReport* built = &*imported->sparse;
  PrintSparseReport(*built, output, as_json, quiet);
  if (input.scaled() && !quiet && !as_json) {
    fmt::print("  scaled: {} -> {}\n", FormatScaling(input),
               VoxelTypeName(built->header.voxel_type));
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
      "store. --to sparse keeps a diamond only when its error or a descendant's exceeds\n"
      "--tolerance (0: lossless); --to dense checks every block of the sparse store\n"
      "(a damaged one is refused), then rebuilds the full grid from it (at a tolerance,\n"
      "an integer field's rebuilt values are rounded to its type).\n"
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
               size_t memory_mb, int threads, bool as_json, bool quiet) {
  if (ProbeStoreKind(store) != StoreKind::kSparse) {
    throw CommandError(store + " is not a sparse store: only sparse (LMDB) stores are updated in "
                                   "place; import the volume again for a dense one",
                       2);
  }
  if (memory_mb > (std::numeric_limits<size_t>::max() >> 20)) {
    throw CommandError(fmt::format("--memory-mb {} is beyond this machine's address space",
                                   memory_mb),
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
  HzSparseUpdateOptions options;
  options.progress = ProgressTo(line, store);
  options.memory_bytes = memory_mb << 20;
  options.threads = threads;
  const Result<HzSparseUpdateReport> r = UpdateHzSparseStore(store, *volume, box, options);
  line.Finish();
  if (!r.ok()) Fail(r.status());
  if (as_json) {
    json j;
    SetJsonBytes(j, "store", store);
    j["blocks_written"] = r->blocks_written;
    j["blocks_deleted"] = r->blocks_deleted;
    j["blocks_unchanged"] = r->blocks_unchanged;
    j["blocks"] = r->header.blocks;
    j["kept"] = r->header.kept;
    j["seconds"] = r->seconds;
    std::cout << j.dump() << "\n";
  } else if (!quiet) {
    fmt::print("{}: box {} of {} re-imported in one transaction: {} blocks written, {} deleted, {} "
               "unchanged; now {} blocks, {} kept vertices ({:.2f} s)\n",
               store, box_text, input, r->blocks_written, r->blocks_deleted, r->blocks_unchanged,
               r->header.blocks, r->header.kept, r->seconds);
  }
}

void RegisterUpdateCommand(CLI::App& app) {
  struct Args {
    std::string store, input, box;
    size_t memory_mb = 8192;
    int threads = 0;
    bool json = false, quiet = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "update",
      "Re-import a box of a volume into a sparse store, in one LMDB transaction: readers\n"
      "see the old store or the new one, never a mix. The store becomes what importing\n"
      "VOLUME with its tolerance gives; only the blocks that change are written. VOLUME\n"
      "must have the store's grid and voxel type, and outside --box the values the store\n"
      "holds (within its tolerance): a point that differs there is named and nothing is\n"
      "written. The whole volume is read and rebuilt in memory (as import --sparse).\n"
      "Example: simplexdb update tooth.lmdb tooth-fixed.nrrd --box 10,10,10,40,40,40");
  cmd->add_option("store", a->store, "the sparse store to update")->required();
  cmd->add_option("volume", a->input, "the new volume (NRRD or NIfTI-1)")->required();
  cmd->add_option("--box", a->box,
                  "the grid points that changed, inclusive: x0,y0,z0,x1,y1,z1 (4D: "
                  "x0,y0,z0,t0,x1,y1,z1,t1)")
      ->required();
  cmd->add_option("--memory-mb", a->memory_mb, "the rebuild's memory bound")->capture_default_str();
  cmd->add_option("--threads", a->threads, "worker threads (0: one per core)")->capture_default_str();
  cmd->add_flag("--json", a->json, "print the report as JSON");
  cmd->add_flag("-q,--quiet", a->quiet, "no progress or summary");
  cmd->callback([a] {
    RunUpdate(a->store, a->input, a->box, a->memory_mb, a->threads, a->json, a->quiet);
  });
}

}  // namespace simplexdb::tools
