// Helpers for the query tests: the stores that ship (the dense store and
// the sparse LMDB store) built from small volumes, a source that refines
// everywhere, and a mesh's split nodes as keys. The independent truth they
// are checked against is tests/query/brute_force_errors.h.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "query/criteria.h"
#include "query/refine.h"
#include "query/source.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb::testing {

// The dense build the oracle tests use: float32 errors, so a stored bound
// is the exact error moved up by at most a float's rounding
// (BruteForceErrors::UpperBound), and small blocks, so that even a 9^3 grid
// has several.
inline DenseBuildOptions ExactDenseOptions(Compression compression = Compression::kZstd) {
  DenseBuildOptions o;
  o.quantization = Quantization::kF32;
  o.compression = compression;
  o.block_bits = 8;
  return o;
}

// The sparse build to compare with it: lossless, float32 errors (the
// dense store's quantizer), small blocks.
inline SparseBuildOptions ExactSparseOptions() {
  SparseBuildOptions o;
  o.quantization = Quantization::kF32;
  o.block_bits = 9;
  return o;
}

// Writes `volume` to dir/name.nrrd and returns the path.
inline std::string WriteInput(const TestVolume& volume, const std::string& dir, const std::string& name) {
  const std::string nrrd = dir + "/" + name + ".nrrd";
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  return nrrd;
}

// Builds `volume` (written as dir/name.nrrd) into dir/name + `extension`
// with build(input, path), and opens it with Store::Open(path, open); null
// after a failed expectation.
template <class Store, class Build>
std::unique_ptr<Store> BuildAndOpen(const TestVolume& volume, const std::string& dir, const std::string& name,
                                    const std::string& extension, Build&& build,
                                    const typename Store::Options& open) {
  const std::string path = dir + "/" + name + extension;
  const auto built = build(*OpenVolume(WriteInput(volume, dir, name)), path);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  auto store = Store::Open(path, open);
  EXPECT_TRUE(store.ok()) << store.status().ToString();
  return store.ok() ? std::move(store).value() : nullptr;
}

// The dense store of `volume` at dir/name.sdb, opened with `open`.
inline std::unique_ptr<DenseStore> BuildDense(const TestVolume& volume, const std::string& dir,
                                              const std::string& name,
                                              const DenseBuildOptions& options = ExactDenseOptions(),
                                              const DenseStore::Options& open = {}) {
  return BuildAndOpen<DenseStore>(
      volume, dir, name, ".sdb",
      [&](const VolumeInfo& input, const std::string& path) { return BuildDenseStore(input, path, options); }, open);
}

// The sparse store of `volume` at dir/name.lmdb, opened with `open`.
inline std::unique_ptr<SparseStore> BuildSparse(const TestVolume& volume, const std::string& dir,
                                                const std::string& name,
                                                const SparseBuildOptions& options = ExactSparseOptions(),
                                                const SparseStore::Options& open = {}) {
  return BuildAndOpen<SparseStore>(
      volume, dir, name, ".lmdb",
      [&](const VolumeInfo& input, const std::string& path) { return BuildSparseStore(input, path, options); }, open);
}

// Calls check(source) over the dense store of `volume` as import makes it
// (u16 errors) and over the lossless sparse store, both built in `dir`, each
// under a SCOPED_TRACE naming it.
template <int D, class Check>
void OverDenseAndSparse(const TestVolume& volume, const std::string& dir, const std::string& name, Check&& check) {
  const auto dense = BuildDense(volume, dir, name, DenseBuildOptions{});
  const auto sparse = BuildSparse(volume, dir, name, SparseBuildOptions{});
  ASSERT_TRUE(dense != nullptr && sparse != nullptr);
  DenseSource<D> d(*dense);
  SparseSource<D> s(*sparse);
  {
    SCOPED_TRACE("dense");
    check(d);
  }
  {
    SCOPED_TRACE("sparse");
    check(s);
  }
}

// The tests the oracle tests add to a uniform error criterion `uniform`,
// by name: a box (0.2-0.55, 0.3-0.6, 0.1-0.45 of the side 2^k), an iso
// value `iso`, and in the HP a time slice at 0.375 of the side.
template <int D>
std::vector<std::pair<std::string, CriteriaSpec>> OtherCriteria(const CriteriaSpec& uniform, int k, double iso) {
  std::vector<std::pair<std::string, CriteriaSpec>> out;
  const double side = std::ldexp(1.0, k);
  CriteriaSpec box = uniform;
  box.box = std::vector<double>{side * 0.2, side * 0.3, side * 0.1, side * 0.55, side * 0.6, side * 0.45};
  out.emplace_back("box", box);
  CriteriaSpec with_iso = uniform;
  with_iso.iso = iso;
  out.emplace_back("iso", with_iso);
  if constexpr (D == 4) {
    CriteriaSpec time = uniform;
    time.time = side * 0.375;
    out.emplace_back("time", time);
  }
  return out;
}

// A field with structure at every scale and flat regions: a ramp plus a
// few bumps, clamped.
inline TestVolume Structured(int dimension, uint32_t side) {
  std::array<uint32_t, 4> dims = {side, side, side, dimension == 4 ? side : 1};
  TestVolume v = TestVolume::Random(dimension, dims, VoxelType::kU8, 5);
  std::mt19937_64 rng(17);
  for (size_t i = 0; i < v.values.size(); ++i) {
    size_t r = i;
    double x[4] = {0, 0, 0, 0};
    for (int a = 0; a < dimension; ++a) {
      x[a] = static_cast<double>(r % dims[a]) / (side - 1);
      r /= dims[a];
    }
    const double d = (x[0] - 0.3) * (x[0] - 0.3) + (x[1] - 0.6) * (x[1] - 0.6) + (x[2] - 0.5) * (x[2] - 0.5);
    double f = d < 0.08 ? 200 * (0.08 - d) / 0.08 : 0;  // a cone: flat outside
    if (x[0] > 0.75) f += static_cast<double>(rng() % 40);  // noise in one slab
    v.values[i] = std::round(std::min(255.0, f + 20));
  }
  return v;
}

// A source over no store: every node above the leaf level of a domain of
// side 2^k has error 1, so any threshold below 1 refines to full resolution.
template <int D>
class FullSource {
 public:
  explicit FullSource(int k) {
    info_.dimension = D;
    info_.domain_bits = k;
    info_.field_max = 1;
    info_.path = "full";
  }
  const SourceInfo& info() const { return info_; }
  SourceStats stats() const { return stats_; }
  Result<double> Error(SimplexCode<D> c) {
    ++stats_.error_lookups;
    return c.level() < info_.leaf_level() ? 1.0 : 0.0;
  }
  Result<std::optional<double>> Field(const std::array<int64_t, D>&) { return std::optional<double>(0.0); }

 private:
  SourceInfo info_;
  SourceStats stats_;
};

template <int D>
std::vector<uint64_t> Keys(const std::vector<SimplexCode<D>>& codes) {
  std::vector<uint64_t> k;
  for (auto c : codes) k.push_back(c.key());
  return k;
}

// The split nodes' keys, sorted, walking down from the roots: O(split
// nodes), where SplitSet::ForEach reads its whole bitmap (48 MiB in the HT).
template <int D>
std::vector<uint64_t> SplitKeys(const Mesh<D>& mesh) {
  std::vector<uint64_t> s;
  std::vector<SimplexCode<D>> stack;
  for (int t = 0; t < SimplexCode<D>::kRoots; ++t) stack.push_back(SimplexCode<D>::Root(t));
  while (!stack.empty()) {
    const SimplexCode<D> c = stack.back();
    stack.pop_back();
    if (!mesh.is_split(c)) continue;
    s.push_back(c.key());
    stack.push_back(c.child(0));
    stack.push_back(c.child(1));
  }
  EXPECT_EQ(s.size(), mesh.split_count()) << "split nodes below a leaf";
  std::sort(s.begin(), s.end());
  return s;
}

// Runs `algorithm` over `source` from the roots (or from `mesh` as it is,
// for kIncremental) and returns the split nodes' keys, sorted.
template <int D, class Source>
std::vector<uint64_t> RunSplits(Source& source, const Criteria<D>& criteria, Algorithm algorithm,
                             Mesh<D>& mesh, QueryStats& stats) {
  Refiner<D, Source> refiner(source, criteria);
  const Status s = refiner.Run({algorithm}, mesh, stats);
  EXPECT_TRUE(s.ok()) << s.ToString();
  return SplitKeys(mesh);
}

}  // namespace simplexdb::testing
