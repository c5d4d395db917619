// The test suite's brute force over the grid points of a simplex, shared by
// every oracle that needs one (tests/storage/store_test_util.h's seed
// errors, tests/storage/error/simplex_scan_test.cc's enumeration and
// errors, tests/query/brute_force_errors.h's box walk). It shares no code
// with storage/error/simplex_scan.h, which it checks: a point is inside the
// closed simplex iff replacing any vertex by it gives a signed volume of the
// simplex's sign or zero (the definition, not the library's row scan with
// adjugate normals), every point of the bounding box tested; volumes are
// exact determinants by cofactor expansion in 128 bits.
//
// Only the types Int128 and IPoint come from the library
// (storage/error/simplex_scan.h), and SimplexCode's lattice vertices from
// hierarchy/ (checked by tests/hierarchy/).
//
// Cost: O(box points * (D+1) * D!) for ForEachPointInside; meant for
// domains of a few thousand points per simplex. Thread safety: pure
// functions.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "storage/error/simplex_scan.h"

namespace simplexdb::testing {

// Determinant by cofactor expansion along the first row, in 128 bits: the
// reference for the library's closed-form adjugate and determinant.
template <int N>
Int128 Det(const std::array<std::array<int64_t, N>, N>& m) {
  if constexpr (N == 1) {
    return m[0][0];
  } else if constexpr (N == 2) {
    return m[0][0] * m[1][1] - m[0][1] * m[1][0];
  } else {
    Int128 det = 0;
    for (int c = 0; c < N; ++c) {
      std::array<std::array<int64_t, N - 1>, N - 1> minor{};
      for (int r = 1; r < N; ++r) {
        int cc = 0;
        for (int k = 0; k < N; ++k) {
          if (k != c) minor[r - 1][cc++] = m[r][k];
        }
      }
      const Int128 term = m[0][c] * Det<N - 1>(minor);
      det += (c % 2 == 0) ? term : -term;
    }
    return det;
  }
}

// A simplex's D+1 vertices on the integer grid.
template <int D>
using GridSimplex = std::array<IPoint<D>, D + 1>;

// The vertices of node `code` on the grid of a domain of side 2^k.
// REQUIRES: code above the leaf level of that domain (vertices on the grid).
template <int D>
GridSimplex<D> GridVertices(SimplexCode<D> code, int k) {
  const auto lattice = Vertices(code);
  GridSimplex<D> v{};
  for (int i = 0; i <= D; ++i) {
    for (int c = 0; c < D; ++c) v[i][c] = lattice[i][c] >> (kCoordBits<D> - k);
  }
  return v;
}

// Signed volume (times D!) of the simplex v.
template <int D>
Int128 SignedVolume(const GridSimplex<D>& v) {
  std::array<std::array<int64_t, D>, D> m{};
  for (int j = 0; j < D; ++j) {
    for (int c = 0; c < D; ++c) m[j][c] = v[j + 1][c] - v[0][c];
  }
  return Det<D>(m);
}

// Signed volume (times D!) of the simplex v with vertex i replaced by p:
// SignedVolume(v) times p's barycentric coordinate for vertex i.
template <int D>
Int128 VolumeWith(const GridSimplex<D>& v, int i, const IPoint<D>& p) {
  GridSimplex<D> w = v;
  w[i] = p;
  return SignedVolume<D>(w);
}

// Whether p is in the closed simplex v: every VolumeWith zero or of the
// simplex's sign. Sets (*weights)[i] = VolumeWith(v, i, p) for each i it
// reaches (all of them when p is inside).
template <int D>
bool WeightsInside(const GridSimplex<D>& v, Int128 total, const IPoint<D>& p,
                   std::array<Int128, D + 1>* weights) {
  for (int i = 0; i <= D; ++i) {
    const Int128 w = (*weights)[i] = VolumeWith<D>(v, i, p);
    if (w != 0 && (w > 0) != (total > 0)) return false;
  }
  return true;
}

template <int D>
bool InsideBrute(const GridSimplex<D>& v, const IPoint<D>& p) {
  std::array<Int128, D + 1> weights{};
  return WeightsInside<D>(v, SignedVolume<D>(v), p, &weights);
}

// The smallest box [lo, hi] holding the simplex v.
template <int D>
std::pair<IPoint<D>, IPoint<D>> BoundingBox(const GridSimplex<D>& v) {
  IPoint<D> lo = v[0], hi = v[0];
  for (const auto& q : v) {
    for (int c = 0; c < D; ++c) {
      lo[c] = std::min(lo[c], q[c]);
      hi[c] = std::max(hi[c], q[c]);
    }
  }
  return {lo, hi};
}

// Calls f(p) for every point of the box [lo, hi], x fastest.
// REQUIRES: lo <= hi on every axis.
template <int D, class F>
void ForEachBoxPoint(const IPoint<D>& lo, const IPoint<D>& hi, F&& f) {
  IPoint<D> p = lo;
  while (true) {
    f(p);
    int c = 0;
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

// Calls fn(p, weights, total) for every grid point p of the closed simplex v
// within the box [lo, hi] (on each axis clipped to the simplex's bounding
// box; none when the two do not meet): total = SignedVolume(v), weights[i]
// = VolumeWith(v, i, p), total times p's barycentric coordinates.
template <int D, class Fn>
void ForEachPointInside(const GridSimplex<D>& v, const IPoint<D>& lo, const IPoint<D>& hi, Fn&& fn) {
  auto [box_lo, box_hi] = BoundingBox<D>(v);
  for (int c = 0; c < D; ++c) {
    box_lo[c] = std::max(box_lo[c], lo[c]);
    box_hi[c] = std::min(box_hi[c], hi[c]);
    if (box_lo[c] > box_hi[c]) return;
  }
  const Int128 total = SignedVolume<D>(v);
  ForEachBoxPoint<D>(box_lo, box_hi, [&](const IPoint<D>& p) {
    std::array<Int128, D + 1> weights{};
    if (WeightsInside<D>(v, total, p, &weights)) fn(p, weights, total);
  });
}

// The largest |f(p) - linear interpolation of fv over v at p| over the
// grid points p of v within [lo, hi], as an exact fraction: numerator /
// denominator with numerator = max |total * field(p) - sum_i weights[i] *
// fv[i]| and denominator = |total| (0 / 1 when no point is there).
struct ExactError {
  Int128 numerator = 0;
  Int128 denominator = 1;
  bool any_point = false;
  // numerator / (denominator * scale) in long double: one rounding.
  long double Value(long double scale = 1) const {
    return static_cast<long double>(numerator) / (static_cast<long double>(denominator) * scale);
  }
};

// REQUIRES: field(p) and fv integers whose products with the volumes fit
// in 127 bits.
template <int D, class Field>
ExactError MaxInterpolationError(const GridSimplex<D>& v, const std::array<Int128, D + 1>& fv,
                                 const IPoint<D>& lo, const IPoint<D>& hi, Field&& field) {
  ExactError e;
  ForEachPointInside<D>(v, lo, hi, [&](const IPoint<D>& p, const std::array<Int128, D + 1>& w, Int128 total) {
    Int128 interp = 0;  // total * interpolation
    for (int i = 0; i <= D; ++i) interp += w[i] * fv[i];
    const Int128 num = Int128{field(p)} * total - interp;
    e.numerator = std::max(e.numerator, num < 0 ? -num : num);
    e.denominator = total < 0 ? -total : total;
    e.any_point = true;
  });
  return e;
}

}  // namespace simplexdb::testing
