#include "ops/read_grid.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_store.h"

namespace simplexdb {
namespace {

Status CheckBox(const ExportBox& box, int dimension, const std::array<uint32_t, 4>& dims,
                const std::string& path) {
  if (box.step < 1) {
    return Status::InvalidArgument(path + ": step " + std::to_string(box.step) +
                                   ": expected a whole number >= 1");
  }
  for (int c = 0; c < dimension; ++c) {
    if (box.lo[c] < 0 || box.hi[c] >= dims[c] || box.lo[c] > box.hi[c]) {
      return Status::InvalidArgument(path + ": axis " + std::to_string(c) + " range " +
                                     std::to_string(box.lo[c]) + ".." + std::to_string(box.hi[c]) +
                                     " is not within 0.." + std::to_string(dims[c] - 1));
    }
  }
  return Status::OK();
}

uint64_t Count(const std::array<uint32_t, 4>& dims) {
  uint64_t n = 1;
  for (const uint32_t d : dims) n *= d;
  return n;
}

// Calls field(p) for every point of the box, x fastest, into values.
template <int D, class Reader>
Status ReadPoints(Reader& reader, const ExportBox& box, const std::array<uint32_t, 4>& dims,
                  std::vector<double>& values) {
  std::array<int64_t, D> p{};
  for (uint64_t i = 0; i < values.size(); ++i) {
    uint64_t rest = i;
    for (int c = 0; c < D; ++c) {
      p[c] = box.lo[c] + static_cast<int64_t>(rest % dims[c]) * box.step;
      rest /= dims[c];
    }
    SDB_ASSIGN_OR_RETURN(values[i], reader.Field(p));
  }
  return Status::OK();
}

template <int D>
Result<std::vector<double>> ReadDense(const DenseStore& store, const ExportBox& box) {
  const DenseHeader& h = store.header();
  const std::array<uint32_t, 4> dims = ExportDims(box, D);
  std::vector<double> values(Count(dims));
  const int lattice = std::countr_zero(static_cast<uint64_t>(box.step));
  bool read = (box.step & (box.step - 1)) == 0 && lattice <= h.domain_bits;
  for (int c = 0; c < D; ++c) read = read && box.lo[c] % box.step == 0;
  if (read) {
    SDB_RETURN_IF_ERROR(ReadLattice(store, lattice, box.lo, box.hi, values.data()));
    return values;
  }
  DenseStore::Reader<D> reader(store);
  SDB_RETURN_IF_ERROR(ReadPoints<D>(reader, box, dims, values));
  return values;
}

template <int D>
Result<std::vector<double>> ReadSparse(const SparseStore& store, const ExportBox& box) {
  const std::array<uint32_t, 4> dims = ExportDims(box, D);
  std::vector<double> values(Count(dims));
  typename SparseStore::template Reader<D> reader(store);
  SDB_RETURN_IF_ERROR(ReadPoints<D>(reader, box, dims, values));
  return values;
}

}  // namespace

ExportBox WholeGrid(const SourceInfo& info, int step) {
  ExportBox box;
  for (int c = 0; c < info.dimension; ++c) box.hi[c] = info.dims[c] - 1;
  box.step = step;
  return box;
}

std::array<uint32_t, 4> ExportDims(const ExportBox& box, int dimension) {
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  for (int c = 0; c < dimension; ++c) {
    dims[c] = static_cast<uint32_t>((box.hi[c] - box.lo[c]) / box.step + 1);
  }
  return dims;
}

Result<std::vector<double>> ReadGridBox(const DenseStore& store, const ExportBox& box) {
  const DenseHeader& h = store.header();
  SDB_RETURN_IF_ERROR(CheckBox(box, h.dimension, h.dims, store.path()));
  return h.dimension == 3 ? ReadDense<3>(store, box) : ReadDense<4>(store, box);
}

VoxelType StoreVoxelType(const AnyStore& store) {
  return store.dense() != nullptr ? store.dense()->header().voxel_type : store.sparse()->header().voxel_type;
}

void RoundToVoxelType(VoxelType type, std::span<double> values) {
  if (IsFloatType(type)) return;
  WithVoxelCppType(type, [&](auto zero) {
    using T = decltype(zero);
    const double lo = static_cast<double>(std::numeric_limits<T>::lowest());
    const double hi = static_cast<double>(std::numeric_limits<T>::max());
    for (double& v : values) {
      if (!std::isnan(v)) v = std::clamp(std::round(v), lo, hi);
    }
  });
}

namespace {

Result<std::vector<double>> ReadGridBoxOf(const AnyStore& store, const ExportBox& box) {
  if (store.dense() != nullptr) return ReadGridBox(*store.dense(), box);
  const SourceInfo& info = store.info();
  SDB_RETURN_IF_ERROR(CheckBox(box, info.dimension, info.dims, info.path));
  SDB_ASSIGN_OR_RETURN(std::vector<double> values,
                       info.dimension == 3 ? ReadSparse<3>(*store.sparse(), box)
                                           : ReadSparse<4>(*store.sparse(), box));
  RoundToVoxelType(store.sparse()->header().voxel_type, values);
  return values;
}

}  // namespace

Result<std::vector<double>> ReadGridBox(const AnyStore& store, const ExportBox& box) {
  // Nothing read from a file changed under the store is an answer.
  SDB_RETURN_IF_ERROR(store.CheckUnchanged());
  Result<std::vector<double>> values = ReadGridBoxOf(store, box);
  SDB_RETURN_IF_ERROR(store.CheckUnchanged());
  return values;
}

}  // namespace simplexdb
