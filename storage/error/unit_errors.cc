#include "storage/error/unit_errors.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace simplexdb {

template <int D>
void GridRegion<D>::Reset(const IPoint<D>& box_lo, const IPoint<D>& box_hi) {
  lo = box_lo;
  hi = box_hi;
  int64_t total = 1;
  for (int c = 0; c < D; ++c) {
    stride[c] = total;
    total *= hi[c] - lo[c] + 1;
  }
  values.resize(static_cast<size_t>(total));
}

namespace {

// The largest extent of a simplex's bounding box: bounds |p - v_0| per
// coordinate for the kernel's 64-bit decision.
template <int D>
double Extent(const ScannableSimplex<D>& s) {
  double extent = 0;
  for (int c = 0; c < D; ++c) {
    extent = std::max(extent, static_cast<double>(s.box_hi()[c] - s.box_lo()[c]));
  }
  return extent;
}

}  // namespace

template <int D>
AncestorInterpolant<D>::AncestorInterpolant(const ErrorRules<D>& rules, const GridSimplex<D>& grid,
                                            const std::array<double, D + 1>& values) {
  const ScannableSimplex<D> s(grid);
  for (const double v : values) vertex_missing_ = vertex_missing_ || std::isnan(v);
  if (rules.exact) {
    std::array<int64_t, D + 1> f{};
    for (int i = 0; i <= D; ++i) f[i] = static_cast<int64_t>(values[i]);
    exact_ = Interpolant<D, int64_t>(s, f, rules.range, Extent<D>(s));
  } else {
    inexact_ = Interpolant<D, double>(s, values, rules.range, Extent<D>(s));
  }
}

template <int D>
UnitScan<D>::UnitScan(const ErrorRules<D>& rules, SimplexCode<D> code, const GridSimplex<D>& grid)
    : rules_(rules), code_(code), grid_(grid), simplex_(grid) {
  has_real_points_ = true;
  for (int c = 0; c < D; ++c) {
    has_real_points_ = has_real_points_ && simplex_.box_lo()[c] <= rules_.real_hi[c];
  }
  if (!has_real_points_) return;
  region_.Reset(simplex_.box_lo(), simplex_.box_hi());
  for (int c = 0; c < D; ++c) scan_hi_[c] = std::min(region_.hi[c], rules_.real_hi[c]);
}

template <int D>
bool UnitScan<D>::RegionMissing() {
  if (!region_missing_) {
    region_missing_ = rules_.may_miss && std::any_of(region_.values.begin(), region_.values.end(),
                                                     [](double v) { return std::isnan(v); });
  }
  return *region_missing_;
}

template <int D>
void UnitScan<D>::ForEachNode(int leaf_level,
                              const std::function<bool(const GridSimplex<D>&)>& keep,
                              const std::function<void(const UnitNode<D>&)>& visit) {
  assert(has_real_points_);
  const GridView<D> view = region_.view();
  const IPoint<D>& scan_lo = region_.lo;
  // Where the region has no missing value, no node has one: the
  // availability rule would give the scanned error back (0 when a node has
  // no real point, which its scan gives too).
  const bool missing = RegionMissing();
  struct Item {
    SimplexCode<D> code;
    GridSimplex<D> grid;
    uint32_t entry;
  };
  std::vector<Item> stack = {Item{code_, grid_, 0}};
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    const ScannableSimplex<D> s(item.grid);
    double error = 0;
    if (rules_.exact) {
      std::array<int64_t, D + 1> f{};
      for (int i = 0; i <= D; ++i) f[i] = static_cast<int64_t>(view.At(item.grid[i]));
      error = MaxError<D, int64_t>(s, f, rules_.range, scan_lo, scan_hi_, view).error;
    } else {
      std::array<double, D + 1> f{};
      for (int i = 0; i <= D; ++i) f[i] = view.At(item.grid[i]);
      error = MaxError<D, double>(s, f, rules_.range, scan_lo, scan_hi_, view).error;
      if (missing) {
        error = ErrorGivenAvailability(NodeAvailability<D>(s, scan_lo, scan_hi_, view), error,
                                       rules_.range);
      }
    }
    visit(UnitNode<D>{item.code, item.grid, item.entry, error});
    if (item.code.level() + 1 >= leaf_level) continue;
    for (int child = 1; child >= 0; --child) {
      Item next{item.code.child(child), ChildVertices<D>(item.code, item.grid, child),
                2 * item.entry + 1 + static_cast<uint32_t>(child)};
      if (!keep || keep(next.grid)) stack.push_back(next);
    }
  }
}

template <int D>
Availability UnitScan<D>::AncestorPartials(std::span<const AncestorInterpolant<D>> ancestors,
                                           double* partial) {
  assert(has_real_points_);
  assert(ancestors.size() <= static_cast<size_t>(kMaxAncestors));
  const int n = static_cast<int>(ancestors.size());
  const GridView<D> view = region_.view();
  const auto scan = [&](auto tag, auto member) {
    using T = decltype(tag);
    std::array<Interpolant<D, T>, kMaxAncestors> interps;
    for (int j = 0; j < n; ++j) interps[j] = ancestors[j].*member;
    return MaxErrors<D, T>(simplex_, interps.data(), n, region_.lo, scan_hi_, view, partial);
  };
  std::optional<bool> any_point;  // whether the scan met a real point
  if (n > 0) {
    any_point = rules_.exact ? scan(int64_t{}, &AncestorInterpolant<D>::exact_)
                             : scan(double{}, &AncestorInterpolant<D>::inexact_);
  }
  if (!rules_.may_miss) return Availability{true, false};
  // Every point of the unit counts for every ancestor, whether or not this
  // region misses values: an ancestor with a missing vertex and no real
  // point records 0, not the range. Without NaN in the region, the scan
  // above already knows whether there is a point.
  if (any_point && !RegionMissing()) return Availability{*any_point, false};
  return ScanAvailability<D>(simplex_, region_.lo, scan_hi_, view);
}

template struct GridRegion<3>;
template struct GridRegion<4>;
template class AncestorInterpolant<3>;
template class AncestorInterpolant<4>;
template class UnitScan<3>;
template class UnitScan<4>;

}  // namespace simplexdb
