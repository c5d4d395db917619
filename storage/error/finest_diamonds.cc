#include "storage/error/finest_diamonds.h"

#include <algorithm>
#include <cassert>
#include <map>

#include "hierarchy/cluster.h"
#include "hierarchy/geometry.h"
#include "hierarchy/hz_order.h"
#include "storage/error/simplex_scan.h"

namespace simplexdb {

template <int D>
const FinestDiamonds<D>& FinestDiamonds<D>::Get() {
  static const FinestDiamonds<D> diamonds;
  return diamonds;
}

// The templates come from a domain of side 8 (k = 3), where a finest vertex
// v = 2u + m with u in {1, 2}^D (both parities) has its whole diamond inside
// [v - 2, v + 2] within the domain: the nodes whose split creates v are its
// cluster, their vertices the template's simplices.
template <int D>
FinestDiamonds<D>::FinestDiamonds() {
  constexpr int k = 3;
  const int first_level = D * (k - 1);
  std::map<std::array<int64_t, D>, SimplexCode<D>> creator;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = first_level; l < D * k; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) {
        const SimplexCode<D> c = SimplexCode<D>::FromPath(top, p, l);
        creator.emplace(LatticeToGrid<D>(SplitVertex(c), k), c);
      }
    }
  }
  for (uint32_t odd = 1; odd < (1u << D); ++odd) {
    for (uint32_t parity = 0; parity < (1u << D); ++parity) {
      std::array<int64_t, D> v{};
      for (int a = 0; a < D; ++a) {
        const int64_t u = (parity >> a & 1) ? 1 : 2;
        v[a] = 2 * u + (odd >> a & 1);
      }
      const auto it = creator.find(v);
      assert(it != creator.end());
      DiamondTemplate<D>& t = templates_[odd][parity];
      for (const SimplexCode<D> member : Cluster(it->second)) {
        const SimplexVertices<D> lattice = Vertices<D>(member);
        std::array<IPoint<D>, D + 1> g{};
        typename DiamondTemplate<D>::Simplex s;
        for (int i = 0; i <= D; ++i) {
          g[i] = LatticeToGrid<D>(lattice[i], k);
          for (int a = 0; a < D; ++a) s.vertex[i][a] = static_cast<int8_t>(g[i][a] - v[a]);
        }
        const ScannableSimplex<D> scan(g);
        std::array<std::array<int64_t, D>, D> edges{}, adj{};
        for (int j = 0; j < D; ++j) {
          for (int a = 0; a < D; ++a) edges[j][a] = g[j + 1][a] - g[0][a];
        }
        int64_t det = internal::Adjugate<D>(edges, &adj);
        const int64_t sign = det < 0 ? -1 : 1;
        det *= sign;
        s.det = static_cast<int32_t>(det);
        IPoint<D> p = scan.box_lo();
        while (true) {
          bool vertex = false;
          for (int i = 0; i <= D; ++i) vertex = vertex || p == g[i];
          if (!vertex && scan.Contains(p)) {
            typename DiamondTemplate<D>::Point pt{};
            int64_t rest = det;
            for (int i = 0; i < D; ++i) {
              int64_t w = 0;
              for (int a = 0; a < D; ++a) w += adj[a][i] * (p[a] - g[0][a]);
              pt.weight[i + 1] = static_cast<int32_t>(w * sign);
              rest -= w * sign;
            }
            pt.weight[0] = static_cast<int32_t>(rest);
            for (int a = 0; a < D; ++a) pt.offset[a] = static_cast<int8_t>(p[a] - v[a]);
            s.points.push_back(pt);
          }
          int a = 0;
          for (; a < D; ++a) {
            if (p[a] < scan.box_hi()[a]) {
              ++p[a];
              break;
            }
            p[a] = scan.box_lo()[a];
          }
          if (a == D) break;
        }
        t.simplices.push_back(std::move(s));
      }
      // The split edge: the pair of opposite offsets in every simplex.
      const auto has = [](const typename DiamondTemplate<D>::Simplex& s, const std::array<int8_t, D>& o) {
        return std::find(s.vertex.begin(), s.vertex.end(), o) != s.vertex.end();
      };
      std::vector<std::array<int8_t, D>>& offsets = vertices_[odd][parity];
      for (const auto& s : t.simplices) {
        for (const auto& o : s.vertex) {
          if (std::find(offsets.begin(), offsets.end(), o) == offsets.end()) offsets.push_back(o);
        }
      }
      std::sort(offsets.begin(), offsets.end());
      int edges = 0;
      for (const auto& o : offsets) {
        std::array<int8_t, D> minus{};
        for (int a = 0; a < D; ++a) minus[a] = static_cast<int8_t>(-o[a]);
        if (o <= minus) continue;  // each pair once, by its larger offset
        bool shared = true;
        for (const auto& s : t.simplices) shared = shared && has(s, o) && has(s, minus);
        if (shared) {
          split_[odd][parity] = o;
          ++edges;
        }
      }
      assert(edges == 1);
      (void)edges;
    }
  }
}

template <int D>
void ScaledSimplexPoints(const typename DiamondTemplate<D>::Simplex& t, int scale_bits,
                         std::vector<std::array<int64_t, D>>* offsets,
                         std::vector<std::array<double, D + 1>>* weights) {
  offsets->clear();
  weights->clear();
  if (scale_bits == 0) {
    for (const auto& pt : t.points) {
      std::array<int64_t, D> o{};
      std::array<double, D + 1> w{};
      for (int a = 0; a < D; ++a) o[a] = pt.offset[a];
      for (int i = 0; i <= D; ++i) w[i] = static_cast<double>(pt.weight[i]) / t.det;
      offsets->push_back(o);
      weights->push_back(w);
    }
    return;
  }
  // Scanned in coordinates shifted by 2h (the diamond lies in [-2h, 2h]).
  const int64_t h = int64_t{1} << scale_bits;
  std::array<IPoint<D>, D + 1> g{};
  for (int i = 0; i <= D; ++i) {
    for (int a = 0; a < D; ++a) g[i][a] = t.vertex[i][a] * h + 2 * h;
  }
  const ScannableSimplex<D> scan(g);
  std::array<std::array<int64_t, D>, D> edges{}, adj{};
  for (int j = 0; j < D; ++j) {
    for (int a = 0; a < D; ++a) edges[j][a] = g[j + 1][a] - g[0][a];
  }
  const int64_t signed_det = internal::Adjugate<D>(edges, &adj);
  const int64_t sign = signed_det < 0 ? -1 : 1;
  const int64_t det = signed_det * sign;
  scan.ForEachRow(scan.box_lo(), scan.box_hi(), [&](const IPoint<D>& row, int64_t x_end) {
    for (IPoint<D> p = row; p[0] <= x_end; ++p[0]) {
      bool vertex = false;
      for (int i = 0; i <= D; ++i) vertex = vertex || p == g[i];
      if (vertex) continue;
      std::array<int64_t, D> o{};
      std::array<double, D + 1> w{};
      int64_t rest = det;
      for (int i = 0; i < D; ++i) {
        int64_t b = 0;
        for (int a = 0; a < D; ++a) b += adj[a][i] * (p[a] - g[0][a]);
        w[i + 1] = static_cast<double>(b * sign) / static_cast<double>(det);
        rest -= b * sign;
      }
      w[0] = static_cast<double>(rest) / static_cast<double>(det);
      for (int a = 0; a < D; ++a) o[a] = p[a] - 2 * h;
      offsets->push_back(o);
      weights->push_back(w);
    }
  });
}

template void ScaledSimplexPoints<3>(const DiamondTemplate<3>::Simplex&, int,
                                     std::vector<std::array<int64_t, 3>>*,
                                     std::vector<std::array<double, 4>>*);
template void ScaledSimplexPoints<4>(const DiamondTemplate<4>::Simplex&, int,
                                     std::vector<std::array<int64_t, 4>>*,
                                     std::vector<std::array<double, 5>>*);

template class FinestDiamonds<3>;
template class FinestDiamonds<4>;

}  // namespace simplexdb
