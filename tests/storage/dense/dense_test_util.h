// Helpers for the dense store's tests: building a store from a test volume,
// walking every internal node, and the errors a store must hold, by brute
// force (tests/storage/store_test_util.h), independent of the builder.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "hierarchy/cluster.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb::testing {

// Builds `volume` (written as dir/name.nrrd, with dir/name_mask.nrrd when
// `mask` is given) into dir/name.sdb and opens it; null after a failed
// expectation.
inline std::unique_ptr<DenseStore> BuildStore(const TestVolume& volume, const TempDir& dir,
                                              const std::string& name, DenseBuildOptions options = {},
                                              const TestVolume* mask = nullptr) {
  const std::string nrrd = dir / (name + ".nrrd");
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  if (mask != nullptr) {
    EXPECT_TRUE(mask->WriteNrrd(dir / (name + "_mask.nrrd")).ok());
    options.mask = *OpenVolume(dir / (name + "_mask.nrrd"));
  }
  const auto report = BuildDenseStore(*OpenVolume(nrrd), dir / (name + ".sdb"), options);
  EXPECT_TRUE(report.ok()) << report.status().message();
  if (!report.ok()) return nullptr;
  auto store = DenseStore::Open(dir / (name + ".sdb"));
  EXPECT_TRUE(store.ok()) << store.status().message();
  return store.ok() ? *std::move(store) : nullptr;
}

// The error a store records for node m, by brute force: the seed's error
// where every real point and vertex has a value, 0 where none of its points
// has one, `range` where only some have (storage/error/simplex_scan.h,
// ErrorGivenAvailability).
template <int D>
long double BruteForceNodeError(SimplexCode<D> m, int k, const TestVolume& volume, double range) {
  const auto [any_value, any_missing] = BruteForceAvailability<D>(m, k, volume);
  if (!any_value) return 0;
  if (any_missing) return range;
  return BruteForceError<D>(m, k, volume);
}

// Every node's stored bound is at least the largest brute-force error of its
// cluster (its diamond) and at most that plus the quantization's step: a
// quantum for u16/u8, float32 rounding for f32. The field range is the
// store's (the volume's, missing values skipped).
template <int D>
void ExpectDiamondErrors(const DenseStore& store, const TestVolume& volume) {
  const DenseHeader& h = store.header();
  const int k = h.domain_bits;
  const double range = h.field_max - h.field_min;
  const long double step = h.quantization == Quantization::kF32 ? 0 : h.quantum * (1 + 1e-9);
  DenseStore::Reader<D> reader(store);
  std::unordered_map<uint64_t, long double> brute;  // each node's error, once
  int nonzero = 0;
  ForEachInternalCode<D>(h.leaf_level(), [&](SimplexCode<D> c) {
    long double want = 0;
    for (const auto m : Cluster(c)) {
      auto it = brute.find(m.key());
      if (it == brute.end()) it = brute.emplace(m.key(), BruteForceNodeError<D>(m, k, volume, range)).first;
      want = std::max(want, it->second);
    }
    const Result<double> e = reader.ErrorBound(c);
    ASSERT_TRUE(e.ok()) << e.status().message();
    ASSERT_GE(static_cast<long double>(*e), want) << c.ToString();
    ASSERT_LE(static_cast<long double>(*e), want * (1 + 1e-6L) + step + 1e-9L) << c.ToString();
    nonzero += *e > 0;
  });
  EXPECT_GT(nonzero, 0);
}

// Every domain point's field: the volume's, clamped to the real grid (NaN
// where it is missing).
template <int D>
void ExpectFields(const DenseStore& store, const TestVolume& volume) {
  DenseStore::Reader<D> reader(store);
  const int64_t side = int64_t{1} << store.header().domain_bits;
  std::array<int64_t, D> p{};
  while (true) {
    const Result<double> f = reader.Field(p);
    ASSERT_TRUE(f.ok()) << f.status().message();
    const double want = volume.ClampedAt<D>(p);
    if (std::isnan(want)) {
      ASSERT_TRUE(std::isnan(*f)) << ::testing::PrintToString(p);
    } else {
      ASSERT_EQ(*f, want) << ::testing::PrintToString(p);
    }
    int c = 0;
    for (; c < D; ++c) {
      if (p[c] < side) {
        ++p[c];
        break;
      }
      p[c] = 0;
    }
    if (c == D) break;
  }
}

// Every answer a store gives (each node's bound and threshold answer, each
// real grid point's field); nullopt when some lookup fails.
template <int D>
std::optional<std::vector<double>> AllAnswers(const DenseStore& store) {
  DenseStore::Reader<D> reader(store);
  std::vector<double> out;
  bool failed = false;
  ForEachInternalCode<D>(store.header().leaf_level(), [&](SimplexCode<D> c) {
    if (failed) return;
    const Result<double> e = reader.ErrorBound(c);
    const Result<double> t = reader.ErrorBoundForThreshold(c, 3.0);
    if (!e.ok() || !t.ok()) {
      failed = true;
      return;
    }
    out.push_back(*e);
    out.push_back(*t);
  });
  // Every real grid point's field, x fastest.
  const DenseHeader& h = store.header();
  std::array<int64_t, D> p{};
  while (!failed) {
    const Result<double> f = reader.Field(p);
    if (!f.ok()) failed = true;
    else out.push_back(*f);
    int a = 0;
    for (; a < D; ++a) {
      if (++p[a] < int64_t{h.dims[a]}) break;
      p[a] = 0;
    }
    if (a == D) break;
  }
  if (failed) return std::nullopt;
  return out;
}

// Whether two answer lists are the same, NaN equal to NaN.
inline bool SameAnswers(const std::vector<double>& a, const std::vector<double>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](double x, double y) {
    return x == y || (std::isnan(x) && std::isnan(y));
  });
}

// Holes of missing values in `v`: NaN in balls of radius r around a few
// points (seeded), and at every `every`-th voxel. Float volumes only.
inline void PunchHoles(TestVolume& v, uint64_t seed, double r, size_t every) {
  std::mt19937_64 rng(seed);
  std::vector<std::array<double, 4>> centres(3);
  for (auto& c : centres) {
    for (int a = 0; a < 4; ++a) c[a] = static_cast<double>(rng() % v.dims[static_cast<size_t>(a)]);
  }
  std::array<int64_t, 4> p{};
  for (size_t i = 0; i < v.values.size(); ++i) {
    uint64_t rest = i;
    for (int a = 0; a < 4; ++a) {
      p[a] = static_cast<int64_t>(rest % v.dims[static_cast<size_t>(a)]);
      rest /= v.dims[static_cast<size_t>(a)];
    }
    bool hole = every > 0 && i % every == 0;
    for (const auto& c : centres) {
      double d2 = 0;
      for (int a = 0; a < v.dimension; ++a) d2 += (static_cast<double>(p[a]) - c[a]) * (static_cast<double>(p[a]) - c[a]);
      hole = hole || d2 <= r * r;
    }
    if (hole) v.values[i] = std::nan("");
  }
}

}  // namespace simplexdb::testing
