#include "storage/error/finest_box_errors.h"

#include <cassert>

namespace simplexdb {
namespace {

template <int D>
std::array<int64_t, D> WindowStrides(int64_t side) {
  std::array<int64_t, D> s{};
  int64_t n = 1;
  for (int a = 0; a < D; ++a) {
    s[a] = n;
    n *= side;
  }
  return s;
}

}  // namespace

template <int D>
FinestBoxErrors<D>::FinestBoxErrors(int64_t box_side)
    : window_side_(box_side + 4),
      strides_(WindowStrides<D>(box_side + 4)),
      stencils_(FinestDiamonds<D>::Get(), strides_, 0) {}

template <int D>
uint64_t FinestBoxErrors<D>::window_points() const {
  uint64_t n = 1;
  for (int a = 0; a < D; ++a) n *= static_cast<uint64_t>(window_side_);
  return n;
}

template <int D>
void FinestBoxErrors<D>::Compute(const std::array<int64_t, D>& first,
                                 const std::array<int64_t, D>& extent, int k,
                                 const std::array<int64_t, D>& dims, const double* window,
                                 double* out) const {
  const int64_t side = int64_t{1} << k;
  // Window index of grid point p.
  const auto index = [&](const std::array<int64_t, D>& p) {
    int64_t i = 0;
    for (int a = 0; a < D; ++a) {
      assert(p[a] - first[a] + 2 >= 0 && p[a] - first[a] + 2 < window_side_);
      i += (p[a] - first[a] + 2) * strides_[a];
    }
    return i;
  };
  const auto field = [&](const std::array<int64_t, D>& p) { return window[index(p)]; };
  std::array<int64_t, D> local{};
  for (uint64_t slot = 0;; ++slot) {
    std::array<int64_t, D> g{};
    bool finest = false, inside = true;
    for (int a = 0; a < D; ++a) {
      g[a] = first[a] + local[a];
      finest = finest || (g[a] & 1) != 0;
      inside = inside && g[a] <= side;
    }
    out[slot] = finest && inside ? FinestDiamondError<D>(stencils_, window + index(g), g, k, dims, field)
                                 : 0.0;
    int a = 0;
    for (; a < D; ++a) {
      if (++local[a] < extent[a]) break;
      local[a] = 0;
    }
    if (a == D) break;
  }
}

template class FinestBoxErrors<3>;
template class FinestBoxErrors<4>;

}  // namespace simplexdb
