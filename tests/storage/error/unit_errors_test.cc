// The error engine of storage/error/unit_errors.h against the kernels
// applied to each node alone: a node's error does not depend on the unit it
// is scanned in, the units' partial maxima give every ancestor its own
// error (the units tile it), and pruning visits exactly the kept nodes with
// the same errors. Small domains with padding, HT and HP, integer fields
// (exact) and float fields with missing values (NaN), fixed seeds.
#include "storage/error/unit_errors.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>

namespace simplexdb {
namespace {

template <int D>
struct TestField {
  std::array<int64_t, D> dims{};
  std::vector<double> values;  // x fastest

  double At(const IPoint<D>& p) const {  // clamped to the real grid
    size_t i = 0;
    for (int c = D - 1; c >= 0; --c) {
      i = i * static_cast<size_t>(dims[c]) +
          static_cast<size_t>(std::clamp<int64_t>(p[c], 0, dims[c] - 1));
    }
    return values[i];
  }
  void Fill(GridRegion<D>& r) const {
    IPoint<D> p = r.lo;
    size_t at = 0;
    while (true) {
      for (p[0] = r.lo[0]; p[0] <= r.hi[0]; ++p[0]) r.values[at++] = At(p);
      p[0] = r.lo[0];
      if (!NextRow<D>(p, r.lo, r.hi)) break;
    }
  }
};

template <int D>
TestField<D> MakeField(const std::array<int64_t, D>& dims, bool exact, bool holes, uint32_t seed) {
  TestField<D> f;
  f.dims = dims;
  size_t n = 1;
  for (int c = 0; c < D; ++c) n *= static_cast<size_t>(dims[c]);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> ints(-300, 300);
  std::uniform_real_distribution<double> reals(-1, 1);
  f.values.resize(n);
  for (size_t i = 0; i < n; ++i) {
    f.values[i] = exact ? ints(rng) : reals(rng);
    if (holes && rng() % 7 == 0) f.values[i] = std::numeric_limits<double>::quiet_NaN();
  }
  return f;
}

// The recorded error of one node, from the kernels over its own bounding
// box: the reference.
template <int D>
double DirectError(const ErrorRules<D>& rules, const TestField<D>& field,
                   const GridSimplex<D>& grid) {
  const ScannableSimplex<D> s(grid);
  GridRegion<D> r;
  r.Reset(s.box_lo(), s.box_hi());
  field.Fill(r);
  IPoint<D> hi{};
  for (int c = 0; c < D; ++c) hi[c] = std::min(r.hi[c], rules.real_hi[c]);
  for (int c = 0; c < D; ++c) {
    if (r.lo[c] > hi[c]) return 0;
  }
  const GridView<D> view = r.view();
  std::array<double, D + 1> f{};
  for (int i = 0; i <= D; ++i) f[i] = view.At(grid[i]);
  if (rules.exact) {
    std::array<int64_t, D + 1> fi{};
    for (int i = 0; i <= D; ++i) fi[i] = static_cast<int64_t>(f[i]);
    return MaxError<D, int64_t>(s, fi, rules.range, r.lo, hi, view).error;
  }
  const double e = MaxError<D, double>(s, f, rules.range, r.lo, hi, view).error;
  if (!rules.may_miss) return e;
  return ErrorGivenAvailability(NodeAvailability<D>(s, r.lo, hi, view), e, rules.range);
}

template <int D>
void CheckEngine(int k, const std::array<int64_t, D>& dims, bool exact, bool holes,
                 uint32_t seed) {
  SCOPED_TRACE(testing::Message() << D << "D k=" << k << " exact=" << exact
                                  << " holes=" << holes);
  const TestField<D> field = MakeField<D>(dims, exact, holes, seed);
  ErrorRules<D> rules;
  for (int c = 0; c < D; ++c) rules.real_hi[c] = dims[c] - 1;
  rules.range = exact ? 600 : 2;
  rules.exact = exact;
  rules.may_miss = holes;
  const int leaf = D * k;
  const int unit_level = D;  // units a few levels down; ancestors above
  const double tol = exact ? 0 : 1e-12;

  std::map<uint64_t, double> partials;           // ancestor key -> max partial
  std::map<uint64_t, Availability> availability;  // ancestor key -> merged
  std::map<uint64_t, GridSimplex<D>> ancestor_grid;
  int visited = 0;
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (uint64_t u = 0; u < (uint64_t{1} << unit_level); ++u) {
      const SimplexCode<D> unit = SimplexCode<D>::FromPath(top, u, unit_level);
      UnitScan<D> scan(rules, unit, GridOf<D>(Vertices(unit), k));
      if (!scan.has_real_points()) {
        EXPECT_EQ(DirectError<D>(rules, field, GridOf<D>(Vertices(unit), k)), 0);
        continue;
      }
      field.Fill(scan.region());
      // Every node, with its reference error and heap entry.
      std::set<uint64_t> all;
      scan.ForEachNode(leaf, {}, [&](const UnitNode<D>& node) {
        SCOPED_TRACE(node.code.ToString());
        ++visited;
        all.insert(node.code.key());
        EXPECT_EQ(node.grid, GridOf<D>(Vertices(node.code), k));
        const int local = node.code.level() - unit_level;
        const uint64_t path = node.code.path() & ((uint64_t{1} << local) - 1);
        EXPECT_EQ(node.entry, (uint64_t{1} << local) - 1 + path);
        EXPECT_NEAR(node.error, DirectError<D>(rules, field, node.grid), tol);
      });
      EXPECT_EQ(all.size(), (size_t{1} << (leaf - unit_level)) - 1);
      // Pruned: the nodes whose first vertex has an even x, below the unit.
      const auto keep = [](const GridSimplex<D>& g) { return g[0][0] % 2 == 0; };
      std::set<uint64_t> kept;
      scan.ForEachNode(leaf, keep, [&](const UnitNode<D>& node) {
        kept.insert(node.code.key());
        EXPECT_NEAR(node.error, DirectError<D>(rules, field, node.grid), tol);
      });
      for (const uint64_t key : all) {
        const SimplexCode<D> c = SimplexCode<D>::FromKey(key);
        bool expect = true;
        for (SimplexCode<D> a = c; a.level() > unit_level; a = a.parent()) {
          expect = expect && keep(GridOf<D>(Vertices(a), k));
        }
        EXPECT_EQ(kept.contains(key), expect) << c.ToString();
      }
      // The ancestors' partial maxima.
      std::array<AncestorInterpolant<D>, UnitScan<D>::kMaxAncestors> interps;
      for (int l = 0; l < unit_level; ++l) {
        const SimplexCode<D> a = unit.ancestor(l);
        const GridSimplex<D> g = GridOf<D>(Vertices(a), k);
        std::array<double, D + 1> f{};
        for (int i = 0; i <= D; ++i) f[i] = field.At(g[i]);
        interps[l] = AncestorInterpolant<D>(rules, g, f);
        ancestor_grid[a.key()] = g;
        availability[a.key()].any_missing |= interps[l].vertex_missing();
      }
      std::array<double, UnitScan<D>::kMaxAncestors> partial{};
      const Availability av =
          scan.AncestorPartials({interps.data(), static_cast<size_t>(unit_level)}, partial.data());
      for (int l = 0; l < unit_level; ++l) {
        const uint64_t key = unit.ancestor(l).key();
        partials[key] = std::max(partials[key], partial[l]);
        availability[key].Merge(av);
      }
    }
  }
  EXPECT_GT(visited, 0);
  for (const auto& [key, e] : partials) {
    SCOPED_TRACE(SimplexCode<D>::FromKey(key).ToString());
    const double recorded = ErrorGivenAvailability(availability[key], e, rules.range);
    EXPECT_NEAR(recorded, DirectError<D>(rules, field, ancestor_grid[key]), tol);
  }
}

TEST(UnitErrors, HtIntegerFieldWithPadding) { CheckEngine<3>(3, {7, 6, 5}, true, false, 1); }
TEST(UnitErrors, HtFloatFieldWithMissingValues) { CheckEngine<3>(3, {8, 7, 6}, false, true, 2); }
TEST(UnitErrors, HtFloatFieldWithoutMissingValues) {
  CheckEngine<3>(3, {9, 9, 9}, false, false, 3);
}
TEST(UnitErrors, HpIntegerFieldWithPadding) { CheckEngine<4>(2, {4, 3, 5, 2}, true, false, 4); }
TEST(UnitErrors, HpFloatFieldWithMissingValues) {
  CheckEngine<4>(2, {5, 4, 3, 3}, false, true, 5);
}

}  // namespace
}  // namespace simplexdb
