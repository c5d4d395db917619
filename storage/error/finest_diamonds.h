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
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "storage/error/simplex_scan.h"
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

  // The split edge of that template's diamond: its vertex v is the midpoint
  // of v - SplitOffset and v + SplitOffset, the edge every simplex of the
  // diamond shares. At a coarser octave (scale 2^s) both times 2^s.
  const std::array<int8_t, D>& SplitOffset(uint32_t odd, uint32_t parity) const {
    return split_[odd][parity];
  }
  // The distinct vertices of the template's simplices, as offsets from v
  // (v itself is not one: it is created by their split). Every one is
  // created before v by any refinement that creates v: the split vertices
  // of the diamond's ancestors, or domain corners. Scaled like SplitOffset.
  const std::vector<std::array<int8_t, D>>& VertexOffsets(uint32_t odd, uint32_t parity) const {
    return vertices_[odd][parity];
  }

  // The error of the diamond of finest-octave vertex g (coordinates in
  // [0, 2^k]; g's trailing common zero bits 0) of a grid whose real part is
  // [0, dims): the largest |field - interpolation| over the real grid points
  // of the diamond's simplices in the domain, vertex values clamped to the
  // real grid (the seed's rules, storage/error/simplex_scan.h). `field(p)`
  // returns the value at a real grid point p.
  // REQUIRES: no value is NaN (missing values are scanned instead:
  // storage/error/diamond_errors.h).
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
  std::array<std::array<std::array<int8_t, D>, 1 << D>, 1 << D> split_{};
  std::array<std::array<std::vector<std::array<int8_t, D>>, 1 << D>, 1 << D> vertices_;
};

// Where a vertex of the grid [0, 2^k]^D (not one of the domain's corners)
// sits among the diamond templates: its octave's scale 2^scale_bits (the
// trailing zero bits its coordinates share), its odd-axis pattern and its
// cube's parity on that octave's lattice. O(D).
struct DiamondShape {
  int scale_bits;
  uint32_t odd, parity;
};
template <int D>
DiamondShape ShapeOfVertex(const std::array<int64_t, D>& g) {
  uint64_t any = 0;
  for (int a = 0; a < D; ++a) any |= static_cast<uint64_t>(g[a]);
  const int s = std::countr_zero(any);
  DiamondShape shape{s, 0, 0};
  for (int a = 0; a < D; ++a) {
    shape.odd |= static_cast<uint32_t>(g[a] >> s & 1) << a;
    shape.parity |= static_cast<uint32_t>(g[a] >> (s + 1) & 1) << a;
  }
  return shape;
}

// The grid points of template simplex `t` scaled by 2^scale_bits (a
// diamond of octave k-1-scale_bits: the hierarchies are self-similar), the
// simplex's vertices excluded: offsets from the diamond's vertex and
// barycentric weights divided by det. For scale_bits 0, t.points.
template <int D>
void ScaledSimplexPoints(const typename DiamondTemplate<D>::Simplex& t, int scale_bits,
                         std::vector<std::array<int64_t, D>>* offsets,
                         std::vector<std::array<double, D + 1>>* weights);

// The templates laid out for one field array (x fastest, `strides` per
// axis) at one octave's scale: each simplex's vertices and points as index
// offsets from the vertex, weights divided by det. For vertices whose whole
// diamond lies in the domain and the real grid (away from both by 2 << s
// points), the error is then a run of loads and multiply-adds with no
// bounds to test. A stencil of scale s holds about 8^s times the finest
// one's points: worth it for the finest octaves, where a diamond's rows are
// too short for row scans (storage/error/diamond_errors.h).
template <int D>
class DiamondStencils {
 public:
  DiamondStencils(const FinestDiamonds<D>& diamonds, const std::array<int64_t, D>& strides,
                  int scale_bits = 0) {
    const int64_t h = int64_t{1} << scale_bits;
    std::vector<std::array<int64_t, D>> offsets;
    std::vector<std::array<double, D + 1>> weights;
    std::vector<int64_t> seen;
    for (uint32_t odd = 1; odd < (1u << D); ++odd) {
      for (uint32_t parity = 0; parity < (1u << D); ++parity) {
        Flat& f = flat_[odd][parity];
        Flat& u = unique_[odd][parity];
        seen.clear();
        for (const auto& s : diamonds.Of(odd, parity).simplices) {
          f.box.push_back(BoxOf(s, h));
          for (int i = 0; i <= D; ++i) {
            int64_t index = 0;
            for (int a = 0; a < D; ++a) index += s.vertex[i][a] * h * strides[a];
            f.vertex.push_back(index);
          }
          ScaledSimplexPoints<D>(s, scale_bits, &offsets, &weights);
          const size_t unique_before = u.point.size();
          for (size_t p = 0; p < offsets.size(); ++p) {
            int64_t index = 0;
            for (int a = 0; a < D; ++a) index += offsets[p][a] * strides[a];
            f.point.push_back(index);
            for (int i = 0; i <= D; ++i) f.weight.push_back(weights[p][i]);
            if (std::find(seen.begin(), seen.end(), index) != seen.end()) continue;
            seen.push_back(index);
            u.point.push_back(index);
            for (int i = 0; i <= D; ++i) u.weight.push_back(weights[p][i]);
          }
          f.simplex_end.push_back(static_cast<uint32_t>(f.point.size()));
          // A simplex whose points all came earlier is left out.
          if (u.point.size() == unique_before) continue;
          u.vertex.insert(u.vertex.end(), f.vertex.end() - (D + 1), f.vertex.end());
          u.simplex_end.push_back(static_cast<uint32_t>(u.point.size()));
        }
      }
    }
  }

  // The error of the diamond of the vertex whose value is at `center`,
  // with odd-axis pattern `odd` and cube parity `parity` on its octave's
  // lattice.
  // REQUIRES: the diamond, [v - 2h, v + 2h] (h = 2^scale_bits), inside the
  // domain and the real grid and inside the array; no NaN there.
  template <class V>
  double InteriorError(const V* center, uint32_t odd, uint32_t parity) const {
    return Run<false>(center, odd, parity, {}, 0);
  }

  // The same for vertex g of a domain of side `side`, whose diamond may
  // cross the domain's faces: its simplices outside the domain are not its
  // (the clusters end there).
  // REQUIRES: its simplices inside the domain lie in the real grid and the
  // array; no NaN there.
  template <class V>
  double ClippedError(const V* center, uint32_t odd, uint32_t parity,
                      const std::array<int64_t, D>& g, int64_t side) const {
    return Run<true>(center, odd, parity, g, side);
  }

 private:
  struct Box {
    std::array<int32_t, D> lo, hi;  // the simplex's vertex offsets' range per axis
  };
  template <class Template>
  static Box BoxOf(const Template& t, int64_t h) {
    Box b;
    for (int a = 0; a < D; ++a) {
      b.lo[a] = b.hi[a] = static_cast<int32_t>(t.vertex[0][a] * h);
      for (int i = 1; i <= D; ++i) {
        b.lo[a] = std::min(b.lo[a], static_cast<int32_t>(t.vertex[i][a] * h));
        b.hi[a] = std::max(b.hi[a], static_cast<int32_t>(t.vertex[i][a] * h));
      }
    }
    return b;
  }
  static bool Inside(const Box& b, const std::array<int64_t, D>& g, int64_t side) {
    for (int a = 0; a < D; ++a) {
      if (g[a] + b.lo[a] < 0 || g[a] + b.hi[a] > side) return false;
    }
    return true;
  }

  template <bool kClip, class V>
  double Run(const V* center, uint32_t odd, uint32_t parity, const std::array<int64_t, D>& g,
             int64_t side) const {
    // With every simplex in the domain, a point they share (on a common
    // face: the same interpolant there, the mesh being conforming) is
    // computed once; else point by point of the simplices kept.
    bool clipped = false;
    if constexpr (kClip) {
      for (const Box& b : flat_[odd][parity].box) clipped = clipped || !Inside(b, g, side);
    }
    const Flat& f = clipped ? flat_[odd][parity] : unique_[odd][parity];
    double worst = 0, other = 0;
    for (size_t s = 0; s < f.simplex_end.size(); ++s) {
      if (clipped && !Inside(f.box[s], g, side)) continue;
      std::array<double, D + 1> v;
      for (int i = 0; i <= D; ++i) v[i] = center[f.vertex[s * (D + 1) + static_cast<size_t>(i)]];
      // Two running maxima: points alternate between them, so a point's
      // maximum need not wait for the previous one's (the maximum of a set
      // is the same in any order).
      const auto error_at = [&](size_t p) {
        const double* w = &f.weight[p * (D + 1)];
        double interp = 0;
        for (int i = 0; i <= D; ++i) interp += w[i] * v[i];
        return std::abs(static_cast<double>(center[f.point[p]]) - interp);
      };
      size_t p = s == 0 ? 0 : f.simplex_end[s - 1];
      const size_t end = f.simplex_end[s];
      for (; p + 2 <= end; p += 2) {
        worst = std::max(worst, error_at(p));
        other = std::max(other, error_at(p + 1));
      }
      if (p < end) worst = std::max(worst, error_at(p));
    }
    return std::max(worst, other);
  }

  struct Flat {
    std::vector<int64_t> vertex;          // D + 1 per simplex
    std::vector<Box> box;                 // per simplex
    std::vector<uint32_t> simplex_end;    // points of simplex s end here
    std::vector<int64_t> point;
    std::vector<double> weight;           // D + 1 per point, divided by det
  };
  std::array<std::array<Flat, 1 << D>, 1 << D> flat_;
  // The same with each point under the first simplex holding it only, and
  // only the simplices left with points (no boxes: for diamonds wholly
  // inside the domain).
  std::array<std::array<Flat, 1 << D>, 1 << D> unique_;
};

// The templates at a coarser octave's scale as rows: each simplex's grid
// points as runs along x (first point's index offset from the vertex, its
// grid offset from the simplex's first vertex, length), found once. A
// diamond's error is then per simplex a gradient from its vertex values
// and per row one multiply-add per point, with none of the row solving a
// scan does (ScannableSimplex::ForEachRow): in the middle octaves, where
// rows are a few points long, solving them was most of a build's time.
template <int D>
class DiamondRowStencils {
 public:
  DiamondRowStencils(const FinestDiamonds<D>& diamonds, const std::array<int64_t, D>& strides,
                     int scale_bits) {
    const int64_t h = int64_t{1} << scale_bits;
    for (uint32_t odd = 1; odd < (1u << D); ++odd) {
      for (uint32_t parity = 0; parity < (1u << D); ++parity) {
        Flat& f = flat_[odd][parity];
        for (const auto& t : diamonds.Of(odd, parity).simplices) {
          // In coordinates shifted by 2h (the diamond lies in [-2h, 2h]).
          std::array<IPoint<D>, D + 1> g{};
          for (int i = 0; i <= D; ++i) {
            for (int a = 0; a < D; ++a) g[i][a] = t.vertex[i][a] * h + 2 * h;
          }
          Simplex sx;
          for (int a = 0; a < D; ++a) {
            sx.lo[a] = sx.hi[a] = static_cast<int32_t>(g[0][a] - 2 * h);
            for (int i = 1; i <= D; ++i) {
              sx.lo[a] = std::min(sx.lo[a], static_cast<int32_t>(g[i][a] - 2 * h));
              sx.hi[a] = std::max(sx.hi[a], static_cast<int32_t>(g[i][a] - 2 * h));
            }
          }
          for (int i = 0; i <= D; ++i) {
            sx.vertex[i] = 0;
            for (int a = 0; a < D; ++a) sx.vertex[i] += (g[i][a] - 2 * h) * strides[a];
          }
          std::array<std::array<int64_t, D>, D> edges{}, adj{};
          for (int j = 0; j < D; ++j) {
            for (int a = 0; a < D; ++a) edges[j][a] = g[j + 1][a] - g[0][a];
          }
          const double det = static_cast<double>(internal::Adjugate<D>(edges, &adj));
          for (int c = 0; c < D; ++c) {
            for (int j = 0; j < D; ++j) sx.gradient[c][j] = static_cast<double>(adj[c][j]) / det;
          }
          sx.row_begin = static_cast<uint32_t>(f.rows.size());
          const ScannableSimplex<D> scan(g);
          scan.ForEachRow(scan.box_lo(), scan.box_hi(), [&](const IPoint<D>& p, int64_t x_end) {
            Row r;
            r.index = 0;
            for (int a = 0; a < D; ++a) {
              r.index += (p[a] - 2 * h) * strides[a];
              r.from_first[a] = static_cast<int32_t>(p[a] - g[0][a]);
            }
            r.count = static_cast<int32_t>(x_end - p[0] + 1);
            f.rows.push_back(r);
          });
          sx.row_end = static_cast<uint32_t>(f.rows.size());
          f.simplices.push_back(sx);
        }
      }
    }
  }

  // The error of the diamond of the vertex whose value is at `center`, with
  // odd-axis pattern `odd` and cube parity `parity` on its octave's lattice.
  // REQUIRES: as DiamondStencils::InteriorError.
  template <class V>
  double InteriorError(const V* center, uint32_t odd, uint32_t parity) const {
    return Run<false>(center, odd, parity, {}, 0);
  }
  // REQUIRES: as DiamondStencils::ClippedError.
  template <class V>
  double ClippedError(const V* center, uint32_t odd, uint32_t parity,
                      const std::array<int64_t, D>& g, int64_t side) const {
    return Run<true>(center, odd, parity, g, side);
  }

 private:
  template <bool kClip, class V>
  double Run(const V* center, uint32_t odd, uint32_t parity, const std::array<int64_t, D>& g,
             int64_t side) const {
    const Flat& f = flat_[odd][parity];
    // Two running maxima of pairs of lanes, as in Interpolant::RowMax: the
    // same operations per point as one at a time.
    typedef double Pair __attribute__((vector_size(16)));
    const Pair zero = {0, 0}, two = {2, 2};
    Pair w0 = zero, w1 = zero;
    double w = 0;
    for (const Simplex& sx : f.simplices) {
      if constexpr (kClip) {
        bool inside = true;
        for (int a = 0; a < D; ++a) {
          inside = inside && g[a] + sx.lo[a] >= 0 && g[a] + sx.hi[a] <= side;
        }
        if (!inside) continue;
      }
      const double f0 = center[sx.vertex[0]];
      std::array<double, D> step{};
      for (int j = 0; j < D; ++j) step[j] = center[sx.vertex[j + 1]] - f0;
      std::array<double, D> grad{};
      for (int c = 0; c < D; ++c) {
        for (int j = 0; j < D; ++j) grad[c] += sx.gradient[c][j] * step[j];
      }
      for (uint32_t r = sx.row_begin; r < sx.row_end; ++r) {
        const Row& row = f.rows[r];
        double at = f0;
        for (int c = 0; c < D; ++c) at += grad[c] * row.from_first[c];
        const V* v = center + row.index;
        // x counted in double as well (the same small integers, exactly):
        // no conversion per point.
        const Pair ats = {at, at}, g0 = {grad[0], grad[0]};
        Pair x = {0, 1};
        int32_t i = 0;
        for (; i + 4 <= row.count; i += 4, x += two + two) {
          const Pair a = {static_cast<double>(v[i]), static_cast<double>(v[i + 1])};
          const Pair b = {static_cast<double>(v[i + 2]), static_cast<double>(v[i + 3])};
          Pair ea = a - (ats + g0 * x);
          Pair eb = b - (ats + g0 * (x + two));
          ea = ea < zero ? -ea : ea;
          eb = eb < zero ? -eb : eb;
          w0 = ea > w0 ? ea : w0;
          w1 = eb > w1 ? eb : w1;
        }
        for (; i < row.count; ++i) {
          const double e = std::abs(static_cast<double>(v[i]) - (at + grad[0] * i));
          w = e > w ? e : w;
        }
      }
    }
    return std::max(std::max(w, std::max(w0[0], w0[1])), std::max(w1[0], w1[1]));
  }

  struct Simplex {
    std::array<int32_t, D> lo{}, hi{};                    // vertex offsets' range per axis
    std::array<int64_t, D + 1> vertex{};                  // index offsets from the diamond's vertex
    std::array<std::array<double, D>, D> gradient{};      // adj / det: gradient per vertex step
    uint32_t row_begin = 0, row_end = 0;
  };
  struct Row {
    int64_t index;                      // first point's index offset from the diamond's vertex
    std::array<int32_t, D> from_first;  // first point - the simplex's first vertex
    int32_t count;
  };
  struct Flat {
    std::vector<Simplex> simplices;
    std::vector<Row> rows;
  };
  std::array<std::array<Flat, 1 << D>, 1 << D> flat_;
};

extern template class FinestDiamonds<3>;
extern template class FinestDiamonds<4>;

}  // namespace simplexdb
