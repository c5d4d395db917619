// `simplexdb info` and `verify`: a store described (ops/store_info.h, the
// same JSON the Python package's Store.info holds) and checked
// (ops/verify.h), for both kinds. Here: the text printed.
#include <cmath>
#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ops/process_memory.h"
#include "ops/store_info.h"
#include "ops/verify.h"
#include "query/open_store.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

AnyStore OpenStore(const std::string& path) {
  Result<AnyStore> store = AnyStore::Open(path);
  if (!store.ok()) Fail(store.status());
  return *std::move(store);
}

void PrintDenseInfo(const DenseStore& store, const std::string& path, const json& j) {
  const DenseHeader& h = store.header();
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

void PrintSparseInfo(const SparseStore& store, const std::string& path) {
  const SparseHeader& h = store.header();
  const uint64_t points = h.points();
  const uint64_t bytes = store.file_bytes();
  const double domain_vertices = std::pow(std::ldexp(1.0, h.domain_bits) + 1, h.dimension);
  fmt::print("{}: sparse {} store (LMDB, format {})\n", path, h.dimension == 3 ? "HT" : "HP", h.version);
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

void RunInfo(const std::string& path, bool as_json) {
  const AnyStore store = OpenStore(path);
  // The library's description, so the text, the JSON and the Python
  // package's Store.info say the same.
  const json j = StoreInfoJson(store);
  if (as_json) {
    std::cout << j.dump() << "\n";
  } else if (store.dense() != nullptr) {
    PrintDenseInfo(*store.dense(), path, j);
  } else {
    PrintSparseInfo(*store.sparse(), path);
  }
}

void RunVerify(const std::string& path, bool quiet) {
  const AnyStore store = OpenStore(path);  // header, bitmap, index
  ProgressLine line(!quiet);
  const char* what = store.kind() == StoreKind::kSparse ? "block " : "";
  const Result<VerifyReport> r = VerifyStore(store, [&](uint64_t done, uint64_t total) {
    line.Update(fmt::format("{}: verifying {}{}/{}", path, what, done, total));
  });
  line.Finish();
  if (!r.ok()) Fail(r.status());
  if (quiet) return;
  if (r->kind == StoreKind::kSparse) {
    fmt::print("{}: ok ({} blocks, {} kept vertices: pages, checksums, counts and values)\n", path,
               r->blocks, r->kept);
  } else {
    fmt::print("{}: ok ({} blocks and {} bricks{}, every checksum and value range)\n", path, r->blocks,
               r->bricks, r->finest_recomputed ? ", the finest errors recomputed" : "");
  }
}

}  // namespace

void RegisterInfoCommands(CLI::App& app) {
  // Both read one store and take one flag.
  struct Command {
    const char* name;
    const char* help;
    const char* flag;
    const char* flag_help;
    void (*run)(const std::string& path, bool flag);
  };
  const Command commands[] = {
      {"info",
       "Describe a store: kind, grid, levels, value ranges, quantization, sizes on\n"
       "disk against logical, compression ratio.\n"
       "Examples: simplexdb info tooth.sdb\n"
       "          simplexdb info tooth.sdb --json",
       "--json", "as one JSON object", RunInfo},
      {"verify",
       "Check every checksum and invariant of a store; exit 0 only if all hold,\n"
       "otherwise 1 with the first bad block named.\n"
       "Example: simplexdb verify tooth.sdb",
       "-q,--quiet", "no progress or summary", RunVerify},
  };
  struct Args {
    std::string path;
    bool flag = false;
  };
  for (const Command& c : commands) {
    auto [cmd, a] = AddCommand<Args>(app, c.name, c.help,
                                     [run = c.run](const Args& args) { run(args.path, args.flag); });
    cmd->add_option("store", a->path, "a store file")->required();
    cmd->add_flag(c.flag, a->flag, c.flag_help);
  }
}

}  // namespace simplexdb::tools
