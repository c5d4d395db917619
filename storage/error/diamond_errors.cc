#include "storage/error/diamond_errors.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <type_traits>

#include "storage/error/finest_box_errors.h"
#include "storage/error/quantize.h"
#include "storage/error/simplex_scan.h"

namespace simplexdb {
namespace {

template <int D>
std::array<int64_t, D> StridesOf(const std::array<int64_t, D>& dims) {
  std::array<int64_t, D> s{};
  int64_t n = 1;
  for (int a = 0; a < D; ++a) {
    s[a] = n;
    n *= dims[a];
  }
  return s;
}

// Whether the simplex's grid points in [lo, hi] have a value (not NaN) and
// whether any has none. Integer fields have no missing values.
template <int D, class V>
void ScanAvailability(const ScannableSimplex<D>& s, const IPoint<D>& lo, const IPoint<D>& hi,
                      const GridView<D, V>& view, bool& any_value, bool& any_missing) {
  s.ForEachRow(lo, hi, [&](const IPoint<D>& p, int64_t x_end) {
    if constexpr (!std::is_floating_point_v<V>) {
      any_value = true;
    } else {
      const V* row = view.Row(p);
      for (int64_t i = 0; i <= x_end - p[0]; ++i) {
        if (std::isnan(row[i])) {
          any_missing = true;
        } else {
          any_value = true;
        }
      }
    }
  });
}


}  // namespace

template <int D, class V>
template <size_t... S>
auto DiamondErrors<D, V>::MakeStencils(const std::array<int64_t, D>& strides,
                                       std::index_sequence<S...>)
    -> std::array<DiamondStencils<D>, kStencilScales> {
  return {DiamondStencils<D>(FinestDiamonds<D>::Get(), strides, static_cast<int>(S))...};
}

template <int D, class V>
DiamondErrors<D, V>::DiamondErrors(const V* field, const std::array<int64_t, D>& dims, int k,
                                   bool exact, double range, int threads, bool stencils,
                                   bool may_miss)
    : field_(field),
      dims_(dims),
      field_stride_(StridesOf<D>(dims)),
      k_(k),
      exact_(exact),
      range_(range),
      use_stencils_(stencils && !may_miss),
      may_miss_(may_miss),
      order_(k),
      stencils_(MakeStencils(field_stride_, std::make_index_sequence<kStencilScales>())),
      far_by_worker_(static_cast<size_t>(std::max(1, threads))) {
  for (int sb = kStencilScales; sb < std::min(k, kRowStencilScales); ++sb) {
    row_stencils_.emplace_back(FinestDiamonds<D>::Get(), field_stride_, sb);
  }
  size_ = 1;
  for (int a = 0; a < D; ++a) {
    assert(dims[a] >= 1 && dims[a] <= (int64_t{1} << k) + 1);
    extent_[a] = std::min<int64_t>(int64_t{1} << k, dims[a] + 1) + 1;
    stride_[a] = size_;
    size_ *= static_cast<uint64_t>((extent_[a] + 1) / 2);
  }
  // Work items: per octave but the finest (scale s, coarse first: they are
  // the heavy ones), one slab of vertices per value of the last coordinate,
  // for the vertices whose diamond, [g - 2^(s+1), g + 2^(s+1)], can meet
  // the grid.
  for (int s = k - 1; s >= 1; --s) {
    const int64_t h = int64_t{1} << s;
    for (int64_t j = 0; j * h <= (int64_t{1} << k) && j * h - 2 * h <= dims[D - 1] - 1; ++j) {
      items_.push_back({s, j});
    }
  }
}

template <int D, class V>
uint64_t DiamondErrors<D, V>::TableBytes(const std::array<int64_t, D>& dims, int k) {
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) {
    n *= static_cast<uint64_t>((std::min<int64_t>(int64_t{1} << k, dims[a] + 1) + 2) / 2);
  }
  return n * sizeof(float);
}

template <int D, class V>
void DiamondErrors<D, V>::Allocate() {
  table_ = BigArray<float>(size_);  // zeros, touched first by the workers
}

template <int D, class V>
bool DiamondErrors<D, V>::Interior(const std::array<int64_t, D>& g, int s) const {
  // Every simplex of the diamond inside the domain lies in the real grid:
  // the diamond, [g - 2h, g + 2h], ends before the real grid's last point or
  // the real grid reaches the domain's face (dims = 2^k + 1) there; at 0
  // the real grid and the domain start together.
  const int64_t reach = int64_t{2} << s, side = int64_t{1} << k_;
  for (int a = 0; a < D; ++a) {
    if (g[a] + reach > dims_[a] - 1 && dims_[a] - 1 != side) return false;
  }
  return true;
}

template <int D, class V>
double DiamondErrors<D, V>::FieldAt(const std::array<int64_t, D>& p) const {
  int64_t i = -window_offset_;
  for (int a = 0; a < D; ++a) i += p[a] * field_stride_[a];
  return field_[i];
}

template <int D, class V>
void DiamondErrors<D, V>::SetWindow(const V* planes, int64_t first_plane) {
  field_ = planes;
  window_offset_ = first_plane * field_stride_[D - 1];
}

template <int D, class V>
template <class T, class Corner>
double DiamondErrors<D, V>::CoarseScan(const std::array<int64_t, D>& g, int s, int64_t last_lo,
                                       int64_t last_hi, const Corner& corner,
                                       DiamondAvailability& availability) const {
  uint32_t odd = 0, parity = 0;
  for (int a = 0; a < D; ++a) {
    odd |= static_cast<uint32_t>((g[a] >> s) & 1) << a;
    parity |= static_cast<uint32_t>((g[a] >> (s + 1)) & 1) << a;
  }
  const int64_t h = int64_t{1} << s, side = int64_t{1} << k_;
  IPoint<D> window_lo{};
  window_lo[D - 1] = window_offset_ / field_stride_[D - 1];
  const GridView<D, V> view{field_, window_lo, field_stride_};
  double worst = 0;
  const auto& simplices = FinestDiamonds<D>::Get().Of(odd, parity).simplices;
  static_assert(sizeof(availability.value) * 8 >= 48, "a bit per simplex of the largest diamond");
  for (size_t ti = 0; ti < simplices.size(); ++ti) {
    const auto& t = simplices[ti];
    std::array<IPoint<D>, D + 1> v{};
    bool inside = true;
    for (int i = 0; i <= D; ++i) {
      for (int a = 0; a < D; ++a) {
        v[i][a] = g[a] + t.vertex[i][a] * h;
        inside = inside && v[i][a] >= 0 && v[i][a] <= side;
      }
    }
    if (!inside) continue;
    const ScannableSimplex<D> scan(v);
    IPoint<D> lo{}, hi{};
    bool empty = false;
    for (int a = 0; a < D; ++a) {
      lo[a] = std::max<int64_t>(scan.box_lo()[a], 0);
      hi[a] = std::min<int64_t>(scan.box_hi()[a], dims_[a] - 1);
    }
    lo[D - 1] = std::max(lo[D - 1], last_lo);
    hi[D - 1] = std::min(hi[D - 1], last_hi);
    for (int a = 0; a < D; ++a) empty = empty || lo[a] > hi[a];
    if (empty) continue;
    std::array<T, D + 1> f{};
    for (int i = 0; i <= D; ++i) {
      std::array<int64_t, D> c{};
      for (int a = 0; a < D; ++a) c[a] = std::min(v[i][a], dims_[a] - 1);
      f[i] = static_cast<T>(corner(c));
    }
    if (may_miss_) {
      bool any_value = false, any_missing = false;
      for (int i = 0; i <= D; ++i) any_missing = any_missing || std::isnan(static_cast<double>(f[i]));
      ScanAvailability<D, V>(scan, lo, hi, view, any_value, any_missing);
      const uint64_t bit = uint64_t{1} << ti;
      if (any_value) availability.value |= bit;
      if (any_missing) availability.missing |= bit;
      // Only a part with values everywhere has an error to scan; the others
      // record the range or nothing once the parts are merged.
      if (any_missing || !any_value) continue;
    }
    worst = std::max(worst, MaxError<D, T, V>(scan, f, range_, lo, hi, view).error);
  }
  return worst;
}

template <int D, class V>
double DiamondErrors<D, V>::Coarse(const std::array<int64_t, D>& g, int s) const {
  const auto corner = [this](const std::array<int64_t, D>& c) { return FieldAt(c); };
  const int64_t all = std::numeric_limits<int64_t>::max();
  DiamondAvailability availability;
  const double e = exact_ ? CoarseScan<int64_t>(g, s, -all, all, corner, availability)
                          : CoarseScan<double>(g, s, -all, all, corner, availability);
  return MergedError(e, availability);
}

template <int D, class V>
void DiamondErrors<D, V>::ComputeRowInto(int scale, int64_t j, const RowSink& sink) const {
  ComputeRow(scale, j, [&sink](const std::array<int64_t, D>& g, double e) { sink(g, e); });
}

template <int D, class V>
double DiamondErrors<D, V>::CoarsePart(const std::array<int64_t, D>& g, int s, int64_t last_lo,
                                       int64_t last_hi, const CornerValues& corner,
                                       DiamondAvailability& availability) const {
  const auto at = [&corner](const std::array<int64_t, D>& c) { return corner(c); };
  return exact_ ? CoarseScan<int64_t>(g, s, last_lo, last_hi, at, availability)
                : CoarseScan<double>(g, s, last_lo, last_hi, at, availability);
}

template <int D, class V>
void DiamondErrors<D, V>::ComputeItem(int worker, uint64_t item) {
  const Item it = items_[item];
  ComputeRow(it.s, it.j, [&](const std::array<int64_t, D>& g, double e) {
    if (float* slot = Slot(g)) {
      *slot = RoundUpToFloat(e);
    } else {
      far_by_worker_[static_cast<size_t>(worker)].emplace_back(
          order_.PositionAtLevel(g, order_.Level(g)), RoundUpToFloat(e));
    }
  });
}

template <int D, class V>
template <class F>
void DiamondErrors<D, V>::ForEachRowVertex(int s, int64_t j, F&& f) const {
  const int64_t h = int64_t{1} << s, side = int64_t{1} << k_;
  // Vertices of the row: multiples of h on every axis, odd ones on some,
  // up to the domain and to where a diamond still reaches the real grid.
  std::array<int64_t, D> last{};
  for (int a = 0; a < D - 1; ++a) last[a] = std::min(side, dims_[a] - 1 + 2 * h) / h * h;
  std::array<int64_t, D> g{};
  g[D - 1] = j * h;
  while (true) {
    bool odd = false;
    for (int a = 0; a < D; ++a) odd = odd || ((g[a] >> s) & 1) != 0;
    if (odd) f(g);
    int a = 0;
    for (; a < D - 1; ++a) {
      if (g[a] < last[a]) {
        g[a] += h;
        break;
      }
      g[a] = 0;
    }
    if (a == D - 1) break;
  }
}

template <int D, class V>
double DiamondErrors<D, V>::RowVertexError(const std::array<int64_t, D>& g, int s) const {
  if (!(use_stencils_ && s < kRowStencilScales && Interior(g, s))) return Coarse(g, s);
  const int64_t side = int64_t{1} << k_, reach = int64_t{2} << s;
  uint32_t pattern = 0, parity = 0;
  int64_t index = -window_offset_;
  for (int a = 0; a < D; ++a) {
    pattern |= static_cast<uint32_t>((g[a] >> s) & 1) << a;
    parity |= static_cast<uint32_t>((g[a] >> (s + 1)) & 1) << a;
    index += g[a] * field_stride_[a];
  }
  bool clip = false;
  for (int a = 0; a < D; ++a) clip = clip || g[a] < reach || g[a] + reach > side;
  const V* center = field_ + index;
  if (s < kStencilScales) {
    const auto& st = stencils_[static_cast<size_t>(s)];
    return clip ? st.ClippedError(center, pattern, parity, g, side) : st.InteriorError(center, pattern, parity);
  }
  const auto& st = row_stencils_[static_cast<size_t>(s - kStencilScales)];
  return clip ? st.ClippedError(center, pattern, parity, g, side) : st.InteriorError(center, pattern, parity);
}

template <int D, class V>
template <class Sink>
void DiamondErrors<D, V>::ComputeRow(int scale, int64_t j, Sink&& sink) const {
  ForEachRowVertex(scale, j, [&](const std::array<int64_t, D>& g) {
    const double e = RowVertexError(g, scale);
    if (e > 0) sink(g, e);
  });
}

template <int D, class V>
void DiamondErrors<D, V>::ComputeRowPartInto(int scale, int64_t j, int64_t last_lo, int64_t last_hi,
                                             const CornerValues& corner, const PartSink& sink) const {
  ForEachRowVertex(scale, j, [&](const std::array<int64_t, D>& g) {
    DiamondAvailability availability;
    const double e = CoarsePart(g, scale, last_lo, last_hi, corner, availability);
    if (e > 0 || availability.any()) sink(g, e, availability);
  });
}

template <int D, class V>
void DiamondErrors<D, V>::Finish() {
  for (auto& list : far_by_worker_) {
    for (const auto& [position, e] : list) far_[position] = e;
    list.clear();
    list.shrink_to_fit();
  }
}

template <int D, class V>
float* DiamondErrors<D, V>::Slot(const std::array<int64_t, D>& g) {
  uint64_t i = 0;
  for (int a = 0; a < D; ++a) {
    if (g[a] >= extent_[a]) return nullptr;
    i += static_cast<uint64_t>(g[a] >> 1) * stride_[a];
  }
  return &table_[i];
}

template <int D, class V>
double DiamondErrors<D, V>::At(const std::array<int64_t, D>& g, uint64_t position) const {
  bool finest = false;
  for (int a = 0; a < D; ++a) finest = finest || (g[a] & 1) != 0;
  if (finest) return Finest(g);
  uint64_t i = 0;
  for (int a = 0; a < D; ++a) {
    if (g[a] >= extent_[a]) {
      const auto it = far_.find(position);
      return it == far_.end() ? 0.0 : it->second;
    }
    i += static_cast<uint64_t>(g[a] >> 1) * stride_[a];
  }
  return table_[i];
}

template <int D, class V>
double DiamondErrors<D, V>::Finest(const std::array<int64_t, D>& g) const {
  for (int a = 0; a < D; ++a) {
    if (g[a] - 2 > dims_[a] - 1) return 0;  // the diamond, [g - 2, g + 2], has no real point
  }
  if (!use_stencils_) return Coarse(g, 0);
  // The reader computes these the same way (storage/error/finest_box_errors.h).
  bool real = true;
  int64_t index = -window_offset_;
  for (int a = 0; a < D; ++a) {
    real = real && g[a] < dims_[a];
    index += g[a] * field_stride_[a];
  }
  return FinestDiamondError<D>(stencils_[0], real ? field_ + index : nullptr, g, k_, dims_,
                               [&](const std::array<int64_t, D>& p) { return FieldAt(p); });
}

template <int D, class V>
double DiamondErrors<D, V>::FinestBoxMax(const std::array<int64_t, D>& first,
                                         const std::array<int64_t, D>& extent) const {
  const int64_t side = int64_t{1} << k_;
  std::array<int64_t, D> last{};
  for (int a = 0; a < D; ++a) last[a] = std::min(first[a] + extent[a] - 1, side);
  double m = 0;
  std::array<int64_t, D> g = first;
  for (int a = 0; a < D; ++a) {
    if (first[a] > last[a]) return 0;
  }
  while (true) {
    bool finest = false;
    for (int a = 1; a < D; ++a) finest = finest || (g[a] & 1) != 0;
    // Along x: every point when another coordinate is odd, else the odd x.
    for (int64_t x = finest ? first[0] : (first[0] | 1); x <= last[0]; x += finest ? 1 : 2) {
      g[0] = x;
      m = std::max(m, Finest(g));
    }
    int a = 1;
    for (; a < D; ++a) {
      if (++g[a] <= last[a]) break;
      g[a] = first[a];
    }
    if (a == D) break;
  }
  return m;
}

#define SDB_DIAMOND_ERRORS_(V)       \
  template class DiamondErrors<3, V>; \
  template class DiamondErrors<4, V>;
SDB_FOR_EACH_VOXEL_CPP_TYPE(SDB_DIAMOND_ERRORS_)
#undef SDB_DIAMOND_ERRORS_

}  // namespace simplexdb
