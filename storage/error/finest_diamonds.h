// The diamonds of the finest octave as templates, and their errors from the
// field around a vertex.
//
// Store format 2 keeps one error per diamond (hierarchy/hz_order.h). The
// finest octave holds 7/8 of the HT's vertices and 15/16 of the HP's, and
// its diamonds span a few grid points: vertex v = 2u + m (u its cube, m its
// odd-axis pattern) has a diamond inside [v - 2, v + 2]. Their shapes repeat:
// they depend on the pattern and on the parity of the cube (the cubes'
// Kuhn triangulations alternate by reflection), so 2^D x (2^D - 1) templates
// hold every one, each a list of simplices (vertex offsets from v) with the
// grid points inside or on them and their barycentric weights. A diamond at
// the domain's boundary is the template's simplices that lie in the domain.
// The templates are derived from the hierarchy itself (clusters and
// vertices of a small domain) and checked against every vertex of larger
// ones by the tests.
//
// With them the error of a finest diamond is a fixed stencil over the field
// (at most 27 points in the HT, 81 in the HP): what lets a store compute
// these errors from its field instead of storing them, and a builder compute
// them without scanning simplices.
//
// Thread safety: the templates are built once, at first use, and immutable.
// Lifetimes: Get() lives for the program. Errors: none; preconditions are
// assertions.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "util/status.h"

namespace simplexdb {

template <int D>
struct DiamondTemplate {
  using Offset = std::array<int8_t, D>;  // from the vertex, in grid points
  struct Point {
    Offset offset;
    std::array<int32_t, D + 1> weight;  // barycentric, times det; they sum to det
  };
  struct Simplex {
    std::array<Offset, D + 1> vertex;
    int32_t det = 0;            // > 0
    std::vector<Point> points;  // grid points inside or on it, vertices excluded
  };
  std::vector<Simplex> simplices;
};

template <int D>
class FinestDiamonds {
 public:
  static const FinestDiamonds& Get();

  // The template of a vertex with odd-axis pattern `odd` (non-zero) in a
  // cube of parity `parity` (bit a: u[a] odd).
  const DiamondTemplate<D>& Of(uint32_t odd, uint32_t parity) const {
    return templates_[odd][parity];
  }

  // The error of the diamond of finest-octave vertex g (coordinates in
  // [0, 2^k]; g's trailing common zero bits 0) of a grid whose real part is
  // [0, dims): the largest |field - interpolation| over the real grid points
  // of the diamond's simplices in the domain, vertex values clamped to the
  // real grid (as the error engine, storage/error/unit_errors.h). `field(p)`
  // returns the value at a real grid point p.
  // REQUIRES: no value is NaN (missing values take the engine's slow path).
  template <class Field>
  double Error(const std::array<int64_t, D>& g, int domain_bits,
               const std::array<int64_t, D>& dims, Field&& field) const {
    uint32_t odd = 0, parity = 0;
    for (int a = 0; a < D; ++a) {
      odd |= static_cast<uint32_t>(g[a] & 1) << a;
      parity |= static_cast<uint32_t>((g[a] >> 1) & 1) << a;
    }
    const int64_t side = int64_t{1} << domain_bits;
    const auto at = [&](const std::array<int8_t, D>& o) {
      std::array<int64_t, D> p{};
      for (int a = 0; a < D; ++a) p[a] = std::min(g[a] + o[a], dims[a] - 1);
      return static_cast<double>(field(p));
    };
    double worst = 0;
    for (const auto& s : Of(odd, parity).simplices) {
      bool inside = true;
      for (int i = 0; i <= D && inside; ++i) {
        for (int a = 0; a < D; ++a) {
          const int64_t c = g[a] + s.vertex[i][a];
          inside = inside && c >= 0 && c <= side;
        }
      }
      if (!inside) continue;
      std::array<double, D + 1> f{};
      for (int i = 0; i <= D; ++i) f[i] = at(s.vertex[i]);
      for (const auto& pt : s.points) {
        bool real = true;
        std::array<int64_t, D> p{};
        for (int a = 0; a < D; ++a) {
          p[a] = g[a] + pt.offset[a];
          real = real && p[a] < dims[a];
        }
        if (!real) continue;
        double interp = 0;
        for (int i = 0; i <= D; ++i) interp += static_cast<double>(pt.weight[i]) * f[i];
        worst = std::max(worst, std::abs(static_cast<double>(field(p)) - interp / s.det));
      }
    }
    return worst;
  }

 private:
  FinestDiamonds();
  std::array<std::array<DiamondTemplate<D>, 1 << D>, 1 << D> templates_;
};

// The templates laid out for one field array (x fastest, `strides` per
// axis): each simplex's vertices and points as index offsets from the
// vertex, weights divided by det. For vertices whose whole diamond lies in
// the domain and the real grid (away from both by 2 points), the error is
// then a run of loads and multiply-adds with no bounds to test.
template <int D>
class FinestStencils {
 public:
  FinestStencils(const FinestDiamonds<D>& diamonds, const std::array<int64_t, D>& strides) {
    for (uint32_t odd = 1; odd < (1u << D); ++odd) {
      for (uint32_t parity = 0; parity < (1u << D); ++parity) {
        Flat& f = flat_[odd][parity];
        for (const auto& s : diamonds.Of(odd, parity).simplices) {
          f.simplex_end.push_back(0);
          for (int i = 0; i <= D; ++i) f.vertex.push_back(Index(s.vertex[i], strides));
          for (const auto& pt : s.points) {
            f.point.push_back(Index(pt.offset, strides));
            for (int i = 0; i <= D; ++i) {
              f.weight.push_back(static_cast<double>(pt.weight[i]) / static_cast<double>(s.det));
            }
          }
          f.simplex_end.back() = static_cast<uint32_t>(f.point.size());
        }
      }
    }
  }

  // The error of the diamond of the finest vertex whose value is at
  // `center`, with odd-axis pattern `odd` and cube parity `parity`.
  // REQUIRES: the diamond, [v - 2, v + 2], inside the domain and the real
  // grid and inside the array; no NaN there.
  double InteriorError(const double* center, uint32_t odd, uint32_t parity) const {
    const Flat& f = flat_[odd][parity];
    double worst = 0;
    size_t p = 0, w = 0;
    for (size_t s = 0; s < f.simplex_end.size(); ++s) {
      std::array<double, D + 1> v;
      for (int i = 0; i <= D; ++i) v[i] = center[f.vertex[s * (D + 1) + static_cast<size_t>(i)]];
      for (; p < f.simplex_end[s]; ++p, w += D + 1) {
        double interp = 0;
        for (int i = 0; i <= D; ++i) interp += f.weight[w + static_cast<size_t>(i)] * v[i];
        worst = std::max(worst, std::abs(center[f.point[p]] - interp));
      }
    }
    return worst;
  }

 private:
  struct Flat {
    std::vector<int64_t> vertex;          // D + 1 per simplex
    std::vector<uint32_t> simplex_end;    // points of simplex s end here
    std::vector<int64_t> point;
    std::vector<double> weight;           // D + 1 per point, divided by det
  };
  static int64_t Index(const std::array<int8_t, D>& o, const std::array<int64_t, D>& strides) {
    int64_t i = 0;
    for (int a = 0; a < D; ++a) i += o[a] * strides[a];
    return i;
  }
  std::array<std::array<Flat, 1 << D>, 1 << D> flat_;
};

extern template class FinestDiamonds<3>;
extern template class FinestDiamonds<4>;

}  // namespace simplexdb
