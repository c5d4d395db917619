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

extern template class FinestDiamonds<3>;
extern template class FinestDiamonds<4>;

}  // namespace simplexdb
