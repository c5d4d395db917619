// The finest octave's diamond errors computed where they are needed, from a
// window of the field. The dense store keeps no errors for the finest
// octave (7/8 of the HT's vertices, 15/16 of the HP's:
// docs/format/dense-store.md, "Errors"); its reader computes
// them a box of vertices at a time from the field's bricks around the box.
//
// FinestDiamondError is the one function that computes a finest diamond's
// error: the builder (DiamondErrors) and the reader (FinestBoxErrors) both
// call it, with stencils laid out for their own arrays, so the reader
// reproduces the builder's errors bit for bit (a block's recorded maximum
// then bounds them exactly).
//
// Thread safety: FinestBoxErrors is immutable after construction; Compute
// may run concurrently on distinct outputs.
// Lifetimes: nothing refers to the window or the output after a call.
// Errors: none; preconditions (no NaN: fields with missing values keep
// their finest errors stored) are assertions.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>

#include "storage/error/finest_diamonds.h"

namespace simplexdb {

// The error of the diamond of finest-octave vertex g (some coordinate odd,
// each in [0, 2^k]) of a grid whose real part is [0, dims). `stencils`
// (scale 0) are laid out for the array `center` points into (of doubles, or
// of floats holding the values exactly: the same errors), at g's value (or
// where it would be, for g past the real grid); `field(p)` returns the
// value at real grid point p for the diamonds that cross the real grid's
// last faces, which take the generic template walk.
// REQUIRES: the array holds every real point of [g - 2, g + 2].
template <int D, class V, class Field>
double FinestDiamondError(const DiamondStencils<D>& stencils, const V* center,
                          const std::array<int64_t, D>& g, int k,
                          const std::array<int64_t, D>& dims, Field&& field) {
  const int64_t side = int64_t{1} << k;
  // The stencils serve a diamond whose simplices in the domain lie in the
  // real grid: it ends before the real grid's last point, or the real grid
  // reaches the domain's face there (at 0 both start together).
  bool interior = true, clip = false;
  uint32_t odd = 0, parity = 0;
  for (int a = 0; a < D; ++a) {
    interior = interior && (g[a] + 2 <= dims[a] - 1 || dims[a] - 1 == side);
    clip = clip || g[a] < 2 || g[a] + 2 > side;
    odd |= static_cast<uint32_t>(g[a] & 1) << a;
    parity |= static_cast<uint32_t>((g[a] >> 1) & 1) << a;
  }
  if (!interior) return FinestDiamonds<D>::Get().Error(g, k, dims, field);
  return clip ? stencils.ClippedError(center, odd, parity, g, side)
              : stencils.InteriorError(center, odd, parity);
}

template <int D>
class FinestBoxErrors {
 public:
  // For boxes of up to `box_side` grid points per axis.
  explicit FinestBoxErrors(int64_t box_side);

  // The window around a box: the box grown by 2 points on each side (the
  // reach of a finest diamond), window_side() points per axis, x fastest.
  int64_t window_side() const { return window_side_; }
  uint64_t window_points() const;

  // The diamond errors of the finest vertices g in the box [first, first +
  // extent) (per axis; extent[a] <= box_side), as out[slot], slot x fastest
  // over the extent; 0 where g is not a finest vertex (every coordinate
  // even) or lies past the domain (g[a] > 2^k). `window` holds the field
  // at the points [first - 2, first - 2 + window_side()) per axis; only
  // those in the real grid [0, dims) are read. O(box points x stencil).
  void Compute(const std::array<int64_t, D>& first, const std::array<int64_t, D>& extent, int k,
               const std::array<int64_t, D>& dims, const double* window, double* out) const;

  // One vertex of Compute's: the error of g, a point of the box from
  // `first`, or 0 (g not a finest vertex, or past the domain). `window`
  // as Compute's, of any type V holding the field's values exactly (the
  // store's voxel type: the same errors as from doubles).
  template <class V>
  double ErrorAt(const std::array<int64_t, D>& g, const std::array<int64_t, D>& first, int k,
                 const std::array<int64_t, D>& dims, const V* window) const {
    bool finest = false, inside = true;
    for (int a = 0; a < D; ++a) {
      finest = finest || (g[a] & 1) != 0;
      inside = inside && g[a] <= (int64_t{1} << k);
    }
    if (!finest || !inside) return 0.0;
    const auto field = [&](const std::array<int64_t, D>& p) {
      return static_cast<double>(window[WindowIndex(p, first)]);
    };
    return FinestDiamondError<D>(stencils_, window + WindowIndex(g, first), g, k, dims, field);
  }

 private:
  // The window index of grid point p, for the box from `first`.
  int64_t WindowIndex(const std::array<int64_t, D>& p, const std::array<int64_t, D>& first) const {
    int64_t i = 0;
    for (int a = 0; a < D; ++a) {
      assert(p[a] - first[a] + 2 >= 0 && p[a] - first[a] + 2 < window_side_);
      i += (p[a] - first[a] + 2) * strides_[a];
    }
    return i;
  }

  int64_t window_side_;
  std::array<int64_t, D> strides_{};
  DiamondStencils<D> stencils_;
};

extern template class FinestBoxErrors<3>;
extern template class FinestBoxErrors<4>;

}  // namespace simplexdb
