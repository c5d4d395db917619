// `simplexdb extract`: selective refinement over any store through
// ExtractToFile (ops/extract_output.h; the Python package's Store.extract
// calls the same Extract), and `simplexdb conformity`: the geometric
// conformity check of a mesh given as leaf codes. Here: the options
// parsed, the statistics printed.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "hierarchy/simplex_code.h"
#include "ops/extract.h"
#include "ops/extract_output.h"
#include "parallel/mpi_session.h"
#include "query/conformity.h"
#include "query/open_store.h"
#include "storage/io/file.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

using json = nlohmann::ordered_json;

struct ExtractArgs {
  // The options that need no parsing (--iso, --time, --units, --algorithm,
  // --budget, --time-limit, --check) are bound to the request's fields.
  ExtractRequest request;
  std::string store;
  std::string error;
  std::string box;
  std::string format;  // empty: from the output's extension, else json
  std::string output = "-";
  std::string from;
  std::string slices;
  bool in_memory = false;
  size_t cache_mb = 256;
  bool force = false;
};

// The options of `a` parsed into a.request, the output checked and the
// store opened and checked against the request and `format`: usage errors
// throw with exit 2, a store or a --from file that does not read with 1.
AnyStore PrepareExtract(ExtractArgs& a, const std::string& format) {
  if (a.output != "-") {
    std::vector<std::string> inputs = {a.store};
    if (!a.from.empty()) inputs.push_back(a.from);
    a.output = CheckOutput(a.output, inputs, a.force);
  }
  ExtractRequest& request = a.request;
  request.error = ParseAmountOption(a.error, "--error");
  if (!a.box.empty()) request.box = ParseNumberList(a.box, "--box", 1, 8);
  if (!a.slices.empty()) request.slices = ParseNumberList(a.slices, "--slices", 1, 100000);
  AnyStore store = OpenQueriedStore(a.store, a.in_memory, a.cache_mb);
  CheckUsage(CheckExtract(store.info(), request));
  CheckUsage(CheckExtractOutput(store.info(), request, format, a.output));
  if (!a.from.empty()) {
    Result<std::vector<uint64_t>> from = ReadLeafCodes(a.from, store.dimension());
    if (!from.ok()) Fail(from.status());
    request.from = *std::move(from);
  }
  return store;
}

bool ExtensionIsPvtu(const std::string& path) {
  return path.size() > 5 && path.compare(path.size() - 5, 5, ".pvtu") == 0;
}

// Under mpirun with several ranks: each rank extracts its piece of the
// mesh (query/pieces.h), trading the splits that cross with the others;
// -o OUT.pvtu: OUT_<rank>.vtu from each rank, then OUT.pvtu from rank 0;
// the statistics of every piece and of the whole printed by rank 0.
void RunExtractInPieces(ExtractArgs a, MpiSession& mpi) {
  std::string format;
  std::optional<AnyStore> store;
  ExtractRequest& request = a.request;
  Together(mpi, [&]() -> Status {
    format = UsageValue(ResolveExtractFormat(a.format, a.output));
    if (format != "pvtu" && format != "pvd" && format != "json") {
      return Status::InvalidArgument(fmt::format(
          "under mpirun extract writes the mesh in pieces (-o OUT.pvtu: one .vtu per rank; an HP's slices "
          "-o OUT.pvd), or the statistics (.json, or -); not {}",
          format));
    }
    request.piece = mpi.rank();
    request.pieces = mpi.size();
    store.emplace(PrepareExtract(a, format));
    return Status::OK();
  });
  const PieceExchange exchange = [&mpi](const std::vector<std::vector<uint64_t>>& outbox, bool failed, bool* quiet) {
    return mpi.Exchange(outbox, failed, quiet);
  };
  std::optional<ExtractResult> result;
  // This rank's files, removed if any rank fails.
  std::vector<std::string> piece_files;
  if (format == "pvtu") piece_files.push_back(PvtuPieceFile(a.output, mpi.rank()));
  for (size_t i = 0; format == "pvd" && i < request.slices.size(); ++i) {
    piece_files.push_back(PvdPieceFile(a.output, i, mpi.rank()));
  }
  try {
    Together(mpi, [&]() -> Status {
      SDB_ASSIGN_OR_RETURN(ExtractResult r,
                           ExtractToFile(*store, request, format, format == "json" ? "-" : a.output, exchange));
      result.emplace(std::move(r));
      return Status::OK();
    });
    // The .pvtu (.pvd) last, naming only pieces that every rank wrote.
    Together(mpi, [&]() -> Status {
      if (mpi.rank() != 0) return Status::OK();
      if (format == "pvtu") return WritePvtuOf(a.output, mpi.size());
      if (format == "pvd") return WritePiecesPvd(a.output, mpi.size(), result->slice_times);
      return Status::OK();
    });
  } catch (const CommandError&) {
    for (const std::string& f : piece_files) std::remove(f.c_str());  // no pieces of a mesh that failed
    throw;
  }
  json mine = ExtractStatsJson(*result);
  if (result->mesh) mine["cells_written"] = result->mesh->cells();
  if (format == "pvd") mine["slices_written"] = result->slice_times.size();
  const Result<std::vector<std::string>> all = mpi.Gather(mine.dump());
  if (!all.ok()) Fail(all.status());
  if (mpi.rank() != 0) return;
  json whole;
  whole["store"] = mine["store"];
  whole["pieces"] = mpi.size();
  uint64_t simplices = 0, largest = 0, sent = 0, max_sent = 0;
  double seconds = 0;
  json each = json::array();
  for (const std::string& text : *all) {
    json j = json::parse(text);
    const uint64_t n = j["simplices"].get<uint64_t>();
    simplices += n;
    largest = std::max(largest, n);
    const uint64_t bytes = j.value("exchange_bytes_sent", uint64_t{0});  // none in one piece
    sent += bytes;
    max_sent = std::max(max_sent, bytes);
    seconds = std::max(seconds, j["seconds"].get<double>());
    each.push_back(std::move(j));
  }
  whole["simplices"] = simplices;
  whole["largest_piece_over_mean"] = simplices > 0 ? static_cast<double>(largest) * mpi.size() / simplices : 0.0;
  whole["exchange_rounds"] = each[0].value("exchange_rounds", 0);
  whole["exchange_bytes_sent"] = sent;
  whole["exchange_bytes_sent_max_rank"] = max_sent;
  whole["seconds"] = seconds;  // the slowest rank's
  if (format != "json") whole["output"] = a.output;
  whole["per_piece"] = std::move(each);
  const std::string text = whole.dump(2) + "\n";
  if (format == "json" && a.output != "-") {
    if (const Status s = WriteFileAtomically(a.output, text); !s.ok()) Fail(s);
  } else {
    std::fputs(text.c_str(), stdout);
  }
}

void RunExtract(ExtractArgs a) {
  // Under mpirun: in pieces (with one rank only for a .pvtu; otherwise one
  // rank is a plain run).
  if (MpiSession* mpi = MpiSession::Current();
      mpi != nullptr && (mpi->size() > 1 || ExtensionIsPvtu(a.output) || a.format == "pvtu")) {
    RunExtractInPieces(std::move(a), *mpi);
    return;
  }
  const std::string format = UsageValue(ResolveExtractFormat(a.format, a.output));
  const AnyStore store = PrepareExtract(a, format);
  const Result<ExtractResult> r = ExtractToFile(store, a.request, format, a.output);
  if (!r.ok()) Fail(r.status());
  if (format != "json" || a.output == "-") {
    // With codes on stdout the statistics go to stderr, out of the way.
    const std::string text = ExtractStatsJson(*r).dump(2) + "\n";
    std::fputs(text.c_str(), format == "codes" && a.output == "-" ? stderr : stdout);
  }
  if (r->conformity && !r->conformity->ok) {
    throw CommandError("the extracted mesh is not conforming: " + r->conformity->problem, 3);
  }
}

template <int D>
void RunConformityOf(const std::string& path) {
  Result<std::vector<uint64_t>> keys = ReadLeafCodes(path, D);
  if (!keys.ok()) Fail(keys.status());
  std::vector<SimplexCode<D>> leaves;
  leaves.reserve(keys->size());
  for (const uint64_t k : *keys) leaves.push_back(SimplexCode<D>::FromKey(k));
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

struct ConformityArgs {
  std::string path;
  std::string hierarchy = "ht";
};

void RunConformity(const ConformityArgs& a) {
  if (a.hierarchy == "ht") {
    RunConformityOf<3>(a.path);
  } else if (a.hierarchy == "hp") {
    RunConformityOf<4>(a.path);
  } else {
    throw CommandError(fmt::format("--hierarchy {}: expected ht or hp", a.hierarchy), 2);
  }
}

// `simplexdb extract --help`.
constexpr const char* kExtractHelp = R"(Extract the mesh that meets LOD criteria from a store (selective refinement, seed 3.6 / 4.6).
A simplex is split when its error exceeds --error and every other criterion given applies to it;
the result is the minimal conforming mesh (depth-first and priority agree).
The bound: on every tetrahedron (pentatope) of the result that meets the criteria, the field at
every grid point inside it differs from the linear interpolation of its vertices' values by at
most --error (the stored errors are rounded up, never down).
The output's extension names what is written: .vtu the mesh (ParaView; an HP's at --time),
.pvtu the mesh in pieces, .pvd a series of HP time slices (--slices), .json the statistics,
.codes the leaf codes.
Under mpirun every rank extracts one piece (the same pieces whatever the machine), trading the
splits that cross with the others; -o OUT.pvtu writes OUT_<rank>.vtu per rank and OUT.pvtu,
which ParaView opens as one mesh (the union is the one-process mesh, cell for cell).
Examples:
  simplexdb extract tooth.sdb --error 3% -o tooth.vtu
  simplexdb extract tooth.sdb --error 1% --box 20,20,40,80,70,120 --units physical -o zoom.vtu
  simplexdb extract fmri.sdb --error 5% --slices 0,1 -o fmri.pvd
  mpirun -np 4 simplexdb extract tooth.sdb --error 1% -o tooth.pvtu)";

}  // namespace

void RegisterExtractCommand(CLI::App& app) {
  auto [cmd, args] = AddCommand<ExtractArgs>(app, "extract", kExtractHelp, RunExtract);
  cmd->add_option("store", args->store, "Dense (.sdb) or sparse (LMDB) store")->required();
  cmd->add_option("--error", args->error, "Error threshold: 7.3 (field units) or 1% (of the field range)")
      ->required();
  cmd->add_option("--box", args->box,
                  "Hold only simplices meeting this closed box to the threshold: x0,y0,z0,x1,y1,z1[,t0,t1] "
                  "in grid coordinates, or physical ones with --units physical (an exact test)");
  cmd->add_option("--iso", args->request.iso,
                  "Hold only simplices that may contain this isovalue (vertex range widened by their error)")->check(DecimalNumber());
  cmd->add_option("--time", args->request.time, "HP: hold only pentatopes meeting the time slice t = T (grid units, or\n"
                  "physical with --units physical)")->check(DecimalNumber());
  cmd->add_option("--units", args->request.units,
                  "grid (default: point i of an axis is at i) or physical (the store's origin + i x spacing,\n"
                  "`simplexdb info` shows them): the units of --box, --time and --slices. Meshes are\n"
                  "always written in physical coordinates")
      ->capture_default_str();
  cmd->add_option("--algorithm", args->request.algorithm, "depth-first (default), priority, incremental, saturated, or level-order (the\n"
                  "depth-first mesh, candidates taken level by level in the store's order: each\n"
                  "block of a format-2 store read about once, for a cache far smaller than the store)");
  cmd->add_option("--budget", args->request.budget, "priority: stop before the mesh would pass this many simplices");
  cmd->add_option("--time-limit", args->request.time_limit, "priority: stop after this many seconds")->check(DecimalNumber());
  cmd->add_option("--from", args->from, "incremental: the previous mesh, as leaf codes (--format codes)");
  cmd->add_option("--format", args->format,
                  "codes (leaf codes, one per line), vtu (VTK unstructured grid: the HT's tetrahedra, or the\n"
                  "tetrahedra of the HP's time slice --time), pvtu (the same in pieces, OUTPUT_<r>.vtu each:\n"
                  "one per MPI rank), pvd (HP: a ParaView series of time slices\n"
                  "--slices, one .vtu each beside OUTPUT) or json (statistics; with --time also the tetrahedra\n"
                  "of the time slice). Default: named by OUTPUT's extension (.vtu, .pvtu, .pvd, .json, .codes or .txt),\n"
                  "else json; a --format the extension contradicts is an error");
  cmd->add_option("--slices", args->slices, "pvd: the times of the slices, T1,T2,... (in --units)");
  cmd->add_option("-o,--output", args->output, "Output file ('-' for stdout, the default for codes and json)");
  cmd->add_flag("--in-memory", args->in_memory,
                "Decode the whole dense store and compute its finest errors at open (in-core: "
                "slower to open, for comparing with out-of-core)");
  cmd->add_option("--cache-mb", args->cache_mb, "Block cache budget, MiB (out-of-core)")
      ->capture_default_str();
  cmd->add_flag("--check", args->request.check, "Check the result's conformity from geometry (exit 3 if not)");
  AddForceOption(cmd, &args->force);

  auto [conf, c] = AddCommand<ConformityArgs>(
      app, "conformity",
      "Check that a list of leaf codes is a conforming mesh of the domain: the simplices tile it and every\n"
      "interior face is shared by exactly two simplices with the same vertices. Exit 0 if so, 3 if not.",
      RunConformity);
  conf->add_option("codes", c->path, "File of leaf codes, one per line (as extract --format codes writes)")
      ->required();
  conf->add_option("--hierarchy", c->hierarchy, "ht or hp")->capture_default_str();
}

}  // namespace simplexdb::tools
