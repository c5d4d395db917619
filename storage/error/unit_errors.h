// The error engine: the seed's error of every node of the hierarchy, computed
// one unit (a subtree) at a time, once for every writer. The dense builder
// runs it over every unit of the domain, the sparse store's update over the
// units that meet its box; "an update equals a fresh import" holds because
// both call this code (storage/error/simplex_scan.h holds the kernels).
//
// A node's error is the largest |field - linear interpolation of its
// vertices' values| over the REAL grid points inside or on it (points past
// the real grid, the padding, are never scanned: a node wholly in the
// padding has error 0). With missing values (NaN), the error a node records
// is ErrorGivenAvailability's: 0 where no point has a value, the field range
// where some point or vertex has none.
//
// A unit is scanned from a region: the field on its bounding box, clamped to
// the real grid (padding points repeat the last real value along each axis)
// and NaN where missing, filled by the caller from its own source (the dense
// builder's bricks, the update's volume). From the region the engine gives
//   - ForEachNode: every node of the unit's subtree down to the leaf level,
//     depth first, with its error (optionally pruned by a predicate), and
//   - AncestorPartials: for nodes above the unit, the largest error over
//     the unit's points (their share of the ancestor's maximum: the units
//     tile every ancestor, so the maximum of the partials over its units is
//     its error) and where the unit has values (for ErrorGivenAvailability).
//
// Use:
//   UnitScan<D> unit(rules, code, NodeGrid(code, k));
//   if (!unit.has_real_points()) ...;              // every error is 0
//   Fill(unit.region());                           // the caller's source
//   unit.ForEachNode(leaf_level, keep, visit);
//   Availability a = unit.AncestorPartials(ancestors, partial);
//
// Thread safety: a UnitScan is not thread-safe; use one per thread (the
// dense builder scans units on every core, each with its own). Distinct
// objects share nothing. AncestorInterpolant and ErrorRules are values.
// Lifetimes: a UnitScan copies the rules and owns its region; the node
// passed to `visit` (its grid included) is valid during the call only.
// Errors: none are returned: the caller reports its own reading errors
// while filling the region. Programming errors (a region not filled, more
// than kMaxAncestors ancestors) are assertions.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "storage/error/simplex_scan.h"

namespace simplexdb {

// A simplex's vertices in grid coordinates.
template <int D>
using GridSimplex = std::array<IPoint<D>, D + 1>;

// The grid vertices of lattice vertices `v` in a domain of side
// 2^domain_bits. O(D^2) shifts.
template <int D>
GridSimplex<D> GridOf(const SimplexVertices<D>& v, int domain_bits) {
  GridSimplex<D> g{};
  for (int i = 0; i <= D; ++i) g[i] = LatticeToGrid<D>(v[i], domain_bits);
  return g;
}

// What a node's error depends on besides its points: the same for every
// unit of a store.
template <int D>
struct ErrorRules {
  IPoint<D> real_hi{};    // the real grid's last point per axis (dims - 1)
  double range = 0;       // field max - min: bounds |f(p) - f(v_0)| for the
                          // kernel's 64-bit decision, and is the error of a
                          // partly missing node
  bool exact = false;     // integer voxel types: errors computed exactly
                          // (int64/int128); floats: in double precision
  bool may_miss = false;  // the field may hold NaN (missing values); false
                          // skips every availability scan
};

// Field values on a box of grid points, x fastest: a unit's region.
template <int D>
struct GridRegion {
  IPoint<D> lo{}, hi{};
  std::array<int64_t, D> stride{};
  std::vector<double> values;  // (hi - lo + 1) points per axis

  // Sets the box to [box_lo, box_hi] and sizes `values` for it; the
  // caller then fills it row by row (x fastest).
  void Reset(const IPoint<D>& box_lo, const IPoint<D>& box_hi);
  // Valid while `values` is neither resized nor destroyed.
  GridView<D> view() const { return GridView<D>{values.data(), lo, stride}; }
};

// The interpolant of a node above the units (an ancestor), prepared once and
// applied to the points of each of its units.
template <int D>
class AncestorInterpolant {
 public:
  AncestorInterpolant() = default;
  // `grid`: the ancestor's grid vertices; `values`: the field there
  // (clamped to the real grid; NaN where missing).
  AncestorInterpolant(const ErrorRules<D>& rules, const GridSimplex<D>& grid,
                      const std::array<double, D + 1>& values);

  // Whether a vertex value is missing (the ancestor then records the field
  // range, if it has values at all).
  bool vertex_missing() const { return vertex_missing_; }

 private:
  template <int>
  friend class UnitScan;
  Interpolant<D, int64_t> exact_;   // set when rules.exact
  Interpolant<D, double> inexact_;  // set otherwise
  bool vertex_missing_ = false;
};

// A node of a unit, as ForEachNode hands it out.
template <int D>
struct UnitNode {
  SimplexCode<D> code;
  const GridSimplex<D>& grid;  // its grid vertices
  uint32_t entry;  // heap index within the unit: the unit 0, children of i
                   // 2i + 1 and 2i + 2 (the dense store's block order)
  double error;    // as recorded (ErrorGivenAvailability applied)
};

template <int D>
class UnitScan {
 public:
  static constexpr int kMaxAncestors = 64;

  // The unit `code` with grid vertices `grid`. Sizes the region only when
  // the unit has real points. O(D^3) plus the region's allocation.
  UnitScan(const ErrorRules<D>& rules, SimplexCode<D> code, const GridSimplex<D>& grid);

  // False when the unit lies wholly in the padding (its bounding box starts
  // past the real grid on some axis): every error in it is 0, it adds
  // nothing to its ancestors, and it needs no region.
  bool has_real_points() const { return has_real_points_; }

  // The region to fill: box and strides set to the unit's bounding box.
  // REQUIRES: has_real_points(); filled before the scans below.
  GridRegion<D>& region() { return region_; }
  const GridRegion<D>& region() const { return region_; }

  // Calls visit(node) for the unit and its descendants above `leaf_level`
  // (levels < leaf_level), depth first, child 0 first. A child for which
  // keep(child's grid) is false is neither visited nor descended into; an
  // empty `keep` keeps all. The unit itself is always visited.
  // Cost: one exact scan of each node's points (plus an availability scan
  // where the region has missing values).
  void ForEachNode(int leaf_level, const std::function<bool(const GridSimplex<D>&)>& keep,
                   const std::function<void(const UnitNode<D>&)>& visit);

  // For each ancestor j, raises partial[j] to the largest |field - interp_j|
  // over the unit's real points. Returns where the unit has values (the
  // scanned Availability when rules.may_miss; {true, false} otherwise),
  // which the caller merges into each ancestor's, with its vertex_missing().
  // REQUIRES: ancestors.size() <= kMaxAncestors; partial holds as many.
  Availability AncestorPartials(std::span<const AncestorInterpolant<D>> ancestors,
                                double* partial);

 private:
  bool RegionMissing();  // any NaN in the region (computed once)

  ErrorRules<D> rules_;
  SimplexCode<D> code_;
  GridSimplex<D> grid_;
  ScannableSimplex<D> simplex_;
  bool has_real_points_ = false;
  GridRegion<D> region_;
  IPoint<D> scan_hi_{};  // the region's box cut to the real grid
  std::optional<bool> region_missing_;
};

extern template struct GridRegion<3>;
extern template struct GridRegion<4>;
extern template class AncestorInterpolant<3>;
extern template class AncestorInterpolant<4>;
extern template class UnitScan<3>;
extern template class UnitScan<4>;

}  // namespace simplexdb
