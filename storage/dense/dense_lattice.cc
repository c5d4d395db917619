#include "storage/dense/dense_store.h"

#include <algorithm>
#include <string>

namespace simplexdb {

Status ReadLattice(const DenseStore& store, int s, const std::array<int64_t, 4>& lo,
                   const std::array<int64_t, 4>& hi, double* out) {
  const DenseHeader& h = store.header();
  const int D = h.dimension;
  if (s < 0 || s > h.domain_bits) {
    return Status::InvalidArgument(store.path() + ": no lattice " + std::to_string(s));
  }
  const int64_t step = int64_t{1} << s;
  // The box in lattice coordinates, and the bricks it meets.
  std::array<int64_t, 4> qlo{}, qhi{}, n{1, 1, 1, 1}, blo{}, bhi{};
  for (int a = 0; a < D; ++a) {
    if (lo[a] < 0 || lo[a] > hi[a] || hi[a] >= int64_t{h.dims[a]} || lo[a] % step != 0) {
      return Status::InvalidArgument(store.path() + ": axis " + std::to_string(a) + " range " +
                                     std::to_string(lo[a]) + ".." + std::to_string(hi[a]) +
                                     " is not a box of lattice " + std::to_string(s));
    }
    qlo[a] = lo[a] >> s;
    qhi[a] = hi[a] >> s;
    n[a] = qhi[a] - qlo[a] + 1;
    blo[a] = qlo[a] >> h.brick_bits;
    bhi[a] = qhi[a] >> h.brick_bits;
  }
  std::array<int64_t, 4> c = blo;
  while (true) {
    std::array<int64_t, 4> p{};
    for (int a = 0; a < D; ++a) p[a] = (c[a] << h.brick_bits) << s;
    size_t unused = 0;
    const uint64_t b = store.grid().BrickOf(s, p, &unused);
    SDB_ASSIGN_OR_RETURN(const DenseStore::BlockHandle brick, store.Brick(b));
    const BrickPlace place = store.grid().Place(b);
    // The brick's part of the box, in lattice coordinates, row by row.
    std::array<int64_t, 4> first{}, from{}, to{};
    for (int a = 0; a < D; ++a) {
      first[a] = place.first[a] >> s;
      from[a] = std::max(qlo[a], first[a]);
      to[a] = std::min(qhi[a], first[a] + int64_t{place.extent[a]} - 1);
    }
    std::array<int64_t, 4> q = from;
    while (true) {
      size_t slot = 0, at = 0, scale = 1, out_scale = 1;
      for (int a = 0; a < D; ++a) {
        slot += static_cast<size_t>(q[a] - first[a]) * scale;
        scale *= place.extent[a];
        at += static_cast<size_t>(q[a] - qlo[a]) * out_scale;
        out_scale *= static_cast<size_t>(n[a]);
      }
      for (int64_t x = from[0]; x <= to[0]; ++x) out[at++] = store.VoxelAt(brick.data, slot++);
      int a = 1;
      for (; a < D; ++a) {
        if (++q[a] <= to[a]) break;
        q[a] = from[a];
      }
      if (a >= D) break;
    }
    int a = 0;
    for (; a < D; ++a) {
      if (++c[a] <= bhi[a]) break;
      c[a] = blo[a];
    }
    if (a == D) break;
  }
  return Status::OK();
}

}  // namespace simplexdb
