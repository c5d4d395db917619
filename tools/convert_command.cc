// `simplexdb convert` (ops/convert.h, which the Python package's
// simplexdb.convert calls too) and `simplexdb update` (ops/update.h): the
// options parsed, the reports printed.
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ops/convert.h"
#include "ops/process_memory.h"
#include "ops/update.h"
#include "query/open_store.h"
#include "tools/build_reports.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

struct ConvertArgs {
  std::string input, output, to, tolerance = "0", compression = "zstd";
  size_t memory_mb = 1024;
  int threads = 0;
  bool json = false, quiet = false, force = false;
};

void RunConvert(ConvertArgs a) {
  a.output = CheckOutput(a.output, {a.input}, a.force);
  ConvertOptions options;
  options.to = UsageValue(ParseStoreKind(a.to));
  options.tolerance = ParseAmountOption(a.tolerance, "--tolerance");
  Result<Compression> c = ParseCompression(a.compression);
  if (!c.ok()) throw CommandError("--compression: " + std::string(c.status().message()), 2);
  options.compression = *c;
  options.memory_bytes = MebibytesOption(a.memory_mb);
  options.threads = a.threads;
  CheckUsage(CheckConvert(a.input, ProbeStoreKind(a.input), options));
  ProgressLine line(!a.quiet && !a.json);
  options.progress = ProgressTo(line, a.output);
  const Result<ConvertReport> r = Convert(a.input, a.output, options);
  line.Finish();
  if (!r.ok()) Fail(r.status());
  if (r->sparse) {
    PrintSparseBuild(*r->sparse, a.output, a.json, a.quiet);
    return;
  }
  const DenseHeader& h = r->dense->header;
  if (a.json) {
    json j;
    SetJsonBytes(j, "store", a.output);
    j["kind"] = h.dimension == 3 ? "ht-dense" : "hp-dense";
    j["seconds"] = r->seconds;
    j["file_bytes"] = h.file_size;
    std::cout << j.dump() << "\n";
  } else if (!a.quiet) {
    fmt::print("{}: dense store from {} in {:.2f} s, {} on disk\n", a.output, a.input, r->seconds,
               HumanBytes(h.file_size));
  }
}

struct UpdateArgs {
  std::string store, input, box;
  size_t memory_mb = 8192;
  int threads = 0;
  bool json = false, quiet = false;
};

void RunUpdate(const UpdateArgs& a) {
  UpdateOptions options;
  options.memory_bytes = MebibytesOption(a.memory_mb);
  options.threads = a.threads;
  const StoreKind kind = ProbeStoreKind(a.store);
  if (kind != StoreKind::kSparse) CheckUsage(CheckUpdate(a.store, kind, {}, options).status());
  Result<VolumeInfo> volume = OpenVolume(a.input);
  if (!volume.ok()) Fail(volume.status());
  options.box = ParseNumberList(a.box, "--box", 1, 8);
  CheckUsage(CheckUpdate(a.store, kind, *volume, options).status());
  ProgressLine line(!a.quiet && !a.json);
  options.progress = ProgressTo(line, a.store);
  const Result<SparseUpdateReport> r = UpdateStore(a.store, *volume, options);
  line.Finish();
  if (!r.ok()) Fail(r.status());
  if (a.json) {
    json j;
    SetJsonBytes(j, "store", a.store);
    j["blocks_written"] = r->blocks_written;
    j["blocks_deleted"] = r->blocks_deleted;
    j["blocks_unchanged"] = r->blocks_unchanged;
    j["blocks"] = r->header.blocks;
    j["kept"] = r->header.kept;
    j["seconds"] = r->seconds;
    std::cout << j.dump() << "\n";
  } else if (!a.quiet) {
    fmt::print("{}: box {} of {} re-imported in one transaction: {} blocks written, {} deleted, {} "
               "unchanged; now {} blocks, {} kept vertices ({:.2f} s)\n",
               a.store, a.box, a.input, r->blocks_written, r->blocks_deleted, r->blocks_unchanged,
               r->header.blocks, r->header.kept, r->seconds);
  }
}

// `simplexdb convert --help`.
constexpr const char* kConvertHelp = R"(Convert between the dense store and the sparse (LMDB, variable-resolution)
store. --to sparse keeps a diamond only when its error or a descendant's exceeds
--tolerance (0: lossless); --to dense checks every block of the sparse store
(a damaged one is refused), then rebuilds the full grid from it (at a tolerance,
an integer field's rebuilt values are rounded to its type). The field is read
into memory (a double a grid point within --memory-mb) and built from there.
Example: simplexdb convert tooth.sdb --to sparse --tolerance 1% -o tooth.lmdb)";

// `simplexdb update --help`.
constexpr const char* kUpdateHelp = R"(Re-import a box of a volume into a sparse store, in one LMDB transaction: readers
see the old store or the new one, never a mix. The store becomes what importing
VOLUME with its tolerance gives; only the blocks that change are written. VOLUME
must have the store's grid and voxel type, and outside --box the values the store
holds (within its tolerance): a point that differs there is named and nothing is
written. The whole volume is read and rebuilt in memory (as import --sparse).
Example: simplexdb update tooth.lmdb tooth-fixed.nrrd --box 10,10,10,40,40,40)";

}  // namespace

void RegisterConvertCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<ConvertArgs>(app, "convert", kConvertHelp, RunConvert);
  cmd->add_option("store", a->input, "the store to read")->required();
  AddOutputOptions(cmd, &a->output, &a->force, "the store to write");
  cmd->add_option("--to", a->to, "dense or sparse")->required()->check(CLI::IsMember({"dense", "sparse"}));
  cmd->add_option("--tolerance", a->tolerance,
                  "--to sparse: drop subtrees whose errors are all within this (7.3, or 1% of "
                  "the field range)")
      ->capture_default_str();
  cmd->add_option("--compression", a->compression, "--to dense: blocks as zstd or none")->capture_default_str();
  AddMemoryOption(cmd, &a->memory_mb,
                  "memory bound of the conversion (as import's), block index and vertex set "
                  "included; too small fails at once with the need");
  AddThreadsOption(cmd, &a->threads,
                   "the builder's worker threads (0: one per core; a dense store's bricks are laid "
                   "out in the order the threads finish them: the same bytes run after run only "
                   "with 1)");
  AddReportFlags(cmd, &a->json, &a->quiet);
}

void RegisterUpdateCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<UpdateArgs>(app, "update", kUpdateHelp, RunUpdate);
  cmd->add_option("store", a->store, "the sparse store to update")->required();
  cmd->add_option("volume", a->input, "the new volume (NRRD or NIfTI-1)")->required();
  cmd->add_option("--box", a->box,
                  "the grid points that changed, inclusive: x0,y0,z0,x1,y1,z1 (4D: "
                  "x0,y0,z0,t0,x1,y1,z1,t1)")
      ->required();
  AddMemoryOption(cmd, &a->memory_mb, "the rebuild's memory bound");
  AddThreadsOption(cmd, &a->threads);
  AddReportFlags(cmd, &a->json, &a->quiet);
}

}  // namespace simplexdb::tools
