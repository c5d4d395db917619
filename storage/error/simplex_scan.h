// The error of a simplex over a grid: the seed's definition, the maximum
// over grid points inside or on the simplex of |field - linear interpolation
// at the simplex's vertices|, computed without ever approximating which
// points are inside.
//
// Geometry is exact: the simplex's facets are integer half-spaces (inward
// normals from the adjugate of the edge matrix), and each grid row (fixed
// y, z, t) meets the simplex in an x-interval found by integer division.
// Only points inside are visited; no bounding-box rejection. All of it fits
// in 64 bits for every grid a location code can address (coordinates up to
// 2^18 in 3D, 2^13 in 4D): determinants and dot products stay below 2^58.
//
// The interpolant in integer form: with A the matrix of edge vectors
// v_j - v_0 and det = det(A), the gradient is adj(A) b / det for
// b_j = f(v_j) - f(v_0). So
//
//   det * (f(p) - interp(p)) = (f(p) - f(v_0)) * det - G . (p - v_0),
//   G = adj(A) b.
//
// For integer voxel types every term is an integer: the largest numerator
// is exact (64-bit when a bound proves it fits, 128-bit otherwise), and the
// error is one correctly rounded division, exactly zero when the field is
// linear on the simplex. Float voxel types use the same form in double
// precision (subtracting f(v_0) first keeps the rounding relative to the
// field's range).
//
// These are the kernels; storage/error/diamond_errors.h applies them to
// every diamond of a grid (padding, missing values), for every builder.
//
// Thread safety: value types and pure functions; ScannableSimplex and
// Interpolant are immutable once built and may be shared.
// Lifetimes: a GridView does not own its values: it is valid while the
// buffer it points into is. Nothing else refers to its arguments after a
// call.
// Errors: none are returned; preconditions (REQUIRES below: coordinates
// within kMaxScanCoordinate, affinely independent vertices, views covering
// the scanned box) are assertions.
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <type_traits>

namespace simplexdb {

__extension__ typedef __int128 Int128;

template <int D>
using IPoint = std::array<int64_t, D>;

// The largest grid coordinate the 64-bit arithmetic below is proven for.
template <int D>
inline constexpr int64_t kMaxScanCoordinate = D == 3 ? (int64_t{1} << 18) : (int64_t{1} << 13);

namespace internal {

// The adjugate of the edge matrix A (rows are edges, columns coordinates),
// adj[c][j] = (-1)^(c+j) * det(A without row j and column c), so that
// A * adj(A) = det(A) * I. Returns det(A), read off the first row for free.
// Closed forms from shared 2x2 minors: sixteen generic 3x3 cofactor
// expansions per 4-simplex were a third of an HP build.
// REQUIRES: entries bounded so the results fit (see the header comment).
template <int N>
int64_t Adjugate(const std::array<std::array<int64_t, N>, N>& a,
                 std::array<std::array<int64_t, N>, N>* adj) {
  static_assert(N == 3 || N == 4);
  auto& out = *adj;
  if constexpr (N == 3) {
    // Column j is the cross product of the other two rows, in cyclic order.
    for (int j = 0; j < 3; ++j) {
      const auto& u = a[(j + 1) % 3];
      const auto& w = a[(j + 2) % 3];
      out[0][j] = u[1] * w[2] - u[2] * w[1];
      out[1][j] = u[2] * w[0] - u[0] * w[2];
      out[2][j] = u[0] * w[1] - u[1] * w[0];
    }
  } else {
    // 2x2 minors of rows {0,1} and {2,3} over column pairs k < l.
    auto minors = [&](int r, int s) {
      std::array<std::array<int64_t, 4>, 4> m{};
      for (int k = 0; k < 4; ++k) {
        for (int l = k + 1; l < 4; ++l) m[k][l] = a[r][k] * a[s][l] - a[r][l] * a[s][k];
      }
      return m;
    };
    const auto m01 = minors(0, 1);
    const auto m23 = minors(2, 3);
    // Removing row j leaves three rows: one row x and a pair whose minors
    // are known. Expanding along x (first or last; the signs agree for a
    // 3x3) over the columns p < q < r other than c gives the minor.
    static constexpr int kX[4] = {1, 0, 3, 2};
    for (int c = 0; c < 4; ++c) {
      int cols[3], n = 0;
      for (int k = 0; k < 4; ++k) {
        if (k != c) cols[n++] = k;
      }
      const int p = cols[0], q = cols[1], r = cols[2];
      for (int j = 0; j < 4; ++j) {
        const auto& x = a[kX[j]];
        const auto& m = j < 2 ? m23 : m01;
        const int64_t minor = x[p] * m[q][r] - x[q] * m[p][r] + x[r] * m[p][q];
        out[c][j] = ((c + j) % 2 == 0) ? minor : -minor;
      }
    }
  }
  int64_t det = 0;
  for (int c = 0; c < N; ++c) det += a[0][c] * out[c][0];
  return det;
}

// floor(a / b) and ceil(a / b) for b != 0.
inline int64_t FloorDiv(int64_t a, int64_t b) {
  int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) != (b < 0))) --q;
  return q;
}
inline int64_t CeilDiv(int64_t a, int64_t b) {
  int64_t q = a / b;
  if ((a % b != 0) && ((a < 0) == (b < 0))) ++q;
  return q;
}

}  // namespace internal

// Steps p to the next row of the box [lo, hi] (coordinates 1..D-1, the
// first fastest; x is left alone). Returns false, with p back at lo's row,
// after the last row.
template <int D>
bool NextRow(std::array<int64_t, D>& p, const std::array<int64_t, D>& lo,
             const std::array<int64_t, D>& hi) {
  for (int c = 1; c < D; ++c) {
    if (p[c] < hi[c]) {
      ++p[c];
      return true;
    }
    p[c] = lo[c];
  }
  return false;
}

// Field values on a box of grid points, x fastest: rows are contiguous.
// V is the type the field is held in: double, or the C++ type of its
// stored voxels (storage/volume/voxel_type.h); the scans compute in double
// or exact integers whatever it is.
template <int D, class V = double>
struct GridView {
  const V* data = nullptr;
  IPoint<D> lo{};
  std::array<int64_t, D> stride{};  // stride[0] == 1

  // The value at p; x runs contiguously from there.
  const V* Row(const IPoint<D>& p) const {
    int64_t i = 0;
    for (int c = 0; c < D; ++c) i += (p[c] - lo[c]) * stride[c];
    return data + i;
  }
  double At(const IPoint<D>& p) const { return *Row(p); }
};

// A simplex with integer vertices, prepared for scanning.
template <int D>
class ScannableSimplex {
 public:
  // REQUIRES: affinely independent vertices with coordinates in
  // [0, kMaxScanCoordinate<D>].
  explicit ScannableSimplex(const std::array<IPoint<D>, D + 1>& v) : v_(v) {
    std::array<std::array<int64_t, D>, D> a{};
    for (int j = 0; j < D; ++j) {
      for (int c = 0; c < D; ++c) {
        assert(v[j + 1][c] >= 0 && v[j + 1][c] <= kMaxScanCoordinate<D>);
        a[j][c] = v[j + 1][c] - v[0][c];
      }
    }
    det_ = internal::Adjugate<D>(a, &adj_);
    assert(det_ != 0);
    ComputeFacets(v);
  }

 private:
  void ComputeFacets(const std::array<IPoint<D>, D + 1>& v) {
    // Facets: facet i omits vertex i. A * adj(A) = det * I says that column
    // c of adj(A) is orthogonal to every edge e_j = v_{j+1} - v_0 but e_c:
    // it is the normal of the facet omitting v_{c+1}. Facet 0 (omitting
    // v_0) has e_j . n equal for every j: n = -(sum of the columns).
    for (int i = 0; i <= D; ++i) {
      IPoint<D> n{};
      for (int c = 0; c < D; ++c) {
        if (i > 0) {
          n[c] = adj_[c][i - 1];
        } else {
          for (int j = 0; j < D; ++j) n[c] -= adj_[c][j];
        }
      }
      // Orient inward: the omitted vertex must be on the positive side.
      const IPoint<D>& on = v[i == 0 ? 1 : 0];  // a vertex of the facet
      int64_t side = 0;
      for (int c = 0; c < D; ++c) side += n[c] * (v[i][c] - on[c]);
      assert(side != 0);
      if (side < 0) {
        for (int c = 0; c < D; ++c) n[c] = -n[c];
      }
      int64_t offset = 0;
      for (int c = 0; c < D; ++c) offset += n[c] * on[c];
      normal_[i] = n;
      offset_[i] = offset;
    }
    for (int c = 0; c < D; ++c) {
      lo_[c] = hi_[c] = v[0][c];
      for (int i = 1; i <= D; ++i) {
        lo_[c] = std::min(lo_[c], v[i][c]);
        hi_[c] = std::max(hi_[c], v[i][c]);
      }
    }
  }

 public:
  const std::array<IPoint<D>, D + 1>& vertices() const { return v_; }
  int64_t det() const { return det_; }
  const IPoint<D>& box_lo() const { return lo_; }
  const IPoint<D>& box_hi() const { return hi_; }

  // True when p is inside or on the simplex (exact).
  bool Contains(const IPoint<D>& p) const {
    for (int i = 0; i <= D; ++i) {
      int64_t s = 0;
      for (int c = 0; c < D; ++c) s += normal_[i][c] * p[c];
      if (s < offset_[i]) return false;
    }
    return true;
  }

  // Calls row(p, x_end) for every row of grid points inside or on the
  // simplex and inside the box [lo, hi] (inclusive): p is the row's first
  // point, x runs from p[0] to x_end inclusive.
  template <class RowFn>
  void ForEachRow(const IPoint<D>& box_lo, const IPoint<D>& box_hi, RowFn&& row) const {
    IPoint<D> lo, hi;
    for (int c = 0; c < D; ++c) {
      lo[c] = std::max(lo_[c], box_lo[c]);
      hi[c] = std::min(hi_[c], box_hi[c]);
      if (lo[c] > hi[c]) return;
    }
    // Most rows of the box miss the simplex (5/6 of a 4-simplex's, half a
    // tetrahedron's). Rows with a point satisfy the facets free of x and,
    // for each facet bounding x from below and each bounding it from
    // above, the pair's combination free of x (a real x must lie between
    // them): half-spaces in y, z, t that give each (z, t) an interval of y
    // holding every such row. Rows in it are solved exactly; the interval
    // only needs to contain them, so it is found in double precision and
    // widened by a point.
    const YBounds yb = BoundsOfY(lo, hi);
    IPoint<D> p = lo;
    // Odometer over the coordinates 2..D-1 (z fastest), then y over its
    // interval, x solved per row.
    while (true) {
      int64_t ylo = lo[1], yhi = hi[1];
      for (int b = 0; b < yb.count && ylo <= yhi; ++b) {
        const YBound& c = yb.bound[b];
        Int128 r = c.q;  // need m_y * y <= r
        for (int k = 2; k < D; ++k) r -= c.m[k] * p[k];
        if (c.m[1] == 0) {
          if (r < 0) ylo = yhi + 1;
          continue;
        }
        const double y = std::clamp(static_cast<double>(r) / static_cast<double>(c.m[1]),
                                    static_cast<double>(lo[1] - 2), static_cast<double>(hi[1] + 2));
        if (c.m[1] > 0) {
          yhi = std::min(yhi, static_cast<int64_t>(std::floor(y)) + 1);
        } else {
          ylo = std::max(ylo, static_cast<int64_t>(std::ceil(y)) - 1);
        }
      }
      for (p[1] = ylo; p[1] <= yhi; ++p[1]) {
        int64_t xmin = lo[0], xmax = hi[0];
        bool empty = false;
        for (int i = 0; i <= D && !empty; ++i) {
          int64_t rest = 0;
          for (int c = 1; c < D; ++c) rest += normal_[i][c] * p[c];
          const int64_t rhs = offset_[i] - rest;  // need normal_x * x >= rhs
          const int64_t nx = normal_[i][0];
          if (nx == 1) {
            xmin = std::max(xmin, rhs);
          } else if (nx == -1) {
            xmax = std::min(xmax, -rhs);
          } else if (nx > 0) {
            xmin = std::max(xmin, internal::CeilDiv(rhs, nx));
          } else if (nx < 0) {
            xmax = std::min(xmax, internal::FloorDiv(rhs, nx));
          } else if (rhs > 0) {
            empty = true;
          }
        }
        if (!empty && xmin <= xmax) {
          p[0] = xmin;
          row(p, xmax);
        }
      }
      p[1] = lo[1];
      int c = 2;
      for (; c < D; ++c) {
        if (p[c] < hi[c]) {
          ++p[c];
          break;
        }
        p[c] = lo[c];
      }
      if (c == D) return;
    }
  }

  // m . (y, z, t) <= q (m[0] unused), exact in 128 bits: normals reach
  // 2^39 and offsets 2^52 in 4D.
  struct YBound {
    std::array<Int128, D> m;
    Int128 q;
  };
  struct YBounds {
    std::array<YBound, (D + 3) * (D + 3) / 4 + D + 1> bound;
    int count = 0;
  };
  // The half-spaces free of x that every row of the box [lo, hi] meeting
  // the simplex satisfies (ForEachRow).
  YBounds BoundsOfY(const IPoint<D>& lo, const IPoint<D>& hi) const {
    // The facets and the box's x bounds, as n . p >= o.
    std::array<IPoint<D>, D + 3> n{};
    std::array<int64_t, D + 3> o{};
    for (int i = 0; i <= D; ++i) {
      n[i] = normal_[i];
      o[i] = offset_[i];
    }
    n[D + 1][0] = 1;
    o[D + 1] = lo[0];
    n[D + 2][0] = -1;
    o[D + 2] = -hi[0];
    YBounds out;
    for (int i = 0; i < D + 3; ++i) {
      if (n[i][0] != 0) continue;
      YBound& b = out.bound[static_cast<size_t>(out.count++)];  // -n . p <= -o
      for (int c = 1; c < D; ++c) b.m[c] = -static_cast<Int128>(n[i][c]);
      b.q = -static_cast<Int128>(o[i]);
    }
    for (int i = 0; i < D + 3; ++i) {
      if (n[i][0] <= 0) continue;
      for (int j = 0; j < D + 3; ++j) {
        if (n[j][0] >= 0) continue;
        // x >= (o_i - R_i) / n_i,x and x <= (o_j - R_j) / n_j,x (R: the
        // terms in y, z, t) meet when n_j,x R_i - n_i,x R_j <= n_j,x o_i - n_i,x o_j.
        YBound& b = out.bound[static_cast<size_t>(out.count++)];
        const Int128 ni = n[i][0], nj = n[j][0];
        for (int c = 1; c < D; ++c) b.m[c] = nj * n[i][c] - ni * n[j][c];
        b.q = nj * o[i] - ni * o[j];
      }
    }
    return out;
  }

  // G = adj(A) b for b_j = f(v_{j+1}) - f(v_0): the scaled gradient.
  template <class T>
  std::array<T, D> ScaledGradient(const std::array<T, D + 1>& f) const {
    std::array<T, D> g{};
    for (int c = 0; c < D; ++c) {
      T s = 0;
      for (int j = 0; j < D; ++j) s += static_cast<T>(adj_[c][j]) * (f[j + 1] - f[0]);
      g[c] = s;
    }
    return g;
  }

 private:
  std::array<IPoint<D>, D + 1> v_;
  int64_t det_ = 0;
  std::array<std::array<int64_t, D>, D> adj_{};
  std::array<IPoint<D>, D + 1> normal_{};
  std::array<int64_t, D + 1> offset_{};
  IPoint<D> lo_{}, hi_{};
};

// The linear interpolant of a simplex's vertex values, scaled by det so it
// stays integral for integer fields (see the header comment). T is int64_t
// (integer voxel types: exact) or double (float voxel types).
template <int D, class T>
class Interpolant {
 public:
  Interpolant() = default;
  // `f` holds the field at the vertices (clamped values for vertices
  // outside the real grid). `max_value_step` bounds |f(p) - f(v_0)| over the
  // points to scan (integer types: the type's range); `max_extent` bounds
  // |p - v_0| per coordinate. Together they decide whether 64-bit numerators
  // cannot overflow.
  Interpolant(const ScannableSimplex<D>& s, const std::array<T, D + 1>& f, double max_value_step,
              double max_extent)
      : g_(s.template ScaledGradient<T>(f)), det_(s.det()), v0_(s.vertices()[0]), f0_(f[0]) {
    double bound = max_value_step * std::abs(static_cast<double>(det_));
    for (int c = 0; c < D; ++c) bound += std::abs(static_cast<double>(g_[c])) * max_extent;
    fits64_ = bound < 0x1p61;
  }

  bool fits64() const { return fits64_; }
  int64_t det() const { return det_; }

  // Largest |det * (f(p) - interp(p))| over x in [x0, x1] of the row
  // starting at p, whose values are row[0], row[1], ...; W is int64_t (when
  // fits64()) or Int128 for exact fields, double for float fields.
  template <class W, class V>
  W RowMax(const IPoint<D>& p, int64_t x1, const V* row, W worst) const {
    W along = 0;
    for (int c = 1; c < D; ++c) along += static_cast<W>(g_[c]) * static_cast<W>(p[c] - v0_[c]);
    const W det = static_cast<W>(det_);
    const W gx = static_cast<W>(g_[0]);
    W n_x = -along - gx * static_cast<W>(p[0] - v0_[0]);  // the interpolant's part at x
    const int64_t count = x1 - p[0] + 1;
    if constexpr (std::is_same_v<W, double>) {
      // Four points at a time, each with its own running maximum and the
      // interpolant's part computed from x rather than accumulated: no
      // chain from one point to the next (the loop ran at a point per
      // maximum's latency), and no rounding accumulating along a row.
      // In pairs of lanes (the compiler left the loop scalar): the same
      // operations per point, so the same bits.
      typedef double Pair __attribute__((vector_size(16)));
      const double base = n_x, f0 = f0_;
      const Pair f0s = {f0, f0}, dets = {det, det}, bases = {base, base}, gxs = {gx, gx};
      const Pair zero = {0, 0}, two = {2, 2}, four = {4, 4};
      Pair w0 = {worst, 0}, w1 = zero, x0 = {0, 1};
      int64_t i = 0;
      for (; i + 4 <= count; i += 4, x0 += four) {
        const Pair a = {static_cast<double>(row[i]), static_cast<double>(row[i + 1])};
        const Pair b = {static_cast<double>(row[i + 2]), static_cast<double>(row[i + 3])};
        Pair na = (a - f0s) * dets + (bases - gxs * x0);
        Pair nb = (b - f0s) * dets + (bases - gxs * (x0 + two));
        na = na < zero ? -na : na;
        nb = nb < zero ? -nb : nb;
        w0 = na > w0 ? na : w0;
        w1 = nb > w1 ? nb : w1;
      }
      double w = std::max(std::max(w0[0], w0[1]), std::max(w1[0], w1[1]));
      for (; i < count; ++i) {
        const double n = (static_cast<double>(row[i]) - f0) * det + (base - gx * static_cast<double>(i));
        w = std::max(w, std::abs(n));
      }
      return w;
    } else {
      // Exact integers: the interpolant's part accumulated along the row.
      for (int64_t i = 0; i < count; ++i) {
        const W value = static_cast<W>(static_cast<int64_t>(row[i]) - static_cast<int64_t>(f0_));
        const W n = value * det + n_x;
        worst = std::max(worst, n < 0 ? -n : n);
        n_x -= gx;
      }
      return worst;
    }
  }

  // The error from the largest numerator.
  template <class W>
  double ErrorOf(W numerator) const {
    const int64_t adet = det_ < 0 ? -det_ : det_;
    return static_cast<double>(numerator) / static_cast<double>(adet);
  }

 private:
  std::array<T, D> g_{};
  int64_t det_ = 1;
  IPoint<D> v0_{};
  T f0_{};
  bool fits64_ = true;
};

// For every grid point p of simplex `rows` inside the box [lo, hi] (which
// `view` must cover), and every interpolant j, tracks the largest
// |field(p) - interp_j(p)|; raises errors[j] to it. Returns whether any
// point was visited.
template <int D, class T, class V = double>
bool MaxErrors(const ScannableSimplex<D>& rows, const Interpolant<D, T>* interps, int count,
               const IPoint<D>& lo, const IPoint<D>& hi, const GridView<D, V>& view,
               double* errors) {
  constexpr int kMaxInterps = 64;
  assert(count <= kMaxInterps);
  const auto scan = [&](auto zero) {
    using W = decltype(zero);
    W worst[kMaxInterps] = {};
    bool any = false;
    rows.ForEachRow(lo, hi, [&](const IPoint<D>& p, int64_t x_end) {
      any = true;
      const V* row = view.Row(p);
      // The next row (y + 1) starts about here: ask for it now, so its
      // first lines arrive while this one is scanned (rows are short and
      // a stride apart, which the hardware's prefetcher does not follow).
      const V* next = row + view.stride[1];
      for (int64_t i = 0; i <= x_end - p[0]; i += 64 / sizeof(V)) __builtin_prefetch(next + i);
      for (int j = 0; j < count; ++j) worst[j] = interps[j].RowMax(p, x_end, row, worst[j]);
    });
    for (int j = 0; j < count; ++j) errors[j] = std::max(errors[j], interps[j].ErrorOf(worst[j]));
    return any;
  };
  if constexpr (std::is_same_v<T, double>) {
    return scan(double{0});
  } else {
    bool all64 = true;
    for (int j = 0; j < count; ++j) all64 = all64 && interps[j].fits64();
    return all64 ? scan(int64_t{0}) : scan(Int128{0});
  }
}

// The error of simplex `s` itself over the box, with its own interpolant.
struct ScanResult {
  double error = 0;
  bool any_point = false;
};

template <int D, class T, class V = double>
ScanResult MaxError(const ScannableSimplex<D>& s, const std::array<T, D + 1>& f,
                    double max_value_step, const IPoint<D>& lo, const IPoint<D>& hi,
                    const GridView<D, V>& view) {
  double extent = 0;
  for (int c = 0; c < D; ++c) {
    extent = std::max(extent, static_cast<double>(s.box_hi()[c] - s.box_lo()[c]));
  }
  const Interpolant<D, T> interp(s, f, max_value_step, extent);
  ScanResult r;
  r.any_point = MaxErrors<D, T, V>(s, &interp, 1, lo, hi, view, &r.error);
  return r;
}

// Missing values. A NaN in a float field marks a point where the field is
// not available (a masked region). Which of a simplex's real grid points
// have a value, and whether any has none; a vertex whose (clamped) value is
// missing counts as missing too, since the interpolant needs it.
struct Availability {
  bool any_value = false;
  bool any_missing = false;
  void Merge(const Availability& o) {
    any_value = any_value || o.any_value;
    any_missing = any_missing || o.any_missing;
  }
};

template <int D>
Availability ScanAvailability(const ScannableSimplex<D>& s, const IPoint<D>& lo,
                              const IPoint<D>& hi, const GridView<D>& view) {
  Availability a;
  s.ForEachRow(lo, hi, [&](const IPoint<D>& p, int64_t x_end) {
    const double* row = view.Row(p);
    for (int64_t i = 0; i <= x_end - p[0]; ++i) {
      if (std::isnan(row[i])) {
        a.any_missing = true;
      } else {
        a.any_value = true;
      }
    }
  });
  return a;
}

// ScanAvailability, with the simplex's vertices' values (read from `view`,
// which must cover them) counted as missing where they are NaN.
template <int D>
Availability NodeAvailability(const ScannableSimplex<D>& s, const IPoint<D>& lo,
                              const IPoint<D>& hi, const GridView<D>& view) {
  Availability a = ScanAvailability<D>(s, lo, hi, view);
  for (const IPoint<D>& v : s.vertices()) a.any_missing = a.any_missing || std::isnan(view.At(v));
  return a;
}

// The error a node records, given where the field is available: the seed's
// error where every point and vertex has a value; 0 where no point has one
// (nothing to approximate: never refined); `range`, the largest error a
// store records, where only some have (the approximation cannot be checked:
// refined wherever the threshold is below the field range).
inline double ErrorGivenAvailability(const Availability& a, double error, double range) {
  if (!a.any_value) return 0;
  return a.any_missing ? range : error;
}

}  // namespace simplexdb
