// FieldAt: the field at any point of a store's grid, as the store's
// hierarchy interpolates it: linearly over the finest simplex (level D * k
// of a domain of side 2^k) that contains the point. At a grid point it is
// the value stored there; along a grid edge it is the linear interpolation
// of the edge's two ends; inside a grid cell it lies between the cell's
// smallest and largest corner values (the finest simplices tile each cell,
// with the cell's corners as their vertices). This is the full-resolution
// field every extraction approximates within its error.
//
// Thread safety: a free function over the caller's source (one thread's:
// query/source.h).
//
// Errors: InvalidArgument naming the point and the grid's range when a
// coordinate is outside 0..dims-1 or not finite; the source's errors
// (Corruption, IOError); Corruption when the source has no value at a
// vertex (the stores' sources have one at every grid point: query/source.h).
//
// Cost: O(D * k) descent steps of a (D+1)-point barycentric solve, then D+1
// field lookups.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "query/source.h"
#include "util/status.h"

namespace simplexdb {
namespace field_at_internal {

// Barycentric coordinates of x in the simplex v (lattice coordinates), by
// Gaussian elimination with partial pivoting on the D x D system
// sum_i b_i (v_i - v_0) = x - v_0. O(D^3), D <= 4.
template <int D>
std::array<double, D + 1> Barycentric(const std::array<Point<D>, D + 1>& v,
                                      const std::array<double, D>& x) {
  double m[D][D + 1];
  for (int r = 0; r < D; ++r) {
    for (int c = 0; c < D; ++c) m[r][c] = static_cast<double>(v[c + 1][r]) - v[0][r];
    m[r][D] = x[r] - v[0][r];
  }
  for (int c = 0; c < D; ++c) {
    int pivot = c;
    for (int r = c + 1; r < D; ++r) {
      if (std::fabs(m[r][c]) > std::fabs(m[pivot][c])) pivot = r;
    }
    for (int k = 0; k <= D; ++k) std::swap(m[c][k], m[pivot][k]);
    for (int r = 0; r < D; ++r) {
      if (r == c) continue;
      const double f = m[r][c] / m[c][c];  // simplices are not degenerate
      for (int k = c; k <= D; ++k) m[r][k] -= f * m[c][k];
    }
  }
  std::array<double, D + 1> b{};
  b[0] = 1;
  for (int c = 0; c < D; ++c) {
    b[c + 1] = m[c][D] / m[c][c];
    b[0] -= b[c + 1];
  }
  return b;
}

// The smallest barycentric coordinate: >= -tolerance when x is inside.
template <int D>
double Inside(const std::array<double, D + 1>& b) {
  double lowest = b[0];
  for (const double w : b) lowest = std::min(lowest, w);
  return lowest;
}

}  // namespace field_at_internal

// `p` in grid units (0 <= p[a] <= dims[a] - 1; the padding is not asked
// about).
template <int D, ReadSource<D> Source>
Result<double> FieldAt(Source& source, const std::array<double, D>& p) {
  using field_at_internal::Barycentric;
  using field_at_internal::Inside;
  const SourceInfo& info = source.info();
  for (int a = 0; a < D; ++a) {
    if (!std::isfinite(p[a]) || p[a] < 0 || p[a] > static_cast<double>(info.dims[a]) - 1) {
      std::string point, range;
      for (int c = 0; c < D; ++c) {
        char number[32];
        std::snprintf(number, sizeof number, "%.17g", p[c]);
        point += (c ? ", " : "") + std::string(number);
        range += (c ? ", " : "") + std::string("0..") + std::to_string(info.dims[c] - 1);
      }
      return Status::InvalidArgument(info.path + ": point (" + point + ") is outside the grid (" +
                                     range + ", grid units)");
    }
  }
  // A grid point: its stored value, exactly.
  bool grid_point = true;
  std::array<int64_t, D> g{};
  for (int a = 0; a < D; ++a) {
    g[a] = static_cast<int64_t>(p[a]);
    grid_point = grid_point && static_cast<double>(g[a]) == p[a];
  }
  if (grid_point) {
    SDB_ASSIGN_OR_RETURN(const std::optional<double> f, source.Field(g));
    if (!f) return Status::Corruption(info.path + ": no field value at a grid point");
    return *f;
  }
  const int k = info.domain_bits;
  const double scale = std::ldexp(1.0, kCoordBits<D> - k);
  std::array<double, D> x{};
  for (int a = 0; a < D; ++a) x[a] = p[a] * scale;
  // The root containing x (the most inside one, for x on a shared face).
  SimplexCode<D> code = SimplexCode<D>::Root(0);
  SimplexVertices<D> v = RootVertices<D>(0);
  double best = -1e300;
  for (int r = 0; r < SimplexCode<D>::kRoots; ++r) {
    const SimplexVertices<D> rv = RootVertices<D>(r);
    const double inside = Inside<D>(Barycentric<D>(rv, x));
    if (inside > best) {
      best = inside;
      code = SimplexCode<D>::Root(r);
      v = rv;
    }
  }
  // Down to the finest level, into the child x is more inside of (on the
  // split face either child gives the same value: the mesh is conforming).
  for (int level = 0; level < D * k; ++level) {
    const SimplexVertices<D> c0 = ChildVertices<D>(code, v, 0);
    const SimplexVertices<D> c1 = ChildVertices<D>(code, v, 1);
    const bool first = Inside<D>(Barycentric<D>(c0, x)) >= Inside<D>(Barycentric<D>(c1, x));
    v = first ? c0 : c1;
    code = code.child(first ? 0 : 1);
  }
  const std::array<double, D + 1> b = Barycentric<D>(v, x);
  double value = 0;
  for (int i = 0; i <= D; ++i) {
    // A vertex of weight 0 (up to rounding) may be in the padding or a
    // missing value (NaN): it does not count.
    if (std::fabs(b[i]) <= 1e-12) continue;
    SDB_ASSIGN_OR_RETURN(const std::optional<double> f, source.Field(LatticeToGrid<D>(v[i], k)));
    if (!f) return Status::Corruption(info.path + ": no field value at a vertex of the finest mesh");
    value += b[i] * *f;
  }
  return value;
}

}  // namespace simplexdb
