// The exact point enumeration and error kernel of storage/error/simplex_scan.h
// against brute force: every point of the bounding box tested with signed
// volumes (an independent predicate), errors from barycentric weights in
// exact rational arithmetic.
#include "storage/error/simplex_scan.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "tests/util/brute_force_simplex.h"

namespace simplexdb {
namespace {

using testing::BoundingBox;
using testing::Det;
using testing::ForEachBoxPoint;
using testing::GridVertices;
using testing::InsideBrute;

template <int D>
using Verts = testing::GridSimplex<D>;

// Random simplices from the hierarchy, scaled onto a grid of side 2^k.
template <int D>
Verts<D> RandomHierarchySimplex(std::mt19937_64& rng, int k) {
  const int level = static_cast<int>(rng() % (D * k));
  const auto code = SimplexCode<D>::FromPath(static_cast<int>(rng() % SimplexCode<D>::kRoots),
                                             level ? rng() >> (64 - level) : 0, level);
  return GridVertices<D>(code, k);
}

// A * adj(A) = det(A) * I, with det(A) by cofactor expansion, for random
// matrices with entries as large as edge vectors get.
template <int D>
void CheckAdjugate(uint64_t seed, int trials) {
  std::mt19937_64 rng(seed);
  const int64_t span = 2 * kMaxScanCoordinate<D> + 1;
  for (int t = 0; t < trials; ++t) {
    std::array<std::array<int64_t, D>, D> a{};
    for (auto& row : a) {
      for (auto& x : row) {
        // Mostly small entries (hierarchy edges are axis steps), some at
        // the extremes.
        x = (t % 3 == 0) ? static_cast<int64_t>(rng() % span) - kMaxScanCoordinate<D>
                         : static_cast<int64_t>(rng() % 5) - 2;
      }
    }
    std::array<std::array<int64_t, D>, D> adj{};
    const int64_t det = internal::Adjugate<D>(a, &adj);
    ASSERT_EQ(Int128{det}, Det<D>(a)) << "trial " << t;
    for (int r = 0; r < D; ++r) {
      for (int j = 0; j < D; ++j) {
        Int128 s = 0;
        for (int c = 0; c < D; ++c) s += Int128{a[r][c]} * adj[c][j];
        ASSERT_EQ(s, r == j ? Int128{det} : Int128{0}) << "trial " << t << " entry " << r << "," << j;
      }
    }
  }
}

TEST(SimplexScan, AdjugateTimesMatrixIsDeterminant3D) { CheckAdjugate<3>(11, 30000); }
TEST(SimplexScan, AdjugateTimesMatrixIsDeterminant4D) { CheckAdjugate<4>(12, 30000); }

template <int D>
void CheckEnumeration(uint64_t seed, int k, int trials) {
  std::mt19937_64 rng(seed);
  for (int t = 0; t < trials; ++t) {
    const Verts<D> v = RandomHierarchySimplex<D>(rng, k);
    const ScannableSimplex<D> s(v);
    // A clipping box, sometimes smaller than the simplex.
    IPoint<D> lo, hi;
    for (int c = 0; c < D; ++c) {
      lo[c] = static_cast<int64_t>(rng() % 3);
      hi[c] = (int64_t{1} << k) - static_cast<int64_t>(rng() % 3);
    }
    std::set<IPoint<D>> got;
    s.ForEachRow(lo, hi, [&](IPoint<D> p, int64_t x_end) {
      for (int64_t x = p[0]; x <= x_end; ++x) {
        p[0] = x;
        ASSERT_TRUE(got.insert(p).second) << "a point visited twice";
      }
    });
    std::set<IPoint<D>> expected;
    ForEachBoxPoint<D>(s.box_lo(), s.box_hi(), [&](const IPoint<D>& p) {
      bool in_box = true;
      for (int c = 0; c < D; ++c) in_box = in_box && p[c] >= lo[c] && p[c] <= hi[c];
      if (in_box && InsideBrute<D>(v, p)) expected.insert(p);
      ASSERT_EQ(s.Contains(p), InsideBrute<D>(v, p));
    });
    ASSERT_EQ(got, expected) << "trial " << t;
  }
}

TEST(SimplexScan, RowsVisitExactlyThePointsInside3D) { CheckEnumeration<3>(1, 4, 300); }
TEST(SimplexScan, RowsVisitExactlyThePointsInside4D) { CheckEnumeration<4>(2, 3, 200); }

// The same at the largest coordinates the scan is proven for (where the
// rows' y intervals need 128-bit products), in a small box around a point
// near a random vertex: the box cuts the simplex's faces and edges there.
template <int D>
void CheckEnumerationAtScale(uint64_t seed, int trials) {
  std::mt19937_64 rng(seed);
  int k = 0;
  while ((int64_t{1} << (k + 1)) <= kMaxScanCoordinate<D>) ++k;
  int nonempty = 0;
  for (int t = 0; t < trials; ++t) {
    const Verts<D> v = RandomHierarchySimplex<D>(rng, k);
    const ScannableSimplex<D> s(v);
    const IPoint<D>& corner = v[rng() % (D + 1)];
    IPoint<D> lo, hi;
    for (int c = 0; c < D; ++c) {
      lo[c] = std::max<int64_t>(0, corner[c] - 3 + static_cast<int64_t>(rng() % 3));
      hi[c] = std::min<int64_t>(kMaxScanCoordinate<D>, lo[c] + 4);
    }
    std::set<IPoint<D>> got, expected;
    s.ForEachRow(lo, hi, [&](IPoint<D> p, int64_t x_end) {
      for (int64_t x = p[0]; x <= x_end; ++x) {
        p[0] = x;
        got.insert(p);
      }
    });
    ForEachBoxPoint<D>(lo, hi, [&](const IPoint<D>& p) {
      if (InsideBrute<D>(v, p)) expected.insert(p);
    });
    ASSERT_EQ(got, expected) << "trial " << t;
    nonempty += expected.empty() ? 0 : 1;
  }
  EXPECT_GT(nonempty, trials / 2);
}

TEST(SimplexScan, RowsVisitExactlyThePointsInsideAtScale3D) { CheckEnumerationAtScale<3>(5, 2000); }
TEST(SimplexScan, RowsVisitExactlyThePointsInsideAtScale4D) { CheckEnumerationAtScale<4>(6, 2000); }

// Exact error by barycentric weights: |f(p) - sum w_i f(v_i)|, w_i = vol_i /
// vol, as a long double from exact integers (one division).
template <int D>
long double ErrorBrute(const Verts<D>& v, const std::array<int64_t, D + 1>& fv,
                       const std::function<int64_t(const IPoint<D>&)>& field) {
  std::array<Int128, D + 1> f{};
  for (int i = 0; i <= D; ++i) f[i] = fv[i];
  const auto [lo, hi] = BoundingBox<D>(v);
  return testing::MaxInterpolationError<D>(v, f, lo, hi, field).Value();
}

// Field values on the box [0, 2^k]^D, as the kernel reads them.
template <int D>
struct Buffer {
  std::vector<double> values;
  GridView<D> view;
  template <class Fn>
  Buffer(int k, Fn&& field) {
    const int64_t n = (int64_t{1} << k) + 1;
    int64_t total = 1;
    for (int c = 0; c < D; ++c) {
      view.stride[c] = total;
      total *= n;
    }
    values.resize(static_cast<size_t>(total));
    for (int64_t i = 0; i < total; ++i) {
      IPoint<D> p{};
      int64_t rest = i;
      for (int c = 0; c < D; ++c) {
        p[c] = rest % n;
        rest /= n;
      }
      values[static_cast<size_t>(i)] = static_cast<double>(field(p));
    }
    view.data = values.data();
  }
};

template <int D>
void CheckErrors(uint64_t seed, int k, int trials) {
  std::mt19937_64 rng(seed);
  for (int t = 0; t < trials; ++t) {
    const Verts<D> v = RandomHierarchySimplex<D>(rng, k);
    const ScannableSimplex<D> s(v);
    const uint64_t salt = rng();
    const auto field = [salt](const IPoint<D>& p) -> int64_t {
      uint64_t h = salt;
      for (int c = 0; c < D; ++c) h = (h ^ static_cast<uint64_t>(p[c])) * 0x9E3779B97F4A7C15ULL;
      return static_cast<int64_t>(h >> 48) - 30000;  // int16-like values
    };
    const Buffer<D> buffer(k, field);
    std::array<int64_t, D + 1> fv{};
    std::array<double, D + 1> fd{};
    for (int i = 0; i <= D; ++i) {
      fv[i] = field(v[i]);
      fd[i] = static_cast<double>(fv[i]);
    }
    IPoint<D> lo{}, hi{};
    for (int c = 0; c < D; ++c) hi[c] = int64_t{1} << k;
    const long double brute = ErrorBrute<D>(v, fv, field);
    // 65536: the values' range; the 64-bit path. 1e30: forces 128 bits.
    const ScanResult exact = MaxError<D, int64_t>(s, fv, 65536, lo, hi, buffer.view);
    const ScanResult wide = MaxError<D, int64_t>(s, fv, 1e30, lo, hi, buffer.view);
    const ScanResult approx = MaxError<D, double>(s, fd, 65536, lo, hi, buffer.view);
    ASSERT_TRUE(exact.any_point);
    // Exact up to the final rounding of one division.
    ASSERT_NEAR(static_cast<double>(brute), exact.error, 1e-12 * (1 + brute)) << t;
    ASSERT_EQ(exact.error, wide.error) << t;
    ASSERT_NEAR(static_cast<double>(brute), approx.error, 1e-9 * 65536) << t;
  }
}

TEST(SimplexScan, ErrorsEqualBarycentricBruteForce3D) { CheckErrors<3>(3, 4, 300); }
TEST(SimplexScan, ErrorsEqualBarycentricBruteForce4D) { CheckErrors<4>(4, 3, 200); }

// A linear field has error exactly zero on every simplex.
TEST(SimplexScan, LinearFieldsHaveZeroError) {
  std::mt19937_64 rng(5);
  const auto field = [](const IPoint<3>& p) { return 3 * p[0] - 7 * p[1] + 11 * p[2] + 5; };
  const Buffer<3> buffer(5, field);
  for (int t = 0; t < 200; ++t) {
    const Verts<3> v = RandomHierarchySimplex<3>(rng, 5);
    const ScannableSimplex<3> s(v);
    std::array<int64_t, 4> fv{};
    for (int i = 0; i < 4; ++i) fv[i] = field(v[i]);
    const ScanResult r = MaxError<3, int64_t>(s, fv, 1000, {0, 0, 0}, {32, 32, 32}, buffer.view);
    ASSERT_EQ(r.error, 0.0);
  }
}

// One scan of a child's points against its ancestors' interpolants gives
// each ancestor's error over that child's points.
TEST(SimplexScan, SeveralInterpolantsOverOneSimplex) {
  std::mt19937_64 rng(9);
  const int k = 4;
  const auto field = [](const IPoint<3>& p) {
    return static_cast<int64_t>((p[0] * 37 + p[1] * 101 + p[2] * 59) % 97);
  };
  const Buffer<3> buffer(k, field);
  for (int t = 0; t < 100; ++t) {
    const int level = 3 + static_cast<int>(rng() % 9);
    const TetCode c = TetCode::FromPath(static_cast<int>(rng() % 6), rng() >> (64 - level), level);
    const auto grid_of = [&](TetCode code) { return GridVertices<3>(code, k); };
    const ScannableSimplex<3> child(grid_of(c));
    std::vector<Interpolant<3, int64_t>> interps;
    std::vector<double> expected;
    for (int l = 0; l < level; ++l) {
      const Verts<3> av = grid_of(c.ancestor(l));
      const ScannableSimplex<3> a(av);
      std::array<int64_t, 4> f{};
      for (int i = 0; i < 4; ++i) f[i] = field(av[i]);
      interps.emplace_back(a, f, 100, 16);
      // The ancestor's interpolant at the child's points, one by one.
      double e = 0;
      child.ForEachRow({0, 0, 0}, {16, 16, 16}, [&](IPoint<3> p, int64_t x_end) {
        for (int64_t x = p[0]; x <= x_end; ++x) {
          p[0] = x;
          double worst = 0;
          worst = interps.back().ErrorOf(interps.back().RowMax(p, x, buffer.view.Row(p), int64_t{0}));
          e = std::max(e, worst);
        }
      });
      expected.push_back(e);
    }
    std::vector<double> got(level, 0);
    MaxErrors<3, int64_t>(child, interps.data(), level, {0, 0, 0}, {16, 16, 16}, buffer.view,
                          got.data());
    ASSERT_EQ(got, expected) << c.ToString();
  }
}

}  // namespace
}  // namespace simplexdb
