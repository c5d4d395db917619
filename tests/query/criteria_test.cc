// The LOD criteria: the exact box test against a brute-force linear program
// (every vertex of the feasible region, exact rationals), the slice and
// isovalue rules, and the conversion from the command line's units.
#include <gtest/gtest.h>

#include <random>

#include "hierarchy/geometry.h"
#include "query/criteria.h"

namespace simplexdb {
namespace {

__extension__ typedef __int128 Int128;

// Determinant of an n x n matrix (n <= 4) by cofactor expansion.
Int128 Det(const std::vector<std::vector<Int128>>& m) {
  const size_t n = m.size();
  if (n == 1) return m[0][0];
  Int128 d = 0;
  for (size_t c = 0; c < n; ++c) {
    std::vector<std::vector<Int128>> minor;
    for (size_t r = 1; r < n; ++r) {
      std::vector<Int128> row;
      for (size_t j = 0; j < n; ++j) {
        if (j != c) row.push_back(m[r][j]);
      }
      minor.push_back(row);
    }
    d += (c % 2 ? -1 : 1) * m[0][c] * Det(minor);
  }
  return d;
}

// Whether the simplex meets the box, as a linear program in barycentric
// coordinates mu (lambda_D = 1 - sum mu): the feasible region is bounded,
// so it is non-empty iff one of its vertices exists. Every choice of D
// constraints as equalities is solved exactly (Cramer) and checked against
// all the others.
template <int D>
bool BruteMeetsBox(const SimplexVertices<D>& v, const LatticeBox<D>& box) {
  std::vector<std::vector<Int128>> a;  // a . mu <= b
  std::vector<Int128> b;
  for (int i = 0; i < D; ++i) {
    std::vector<Int128> row(D, 0);
    row[i] = -1;
    a.push_back(row);
    b.push_back(0);
  }
  a.push_back(std::vector<Int128>(D, 1));
  b.push_back(1);
  for (int ax = 0; ax < D; ++ax) {
    std::vector<Int128> row(D);
    for (int i = 0; i < D; ++i) row[i] = Int128{v[i][ax]} - v[D][ax];
    a.push_back(row);
    b.push_back(Int128{box.hi[ax]} - v[D][ax]);
    for (auto& x : row) x = -x;
    a.push_back(row);
    b.push_back(-(Int128{box.lo[ax]} - v[D][ax]));
  }
  const size_t n = a.size();
  std::vector<int> pick(D);
  const auto solve = [&]() {
    std::vector<std::vector<Int128>> m;
    for (int r = 0; r < D; ++r) m.push_back(a[pick[r]]);
    const Int128 det = Det(m);
    if (det == 0) return false;
    std::vector<Int128> num(D);
    for (int c = 0; c < D; ++c) {
      auto mc = m;
      for (int r = 0; r < D; ++r) mc[r][c] = b[pick[r]];
      num[c] = Det(mc);
    }
    // mu = num / det; check a . num <= b * det (signs by det).
    for (size_t k = 0; k < n; ++k) {
      Int128 lhs = 0;
      for (int c = 0; c < D; ++c) lhs += a[k][c] * num[c];
      const Int128 rhs = b[k] * det;
      if (det > 0 ? lhs > rhs : lhs < rhs) return false;
    }
    return true;
  };
  std::function<bool(int, size_t)> choose = [&](int depth, size_t from) {
    if (depth == D) return solve();
    for (size_t i = from; i < n; ++i) {
      pick[depth] = static_cast<int>(i);
      if (choose(depth + 1, i + 1)) return true;
    }
    return false;
  };
  return choose(0, 0);
}

template <int D>
void CompareWithLinearProgram(uint64_t seed, int rounds) {
  std::mt19937_64 rng(seed);
  int met = 0, missed = 0;
  for (int round = 0; round < rounds; ++round) {
    SimplexVertices<D> v;
    // Half the rounds: real simplices of the hierarchy (axis-parallel edges
    // and faces, the degenerate cases); half: random ones.
    if (round % 2 == 0) {
      SimplexCode<D> c = SimplexCode<D>::Root(static_cast<int>(rng() % SimplexCode<D>::kRoots));
      const int level = static_cast<int>(rng() % 9);
      for (int l = 0; l < level; ++l) c = c.child(static_cast<int>(rng() % 2));
      v = Vertices<D>(c);
      // Scale to small numbers: the hierarchy's lattice is 2^kCoordBits wide.
      for (auto& p : v) {
        for (auto& x : p) x >>= (kCoordBits<D> - 5);
      }
    } else {
      for (auto& p : v) {
        for (auto& x : p) x = static_cast<int32_t>(rng() % 33);
      }
    }
    LatticeBox<D> box;
    for (int a = 0; a < D; ++a) {
      int64_t lo = static_cast<int64_t>(rng() % 40) - 4, hi = static_cast<int64_t>(rng() % 40) - 4;
      if (lo > hi) std::swap(lo, hi);
      if (rng() % 8 == 0) hi = lo;  // flat boxes
      box.lo[a] = lo;
      box.hi[a] = hi;
    }
    const bool want = BruteMeetsBox<D>(v, box);
    ASSERT_EQ(SimplexMeetsBox<D>(v, box), want) << "round " << round;
    (want ? met : missed)++;
  }
  // Both answers occur often: the comparison means something.
  EXPECT_GT(met, rounds / 10);
  EXPECT_GT(missed, rounds / 10);
}

TEST(Criteria, BoxTestMatchesLinearProgram3D) { CompareWithLinearProgram<3>(1, 6000); }
TEST(Criteria, BoxTestMatchesLinearProgram4D) { CompareWithLinearProgram<4>(2, 1000); }

// A case the bounding boxes get wrong: the box sits in the corner of the
// tetrahedron's bounding box that the tetrahedron does not reach.
TEST(Criteria, BoxNearAFaceButOutside) {
  const SimplexVertices<3> v = {{{0, 0, 0}, {8, 0, 0}, {0, 8, 0}, {0, 0, 8}}};
  EXPECT_FALSE(SimplexMeetsBox<3>(v, {{6, 6, 6}, {8, 8, 8}}));
  EXPECT_TRUE(SimplexMeetsBox<3>(v, {{2, 2, 2}, {8, 8, 8}}));   // holds (2,2,2), inside
  EXPECT_TRUE(SimplexMeetsBox<3>(v, {{4, 4, 0}, {8, 8, 0}}));   // touches at one point (4,4,0)
  EXPECT_FALSE(SimplexMeetsBox<3>(v, {{5, 4, 0}, {8, 8, 0}}));
}

TEST(Criteria, SliceAndIso) {
  const SimplexVertices<4> v = {{{0, 0, 0, 0}, {4, 0, 0, 0}, {0, 4, 0, 2}, {0, 0, 4, 2}, {0, 0, 0, 4}}};
  EXPECT_TRUE(SimplexMeetsSlice<4>(v, 0));
  EXPECT_TRUE(SimplexMeetsSlice<4>(v, 4));
  EXPECT_FALSE(SimplexMeetsSlice<4>(v, 4.5));
  Criteria<4> c;
  c.iso = 10;
  const std::array<double, 5> values = {1, 2, 3, 4, 5};
  EXPECT_FALSE(Applies<4>(c, v, &values, 4.9));  // 5 + 4.9 < 10
  EXPECT_TRUE(Applies<4>(c, v, &values, 5.0));   // reaches it exactly
}

TEST(Criteria, UnitsAndErrors) {
  CriteriaSpec spec;
  spec.error = {2, true};
  auto c = MakeCriteria<3>(spec, 4, 250);
  ASSERT_TRUE(c.ok());
  EXPECT_DOUBLE_EQ(c->threshold, 5);
  spec.box = std::vector<double>{1, 2, 3, 4, 5, 6};
  c = MakeCriteria<3>(spec, 4, 250);
  ASSERT_TRUE(c.ok());
  // Grid point g of a 2^4 domain is lattice point g * 2^(kCoordBits - 4).
  EXPECT_EQ(c->box->lo[1], int64_t{2} << (kCoordBits<3> - 4));
  EXPECT_EQ(c->box->hi[2], int64_t{6} << (kCoordBits<3> - 4));
  spec.box = std::vector<double>{4, 0, 0, 1, 1, 1};
  EXPECT_FALSE(MakeCriteria<3>(spec, 4, 250).ok());  // low > high
  spec.box = std::vector<double>{0, 0, 0, 1, 1};
  EXPECT_FALSE(MakeCriteria<3>(spec, 4, 250).ok());
  spec.box.reset();
  spec.time = 3;
  EXPECT_FALSE(MakeCriteria<3>(spec, 4, 250).ok());  // the HT has no time
  EXPECT_TRUE(MakeCriteria<4>(spec, 4, 250).ok());
}

}  // namespace
}  // namespace simplexdb
