#include "query/criteria.h"

#include <bit>
#include <cmath>
#include <limits>

namespace simplexdb {
namespace {

__extension__ typedef __int128 Int128;

// The normal, within the m coordinates `axes`, of the projection of the
// face with vertices `face` (m of them): the generalized cross product of
// its m-1 edge vectors. Zero when the projection is degenerate.
template <int D>
std::array<Int128, D> FaceNormal(const SimplexVertices<D>& v, const std::array<int, D>& face,
                                 const std::array<int, D>& axes, int m) {
  std::array<Int128, D> w{};
  // e[r][c]: edge r (vertex r+1 minus vertex 0) along axis c.
  Int128 e[D][D] = {};
  for (int r = 0; r + 1 < m; ++r) {
    for (int c = 0; c < m; ++c) {
      e[r][c] = Int128{v[face[r + 1]][axes[c]]} - v[face[0]][axes[c]];
    }
  }
  if (m == 2) {
    w[0] = -e[0][1];
    w[1] = e[0][0];
  } else if (m == 3) {
    w[0] = e[0][1] * e[1][2] - e[0][2] * e[1][1];
    w[1] = e[0][2] * e[1][0] - e[0][0] * e[1][2];
    w[2] = e[0][0] * e[1][1] - e[0][1] * e[1][0];
  } else if constexpr (D == 4) {
    // m == 4: cofactors of the 3x4 matrix of edges (Laplace along a fourth
    // row of unit vectors).
    for (int c = 0; c < 4; ++c) {
      int cols[3], n = 0;
      for (int j = 0; j < 4; ++j) {
        if (j != c) cols[n++] = j;
      }
      const Int128 det = e[0][cols[0]] * (e[1][cols[1]] * e[2][cols[2]] - e[1][cols[2]] * e[2][cols[1]]) -
                         e[0][cols[1]] * (e[1][cols[0]] * e[2][cols[2]] - e[1][cols[2]] * e[2][cols[0]]) +
                         e[0][cols[2]] * (e[1][cols[0]] * e[2][cols[1]] - e[1][cols[1]] * e[2][cols[0]]);
      w[c] = (c % 2 == 0) ? det : -det;
    }
  }
  return w;
}

}  // namespace

template <int D>
bool SimplexMeetsBox(const SimplexVertices<D>& v, const LatticeBox<D>& box) {
  // Bounding boxes (the m = 1 directions), and a vertex inside the box.
  for (int a = 0; a < D; ++a) {
    int64_t lo = v[0][a], hi = lo;
    for (const auto& p : v) {
      lo = std::min<int64_t>(lo, p[a]);
      hi = std::max<int64_t>(hi, p[a]);
    }
    if (hi < box.lo[a] || lo > box.hi[a]) return false;
  }
  for (const auto& p : v) {
    bool inside = true;
    for (int a = 0; a < D; ++a) inside = inside && box.lo[a] <= p[a] && p[a] <= box.hi[a];
    if (inside) return true;
  }
  // Every set of m >= 2 axes, every face with m vertices.
  for (unsigned axis_set = 1; axis_set < (1u << D); ++axis_set) {
    const int m = std::popcount(axis_set);
    if (m < 2) continue;
    std::array<int, D> axes{};
    for (int a = 0, n = 0; a < D; ++a) {
      if (axis_set >> a & 1) axes[n++] = a;
    }
    for (unsigned face_set = 0; face_set < (1u << (D + 1)); ++face_set) {
      if (std::popcount(face_set) != m) continue;
      std::array<int, D> face{};
      for (int i = 0, n = 0; i <= D; ++i) {
        if (face_set >> i & 1) face[n++] = i;
      }
      const std::array<Int128, D> w = FaceNormal<D>(v, face, axes, m);
      bool zero = true;
      for (int c = 0; c < m; ++c) zero = zero && w[c] == 0;
      if (zero) continue;
      Int128 smin = 0, smax = 0, bmin = 0, bmax = 0;
      for (int i = 0; i <= D; ++i) {
        Int128 dot = 0;
        for (int c = 0; c < m; ++c) dot += w[c] * v[i][axes[c]];
        smin = i == 0 ? dot : std::min(smin, dot);
        smax = i == 0 ? dot : std::max(smax, dot);
      }
      for (int c = 0; c < m; ++c) {
        const Int128 a = w[c] * box.lo[axes[c]], b = w[c] * box.hi[axes[c]];
        bmin += std::min(a, b);
        bmax += std::max(a, b);
      }
      if (smax < bmin || bmax < smin) return false;
    }
  }
  return true;
}

template <int D>
Result<Criteria<D>> MakeCriteria(const CriteriaSpec& spec, int domain_bits, double range) {
  Criteria<D> c;
  if (!std::isfinite(spec.error.value) || spec.error.value < 0) {
    return Status::InvalidArgument("error threshold " + std::to_string(spec.error.value) +
                                   ": expected a number >= 0");
  }
  c.threshold = spec.error.Resolve(range);
  const double scale = std::ldexp(1.0, kCoordBits<D> - domain_bits);
  const double side = std::ldexp(1.0, domain_bits);
  if (spec.box) {
    const std::vector<double>& b = *spec.box;
    const size_t want = D == 3 ? 6 : 8;
    if (b.size() != 6 && b.size() != want) {
      return Status::InvalidArgument("box with " + std::to_string(b.size()) + " numbers: expected " +
                                     (D == 3 ? std::string("x0,y0,z0,x1,y1,z1")
                                             : std::string("x0,y0,z0,x1,y1,z1 or x0,y0,z0,x1,y1,z1,t0,t1")));
    }
    LatticeBox<D> box;
    for (int a = 0; a < D; ++a) {
      double lo = 0, hi = side;  // the HP's time, when the box leaves it out
      if (a < 3) {
        lo = b[a];
        hi = b[3 + a];
      } else if (b.size() == 8) {
        lo = b[6];
        hi = b[7];
      }
      if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi) {
        return Status::InvalidArgument("box axis " + std::to_string(a) + " from " + std::to_string(lo) +
                                       " to " + std::to_string(hi) + ": expected finite bounds, low <= high");
      }
      // Clamp to just outside the domain, then round outward.
      lo = std::clamp(lo, -1.0, side + 1) * scale;
      hi = std::clamp(hi, -1.0, side + 1) * scale;
      box.lo[a] = static_cast<int64_t>(std::floor(lo));
      box.hi[a] = static_cast<int64_t>(std::ceil(hi));
    }
    c.box = box;
  }
  if (spec.iso) {
    if (!std::isfinite(*spec.iso)) return Status::InvalidArgument("isovalue: expected a finite number");
    c.iso = spec.iso;
  }
  if (spec.time) {
    if (D != 4) return Status::InvalidArgument("--time applies to the HP (4D) only");
    if (!std::isfinite(*spec.time)) return Status::InvalidArgument("time: expected a finite number");
    c.time = *spec.time * scale;
  }
  return c;
}

template bool SimplexMeetsBox<3>(const SimplexVertices<3>&, const LatticeBox<3>&);
template bool SimplexMeetsBox<4>(const SimplexVertices<4>&, const LatticeBox<4>&);
template Result<Criteria<3>> MakeCriteria<3>(const CriteriaSpec&, int, double);
template Result<Criteria<4>> MakeCriteria<4>(const CriteriaSpec&, int, double);

}  // namespace simplexdb
