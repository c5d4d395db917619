// The error of every diamond of a grid held in memory, computed octave by
// octave from the diamonds' shapes instead of node by node.
//
// A diamond is the cluster of nodes whose split creates one vertex
// (hierarchy/hz_order.h); its error is the largest of the seed's errors of
// those nodes (storage/error/simplex_scan.h). The hierarchies are
// self-similar across octaves: the diamonds of octave o are those of the
// finest octave (storage/error/finest_diamonds.h) scaled by 2^s, s = k-1-o,
// with the same templates chosen by the vertex's odd-axis pattern and cube
// parity on the octave's lattice, and cut to the domain the same way. So
// a diamond whose simplices in the domain lie in the real grid is
//   - in the finest octaves (7/8 of the HT's vertices, 15/16 of the HP's,
//     and the next octave in the HT), a fixed point stencil over the field
//     (DiamondStencils), and
//   - in the middle octaves, a row stencil (DiamondRowStencils: rows found
//     once per template, one multiply-add per point);
// the others (coarse octaves, and diamonds crossing the real grid's last
// faces) scan their scaled simplices' grid points row by row with the exact
// kernels (ScannableSimplex, Interpolant: integer voxel types exactly, float
// ones in double precision), or take the generic template walk in the
// finest octave. Stencils compute in double precision: the writer's margin
// for computed errors (storage/error/quantize.h) covers their rounding.
// Every node is scanned once, by the one diamond it belongs to, so the work
// is one pass over the grid per level with no per-node bookkeeping, and
// diamonds are independent: work items (one slab of an octave's vertices
// each) run on any thread in any order.
//
// The seed's rules for a simplex's error: only real grid points (inside
// dims) are scanned; a vertex past the real grid takes the value of the
// nearest real point (clamped per axis); a simplex with no real point has
// error 0.
//
// Missing values (NaN: a masked or absent voxel), when `may_miss` is set:
// a simplex records ErrorGivenAvailability's error (storage/error/
// simplex_scan.h): 0 where none of its real points has a value, the field
// range where some point or vertex has none, the seed's error otherwise.
// Every diamond is then scanned (no stencils: they assume values
// everywhere), and the finest octave too, so a store built from such a
// field keeps every octave's errors (the reader's stencils cannot compute
// them).
//
// The finest octave (scale 0) is not tabled: a format-2 store keeps only
// each grid brick's largest finest error (FinestBoxMax), and its reader
// computes the others with the same function (storage/error/
// finest_box_errors.h); with missing values At() scans them. The table holds
// the vertices whose coordinates are all even: an eighth of the HT's grid, a
// sixteenth of the HP's.
//
// Use:
//   DiamondErrors<3, uint16_t> d(field, dims, k, exact, range, threads);
//   d.Allocate();                              // DiamondErrors::TableBytes
//   for (item in 0 .. d.item_count()) d.ComputeItem(worker, item);  // any threads
//   d.Finish();
//   double e = d.At(g, position);              // coarser octaves: a lookup
//   double m = d.FinestBoxMax(first, extent);  // finest octave: computed
//
// V, the field's element type: the C++ type of its stored voxel type
// (uint8_t ... double: WithVoxelCppType), so the field takes the memory its
// voxels do; the errors are the same whatever V holds the values (the
// kernels compute in double, or exactly in integers).
//
// Thread safety: ComputeItem may run concurrently for distinct items, each
// with its own worker index (0 .. threads - 1); everything else is
// single-threaded but FinestBoxMax, which reads only the field and may run
// concurrently with anything (At is const and may be shared once Finish
// returned).
// Lifetimes: the field is read during ComputeItem, At (finest vertices) and
// FinestBoxMax, and must outlive them.
// Errors: none; preconditions (no NaN unless may_miss, dims within the
// domain) are assertions. Allocate throws std::bad_alloc.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/error/finest_diamonds.h"
#include "storage/volume/voxel_type.h"
#include "util/big_array.h"

namespace simplexdb {

// Where a part of a diamond has values, simplex by simplex (bit i: the i-th
// simplex of the diamond's template, FinestDiamonds): the parts of one
// diamond merge, and the diamond is partly missing when some simplex has
// both a point with a value and a point or vertex without one.
struct DiamondAvailability {
  uint64_t value = 0;    // simplices with a real point that has a value
  uint64_t missing = 0;  // simplices with a real point or vertex that has none
  void Merge(const DiamondAvailability& o) {
    value |= o.value;
    missing |= o.missing;
  }
  bool any() const { return (value | missing) != 0; }
  bool partly_missing() const { return (value & missing) != 0; }
};

template <int D, class V = double>
class DiamondErrors {
 public:
  // `field`: the real grid's values, x fastest, dims[a] points per axis, in
  // a domain of side 2^k. `exact`: integer voxel types (every value an
  // integer), errors computed exactly. `range`: field max - min.
  // `stencils` false scans every diamond's simplices (the reference the
  // stencils are tested against). `may_miss`: the field may hold NaN
  // (missing values; implies no stencils).
  DiamondErrors(const V* field, const std::array<int64_t, D>& dims, int k, bool exact,
                double range, int threads, bool stencils = true, bool may_miss = false);

  // The table's bytes: a float per even point (every coordinate even) of
  // the real grid grown by two points per axis (the diamonds of vertices
  // there reach real points), within the domain.
  static uint64_t TableBytes(const std::array<int64_t, D>& dims, int k);
  void Allocate();

  uint64_t item_count() const { return items_.size(); }
  void ComputeItem(int worker, uint64_t item);

  // For a builder holding the field a window at a time (planes of the last
  // axis): the field given to the constructor, and here, holds the real
  // grid's planes from `first_plane` on (x fastest, the same strides);
  // every lookup subtracts that. REQUIRES: the planes a call reads are in
  // the window (a diamond of scale s reaches 2^(s+1) from its vertex; the
  // finest boxes 2).
  void SetWindow(const V* planes, int64_t first_plane);
  // Scales below this use stencils over the field near the vertex (reach
  // at most 2^kLocalScales); coarser diamonds are scanned.
  static constexpr int kLocalScales = D == 3 ? 5 : 3;
  // Calls sink(g, error) for every vertex g of scale `scale` (0 < scale <
  // kLocalScales) whose last coordinate is j * 2^scale and whose error is
  // not 0, computed as ComputeItem does (without the table).
  using RowSink = std::function<void(const std::array<int64_t, D>&, double)>;
  void ComputeRowInto(int scale, int64_t j, const RowSink& sink) const;
  // The same row's vertices (scale >= kLocalScales: scanned), each the
  // largest error over the part of its diamond whose grid points have
  // their last coordinate in [last_lo, last_hi] (the exact scan), taking
  // the simplices' corner values from `corner` (real grid points, clamped:
  // a corner may lie outside the window); sink(g, part, availability)
  // where the part is not 0 or, with may_miss, has points or a missing
  // vertex. Over a partition of the last axis, the diamond's error is the
  // maximum of the parts, or (may_miss) the field range where the merged
  // availability is partly_missing() (MergedError).
  using CornerValues = std::function<double(const std::array<int64_t, D>&)>;
  using PartSink =
      std::function<void(const std::array<int64_t, D>&, double, const DiamondAvailability&)>;
  void ComputeRowPartInto(int scale, int64_t j, int64_t last_lo, int64_t last_hi,
                          const CornerValues& corner, const PartSink& sink) const;
  // A diamond's error from the largest of its parts and their merged
  // availability.
  double MergedError(double parts_max, const DiamondAvailability& a) const {
    return a.partly_missing() ? range_ : parts_max;
  }
  // Gathers the few coarse diamonds past the table (vertices beyond the real
  // grid whose diamonds reach back into it).
  void Finish();

  // The diamond error of vertex g (HZ position `position`, for the vertices
  // past the table); 0 for vertices with no real point in their diamond.
  // A finest vertex's is computed (O(stencil)), the others' looked up.
  double At(const std::array<int64_t, D>& g, uint64_t position) const;
  // The largest diamond error of the finest vertices in the box [first,
  // first + extent) (coordinates up to 2^k; the others are skipped).
  double FinestBoxMax(const std::array<int64_t, D>& first,
                      const std::array<int64_t, D>& extent) const;
  // Asks the processor for the table entry At(g) will read. A caller
  // reading in another order than the table's (x fastest) issues these a
  // batch ahead: one miss at a time would wait on memory for each.
  void Prefetch(const std::array<int64_t, D>& g) const {
    uint64_t i = 0;
    for (int a = 0; a < D; ++a) {
      if (g[a] >= extent_[a]) return;
      i += static_cast<uint64_t>(g[a] >> 1) * stride_[a];
    }
    __builtin_prefetch(table_.data() + i);
  }

 private:
  struct Item {
    int s;        // the octave's scale: vertices are multiples of 2^s
    int64_t j;    // the last coordinate is j * 2^s
  };
  double FieldAt(const std::array<int64_t, D>& p) const;  // a real grid point's value
  double Finest(const std::array<int64_t, D>& g) const;   // a finest vertex's error
  // Whether the simplices in the domain of g's diamond (scale s) all lie in
  // the real grid: the stencils then serve it, clipped at the domain's faces.
  bool Interior(const std::array<int64_t, D>& g, int s) const;
  double Coarse(const std::array<int64_t, D>& g, int s) const;
  // The largest error over the diamond's simplices' points whose last
  // coordinate is in [last_lo, last_hi], skipping (may_miss) simplices
  // whose part has a missing point or vertex; `availability` records where
  // the part has values.
  template <class T, class Corner>
  double CoarseScan(const std::array<int64_t, D>& g, int s, int64_t last_lo, int64_t last_hi,
                    const Corner& corner, DiamondAvailability& availability) const;
  template <class Sink>
  void ComputeRow(int scale, int64_t j, Sink&& sink) const;
  // f(g) for every vertex of scale s whose last coordinate is j * 2^s and
  // whose diamond can reach the real grid.
  template <class F>
  void ForEachRowVertex(int s, int64_t j, F&& f) const;
  double RowVertexError(const std::array<int64_t, D>& g, int s) const;
  double CoarsePart(const std::array<int64_t, D>& g, int s, int64_t last_lo, int64_t last_hi,
                    const CornerValues& corner, DiamondAvailability& availability) const;
  float* Slot(const std::array<int64_t, D>& g);

  const V* field_;
  int64_t window_offset_ = 0;  // the first plane's index in the whole grid
  std::array<int64_t, D> dims_;
  std::array<int64_t, D> field_stride_{};
  int k_;
  bool exact_;
  double range_;
  bool use_stencils_;
  bool may_miss_;
  HzOrder<D> order_;
  // Stencils of the finest octaves (scale 0 .. kStencilScales - 1): their
  // diamonds' rows are a few points long, too short for row scans.
  static constexpr int kStencilScales = D == 3 ? 2 : 1;
  template <size_t... S>
  static auto MakeStencils(const std::array<int64_t, D>& strides, std::index_sequence<S...>)
      -> std::array<DiamondStencils<D>, kStencilScales>;
  std::array<DiamondStencils<D>, kStencilScales> stencils_;
  // Row stencils of the middle octaves (scale kStencilScales ..
  // kRowStencilScales - 1); coarser diamonds are few, scanned directly.
  static constexpr int kRowStencilScales = kLocalScales;
  std::vector<DiamondRowStencils<D>> row_stencils_;
  // The table: extent_[a] grid points per axis, even ones tabled
  // (stride_ per half coordinate).
  std::array<int64_t, D> extent_{};
  std::array<uint64_t, D> stride_{};
  uint64_t size_ = 0;
  BigArray<float> table_;
  std::vector<Item> items_;
  std::vector<std::vector<std::pair<uint64_t, float>>> far_by_worker_;
  std::unordered_map<uint64_t, float> far_;
};

#define SDB_DIAMOND_ERRORS_(V)                \
  extern template class DiamondErrors<3, V>; \
  extern template class DiamondErrors<4, V>;
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_DIAMOND_ERRORS_)
#undef SDB_DIAMOND_ERRORS_

}  // namespace simplexdb
