#include "query/conformity.h"

#include <algorithm>
#include <array>
#include <vector>

#include "hierarchy/geometry.h"

namespace simplexdb {
namespace {

__extension__ typedef unsigned __int128 UInt128;

template <int D>
std::string DescribePoint(const Point<D>& p) {
  std::string s(1, '(');
  for (int i = 0; i < D; ++i) {
    if (i > 0) s += ',';
    s += std::to_string(p[i]);
  }
  s += ')';
  return s;
}

}  // namespace

template <int D>
ConformityReport CheckConformity(std::span<const SimplexCode<D>> simplices) {
  using Code = SimplexCode<D>;
  ConformityReport r;
  r.simplices = simplices.size();
  std::vector<Code> sorted(simplices.begin(), simplices.end());
  std::sort(sorted.begin(), sorted.end());
  // Partition: sorted by preorder key, a code contains the next one iff the
  // next lies in its key range.
  UInt128 volume = 0;  // in units of the deepest possible simplex
  for (size_t i = 0; i < sorted.size(); ++i) {
    const Code c = sorted[i];
    if (!c.is_valid()) {
      r.problem = "an invalid code (key " + std::to_string(c.key()) + ")";
      return r;
    }
    if (i + 1 < sorted.size() && sorted[i + 1].key() <= c.range_max()) {
      r.problem = c.ToString() + (sorted[i + 1] == c ? " appears twice" : " overlaps " + sorted[i + 1].ToString());
      return r;
    }
    volume += static_cast<UInt128>(1) << (Code::kMaxLevel - c.level());
  }
  const UInt128 whole = static_cast<UInt128>(Code::kRoots) << Code::kMaxLevel;
  if (volume != whole) {
    r.problem = "the simplices cover " + std::to_string(static_cast<double>(volume) / static_cast<double>(whole)) +
                " of the domain, not all of it";
    return r;
  }
  // Faces: each as its D packed vertices, sorted, with the simplex it is of.
  struct Face {
    std::array<uint64_t, D> v;
    uint32_t simplex;
    bool operator<(const Face& o) const { return v < o.v; }
  };
  std::vector<Face> faces;
  faces.reserve(sorted.size() * (D + 1));
  for (size_t i = 0; i < sorted.size(); ++i) {
    const SimplexVertices<D> v = Vertices<D>(sorted[i]);
    for (int skip = 0; skip <= D; ++skip) {
      Face f{{}, static_cast<uint32_t>(i)};
      for (int j = 0, n = 0; j <= D; ++j) {
        if (j != skip) f.v[n++] = internal::Pack<D>(v[j]);
      }
      std::sort(f.v.begin(), f.v.end());
      faces.push_back(f);
    }
  }
  std::sort(faces.begin(), faces.end());
  const auto on_boundary = [](const std::array<uint64_t, D>& f) {
    for (int a = 0; a < D; ++a) {
      bool low = true, high = true;
      for (uint64_t w : f) {
        const int32_t x = internal::Unpack<D>(w)[a];
        low = low && x == 0;
        high = high && x == kDomainSide<D>;
      }
      if (low || high) return true;
    }
    return false;
  };
  for (size_t i = 0; i < faces.size();) {
    size_t j = i;
    while (j < faces.size() && faces[j].v == faces[i].v) ++j;
    const size_t uses = j - i;
    const bool boundary = on_boundary(faces[i].v);
    if (uses == 2 && !boundary) {
      ++r.interior_faces;
    } else if (uses == 1 && boundary) {
      ++r.boundary_faces;
    } else {
      std::string verts;
      for (uint64_t w : faces[i].v) verts += DescribePoint<D>(internal::Unpack<D>(w));
      r.problem = "the face " + verts + " of " + sorted[faces[i].simplex].ToString() + " is used by " +
                  std::to_string(uses) + " simplices" + (boundary ? " on the boundary" : "") +
                  (uses == 1 ? " (a neighbor across it is split or coarser: a hanging vertex)" : "");
      return r;
    }
    i = j;
  }
  r.ok = true;
  return r;
}

template ConformityReport CheckConformity<3>(std::span<const SimplexCode<3>>);
template ConformityReport CheckConformity<4>(std::span<const SimplexCode<4>>);

}  // namespace simplexdb
