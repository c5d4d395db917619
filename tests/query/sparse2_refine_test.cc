// Queries over the sparse store of format 2 (storage/sparse/sparse_store.h):
// lossless, the meshes of the dense store of format 2 under every
// criterion and algorithm; at a tolerance t, every leaf of a mesh at
// threshold e within max(e, t) of its brute-force error.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::SplitKeys;
using testing::TempDir;
using testing::TestVolume;

// Smooth with a bump of noise and a flat floor: a store keeps some diamonds
// and drops many, lossless too.
TestVolume Mixed(int dimension, std::array<uint32_t, 4> dims, uint64_t seed) {
  TestVolume v = TestVolume::Random(dimension, dims, VoxelType::kU8, seed);
  size_t i = 0;
  for (uint32_t t = 0; t < dims[3]; ++t) {
    for (uint32_t z = 0; z < dims[2]; ++z) {
      for (uint32_t y = 0; y < dims[1]; ++y) {
        for (uint32_t x = 0; x < dims[0]; ++x, ++i) {
          if (x + y < 6) continue;  // noise
          v.values[i] = z < 3 ? 40.0 : std::round(120 + 50 * std::sin(0.3 * x + 0.2 * y) * std::cos(0.25 * z + 0.4 * t));
        }
      }
    }
  }
  return v;
}

struct Stores {
  std::unique_ptr<DenseStore> dense;
  std::unique_ptr<SparseStore> sparse;
};

// The dense store as import makes it, the sparse one at `tolerance`.
Stores Build(const TestVolume& volume, const TempDir& dir, double tolerance) {
  DenseBuildOptions dense;
  dense.threads = 1;
  SparseBuildOptions o;
  o.tolerance = tolerance;
  o.block_bits = 9;
  return Stores{testing::BuildDense(volume, dir.path(), "dense", dense),
                testing::BuildSparse(volume, dir.path(), "sparse", o)};
}

template <int D>
std::vector<std::pair<std::string, CriteriaSpec>> Specs(int k, double fmin, double range) {
  std::vector<std::pair<std::string, CriteriaSpec>> out;
  for (double pct : {0.5, 3.0, 12.0}) {
    CriteriaSpec uniform;
    uniform.error = {pct, true};
    out.emplace_back("uniform " + std::to_string(pct) + "%", uniform);
  }
  const double s = std::ldexp(1.0, k);
  CriteriaSpec box;
  box.error = {1.0, true};
  box.box = std::vector<double>{s * 0.2, s * 0.3, s * 0.1, s * 0.55, s * 0.6, s * 0.45};
  out.emplace_back("box", box);
  CriteriaSpec iso;
  iso.error = {2.0, true};
  iso.iso = fmin + range / 3;
  out.emplace_back("iso", iso);
  if constexpr (D == 4) {
    CriteriaSpec time;
    time.error = {2.0, true};
    time.time = s * 0.375;
    out.emplace_back("time", time);
  }
  return out;
}

template <int D>
void ExpectLosslessMeshesAreDense(const TestVolume& volume) {
  TempDir dir;
  const Stores s = Build(volume, dir, 0);
  DenseSource<D> dense(*s.dense);
  SparseSource<D> sparse(*s.sparse);
  const SourceInfo& info = dense.info();
  ASSERT_EQ(sparse.info().field_range(), info.field_range());
  for (const auto& [name, spec] : Specs<D>(info.domain_bits, info.field_min, info.field_range())) {
    SCOPED_TRACE(name);
    const Criteria<D> c = *MakeCriteria<D>(spec, info.domain_bits, info.field_range());
    // (The HP's meshes, each a bitmap of millions of bits to compare, take
    // the depth-first walk only.)
    const std::vector<Algorithm> algorithms =
        D == 3 ? std::vector<Algorithm>{Algorithm::kDepthFirst, Algorithm::kPriority}
               : std::vector<Algorithm>{Algorithm::kDepthFirst};
    for (const Algorithm a : algorithms) {
      Mesh<D> want, got;
      QueryStats stats;
      ASSERT_TRUE((Refiner<D, DenseSource<D>>(dense, c).Run({a}, want, stats).ok()));
      ASSERT_TRUE((Refiner<D, SparseSource<D>>(sparse, c).Run({a}, got, stats).ok()));
      EXPECT_EQ(SplitKeys(got), SplitKeys(want));
      EXPECT_GT(want.split_count(), 0u);
    }
  }
}

TEST(Sparse2Refine, LosslessMeshesAreTheDenseStoresHt) {
  ExpectLosslessMeshesAreDense<3>(Mixed(3, {17, 14, 11, 1}, 1));
}
TEST(Sparse2Refine, LosslessMeshesAreTheDenseStoresHp) {
  ExpectLosslessMeshesAreDense<4>(Mixed(4, {9, 7, 8, 5}, 2));
}

// Every leaf of a uniform mesh within max(threshold, t) of its brute-force
// error (its vertices are kept: their values are the input's).
template <int D>
void ExpectLeavesWithinTolerance(const TestVolume& volume, double tolerance) {
  SCOPED_TRACE("tolerance " + std::to_string(tolerance));
  TempDir dir;
  const Stores s = Build(volume, dir, tolerance);
  SparseSource<D> sparse(*s.sparse);
  const SourceInfo& info = sparse.info();
  for (const double threshold : {tolerance / 2, tolerance, 2 * tolerance}) {
    CriteriaSpec spec;
    spec.error = {threshold, false};
    const Criteria<D> c = *MakeCriteria<D>(spec, info.domain_bits, info.field_range());
    Mesh<D> mesh;
    QueryStats stats;
    ASSERT_TRUE((Refiner<D, SparseSource<D>>(sparse, c).Run({Algorithm::kDepthFirst}, mesh, stats).ok()));
    const double bound = std::max(threshold, tolerance);
    for (const SimplexCode<D> leaf : mesh.Leaves()) {
      const long double exact = testing::BruteForceError<D>(leaf, info.domain_bits, volume);
      ASSERT_LE(static_cast<double>(exact), bound + 1e-9) << leaf.ToString() << " at threshold " << threshold;
    }
    EXPECT_GT(mesh.split_count(), 0u);
  }
}

TEST(Sparse2Refine, LeavesWithinToleranceHt) {
  ExpectLeavesWithinTolerance<3>(Mixed(3, {17, 14, 11, 1}, 3), 8);
  ExpectLeavesWithinTolerance<3>(TestVolume::Random(3, {9, 12, 10, 1}, VoxelType::kU8, 4), 50);
}
TEST(Sparse2Refine, LeavesWithinToleranceHp) {
  ExpectLeavesWithinTolerance<4>(Mixed(4, {9, 7, 8, 5}, 5), 10);
}

}  // namespace
}  // namespace simplexdb
