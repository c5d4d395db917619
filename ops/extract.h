// Extract: the mesh a store's LOD criteria give (selective refinement,
// query/refine.h), `simplexdb extract` and the Python package's
// Store.extract. One function from the request to the result: the
// criteria in the grid's or physical units, the algorithm, the leaves, the
// tetrahedra (the HT's, or an HP's time slices) clipped to the grid and
// placed physically, the statistics. The front ends only parse the options
// into an ExtractRequest and print or hand over the result; files are
// written from it by ops/extract_output.h.
//
// Thread safety: reentrant over a const AnyStore (each call makes its own
// source); the slice callback is called from the calling thread.
//
// Lifetimes: the result is a value; the store is read during the call.
//
// Errors: CheckExtract's InvalidArgument (below), naming the option as the
// command spells it; then the refinement's and the store's (Corruption,
// IOError), ResourceExhausted "not enough memory for the mesh ..." when the
// mesh outgrows memory, InvalidArgument for a previous mesh (--from) that
// is not a conforming mesh of the domain, and the slice callback's.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "query/conformity.h"
#include "query/criteria.h"
#include "query/isosurface.h"
#include "query/mesh_io.h"
#include "query/open_store.h"
#include "query/refine.h"
#include "util/status.h"

namespace simplexdb {

struct ExtractRequest {
  Amount error;  // --error: the threshold, in field units or percent of the range
  // --box x0,y0,z0,x1,y1,z1[,t0,t1], in `units`: only simplices meeting it
  // are held to the threshold.
  std::optional<std::vector<double>> box;
  std::optional<double> iso;   // --iso
  std::optional<double> time;  // --time: HP, the slice t = T, in `units`
  // --units: "grid" (point i of an axis is at i) or "physical" (the
  // store's origin + i x spacing) for box, time and slices.
  std::string units = "grid";
  std::string algorithm = "depth-first";  // --algorithm (ParseAlgorithm)
  uint64_t budget = 0;                    // --budget: priority's simplex budget; 0: none
  double time_limit = 0;                  // --time-limit: priority's seconds; 0: none
  // --from: the previous mesh of --algorithm incremental as its leaves'
  // packed codes (SimplexCode::key); checked to be a conforming mesh.
  std::optional<std::vector<uint64_t>> from;
  // --slices: HP, the times (in `units`) of a series of time slices, each
  // handed to Extract's slice callback (or kept in the result).
  std::vector<double> slices;
  // What to collect besides the statistics.
  bool leaves = true;       // the leaves' codes
  bool tetrahedra = false;  // the HT's tetrahedra, or the slice at `time` of an HP
  bool count_slice = false;  // HP with `time`: the slice's tetrahedra counted (statistics)
  bool check = false;        // --check: the result's conformity, from geometry
  // The isosurface at `iso` of the leaves (query/isosurface.h), clipped
  // and placed physically: `simplexdb isosurface`. Needs iso; an HP's, time.
  bool surface = false;
  // --piece/--pieces: piece `piece` (0-based) alone of the mesh cut in
  // `pieces` (query/pieces.h: the same parts for every caller): its leaves,
  // tetrahedra and slices; depth-first only. Under MPI each rank asks for
  // its own, exchanging (PieceExchange); without, this process walks every
  // piece to know the splits that cross into its own.
  int piece = 0;
  int pieces = 1;
};

// One round's trade of the splits that cross between pieces, among the
// processes extracting them (parallel/mpi_session.h): outbox[s] the packed
// codes for piece s; returns those sent to this process's piece and sets
// *quiet when no piece sent any (then every process stops). `failed`: this
// process's walk failed (its last call); the exchange then returns an
// error to every process.
using PieceExchange = std::function<Result<std::vector<uint64_t>>(const std::vector<std::vector<uint64_t>>& outbox,
                                                                  bool failed, bool* quiet)>;

// An HP time slice's tetrahedra, clipped and placed, and its physical time.
struct ExtractSlice {
  double time = 0;  // origin[3] + t x spacing[3]
  TetMeshData mesh;
};

struct ExtractResult {
  SourceInfo info;  // the store's
  Algorithm algorithm = Algorithm::kDepthFirst;
  double threshold = 0;  // --error in field units
  QueryStats stats;
  std::vector<uint64_t> leaves;          // request.leaves: packed codes, ascending
  std::optional<TetMeshData> mesh;       // request.tetrahedra (an HP: with a time only)
  std::optional<double> mesh_time;       // an HP with `time`: the slice's physical time
  std::vector<ExtractSlice> slices;      // request.slices, without a slice callback
  std::vector<double> slice_times;       // ExtractToFile's pvd: the slices' physical times
  std::optional<uint64_t> slice_tetrahedra;  // an HP slice at `time`, counted or collected
  std::optional<double> given_time;          // request.time, as given
  std::optional<ConformityReport> conformity;  // request.check
  std::optional<SurfaceData> surface;          // request.surface
  double surface_seconds = 0;                  // contouring it (after the refinement's seconds)
  // request.pieces > 1: which piece, of how many, the mesh's level-L
  // partition (query/pieces.h), and the exchange: rounds, and splits sent
  // to and received from other pieces (8 bytes each).
  struct PieceCounters {
    int piece = 0, pieces = 1, level = 0, rounds = 0;
    uint64_t splits_sent = 0, splits_received = 0;
  };
  std::optional<PieceCounters> piece;
  // A dense store's counters since it opened (DenseStore::Stats): blocks and
  // bricks decoded or checked (and of those the bricks), distinct ones,
  // bricks' finest boxes made and finest vertices' errors computed, and the
  // decoded bytes its cache holds.
  struct DenseCounters {
    uint64_t blocks_decoded = 0, distinct_blocks = 0, finest_boxes_computed = 0,
             finest_vertices_computed = 0, bricks_decoded = 0;
    std::optional<uint64_t> cache_bytes;
  };
  std::optional<DenseCounters> dense;
  // This process's memory when the mesh was complete (ops/process_memory.h).
  uint64_t peak_memory_bytes = 0, anonymous_memory_bytes = 0;
};

// The request's checks against the store `info` describes, nothing read:
// --units, --error, --box (count, bounds, missing the grid), --iso (outside
// the field's range), --time (an HT's, outside the store's times),
// --algorithm, --from without incremental, --budget and --time-limit but
// with priority, --slices (an HT's, outside the store's times), --piece
// outside 0..pieces-1, --pieces with another algorithm, --from or --check
// (the pieces' union is the mesh, not one piece), surface without --iso
// or (an HP's) --time. O(1).
Status CheckExtract(const SourceInfo& info, const ExtractRequest& request);

// Called with each time slice of request.slices in order: its index, then
// the slice (moved from). Its error stops the extraction.
using SliceSink = std::function<Status(size_t index, ExtractSlice&& slice)>;

// Runs the request over `store` (CheckExtract first). Slices go to
// `on_slice` when given (one slice in memory at a time), else into the
// result. Cost: the refinement's, then O(leaves) per mesh collected.
// With request.pieces > 1 and an `exchange`, only this piece's walk runs
// (one process per piece, each calling Extract with the same request but
// its piece).
Result<ExtractResult> Extract(const AnyStore& store, const ExtractRequest& request,
                              const SliceSink& on_slice = {}, const PieceExchange& exchange = {});

// The statistics as `simplexdb extract --format json` prints them (the
// keys DESIGN.md's contract names and more), and the Python package's
// Mesh.stats holds.
nlohmann::ordered_json ExtractStatsJson(const ExtractResult& result);

// The leaf codes in a file, "T:bits" a line (blank lines skipped), as
// packed codes of the hierarchy of `dimension` (3 or 4). NotFound or
// IOError naming the file; InvalidArgument "<path>:<line>: <reason>".
Result<std::vector<uint64_t>> ReadLeafCodes(const std::string& path, int dimension);

}  // namespace simplexdb
