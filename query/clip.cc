#include "query/clip.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <unordered_map>
#include <vector>

namespace simplexdb {
namespace {

// Clips a mesh by the half-space x[axis] <= h, keeping point indices: the
// input's points keep theirs, cut points are appended.
class PlaneClipper {
 public:
  PlaneClipper(const TetMeshData& in, int axis, double h) : in_(in), axis_(axis), h_(h) {
    out_.points = in.points;
    out_.field = in.field;
  }

  TetMeshData Run() && {
    for (uint64_t c = 0; c < in_.cells(); ++c) ClipCell(c);
    return std::move(out_);
  }

 private:
  double Side(int64_t p) const { return out_.points[3 * p + axis_] - h_; }

  // The global order of points: by position (x, then y, then z). Not by
  // index: a piece of a mesh (query/pieces.h) numbers its points otherwise
  // than the whole, and must cut and fan its cells as the whole does.
  bool Less(int64_t a, int64_t b) const {
    const double* pa = &out_.points[3 * a];
    const double* pb = &out_.points[3 * b];
    return std::lexicographical_compare(pa, pa + 3, pb, pb + 3);
  }

  // The point where edge a-b (one end on each side) meets the plane, named
  // by the edge: computed once, from its smaller end in the global order.
  int64_t Cut(int64_t a, int64_t b) {
    if (Less(b, a)) std::swap(a, b);
    assert(a < (int64_t{1} << 32) && b < (int64_t{1} << 32));
    const uint64_t key = static_cast<uint64_t>(std::min(a, b)) << 32 | static_cast<uint64_t>(std::max(a, b));
    const auto [it, fresh] = cuts_.emplace(key, static_cast<int64_t>(out_.field.size()));
    if (fresh) {
      const double sa = Side(a), sb = Side(b), w = sa / (sa - sb);
      for (int x = 0; x < 3; ++x) {
        const double pa = out_.points[3 * a + x], pb = out_.points[3 * b + x];
        out_.points.push_back(x == axis_ ? h_ : pa + (pb - pa) * w);
      }
      out_.field.push_back(out_.field[a] + (out_.field[b] - out_.field[a]) * w);
    }
    return it->second;
  }

  double Det(int64_t p0, int64_t p1, int64_t p2, int64_t p3) const {
    const double* x0 = &out_.points[3 * p0];
    std::array<std::array<double, 3>, 3> e{};
    const int64_t q[3] = {p1, p2, p3};
    for (int i = 0; i < 3; ++i) {
      for (int a = 0; a < 3; ++a) e[i][a] = out_.points[3 * q[i] + a] - x0[a];
    }
    return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
           e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  }

  void Emit(uint64_t cell, std::array<int64_t, 4> t) {
    const double det = Det(t[0], t[1], t[2], t[3]);
    if (det == 0) return;  // a fan over collinear points; not expected, harmless
    if (det < 0) std::swap(t[0], t[1]);
    out_.connectivity.insert(out_.connectivity.end(), t.begin(), t.end());
    out_.error.push_back(in_.error[cell]);
    out_.level.push_back(in_.level[cell]);
    out_.code.push_back(in_.code[cell]);
  }

  void ClipCell(uint64_t cell) {
    std::array<int64_t, 4> p;
    std::array<double, 4> s;
    int inside = 0, outside = 0;
    for (int i = 0; i < 4; ++i) {
      p[i] = in_.connectivity[4 * cell + i];
      s[i] = Side(p[i]);
      inside += s[i] < 0;
      outside += s[i] > 0;
    }
    if (outside == 0) return Emit(cell, p);
    if (inside == 0) return;  // wholly outside, or touching the plane only

    // The faces of the part inside: each face of the cell clipped
    // (Sutherland-Hodgman keeps the polygon's cyclic order), then the cut.
    using Polygon = std::vector<int64_t>;
    std::vector<Polygon> faces;
    Polygon cap;
    for (int skip = 0; skip < 4; ++skip) {
      Polygon face;
      int tri[3], n = 0;
      for (int i = 0; i < 4; ++i) {
        if (i != skip) tri[n++] = i;
      }
      for (int i = 0; i < 3; ++i) {
        const int a = tri[i], b = tri[(i + 1) % 3];
        if (s[a] <= 0) face.push_back(p[a]);
        if ((s[a] < 0 && s[b] > 0) || (s[a] > 0 && s[b] < 0)) face.push_back(Cut(p[a], p[b]));
      }
      for (const int64_t q : face) {
        if (Side(q) == 0 && std::find(cap.begin(), cap.end(), q) == cap.end()) cap.push_back(q);
      }
      if (face.size() >= 3) faces.push_back(std::move(face));
    }
    // The cut is convex and in the plane: order its points by angle about
    // their centre, in the other two axes.
    const int u = (axis_ + 1) % 3, v = (axis_ + 2) % 3;
    double cu = 0, cv = 0;
    for (const int64_t q : cap) {
      cu += out_.points[3 * q + u];
      cv += out_.points[3 * q + v];
    }
    cu /= static_cast<double>(cap.size());
    cv /= static_cast<double>(cap.size());
    const auto angle = [&](int64_t q) { return std::atan2(out_.points[3 * q + v] - cv, out_.points[3 * q + u] - cu); };
    std::sort(cap.begin(), cap.end(), [&](int64_t a, int64_t b) { return angle(a) < angle(b); });
    if (cap.size() >= 3) faces.push_back(std::move(cap));

    const auto less = [this](int64_t a, int64_t b) { return Less(a, b); };
    int64_t apex = faces[0][0];
    for (const Polygon& f : faces) apex = std::min(apex, *std::min_element(f.begin(), f.end(), less), less);
    for (Polygon& f : faces) {
      if (std::find(f.begin(), f.end(), apex) != f.end()) continue;
      std::rotate(f.begin(), std::min_element(f.begin(), f.end(), less), f.end());
      for (size_t i = 1; i + 1 < f.size(); ++i) Emit(cell, {apex, f[0], f[i], f[i + 1]});
    }
  }

  const TetMeshData& in_;
  TetMeshData out_;
  const int axis_;
  const double h_;
  std::unordered_map<uint64_t, int64_t> cuts_;
};

// Drops the points no cell uses, renumbering the rest in order.
void DropUnusedPoints(TetMeshData& mesh) {
  std::vector<int64_t> renumber(mesh.field.size(), -1);
  for (const int64_t p : mesh.connectivity) renumber[p] = 0;
  int64_t next = 0;
  for (size_t p = 0; p < renumber.size(); ++p) {
    if (renumber[p] < 0) continue;
    renumber[p] = next;
    for (int a = 0; a < 3; ++a) mesh.points[3 * next + a] = mesh.points[3 * p + a];
    mesh.field[next] = mesh.field[p];
    ++next;
  }
  mesh.points.resize(3 * next);
  mesh.field.resize(next);
  for (int64_t& p : mesh.connectivity) p = renumber[p];
}

}  // namespace

TetMeshData ClipToGrid(TetMeshData mesh, const std::array<uint32_t, 4>& dims) {
  TetMeshData out = std::move(mesh);
  bool clipped = false;
  for (int axis = 0; axis < 3; ++axis) {
    assert(dims[axis] >= 2);
    const double h = static_cast<double>(dims[axis] - 1);
    bool beyond = false;
    for (size_t p = axis; p < out.points.size() && !beyond; p += 3) beyond = out.points[p] > h;
    if (!beyond) continue;
    out = PlaneClipper(out, axis, h).Run();
    clipped = true;
  }
  if (clipped) DropUnusedPoints(out);
  return out;
}

void PlacePhysically(TetMeshData& mesh, const SourceInfo& info) {
  for (size_t p = 0; p < mesh.points.size(); p += 3) {
    for (int a = 0; a < 3; ++a) mesh.points[p + a] = info.origin[a] + mesh.points[p + a] * info.spacing[a];
  }
  // An odd number of flipped axes mirrors space, and every tetrahedron with
  // it: swapping two vertices turns each positive again.
  const int flips = (info.spacing[0] < 0) + (info.spacing[1] < 0) + (info.spacing[2] < 0);
  if (flips % 2 == 1) {
    for (size_t c = 0; c + 3 < mesh.connectivity.size(); c += 4) {
      std::swap(mesh.connectivity[c + 2], mesh.connectivity[c + 3]);
    }
  }
}

}  // namespace simplexdb
