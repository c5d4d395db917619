// `simplexdb extract`: selective refinement over any store (query/), and
// `simplexdb conformity`: the geometric conformity check of a mesh given as
// leaf codes.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "query/clip.h"
#include "query/conformity.h"
#include "query/criteria.h"
#include "query/mesh.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "query/pvd_writer.h"
#include "query/refine.h"
#include "query/slice.h"
#include "query/source.h"
#include "storage/io/file.h"
#include "tools/cli_util.h"
#include "tools/commands.h"
#include "util/out_of_memory.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

struct ExtractArgs {
  std::string store;
  std::string error;
  std::string box;
  std::optional<double> iso;
  std::optional<double> time;
  std::string algorithm = "depth-first";
  std::string format;  // empty: from the output's extension, else json
  std::string output = "-";
  std::string from;
  std::string slices;
  std::string units = "grid";  // of --box, --time and --slices: grid or physical
  uint64_t budget = 0;
  double time_limit = 0;
  bool in_memory = false;
  size_t cache_mb = 256;
  bool check = false;
  bool force = false;
};

// The codes in `path`, "T:bits" per line (blank lines skipped).
template <int D>
std::vector<SimplexCode<D>> ReadCodes(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw CommandError(fmt::format("{}: cannot open the file", path));
  std::vector<SimplexCode<D>> codes;
  std::string line;
  for (uint64_t n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    Result<SimplexCode<D>> c = SimplexCode<D>::Parse(line);
    if (!c.ok()) throw CommandError(fmt::format("{}:{}: {}", path, n, c.status().message()));
    codes.push_back(*c);
  }
  return codes;
}

// The leaf codes in `path` ("T:bits" per line) as a mesh: every proper
// ancestor of a leaf is split. The list must be a conforming mesh (checked).
template <int D>
Mesh<D> ReadMesh(const std::string& path) {
  const std::vector<SimplexCode<D>> leaves = ReadCodes<D>(path);
  const ConformityReport report = CheckConformity<D>(leaves);
  if (!report.ok) {
    throw CommandError(fmt::format("--from {}: not a conforming mesh of the domain: {}", path, report.problem));
  }
  Mesh<D> mesh;
  for (SimplexCode<D> c : leaves) {
    for (int l = c.level() - 1; l >= 0 && mesh.split_set().insert(c.ancestor(l)); --l) {
    }
  }
  return mesh;
}

// Writes a mesh of grid-unit points as ParaView should see it: clipped to
// the real grid and placed physically.
void WriteMeshOnGrid(TetMeshData data, const SourceInfo& info, const std::string& path) {
  data = ClipToGrid(std::move(data), info.dims);
  PlacePhysically(data, info);
  if (Status st = WriteVtu(data, path); !st.ok()) Fail(st);
}

// OUTPUT.pvd and one OUTPUT_<i>.vtu per time (grid units) beside it; the
// collection's times are physical.
template <class Source>
void WriteSliceSeries(const Mesh<4>& mesh, Source& source, const std::vector<double>& times,
                      const std::string& output) {
  const std::string stem = output.size() > 4 && output.ends_with(".pvd") ? output.substr(0, output.size() - 4) : output;
  const SourceInfo& info = source.info();
  const double scale = std::ldexp(1.0, kCoordBits<4> - info.domain_bits);
  std::vector<PvdDataSet> pvd;
  for (size_t i = 0; i < times.size(); ++i) {
    const std::string file = fmt::format("{}_{}.vtu", stem, i);
    Result<TetMeshData> data = SliceHpMesh(mesh, source, times[i] * scale);
    if (!data.ok()) Fail(data.status());
    WriteMeshOnGrid(std::move(*data), info, file);
    const size_t slash = file.find_last_of('/');
    pvd.push_back({info.origin[3] + times[i] * info.spacing[3],
                   slash == std::string::npos ? file : file.substr(slash + 1)});
  }
  if (Status st = WritePvd(pvd, output); !st.ok()) Fail(st);
}

// The format an output file's extension names, or "" for another one.
std::string FormatOfExtension(const std::string& output) {
  const size_t slash = output.find_last_of('/'), dot = output.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  const std::string ext = output.substr(dot + 1);
  if (ext == "vtu" || ext == "pvd" || ext == "json") return ext;
  if (ext == "codes" || ext == "txt") return "codes";
  return "";
}

// --format as given, else from the output's extension, else json; an
// explicit one that contradicts the extension is an error.
std::string ResolveFormat(const ExtractArgs& a) {
  const std::string implied = a.output == "-" ? "" : FormatOfExtension(a.output);
  if (a.format.empty()) return implied.empty() ? "json" : implied;
  if (!implied.empty() && implied != a.format) {
    throw CommandError(fmt::format("--format {} contradicts the output's extension: {} names {} (leave --format "
                                   "out, or name the file for what it holds)",
                                   a.format, a.output, implied),
                       2);
  }
  return a.format;
}

// The units --box, --time and --slices are given in: grid units (the
// contract's: point i of an axis is at i) or physical ones (the store's
// origin + i * spacing; a flipped axis's spacing is negative).
struct AxisUnits {
  bool physical = false;
  const SourceInfo* info = nullptr;

  double ToGrid(int axis, double x) const {
    return physical ? (x - info->origin[axis]) / info->spacing[axis] : x;
  }
  double FromGrid(int axis, double i) const { return physical ? info->origin[axis] + i * info->spacing[axis] : i; }
  const char* name() const { return physical ? "physical units" : "grid units"; }
};

// Criteria that can meet no simplex of the real grid are a mistake in the
// command line, not an empty mesh: a box outside the grid, an isovalue
// outside the field's range, a time outside the store's.
template <int D>
void CheckCriteriaMeetTheGrid(const CriteriaSpec& spec, const std::string& box_text, const SourceInfo& info,
                              const AxisUnits& units) {
  if (spec.box) {
    const std::vector<double>& b = *spec.box;  // x0,y0,z0,x1,y1,z1[,t0,t1]
    for (size_t k = 0; k < b.size() / 2 && k < static_cast<size_t>(D); ++k) {  // MakeCriteria checks counts
      const double lo = k < 3 ? b[k] : b[6], hi = k < 3 ? b[k + 3] : b[7];
      const double last = static_cast<double>(info.dims[k]) - 1;
      if (hi < 0 || lo > last) {
        const int axis = static_cast<int>(k);
        // In the units given, smaller first (a flipped axis runs backwards).
        const auto span = [&](double from, double to) {
          return std::minmax({units.FromGrid(axis, from), units.FromGrid(axis, to)});  // by value
        };
        const auto [box_lo, box_hi] = span(lo, hi);
        const auto [grid_lo, grid_hi] = span(0, last);
        throw CommandError(fmt::format("--box {}: {} from {} to {} misses the grid, whose {} runs from {} to {} ({})",
                                       box_text, "xyzt"[k], box_lo, box_hi, "xyzt"[k], grid_lo, grid_hi,
                                       units.name()),
                           2);
      }
    }
  }
  if (spec.iso && !(*spec.iso >= info.field_min && *spec.iso <= info.field_max)) {
    throw CommandError(fmt::format("--iso {}: outside the field's range, {} to {}: no simplex contains it",
                                   *spec.iso, info.field_min, info.field_max),
                       2);
  }
  if (D == 4 && spec.time) {  // an HT's --time is refused by MakeCriteria
    const double last = static_cast<double>(info.dims[3]) - 1;
    if (!(*spec.time >= 0 && *spec.time <= last)) {
      throw CommandError(fmt::format("--time {}: outside the store's times, {} to {} ({})",
                                     units.FromGrid(3, *spec.time), units.FromGrid(3, 0), units.FromGrid(3, last),
                                     units.name()),
                         2);
    }
  }
}

// `hz`: the store behind `source` when it is a dense one (its cache and
// blocks are reported), null otherwise.
template <int D, class Source>
void Extract(Source& source, const ExtractArgs& given, const HzStore* hz = nullptr) {
  ExtractArgs a = given;
  a.format = ResolveFormat(given);
  const SourceInfo& info = source.info();
  if (a.units != "grid" && a.units != "physical") {
    throw CommandError(fmt::format("--units {}: expected grid or physical", a.units), 2);
  }
  const AxisUnits units{a.units == "physical", &info};
  CriteriaSpec spec;
  spec.error.value = ParseAmount(a.error, "--error", info.field_range());
  if (!a.box.empty()) {
    std::vector<double> box = ParseNumberList(a.box, "--box", 6, 8);
    for (size_t i = 0; i < box.size(); ++i) box[i] = units.ToGrid(i < 6 ? static_cast<int>(i % 3) : 3, box[i]);
    // A flipped axis (negative spacing) runs the other way in grid units.
    for (size_t k = 0; k < 3 && units.physical; ++k) {
      if (info.spacing[k] < 0) std::swap(box[k], box[k + 3]);
    }
    spec.box = std::move(box);
  }
  spec.iso = a.iso;
  if (a.time) spec.time = units.ToGrid(3, *a.time);
  CheckCriteriaMeetTheGrid<D>(spec, a.box, info, units);
  Result<Criteria<D>> criteria = MakeCriteria<D>(spec, info.domain_bits, info.field_range());
  if (!criteria.ok()) throw CommandError(std::string(criteria.status().message()), 2);
  Result<Algorithm> algorithm = ParseAlgorithm(a.algorithm);
  if (!algorithm.ok()) throw CommandError(std::string(algorithm.status().message()), 2);
  if (!a.from.empty() && *algorithm != Algorithm::kIncremental) {
    throw CommandError("--from gives the previous mesh of --algorithm incremental", 2);
  }
  if (a.format != "codes" && a.format != "json" && a.format != "vtu" && a.format != "pvd") {
    throw CommandError(fmt::format("--format {}: expected codes, vtu, pvd or json", a.format), 2);
  }
  if ((a.format == "vtu" || a.format == "pvd") && a.output == "-") {
    throw CommandError(fmt::format("--format {} needs -o FILE", a.format), 2);
  }
  if (a.format == "vtu" && D == 4 && !a.time) {
    throw CommandError("--format vtu of an HP writes the 3D mesh of a time slice: give --time T", 2);
  }
  std::vector<double> slices;
  if (a.format == "pvd") {
    if (D != 4) throw CommandError("--format pvd writes a series of HP time slices; the HT has no time", 2);
    if (a.slices.empty()) throw CommandError("--format pvd needs --slices T1,T2,... (times in --units)", 2);
    slices = ParseNumberList(a.slices, "--slices", 1, 100000);
    for (double& t : slices) t = units.ToGrid(3, t);
  }

  Mesh<D> mesh = a.from.empty() ? Mesh<D>() : ReadMesh<D>(a.from);
  RefineOptions options;
  options.algorithm = *algorithm;
  options.max_simplices = a.budget;
  options.max_seconds = a.time_limit;
  Refiner<D, Source> refiner(source, *criteria);
  QueryStats stats;
  try {
    if (Status s = refiner.Run(options, mesh, stats); !s.ok()) Fail(s);
  } catch (const std::bad_alloc&) {
    Fail(NotEnoughMemory("the mesh refined from " + info.path,
                         fmt::format("{} simplices so far", mesh.leaf_count())));
  }

  std::optional<ConformityReport> check;
  std::vector<SimplexCode<D>> leaves;
  if (a.format == "codes" || a.check) leaves = mesh.Leaves();
  if (a.check) check = CheckConformity<D>(leaves);

  // The HP's time slice, for vtu and for the statistics (the seed's Fig. 63
  // counts the slice's tetrahedra beside the pentatopes).
  std::optional<uint64_t> slice_tetrahedra;
  if constexpr (D == 4) {
    if (criteria->time && (a.format == "vtu" || a.format == "json")) {
      Result<TetMeshData> data = SliceHpMesh(mesh, source, *criteria->time);
      if (!data.ok()) Fail(data.status());
      slice_tetrahedra = data->cells();
      if (a.format == "vtu") WriteMeshOnGrid(std::move(*data), info, a.output);
    }
  }
  if (a.format == "codes") {
    if (Status s = WriteCodes<D>(leaves, a.output); !s.ok()) Fail(s);
  } else if (a.format == "vtu") {
    if constexpr (D == 3) {
      Result<TetMeshData> data = CollectTetMesh(mesh, source);
      if (!data.ok()) Fail(data.status());
      WriteMeshOnGrid(std::move(*data), info, a.output);
    }
  } else if (a.format == "pvd") {
    if constexpr (D == 4) WriteSliceSeries(mesh, source, slices, a.output);
  }
  json j;
  SetJsonBytes(j, "store", info.path);
  j["hierarchy"] = D == 3 ? "ht" : "hp";
  j["algorithm"] = AlgorithmName(*algorithm);
  j["threshold"] = criteria->threshold;
  j["simplices"] = stats.simplices;
  j["full_resolution_simplices"] = static_cast<double>(SimplexCode<D>::kRoots) * std::ldexp(1.0, info.leaf_level());
  j["splits"] = stats.splits;
  j["merges"] = stats.merges;
  j["cluster_computations"] = stats.cluster_computations;
  j["candidates"] = stats.candidates;
  j["error_lookups"] = stats.error_lookups;
  j["field_lookups"] = stats.field_lookups;
  j["blocks_read"] = stats.blocks_read;
  j["blocks_skipped"] = stats.blocks_skipped;
  j["seconds"] = stats.seconds;
  if (*algorithm == Algorithm::kSaturated) j["saturation_seconds"] = stats.saturation_seconds;
  if (*algorithm == Algorithm::kPriority) j["interrupted"] = stats.interrupted;
  j["splits_per_second"] = stats.seconds > 0 ? stats.splits / stats.seconds : 0.0;
  if (slice_tetrahedra) {
    j["slice_tetrahedra"] = *slice_tetrahedra;
    // A full-resolution mesh cut at a grid time: 6 tetrahedra per cube of
    // the 3D grid (the seed's 196,608 for 33^4). Between grid times the cut
    // pentatopes give prisms and pyramids, so no such count.
    if (*a.time == std::floor(*a.time)) {
      j["full_resolution_slice_tetrahedra"] = 6 * std::ldexp(1.0, 3 * (info.leaf_level() / 4));
    }
  }
  // Of the whole process: the store's cache, the mesh and the query's sets,
  // and (peak only) the store's mapped file pages the query touched.
  j["peak_memory_bytes"] = PeakResidentBytes();
  j["anonymous_memory_bytes"] = AnonymousResidentBytes();  // the mesh is still alive
  if (hz != nullptr) {
    // Zstd frames decoded plus raw ones read, blocks and bricks (repeats
    // counted), how many different ones the query needed, and how many
    // bricks' finest errors it computed from the field; the decoded blocks
    // held at the end (never more than --cache-mb).
    const HzStore::Stats hs = hz->stats();
    j["blocks_decoded"] = hs.blocks_decoded + hs.raw_checked;
    j["distinct_blocks"] = hs.distinct;
    j["finest_boxes_computed"] = hs.boxes_computed;
    if (hz->cache() != nullptr) j["cache_bytes"] = hz->cache()->charge();
  }
  if (check) {
    j["conforming"] = check->ok;
    if (!check->ok) j["conformity_problem"] = check->problem;
  }
  const std::string text = j.dump(2) + "\n";
  if (a.format == "json" && a.output != "-") {
    if (Status st = WriteFileAtomically(a.output, text); !st.ok()) Fail(st);
  } else {
    // With codes on stdout the statistics go to stderr, out of the way.
    std::fputs(text.c_str(), a.format == "codes" && a.output == "-" ? stderr : stdout);
  }
  if (check && !check->ok) throw CommandError("the extracted mesh is not conforming: " + check->problem, 3);
}

void RunExtract(ExtractArgs a) {
  if (a.output != "-") {
    std::vector<std::string> inputs = {a.store};
    if (!a.from.empty()) inputs.push_back(a.from);
    a.output = CheckOutput(a.output, inputs, a.force);
  }
  // A usage error (exit 2) before anything is opened, as --in-memory names
  // the option; AnyStore::Open would refuse it too.
  if (a.in_memory && ProbeStoreKind(a.store) == StoreKind::kSparse) {
    throw CommandError("--in-memory applies to dense stores; the LMDB store is read in place", 2);
  }
  StoreOptions options;
  options.in_memory = a.in_memory;
  options.cache_bytes = a.cache_mb << 20;
  Result<AnyStore> store = AnyStore::Open(a.store, options);
  if (!store.ok()) Fail(store.status());
  Status s;
  try {
    s = store->Visit(
        [&]<int D, class Source>(Source& source) { Extract<D>(source, a, store->hz()); });
  } catch (const std::bad_alloc&) {
    // After the refinement (which names itself): the leaves, the slice,
    // the output's cells.
    Fail(NotEnoughMemory("the mesh extracted from " + a.store + " and its output",
                         "size not known"));
  }
  if (!s.ok()) Fail(s);
}

template <int D>
void RunConformity(const std::string& path) {
  const std::vector<SimplexCode<D>> leaves = ReadCodes<D>(path);
  const ConformityReport r = CheckConformity<D>(leaves);
  json j;
  SetJsonBytes(j, "file", path);
  j["simplices"] = r.simplices;
  j["conforming"] = r.ok;
  j["interior_faces"] = r.interior_faces;
  j["boundary_faces"] = r.boundary_faces;
  if (!r.ok) j["problem"] = r.problem;
  std::fputs((j.dump(2) + "\n").c_str(), stdout);
  if (!r.ok) throw CommandError(fmt::format("{}: not a conforming mesh: {}", path, r.problem), 3);
}

}  // namespace

void RegisterExtractCommand(CLI::App& app) {
  auto args = std::make_shared<ExtractArgs>();
  auto* cmd = app.add_subcommand(
      "extract",
      "Extract the mesh that meets LOD criteria from a store (selective refinement, seed 3.6 / 4.6).\n"
      "A simplex is split when its error exceeds --error and every other criterion given applies to it;\n"
      "the result is the minimal conforming mesh (depth-first and priority agree).");
  cmd->add_option("store", args->store, "Dense (.sdb) or sparse (LMDB) store")->required();
  cmd->add_option("--error", args->error, "Error threshold: 7.3 (field units) or 1% (of the field range)")
      ->required();
  cmd->add_option("--box", args->box,
                  "Hold only simplices meeting this closed box to the threshold: x0,y0,z0,x1,y1,z1[,t0,t1] "
                  "in grid coordinates, or physical ones with --units physical (an exact test)");
  cmd->add_option("--iso", args->iso,
                  "Hold only simplices that may contain this isovalue (vertex range widened by their error)");
  cmd->add_option("--time", args->time, "HP: hold only pentatopes meeting the time slice t = T (grid units, or\n"
                  "physical with --units physical)");
  cmd->add_option("--units", args->units,
                  "grid (default: point i of an axis is at i) or physical (the store's origin + i x spacing,\n"
                  "`simplexdb info` shows them): the units of --box, --time and --slices. Meshes are\n"
                  "always written in physical coordinates")
      ->capture_default_str();
  cmd->add_option("--algorithm", args->algorithm, "depth-first (default), priority, incremental, saturated, or level-order (the\n"
                  "depth-first mesh, candidates taken level by level in the store's order: each\n"
                  "block of a format-2 store read about once, for a cache far smaller than the store)");
  cmd->add_option("--budget", args->budget, "priority: stop before the mesh would pass this many simplices");
  cmd->add_option("--time-limit", args->time_limit, "priority: stop after this many seconds");
  cmd->add_option("--from", args->from, "incremental: the previous mesh, as leaf codes (--format codes)");
  cmd->add_option("--format", args->format,
                  "codes (leaf codes, one per line), vtu (VTK unstructured grid: the HT's tetrahedra, or the\n"
                  "tetrahedra of the HP's time slice --time), pvd (HP: a ParaView series of time slices\n"
                  "--slices, one .vtu each beside OUTPUT) or json (statistics; with --time also the tetrahedra\n"
                  "of the time slice). Default: named by OUTPUT's extension (.vtu, .pvd, .json, .codes or .txt),\n"
                  "else json; a --format the extension contradicts is an error");
  cmd->add_option("--slices", args->slices, "pvd: the times of the slices, T1,T2,... (in --units)");
  cmd->add_option("-o,--output", args->output, "Output file ('-' for stdout, the default for codes and json)");
  cmd->add_flag("--in-memory", args->in_memory,
                "Decode the whole dense store and compute its finest errors at open (in-core: "
                "slower to open, for comparing with out-of-core)");
  cmd->add_option("--cache-mb", args->cache_mb, "Block cache budget, MiB (out-of-core)")
      ->capture_default_str();
  cmd->add_flag("--check", args->check, "Check the result's conformity from geometry (exit 3 if not)");
  AddForceOption(cmd, &args->force);
  cmd->callback([args] { RunExtract(*args); });

  auto path = std::make_shared<std::string>();
  auto hierarchy = std::make_shared<std::string>("ht");
  auto* conf = app.add_subcommand(
      "conformity",
      "Check that a list of leaf codes is a conforming mesh of the domain: the simplices tile it and every\n"
      "interior face is shared by exactly two simplices with the same vertices. Exit 0 if so, 3 if not.");
  conf->add_option("codes", *path, "File of leaf codes, one per line (as extract --format codes writes)")
      ->required();
  conf->add_option("--hierarchy", *hierarchy, "ht or hp")->capture_default_str();
  conf->callback([path, hierarchy] {
    if (*hierarchy == "ht") {
      RunConformity<3>(*path);
    } else if (*hierarchy == "hp") {
      RunConformity<4>(*path);
    } else {
      throw CommandError(fmt::format("--hierarchy {}: expected ht or hp", *hierarchy), 2);
    }
  });
}

}  // namespace simplexdb::tools
