#include "storage/error/finest_box_errors.h"

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
  std::array<int64_t, D> g = first;
  for (uint64_t slot = 0;; ++slot) {
    out[slot] = ErrorAt(g, first, k, dims, window);
    int a = 0;
    for (; a < D; ++a) {
      if (++g[a] < first[a] + extent[a]) break;
      g[a] = first[a];
    }
    if (a == D) break;
  }
}

template class FinestBoxErrors<3>;
template class FinestBoxErrors<4>;

}  // namespace simplexdb
