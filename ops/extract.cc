#include "ops/extract.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <new>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "ops/amount.h"
#include "ops/process_memory.h"
#include "query/clip.h"
#include "query/mesh.h"
#include "query/pieces.h"
#include "query/slice.h"
#include "query/source.h"
#include "util/out_of_memory.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

// The units box, time and slices are given in: grid units (the contract's:
// point i of an axis is at i) or physical ones (the store's origin + i *
// spacing; a flipped axis's spacing is negative).
struct AxisUnits {
  bool physical = false;
  const SourceInfo* info = nullptr;

  double ToGrid(int axis, double x) const {
    return physical ? (x - info->origin[axis]) / info->spacing[axis] : x;
  }
  double FromGrid(int axis, double i) const { return physical ? info->origin[axis] + i * info->spacing[axis] : i; }
  const char* name() const { return physical ? "physical units" : "grid units"; }
};

// The request in grid units, checked.
struct Resolved {
  CriteriaSpec spec;  // grid units, the threshold absolute
  Algorithm algorithm = Algorithm::kDepthFirst;
  std::vector<double> slices;  // grid units
};

// Criteria that can meet no simplex of the real grid are a mistake in the
// request, not an empty mesh: a box outside the grid, an isovalue outside
// the field's range, a time outside the store's.
Status CheckCriteriaMeetTheGrid(const CriteriaSpec& spec, const std::vector<double>& given_box,
                                const SourceInfo& info, const AxisUnits& units) {
  const size_t d = static_cast<size_t>(info.dimension);
  if (spec.box) {
    const std::vector<double>& b = *spec.box;  // x0,y0,z0,x1,y1,z1[,t0,t1]
    for (size_t k = 0; k < b.size() / 2 && k < d; ++k) {  // MakeCriteria checks counts
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
        return Status::InvalidArgument(
            fmt::format("--box {}: {} from {} to {} misses the grid, whose {} runs from {} to {} ({})",
                        fmt::join(given_box, ","), "xyzt"[k], box_lo, box_hi, "xyzt"[k], grid_lo,
                        grid_hi, units.name()));
      }
    }
  }
  if (spec.iso && !(*spec.iso >= info.field_min && *spec.iso <= info.field_max)) {
    return Status::InvalidArgument(
        fmt::format("--iso {}: outside the field's range, {} to {}: no simplex contains it", *spec.iso,
                    info.field_min, info.field_max));
  }
  if (d == 4 && spec.time) {  // an HT's time is refused by MakeCriteria
    const double last = static_cast<double>(info.dims[3]) - 1;
    if (!(*spec.time >= 0 && *spec.time <= last)) {
      return Status::InvalidArgument(fmt::format("--time {}: outside the store's times, {} to {} ({})",
                                                 units.FromGrid(3, *spec.time), units.FromGrid(3, 0),
                                                 units.FromGrid(3, last), units.name()));
    }
  }
  return Status::OK();
}

template <int D>
Status CheckCriteria(const SourceInfo& info, const CriteriaSpec& spec) {
  return MakeCriteria<D>(spec, info.domain_bits, info.field_range()).status();
}

Result<Resolved> Resolve(const SourceInfo& info, const ExtractRequest& r) {
  if (r.units != "grid" && r.units != "physical") {
    return Status::InvalidArgument(fmt::format("--units {}: expected grid or physical", r.units));
  }
  const AxisUnits units{r.units == "physical", &info};
  SDB_RETURN_IF_ERROR(CheckAmount(r.error, "--error"));
  Resolved out;
  CriteriaSpec& spec = out.spec;
  spec.error.value = ResolveAmount(r.error, info.field_range());
  if (r.box) {
    std::vector<double> box = *r.box;
    if (box.size() != 6 && box.size() != 8) {
      return Status::InvalidArgument(fmt::format(
          "--box: expected x0,y0,z0,x1,y1,z1 (6 numbers) or, for an HP, x0,y0,z0,x1,y1,z1,t0,t1; got {} "
          "numbers",
          box.size()));
    }
    // Each axis low to high in the units given (a flipped axis is turned
    // around below, in grid units).
    for (size_t k = 0; k < box.size() / 2; ++k) {
      const size_t lo = k < 3 ? k : 6, hi = k < 3 ? k + 3 : 7;
      if (!std::isfinite(box[lo]) || !std::isfinite(box[hi]) || box[lo] > box[hi]) {
        return Status::InvalidArgument(fmt::format("--box {}: {} from {} to {}: expected finite bounds, low <= high ({})",
                                                   fmt::join(box, ","), "xyzt"[k], box[lo], box[hi], units.name()));
      }
    }
    for (size_t i = 0; i < box.size(); ++i) box[i] = units.ToGrid(i < 6 ? static_cast<int>(i % 3) : 3, box[i]);
    // A flipped axis (negative spacing) runs the other way in grid units.
    for (size_t k = 0; k < 3 && units.physical; ++k) {
      if (info.spacing[k] < 0) std::swap(box[k], box[k + 3]);
    }
    spec.box = std::move(box);
  }
  spec.iso = r.iso;
  if (r.time) spec.time = units.ToGrid(3, *r.time);
  SDB_RETURN_IF_ERROR(CheckCriteriaMeetTheGrid(spec, r.box ? *r.box : std::vector<double>{}, info, units));
  SDB_RETURN_IF_ERROR(info.dimension == 3 ? CheckCriteria<3>(info, spec) : CheckCriteria<4>(info, spec));
  Result<Algorithm> algorithm = ParseAlgorithm(r.algorithm);
  if (!algorithm.ok()) return Status::InvalidArgument("--" + std::string(algorithm.status().message()));
  out.algorithm = *algorithm;
  if (r.from && out.algorithm != Algorithm::kIncremental) {
    return Status::InvalidArgument("--from gives the previous mesh of --algorithm incremental");
  }
  if (!(r.time_limit >= 0)) {
    return Status::InvalidArgument(fmt::format("--time-limit {}: expected seconds >= 0", r.time_limit));
  }
  // Only the priority order can stop early; elsewhere they would be ignored.
  if (out.algorithm != Algorithm::kPriority && (r.budget != 0 || r.time_limit != 0)) {
    return Status::InvalidArgument(fmt::format(
        "{}: only --algorithm priority stops at a budget or a time limit (this is {}, which runs to the end)",
        r.budget != 0 ? fmt::format("--budget {}", r.budget) : fmt::format("--time-limit {}", r.time_limit),
        AlgorithmName(out.algorithm)));
  }
  if (r.pieces < 1 || r.piece < 0 || r.piece >= r.pieces) {
    return Status::InvalidArgument(
        fmt::format("--piece {} of --pieces {}: expected pieces >= 1 and 0 <= piece < pieces", r.piece, r.pieces));
  }
  if (r.pieces > 1 && (out.algorithm != Algorithm::kDepthFirst || r.from || r.check)) {
    return Status::InvalidArgument(fmt::format(
        "--pieces {}: {} (a piece is cut from the depth-first mesh; check the union of the pieces instead)", r.pieces,
        r.check ? "--check needs the whole mesh" : r.from ? "--from is for one whole mesh" : "only depth-first"));
  }
  if (r.surface && (!r.iso || (info.dimension == 4 && !r.time))) {
    return Status::InvalidArgument(!r.iso ? "an isosurface needs --iso"
                                          : "--time: an HP's isosurface is that of a time slice; give its time");
  }
  if (!r.slices.empty()) {
    if (info.dimension != 4) {
      return Status::InvalidArgument("--slices: a series of HP time slices; the HT has no time");
    }
    const double last = static_cast<double>(info.dims[3]) - 1;
    for (const double t : r.slices) {
      if (!std::isfinite(t)) return Status::InvalidArgument(fmt::format("--slices: {} is not a time", t));
      const double grid = units.ToGrid(3, t);
      // A slice outside the store's times would cut the padding past them.
      if (!(grid >= 0 && grid <= last)) {
        const auto [first_time, last_time] = std::minmax(units.FromGrid(3, 0), units.FromGrid(3, last));
        return Status::InvalidArgument(fmt::format("--slices: {} is outside the store's times, {} to {} ({})", t,
                                                   first_time, last_time, units.name()));
      }
      out.slices.push_back(grid);
    }
  }
  return out;
}

// A mesh of grid-unit points as ParaView should see it: clipped to the
// real grid and placed physically.
TetMeshData OnGrid(TetMeshData data, const SourceInfo& info) {
  data = ClipToGrid(std::move(data), info.dims);
  PlacePhysically(data, info);
  return data;
}

// The previous mesh (--from): every proper ancestor of a leaf is split. The
// leaves must be a conforming mesh (checked).
template <int D>
Result<Mesh<D>> PreviousMesh(const std::vector<uint64_t>& keys) {
  std::vector<SimplexCode<D>> leaves;
  leaves.reserve(keys.size());
  for (const uint64_t k : keys) leaves.push_back(SimplexCode<D>::FromKey(k));
  const ConformityReport report = CheckConformity<D>(leaves);
  if (!report.ok) {
    return Status::InvalidArgument("--from: not a conforming mesh of the domain: " + report.problem);
  }
  Mesh<D> mesh;
  for (SimplexCode<D> c : leaves) {
    for (int l = c.level() - 1; l >= 0 && mesh.split_set().insert(c.ancestor(l)); --l) {
    }
  }
  return mesh;
}

// What the result holds of a mesh (the whole one, or the nodes `keep`
// keeps of a piece's): leaves, conformity, the HT's tetrahedra or the HP's
// slices, and the process's memory.
template <int D, class Source, class Keep>
Status Collect(const Mesh<D>& mesh, std::vector<SimplexCode<D>> leaves, const Keep& keep, Source& source,
               const Criteria<D>& criteria, const ExtractRequest& r, const Resolved& resolved,
               const SliceSink& on_slice, ExtractResult& out) {
  const SourceInfo& info = source.info();
  if (r.check) out.conformity = CheckConformity<D>(leaves);
  if (r.leaves) {
    out.leaves.reserve(leaves.size());
    for (const SimplexCode<D> c : leaves) out.leaves.push_back(c.key());
  }
  leaves = {};
  if (r.surface) {
    const auto start = std::chrono::steady_clock::now();
    SurfaceData surface;
    if constexpr (D == 3) {
      SDB_ASSIGN_OR_RETURN(surface, ContourHtMesh(mesh, source, *r.iso, keep));
    } else {
      SDB_ASSIGN_OR_RETURN(surface, ContourHpSlice(mesh, source, *r.iso, *criteria.time, keep));
    }
    PlaceSurface(surface, info);
    out.surface = std::move(surface);
    out.surface_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  if constexpr (D == 3) {
    if (r.tetrahedra) {
      SDB_ASSIGN_OR_RETURN(TetMeshData data, CollectTetMesh(mesh, source, keep));
      out.mesh = OnGrid(std::move(data), info);
    }
  } else {
    // The HP's time slice, for the mesh and for the statistics (the seed's
    // Fig. 63 counts the slice's tetrahedra beside the pentatopes).
    if (criteria.time) out.mesh_time = info.origin[3] + *resolved.spec.time * info.spacing[3];
    if (criteria.time && (r.tetrahedra || r.count_slice)) {
      SDB_ASSIGN_OR_RETURN(TetMeshData data, SliceHpMesh(mesh, source, *criteria.time, keep));
      out.slice_tetrahedra = data.cells();
      if (r.tetrahedra) out.mesh = OnGrid(std::move(data), info);
    }
    const double scale = std::ldexp(1.0, kCoordBits<4> - info.domain_bits);
    for (size_t i = 0; i < resolved.slices.size(); ++i) {
      const double t = resolved.slices[i];
      SDB_ASSIGN_OR_RETURN(TetMeshData data, SliceHpMesh(mesh, source, t * scale, keep));
      ExtractSlice slice{info.origin[3] + t * info.spacing[3], OnGrid(std::move(data), info)};
      if (on_slice) {
        SDB_RETURN_IF_ERROR(on_slice(i, std::move(slice)));
      } else {
        out.slices.push_back(std::move(slice));
      }
    }
  }
  // Of the whole process: the store's cache, the mesh and the query's sets,
  // and (peak only) the store's mapped file pages the query touched.
  out.peak_memory_bytes = PeakResidentBytes();
  out.anonymous_memory_bytes = AnonymousResidentBytes();  // the mesh is still alive
  return Status::OK();
}

// Piece r of the mesh (query/pieces.h): its own walk, trading crossing
// splits through `exchange`, or without one every piece's walk here.
template <int D, class Source>
Status RunPiece(Source& source, const Criteria<D>& criteria, const ExtractRequest& r, const Resolved& resolved,
                const SliceSink& on_slice, const PieceExchange& exchange, ExtractResult& out) {
  using Code = SimplexCode<D>;
  const auto start = std::chrono::steady_clock::now();
  const SourceStats before = source.stats();
  SDB_ASSIGN_OR_RETURN(const Partition<D> plan, PlanPieces<D>(source, criteria, r.pieces));
  ExtractResult::PieceCounters counters{r.piece, r.pieces, plan.level()};
  std::vector<std::unique_ptr<PieceWalk<D, Source>>> walks;
  PiecesStats walked;
  if (exchange) {
    walks.push_back(std::make_unique<PieceWalk<D, Source>>(source, criteria, plan, r.piece));
    const auto trade = [&](const std::vector<std::vector<Code>>& outbox, bool failed,
                           bool* quiet) -> Result<std::vector<Code>> {
      std::vector<std::vector<uint64_t>> keys(outbox.size());
      for (size_t s = 0; s < outbox.size(); ++s) {
        for (const Code c : outbox[s]) keys[s].push_back(c.key());
      }
      SDB_ASSIGN_OR_RETURN(const std::vector<uint64_t> in, exchange(keys, failed, quiet));
      counters.splits_received += in.size();
      std::vector<Code> codes;
      codes.reserve(in.size());
      for (const uint64_t k : in) codes.push_back(Code::FromKey(k));
      return codes;
    };
    SDB_ASSIGN_OR_RETURN(walked, WalkPiece<D>(*walks[0], r.pieces, trade));
  } else {
    const std::vector<Source*> sources(static_cast<size_t>(r.pieces), &source);
    // (Parentheses: the template's comma is not the macro's.)
    SDB_ASSIGN_OR_RETURN(walked, (ExtractPieces<D, Source>(std::span<Source* const>(sources), criteria, plan, walks)));
  }
  const PieceWalk<D, Source>& walk = *walks[exchange ? 0 : static_cast<size_t>(r.piece)];
  counters.rounds = walked.rounds;
  counters.splits_sent = walked.splits_sent;
  out.piece = counters;
  std::vector<Code> leaves = walk.Leaves();
  out.stats = walk.stats();
  out.stats.simplices = leaves.size();
  const SourceStats after = source.stats();
  out.stats.error_lookups = after.error_lookups - before.error_lookups;
  out.stats.field_lookups = after.field_lookups - before.field_lookups;
  out.stats.blocks_read = after.blocks_read - before.blocks_read;
  out.stats.blocks_skipped = after.blocks_skipped - before.blocks_skipped;
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return Collect<D>(walk.mesh(), std::move(leaves), [&walk](Code c) { return walk.Keeps(c); }, source, criteria,
                    r, resolved, on_slice, out);
}

template <int D, class Source>
Status Run(Source& source, const ExtractRequest& r, const Resolved& resolved, const SliceSink& on_slice,
           const PieceExchange& exchange, ExtractResult& out) {
  const SourceInfo& info = source.info();
  SDB_ASSIGN_OR_RETURN(const Criteria<D> criteria,
                       MakeCriteria<D>(resolved.spec, info.domain_bits, info.field_range()));
  out.threshold = criteria.threshold;
  if (r.pieces > 1) {
    try {
      return RunPiece<D>(source, criteria, r, resolved, on_slice, exchange, out);
    } catch (const std::bad_alloc&) {
      return NotEnoughMemory("the mesh refined from " + info.path, fmt::format("piece {} of {}", r.piece, r.pieces));
    }
  }
  Mesh<D> mesh;
  if (r.from) {
    SDB_ASSIGN_OR_RETURN(mesh, PreviousMesh<D>(*r.from));
  }
  RefineOptions options;
  options.algorithm = resolved.algorithm;
  options.max_simplices = r.budget;
  options.max_seconds = r.time_limit;
  Refiner<D, Source> refiner(source, criteria);
  try {
    SDB_RETURN_IF_ERROR(refiner.Run(options, mesh, out.stats));
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory("the mesh refined from " + info.path,
                           fmt::format("{} simplices so far", mesh.leaf_count()));
  }
  std::vector<SimplexCode<D>> leaves;
  if (r.leaves || r.check) leaves = mesh.Leaves();
  return Collect<D>(mesh, std::move(leaves), KeepAll{}, source, criteria, r, resolved, on_slice, out);
}

template <int D>
Result<std::vector<uint64_t>> ReadCodesOf(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status::NotFound(fmt::format("{}: cannot open the file", path));
  std::vector<uint64_t> keys;
  std::string line;
  for (uint64_t n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    Result<SimplexCode<D>> c = SimplexCode<D>::Parse(line);
    if (!c.ok()) return Status::InvalidArgument(fmt::format("{}:{}: {}", path, n, c.status().message()));
    keys.push_back(c->key());
  }
  if (in.bad()) return Status::IOError(fmt::format("{}: cannot read the file", path));
  return keys;
}

}  // namespace

Status CheckExtract(const SourceInfo& info, const ExtractRequest& request) {
  return Resolve(info, request).status();
}

Result<ExtractResult> Extract(const AnyStore& store, const ExtractRequest& request,
                              const SliceSink& on_slice, const PieceExchange& exchange) {
  SDB_ASSIGN_OR_RETURN(const Resolved resolved, Resolve(store.info(), request));
  ExtractResult out;
  out.info = store.info();
  out.algorithm = resolved.algorithm;
  out.given_time = request.time;
  Status s;
  try {
    s = store.Visit([&]<int D, class Source>(Source& source) {
      return Run<D>(source, request, resolved, on_slice, exchange, out);
    });
  } catch (const std::bad_alloc&) {
    // After the refinement (which names itself): the leaves, the slices,
    // the meshes' cells.
    return NotEnoughMemory("the mesh extracted from " + store.path() + " and its output", "size not known");
  }
  SDB_RETURN_IF_ERROR(s);
  if (const DenseStore* dense = store.dense(); dense != nullptr) {
    // Zstd frames decoded plus raw ones read, blocks and bricks (repeats
    // counted), how many different ones the store was asked for, and how
    // many bricks' finest errors it computed from the field; the decoded
    // blocks held at the end (never more than the cache's budget).
    const DenseStore::Stats hs = dense->stats();
    ExtractResult::DenseCounters c;
    c.blocks_decoded = hs.blocks_decoded + hs.raw_checked;
    c.distinct_blocks = hs.distinct;
    c.finest_boxes_computed = hs.boxes_computed;
    c.finest_vertices_computed = hs.finest_computed;
    c.bricks_decoded = hs.bricks_read;
    if (dense->cache() != nullptr) c.cache_bytes = dense->cache()->charge();
    out.dense = c;
  }
  return out;
}

nlohmann::ordered_json ExtractStatsJson(const ExtractResult& r) {
  nlohmann::ordered_json j;
  const SourceInfo& info = r.info;
  const QueryStats& stats = r.stats;
  const int d = info.dimension;
  SetJsonBytes(j, "store", info.path);
  j["hierarchy"] = d == 3 ? "ht" : "hp";
  j["algorithm"] = AlgorithmName(r.algorithm);
  // The threshold as a person would write it (3% of 255 is 7.65, not
  // 7.6499999999999995): 15 significant digits, the exact one refines.
  j["threshold"] = std::stod(fmt::format("{:.15g}", r.threshold));
  j["simplices"] = stats.simplices;
  // A count: roots x 2^levels, at most 6 x 2^54 (HT) or 24 x 2^52 (HP).
  j["full_resolution_simplices"] = static_cast<uint64_t>(d == 3 ? SimplexCode<3>::kRoots : SimplexCode<4>::kRoots)
                                   << info.leaf_level();
  j["splits"] = stats.splits;
  j["merges"] = stats.merges;
  j["cluster_computations"] = stats.cluster_computations;
  j["candidates"] = stats.candidates;
  j["error_lookups"] = stats.error_lookups;
  j["field_lookups"] = stats.field_lookups;
  j["blocks_read"] = stats.blocks_read;
  j["blocks_skipped"] = stats.blocks_skipped;
  j["seconds"] = stats.seconds;
  if (r.algorithm == Algorithm::kSaturated) j["saturation_seconds"] = stats.saturation_seconds;
  if (r.algorithm == Algorithm::kPriority) j["interrupted"] = stats.interrupted;
  j["splits_per_second"] = stats.seconds > 0 ? stats.splits / stats.seconds : 0.0;
  if (r.slice_tetrahedra) {
    j["slice_tetrahedra"] = *r.slice_tetrahedra;
    // A full-resolution mesh cut at a grid time: 6 tetrahedra per cube of
    // the 3D grid (the seed's 196,608 for 33^4). Between grid times the cut
    // pentatopes give prisms and pyramids, so no such count.
    if (r.given_time && *r.given_time == std::floor(*r.given_time)) {
      j["full_resolution_slice_tetrahedra"] = 6 * std::ldexp(1.0, 3 * (info.leaf_level() / 4));
    }
  }
  if (r.surface) {
    j["triangles"] = r.surface->triangle_count();
    j["points"] = r.surface->point_count();
    j["surface_seconds"] = r.surface_seconds;
    j["refinement_seconds"] = r.stats.seconds;
    j["seconds"] = r.stats.seconds + r.surface_seconds;  // the whole, as DESIGN.md's contract reads it
    j["triangles_per_second"] = r.surface_seconds > 0 ? r.surface->triangle_count() / r.surface_seconds : 0.0;
  }
  j["peak_memory_bytes"] = r.peak_memory_bytes;
  j["anonymous_memory_bytes"] = r.anonymous_memory_bytes;
  if (r.dense) {
    j["blocks_decoded"] = r.dense->blocks_decoded;
    j["bricks_decoded"] = r.dense->bricks_decoded;  // of blocks_decoded
    j["distinct_blocks"] = r.dense->distinct_blocks;
    j["finest_boxes_computed"] = r.dense->finest_boxes_computed;
    j["finest_vertices_computed"] = r.dense->finest_vertices_computed;
    if (r.dense->cache_bytes) j["cache_bytes"] = *r.dense->cache_bytes;
  }
  if (r.conformity) {
    j["conforming"] = r.conformity->ok;
    if (!r.conformity->ok) j["conformity_problem"] = r.conformity->problem;
  }
  if (r.piece) {
    // This piece's: "simplices" above counts its own leaves.
    j["piece"] = r.piece->piece;
    j["pieces"] = r.piece->pieces;
    j["partition_level"] = r.piece->level;
    j["exchange_rounds"] = r.piece->rounds;
    j["splits_sent"] = r.piece->splits_sent;
    j["splits_received"] = r.piece->splits_received;
    j["exchange_bytes_sent"] = 8 * r.piece->splits_sent;
  }
  return j;
}

Result<std::vector<uint64_t>> ReadLeafCodes(const std::string& path, int dimension) {
  return dimension == 3 ? ReadCodesOf<3>(path) : ReadCodesOf<4>(path);
}

}  // namespace simplexdb
