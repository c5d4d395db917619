// `simplexdb isosurface`: the surface at an isovalue, straight from the
// hierarchy, through IsosurfaceToFile (ops/isosurface.h). Here: the
// options parsed, the report printed.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ops/extract.h"
#include "ops/isosurface.h"
#include "parallel/mpi_session.h"
#include "query/open_store.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

namespace simplexdb::tools {
namespace {

struct IsosurfaceArgs {
  ExtractRequest request;  // iso, time and units bound directly
  std::string store;
  std::string error = "1%";
  std::string box;
  std::string output;
  bool in_memory = false;
  size_t cache_mb = 256;
  bool force = false;
  bool json = false;
  bool quiet = false;
};

// The options of `a` parsed into a.request and the store opened and
// checked against it: usage errors throw with exit 2, a store that does not
// read with 1.
AnyStore PrepareIsosurface(IsosurfaceArgs& a) {
  CheckUsage(SurfaceFormatOf(a.output).status());
  a.output = CheckOutput(a.output, {a.store}, a.force);
  ExtractRequest& request = a.request;
  request.error = ParseAmountOption(a.error, "--error");
  if (!a.box.empty()) request.box = ParseNumberList(a.box, "--box", 1, 8);
  request.surface = true;
  AnyStore store = OpenQueriedStore(a.store, a.in_memory, a.cache_mb);
  CheckUsage(CheckExtract(store.info(), request));
  return store;
}

// Under mpirun with several ranks, -o OUT.pvtp: each rank contours its
// piece of the mesh (query/pieces.h), trading the splits that cross with
// the others, and writes OUT_<rank>.vtp; rank 0 then OUT.pvtp and the
// report: the pieces' triangles summed, the slowest rank's seconds.
void RunIsosurfaceInPieces(IsosurfaceArgs a, MpiSession& mpi) {
  std::optional<AnyStore> store;
  Together(mpi, [&]() -> Status {
    if (UsageValue(SurfaceFormatOf(a.output)) != "pvtp") {
      return Status::InvalidArgument("under mpirun isosurface writes the surface in pieces: -o OUT.pvtp (one .vtp "
                                     "per rank)");
    }
    a.request.piece = mpi.rank();
    a.request.pieces = mpi.size();
    store.emplace(PrepareIsosurface(a));
    return Status::OK();
  });
  const PieceExchange exchange = [&mpi](const std::vector<std::vector<uint64_t>>& outbox, bool failed, bool* quiet) {
    return mpi.Exchange(outbox, failed, quiet);
  };
  std::optional<ExtractResult> result;
  try {
    Together(mpi, [&]() -> Status {
      SDB_ASSIGN_OR_RETURN(ExtractResult r, IsosurfaceToFile(*store, a.request, a.output, exchange));
      result.emplace(std::move(r));
      return Status::OK();
    });
    Together(mpi, [&]() -> Status { return mpi.rank() == 0 ? WritePvtpOf(a.output, mpi.size()) : Status::OK(); });
  } catch (const CommandError&) {
    std::remove(PvtpPieceFile(a.output, mpi.rank()).c_str());  // no pieces of a surface that failed
    throw;
  }
  const nlohmann::ordered_json mine = ExtractStatsJson(*result);
  const Result<std::vector<std::string>> all = mpi.Gather(mine.dump());
  if (!all.ok()) Fail(all.status());
  if (mpi.rank() != 0 || a.quiet) return;
  nlohmann::ordered_json whole, each = nlohmann::ordered_json::array();
  uint64_t triangles = 0, points = 0;
  double seconds = 0;
  for (const std::string& text : *all) {
    nlohmann::ordered_json j = nlohmann::ordered_json::parse(text);
    triangles += j["triangles"].get<uint64_t>();
    points += j["points"].get<uint64_t>();
    seconds = std::max(seconds, j["seconds"].get<double>());
    each.push_back(std::move(j));
  }
  whole["store"] = mine["store"];
  whole["pieces"] = mpi.size();
  whole["triangles"] = triangles;
  whole["points"] = points;  // a point on a boundary between pieces is in each
  whole["seconds"] = seconds;  // the slowest rank's
  SetJsonBytes(whole, "output", a.output);
  whole["per_piece"] = std::move(each);
  if (a.json) {
    std::fputs((whole.dump(2) + "\n").c_str(), stdout);
  } else {
    std::printf("%s\n", fmt::format("isosurface at {} of {} in {} pieces: {} triangles in {:.2f} s; written to {}",
                                    *a.request.iso, a.store, mpi.size(), triangles, seconds, a.output)
                            .c_str());
  }
}

void RunIsosurface(IsosurfaceArgs a) {
  if (MpiSession* mpi = MpiSession::Current(); mpi != nullptr && mpi->size() > 1) {
    RunIsosurfaceInPieces(std::move(a), *mpi);
    return;
  }
  const AnyStore store = PrepareIsosurface(a);
  const ExtractRequest& request = a.request;
  const Result<ExtractResult> r = IsosurfaceToFile(store, request, a.output);
  if (!r.ok()) Fail(r.status());
  if (a.quiet) return;
  if (a.json) {
    nlohmann::ordered_json j = ExtractStatsJson(*r);
    SetJsonBytes(j, "output", a.output);
    std::fputs((j.dump(2) + "\n").c_str(), stdout);
    return;
  }
  std::printf("%s\n", fmt::format("isosurface at {} of {} (--error {}: {:.6g} in field units): {} triangles, {} "
                                  "points, from a mesh of {} {}; refined in {:.2f} s, contoured in {:.2f} s; "
                                  "written to {}",
                                  *request.iso, a.store, a.error, r->threshold, r->surface->triangle_count(),
                                  r->surface->point_count(), r->stats.simplices,
                                  store.dimension() == 3 ? "tetrahedra" : "pentatopes", r->stats.seconds,
                                  r->surface_seconds, a.output)
                          .c_str());
}

constexpr const char* kIsosurfaceHelp = R"(The surface where the field equals --iso, straight from the hierarchy: marching tetrahedra over
the leaves of the mesh `extract --iso V --error E` returns (the minimal conforming mesh in which
every tetrahedron that may hold the value has error at most E, 1% of the range unless given),
never collecting the mesh.
The surface has no cracks (points are merged by the edge they cut, across tetrahedra of every
level) and is closed wherever it does not leave the grid; every point's value in the field at
full resolution (linear on the finest tetrahedra) is within E of the isovalue.
Written in physical coordinates: .vtp (VTK PolyData, ParaView) with point normals (the field's
gradient, toward increasing values) and each triangle's tetrahedron's error, or .ply.
An HP store's surface is that of its time slice --time. Under mpirun every rank contours one
piece (the pieces of extract): -o OUT.pvtp writes OUT_<rank>.vtp per rank and OUT.pvtp.
Examples:
  simplexdb isosurface tooth.sdb --iso 120 -o dentin.vtp
  simplexdb isosurface tooth.sdb --iso 120 --error 0.5% --box 20,20,40,80,70,120 --units physical -o zoom.ply
  simplexdb isosurface fmri.sdb --iso 1000 --time 2 -o t2.vtp)";

}  // namespace

void RegisterIsosurfaceCommand(CLI::App& app) {
  auto [cmd, args] = AddCommand<IsosurfaceArgs>(app, "isosurface", kIsosurfaceHelp, RunIsosurface);
  cmd->add_option("store", args->store, "Dense (.sdb) or sparse (LMDB) store")->required();
  cmd->add_option("--iso", args->request.iso, "The isovalue, in field units")->required()->check(DecimalNumber());
  cmd->add_option("--error", args->error,
                  "Error bound of the tetrahedra the surface crosses: 7.3 (field units) or 1% (of the field range)")
      ->capture_default_str();
  cmd->add_option("--box", args->box,
                  "Hold only simplices meeting this closed box to the bound: x0,y0,z0,x1,y1,z1[,t0,t1] in grid "
                  "coordinates, or physical ones with --units physical (the surface elsewhere is coarser)");
  cmd->add_option("--time", args->request.time, "HP: the time slice t = T (grid units, or physical with --units physical)")
      ->check(DecimalNumber());
  cmd->add_option("--units", args->request.units,
                  "grid (default) or physical: the units of --box and --time; the surface is always written in "
                  "physical coordinates")
      ->capture_default_str();
  AddOutputOptions(cmd, &args->output, &args->force, "The surface: OUT.vtp, OUT.ply, or (under mpirun) OUT.pvtp");
  cmd->add_flag("--in-memory", args->in_memory, "Decode the whole dense store at open (in-core)");
  cmd->add_option("--cache-mb", args->cache_mb, "Block cache budget, MiB (out-of-core)")->capture_default_str();
  AddReportFlags(cmd, &args->json, &args->quiet, "print the statistics as JSON (extract's, with triangles and points)");
}

}  // namespace simplexdb::tools
