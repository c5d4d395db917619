#include "query/isosurface.h"

#include <algorithm>
#include <utility>

namespace simplexdb {
namespace {

using Vec = std::array<double, 3>;

Vec Sub(const Vec& a, const Vec& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec Cross(const Vec& a, const Vec& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double Dot(const Vec& a, const Vec& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// (z, y, x) order: a grid point's number x + X (y + Y z) orders them so.
bool Before(const Vec& a, const Vec& b) {
  if (a[2] != b[2]) return a[2] < b[2];
  if (a[1] != b[1]) return a[1] < b[1];
  return a[0] < b[0];
}

// The gradient of the linear function with values f at the vertices p.
Vec Gradient(const std::array<SurfaceVertex, 4>& v) {
  const Vec e1 = Sub(v[1].p, v[0].p), e2 = Sub(v[2].p, v[0].p), e3 = Sub(v[3].p, v[0].p);
  const Vec c1 = Cross(e2, e3), c2 = Cross(e3, e1), c3 = Cross(e1, e2);
  const double det = Dot(e1, c1);
  if (det == 0) return {0, 0, 0};
  const double d1 = v[1].f - v[0].f, d2 = v[2].f - v[0].f, d3 = v[3].f - v[0].f;
  return {(d1 * c1[0] + d2 * c2[0] + d3 * c3[0]) / det, (d1 * c1[1] + d2 * c2[1] + d3 * c3[1]) / det,
          (d1 * c1[2] + d2 * c2[2] + d3 * c3[2]) / det};
}

}  // namespace

// Open addressing over (first, second) names: a cut edge's two vertex ids,
// or a vertex's id twice.
struct SurfaceBuilder::Table {
  struct Slot {
    uint64_t a, b;
    int64_t index;  // -1: empty
  };
  std::vector<Slot> slots = std::vector<Slot>(1024, Slot{0, 0, -1});
  size_t used = 0;

  static size_t Hash(uint64_t a, uint64_t b) {
    uint64_t h = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full;
    return static_cast<size_t>(h ^ (h >> 29));
  }
  // The slot of (a, b): its own, or the empty one where it goes.
  Slot& Find(uint64_t a, uint64_t b) {
    const size_t mask = slots.size() - 1;
    for (size_t i = Hash(a, b) & mask;; i = (i + 1) & mask) {
      Slot& s = slots[i];
      if (s.index < 0 || (s.a == a && s.b == b)) return s;
    }
  }
  void Grow() {
    std::vector<Slot> old(slots.size() * 2, Slot{0, 0, -1});
    old.swap(slots);
    for (const Slot& s : old) {
      if (s.index >= 0) Find(s.a, s.b) = s;
    }
  }
};

SurfaceBuilder::SurfaceBuilder(double iso, uint64_t expected_points) : iso_(iso), points_(std::make_unique<Table>()) {
  size_t slots = points_->slots.size();
  while (slots < 2 * expected_points) slots *= 2;
  points_->slots.assign(slots, Table::Slot{0, 0, -1});
  xyz_.reserve(3 * expected_points);
  normal_sum_.reserve(3 * expected_points);
  at_vertex_.reserve(expected_points);
  triangles_.reserve(6 * expected_points);  // about two triangles a point
  error_.reserve(2 * expected_points);
}
SurfaceBuilder::~SurfaceBuilder() = default;

int64_t SurfaceBuilder::VertexPoint(const SurfaceVertex& a) {
  Table::Slot& s = points_->Find(a.id, a.id);
  if (s.index >= 0) return s.index;
  s = {a.id, a.id, static_cast<int64_t>(at_vertex_.size())};
  const int64_t index = s.index;
  xyz_.insert(xyz_.end(), a.p.begin(), a.p.end());
  normal_sum_.insert(normal_sum_.end(), 3, 0.0);
  at_vertex_.push_back(1);
  if (++points_->used * 2 > points_->slots.size()) points_->Grow();
  return index;
}

int64_t SurfaceBuilder::EdgePoint(const SurfaceVertex& inside, const SurfaceVertex& outside) {
  if (inside.f == iso_) return VertexPoint(inside);
  const bool inside_first = Before(inside.p, outside.p);
  const SurfaceVertex& a = inside_first ? inside : outside;
  const SurfaceVertex& b = inside_first ? outside : inside;
  Table::Slot& s = points_->Find(a.id, b.id);
  if (s.index >= 0) return s.index;
  s = {a.id, b.id, static_cast<int64_t>(at_vertex_.size())};
  const int64_t index = s.index;
  const double t = (iso_ - a.f) / (b.f - a.f);
  for (int k = 0; k < 3; ++k) xyz_.push_back(a.p[k] + t * (b.p[k] - a.p[k]));
  normal_sum_.insert(normal_sum_.end(), 3, 0.0);
  at_vertex_.push_back(0);
  if (++points_->used * 2 > points_->slots.size()) points_->Grow();
  return index;
}

void SurfaceBuilder::Triangle(std::array<int64_t, 3> t, const Vec& outside, const Vec& gradient, double error) {
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return;
  const auto at = [&](int64_t i) { return Vec{xyz_[3 * i], xyz_[3 * i + 1], xyz_[3 * i + 2]}; };
  const Vec p0 = at(t[0]);
  Vec n = Cross(Sub(at(t[1]), p0), Sub(at(t[2]), p0));
  if (n[0] == 0 && n[1] == 0 && n[2] == 0) return;
  // The normal points away from the outside (lower) vertex.
  if (Dot(n, Sub(outside, p0)) > 0) std::swap(t[1], t[2]);
  const uint64_t number = triangles_.size() / 3;
  if (at_vertex_[t[0]] && at_vertex_[t[1]] && at_vertex_[t[2]]) {
    std::array<int64_t, 3> sorted = t;
    std::sort(sorted.begin(), sorted.end());
    const auto [it, fresh] = vertex_triangles_.emplace(sorted, number);
    if (!fresh) {  // the second copy: a sheet
      dropped_.push_back(it->second);
      vertex_triangles_.erase(it);
      return;
    }
  }
  const double area = std::sqrt(Dot(n, n));
  for (const int64_t p : t) {
    for (int k = 0; k < 3; ++k) normal_sum_[3 * p + k] += gradient[k] * area;
  }
  triangles_.insert(triangles_.end(), t.begin(), t.end());
  error_.push_back(error);
}

void SurfaceBuilder::Add(const std::array<SurfaceVertex, 4>& v, double error) {
  std::array<int, 4> in{}, out{};
  int ni = 0, no = 0;
  for (int i = 0; i < 4; ++i) {
    if (v[i].f >= iso_) {
      in[ni++] = i;
    } else {
      out[no++] = i;
    }
  }
  if (ni == 0 || no == 0) return;
  const Vec g = Gradient(v);
  const Vec& low = v[out[0]].p;
  if (ni != 2) {
    const int lone = ni == 1 ? in[0] : out[0];
    std::array<int64_t, 3> t{};
    int k = 0;
    for (int j = 0; j < 4; ++j) {
      if (j != lone) t[k++] = ni == 1 ? EdgePoint(v[lone], v[j]) : EdgePoint(v[j], v[lone]);
    }
    Triangle(t, low, g, error);
    return;
  }
  // The quadrilateral's corners in order around it: each pair of
  // neighbours shares an end.
  const std::array<std::pair<int, int>, 4> corner = {
      {{in[0], out[0]}, {in[0], out[1]}, {in[1], out[1]}, {in[1], out[0]}}};
  std::array<int64_t, 4> q{};
  std::array<std::pair<Vec, Vec>, 4> edge;  // each corner's cut edge, its ends in (z, y, x) order
  for (int c = 0; c < 4; ++c) {
    const auto [i, j] = corner[c];
    q[c] = EdgePoint(v[i], v[j]);
    edge[c] = Before(v[i].p, v[j].p) ? std::pair{v[i].p, v[j].p} : std::pair{v[j].p, v[i].p};
  }
  int first = 0;
  for (int c = 1; c < 4; ++c) {
    const bool earlier = Before(edge[c].first, edge[first].first) ||
                         (edge[c].first == edge[first].first && Before(edge[c].second, edge[first].second));
    if (earlier) first = c;
  }
  const int d = first % 2;  // the diagonal through corners d and d + 2
  Triangle({q[d], q[d + 1], q[d + 2]}, low, g, error);
  Triangle({q[d], q[d + 2], q[(d + 3) % 4]}, low, g, error);
}

SurfaceData SurfaceBuilder::Finish() {
  SurfaceData out;
  std::sort(dropped_.begin(), dropped_.end());
  std::vector<int64_t> renumber(at_vertex_.size(), -1);
  size_t next_dropped = 0;
  const uint64_t triangles = error_.size();
  for (uint64_t t = 0; t < triangles; ++t) {
    if (next_dropped < dropped_.size() && dropped_[next_dropped] == t) {
      ++next_dropped;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const int64_t p = triangles_[3 * t + k];
      if (renumber[p] < 0) {
        renumber[p] = static_cast<int64_t>(out.points.size() / 3);
        const double* s = &normal_sum_[3 * p];
        const double length = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
        for (int a = 0; a < 3; ++a) {
          out.points.push_back(xyz_[3 * p + a]);
          out.normals.push_back(length > 0 ? static_cast<float>(s[a] / length) : 0.0f);
        }
      }
      out.triangles.push_back(renumber[p]);
    }
    out.error.push_back(error_[t]);
  }
  return out;
}

void PlaceSurface(SurfaceData& surface, const SourceInfo& info) {
  for (size_t p = 0; p < surface.points.size(); p += 3) {
    double n[3], length = 0;
    for (int a = 0; a < 3; ++a) {
      surface.points[p + a] = info.origin[a] + surface.points[p + a] * info.spacing[a];
      n[a] = surface.normals[p + a] / info.spacing[a];  // d/dx = (d/di) / spacing
      length += n[a] * n[a];
    }
    length = std::sqrt(length);
    for (int a = 0; a < 3; ++a) surface.normals[p + a] = length > 0 ? static_cast<float>(n[a] / length) : 0.0f;
  }
  const int flips = (info.spacing[0] < 0) + (info.spacing[1] < 0) + (info.spacing[2] < 0);
  if (flips % 2 == 1) {
    for (size_t t = 0; t + 2 < surface.triangles.size(); t += 3) std::swap(surface.triangles[t + 1], surface.triangles[t + 2]);
  }
}

}  // namespace simplexdb
