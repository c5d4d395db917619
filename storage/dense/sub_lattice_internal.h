// A sub-lattice of the field kept beside a window of planes (the dense
// builder, storage/dense/dense_windowed_build.cc): the real grid points
// whose every coordinate is a multiple of 2^shift (and, with `last`, the
// axis's last index), x fastest. The builder keeps two: the corner lattice
// (shift kLocalScales, with the last index: every corner of a coarse
// simplex, clamped to the real grid, is one, so coarse simplices whose
// corners lie outside the window can be scanned) and every 8th point (the
// coarse lattices' bricks, written after the last window). Not part of the
// installed headers.
//
// Thread safety: SetPlane for distinct planes may run concurrently.
// Cost: a T per point, about n / 2^(D shift).
#pragma once

#include <algorithm>
#include <array>
#include <cassert>
#include <cstdint>
#include <vector>

namespace simplexdb::dense_build {

template <int D, class T>
class SubLattice {
 public:
  static constexpr int L = D - 1;  // the axis the windows cut

  SubLattice() = default;
  // REQUIRES: dims[a] >= 1.
  SubLattice(const std::array<int64_t, D>& dims, int shift, bool last)
      : dims_(dims), step_(int64_t{1} << shift), last_(last) {
    uint64_t n = 1;
    for (int a = 0; a < D; ++a) {
      count_[a] = (dims[a] - 1) / step_ + 1 + (last && (dims[a] - 1) % step_ != 0 ? 1 : 0);
      stride_[a] = n;
      n *= static_cast<uint64_t>(count_[a]);
    }
    size_ = n;
  }

  uint64_t size() const { return size_; }
  void Allocate() { values_.assign(size_, T{}); }
  void Release() { std::vector<T>().swap(values_); }
  const T* data() const { return values_.data(); }
  T* mutable_data() { return values_.data(); }
  uint64_t stride(int a) const { return stride_[a]; }

  // The lattice's index of coordinate c on axis a, or -1 when c is not on it.
  int64_t Index(int a, int64_t c) const {
    if (c % step_ == 0) return c / step_;
    if (last_ && c == dims_[a] - 1) return count_[a] - 1;
    return -1;
  }
  bool HasPlane(int64_t z) const { return Index(L, z) >= 0; }

  // Records the lattice points of plane z (HasPlane(z)) from `plane`, the
  // real grid's values of that plane (x fastest, `stride` per axis).
  template <class P>
  void SetPlane(int64_t z, const P* plane, const std::array<int64_t, D>& stride) {
    std::array<int64_t, D> q{}, idx{};
    idx[L] = Index(L, z);
    assert(idx[L] >= 0);
    while (true) {
      uint64_t at = 0, from = 0;
      for (int a = 0; a < D; ++a) at += static_cast<uint64_t>(idx[a]) * stride_[a];
      for (int a = 0; a < L; ++a) from += static_cast<uint64_t>(q[a] * stride[a]);
      values_[at] = static_cast<T>(plane[from]);
      int a = 0;
      for (; a < L; ++a) {
        if (++idx[a] < count_[a]) {
          q[a] = std::min(idx[a] * step_, dims_[a] - 1);
          break;
        }
        idx[a] = 0;
        q[a] = 0;
      }
      if (a == L) break;
    }
  }

  // The value at lattice point c. REQUIRES: c on the lattice.
  T At(const std::array<int64_t, D>& c) const {
    uint64_t at = 0;
    for (int a = 0; a < D; ++a) {
      const int64_t i = Index(a, c[a]);
      assert(i >= 0);
      at += static_cast<uint64_t>(i) * stride_[a];
    }
    return values_[at];
  }

 private:
  std::array<int64_t, D> dims_{};
  int64_t step_ = 1;
  bool last_ = false;
  std::array<int64_t, D> count_{};
  std::array<uint64_t, D> stride_{};
  uint64_t size_ = 0;
  std::vector<T> values_;
};

}  // namespace simplexdb::dense_build
