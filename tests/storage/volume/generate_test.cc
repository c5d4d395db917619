// The synthetic fields (storage/volume/generate.h): determinism pinned by golden
// values, ranges and smoothness of Perlin noise in 3D and 4D, and the
// analytic fields against their formulas written out here.
#include "storage/volume/generate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

namespace simplexdb {
namespace {

std::vector<double> Generate(const GenerateOptions& o) {
  EXPECT_TRUE(ValidateGenerateOptions(o).ok()) << ValidateGenerateOptions(o).ToString();
  const FieldGenerator g(o);
  std::vector<double> v;
  for (uint32_t t = 0; t < o.dims[3]; ++t) {
    for (uint32_t z = 0; z < o.dims[2]; ++z) {
      for (uint32_t y = 0; y < o.dims[1]; ++y) {
        for (uint32_t x = 0; x < o.dims[0]; ++x) v.push_back(g.At(x, y, z, t));
      }
    }
  }
  return v;
}

bool SameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         std::equal(a.begin(), a.end(), b.begin(), [](double x, double y) {
           return std::bit_cast<uint64_t>(x) == std::bit_cast<uint64_t>(y);
         });
}

TEST(FieldKind, NamesRoundTripAndUnknownNamesFail) {
  for (FieldKind k : {FieldKind::kPerlin, FieldKind::kSphere, FieldKind::kSineProduct,
                      FieldKind::kMarschnerLobb, FieldKind::kConstant, FieldKind::kRamp,
                      FieldKind::kBuckyball}) {
    auto parsed = ParseFieldKind(FieldKindName(k));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, k);
  }
  EXPECT_EQ(FieldKindName(FieldKind::kMarschnerLobb), "marschner-lobb");
  EXPECT_EQ(FieldKindName(FieldKind::kSineProduct), "sines");
  auto bad = ParseFieldKind("plasma");
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(bad.status().IsInvalidArgument());
  EXPECT_NE(bad.status().message().find("plasma"), std::string::npos);
  EXPECT_NE(bad.status().message().find("marschner-lobb"), std::string::npos);
}

TEST(GenerateOptions, ValidationNamesTheBadOption) {
  EXPECT_TRUE(ValidateGenerateOptions(GenerateOptions{}).ok());
  const auto fails = [](auto edit, const char* mentions) {
    GenerateOptions o;
    edit(o);
    const Status s = ValidateGenerateOptions(o);
    EXPECT_TRUE(s.IsInvalidArgument()) << mentions;
    EXPECT_NE(s.message().find(mentions), std::string::npos) << s.ToString();
  };
  fails([](GenerateOptions& o) { o.dimension = 2; }, "dimension");
  fails([](GenerateOptions& o) { o.dims = {65, 1, 65, 1}; }, "axis y");
  fails([](GenerateOptions& o) { o.dims = {65, 65, 65, 2}; }, "unused axis t");
  fails([](GenerateOptions& o) { o.dimension = 4; }, "axis t");  // dims[3] = 1
  fails([](GenerateOptions& o) { o.octaves = 0; }, "octaves");
  fails([](GenerateOptions& o) { o.octaves = 17; }, "octaves");
  fails([](GenerateOptions& o) { o.frequency = 0; }, "frequency");
  fails([](GenerateOptions& o) { o.frequency = std::nan(""); }, "frequency");
  fails([](GenerateOptions& o) { o.frequency = 1e7; }, "frequency");
  fails([](GenerateOptions& o) { o.constant = INFINITY; }, "constant");
}

TEST(Perlin, SameSeedSameBitsOtherSeedOtherField) {
  GenerateOptions o;
  o.dims = {33, 21, 17, 1};
  const std::vector<double> a = Generate(o), b = Generate(o);
  EXPECT_TRUE(SameBits(a, b));
  o.seed = 2;
  const std::vector<double> c = Generate(o);
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); ++i) differ += a[i] != c[i];
  EXPECT_GT(differ, a.size() * 9 / 10);  // another field, not a few changed voxels
  // Also in 4D.
  GenerateOptions o4;
  o4.dimension = 4;
  o4.dims = {9, 9, 9, 5};
  const std::vector<double> d = Generate(o4);
  EXPECT_TRUE(SameBits(d, Generate(o4)));
  o4.seed = 99;
  EXPECT_FALSE(SameBits(d, Generate(o4)));
}

// Golden values pin the field bit for bit, so a volume generated from a
// seed is the same on every machine and in every later version (stores
// built from generated volumes in tests and benchmarks stay comparable).
// They were computed by this implementation and agree to the last bit with
// tests/storage/volume/perlin_reference.py, an independent Python transcription of
// the description in generate.h and of Perlin's reference code. The field
// uses only IEEE-exact operations (+ - * / floor fmod) in a fixed order and
// generate.cc is built without fused multiply-add, so exact comparison is
// right; a change here means the generated data changed.
TEST(Perlin, GoldenValues) {
  const FieldGenerator g3(GenerateOptions{});  // 65^3, seed 1, 4 octaves, frequency 4
  EXPECT_EQ(g3.At(0, 0, 0), 71.147959749636158);
  EXPECT_EQ(g3.At(32, 32, 32), 114.23002163806854);
  EXPECT_EQ(g3.At(64, 64, 64), 99.005631317308442);
  EXPECT_EQ(g3.At(1, 2, 3), 67.502424386282797);
  EXPECT_EQ(g3.At(10, 50, 20), 122.97656394492878);
  EXPECT_EQ(g3.At(63, 5, 41), 86.577247992221402);

  GenerateOptions o4;
  o4.dimension = 4;
  o4.dims = {17, 17, 17, 9};
  o4.seed = 42;
  o4.octaves = 3;
  o4.frequency = 2.5;
  const FieldGenerator g4(o4);
  EXPECT_EQ(g4.At(0, 0, 0, 0), 93.418522116766141);
  EXPECT_EQ(g4.At(8, 8, 8, 4), 88.197820559709584);
  EXPECT_EQ(g4.At(16, 16, 16, 8), 110.97870139567472);
  EXPECT_EQ(g4.At(3, 11, 7, 2), 165.40934374015768);
  EXPECT_EQ(g4.At(15, 0, 9, 6), 127.83731959387821);
}

// Within [0, 255], spread over most of it, rarely clamped, centred.
void CheckPerlinRange(const GenerateOptions& o) {
  std::vector<double> v = Generate(o);
  ASSERT_FALSE(v.empty());
  size_t clamped = 0;
  for (double x : v) {
    ASSERT_GE(x, 0.0);
    ASSERT_LE(x, 255.0);
    clamped += x == 0.0 || x == 255.0;
  }
  EXPECT_LT(clamped, v.size() / 1000);
  std::sort(v.begin(), v.end());
  EXPECT_LT(v[v.size() / 100], 60.0);        // 1st percentile
  EXPECT_GT(v[v.size() * 99 / 100], 195.0);  // 99th
  EXPECT_NEAR(v[v.size() / 2], 127.5, 15.0);  // median near the middle
}

// The largest difference between neighbours along x.
double MaxStepAlongX(const GenerateOptions& o) {
  const std::vector<double> v = Generate(o);
  double max_step = 0;
  for (size_t i = 0; i + 1 < v.size(); ++i) {
    if ((i + 1) % o.dims[0] != 0) max_step = std::max(max_step, std::fabs(v[i + 1] - v[i]));
  }
  return max_step;
}

// One continuous field sampled at any resolution: a grid of 2n - 1 samples
// holds the n-sample grid's values exactly at its even points (the noise
// coordinates x * f / (n - 1) are the same doubles), and being smooth, its
// neighbour differences are about half as large (white noise: the same).
void CheckResolutionIndependentAndSmooth(GenerateOptions coarse) {
  GenerateOptions fine = coarse;
  for (int i = 0; i < coarse.dimension; ++i) fine.dims[i] = 2 * coarse.dims[i] - 1;
  const FieldGenerator gc(coarse), gf(fine);
  const uint32_t t_end = coarse.dims[3];
  for (uint32_t t = 0; t < t_end; ++t) {
    for (uint32_t z = 0; z < coarse.dims[2]; ++z) {
      for (uint32_t y = 0; y < coarse.dims[1]; ++y) {
        for (uint32_t x = 0; x < coarse.dims[0]; ++x) {
          ASSERT_EQ(gc.At(x, y, z, t), gf.At(2 * x, 2 * y, 2 * z, coarse.dimension == 4 ? 2 * t : 0));
        }
      }
    }
  }
  EXPECT_LT(MaxStepAlongX(fine), 0.6 * MaxStepAlongX(coarse));
}

TEST(Perlin, RangeAndSpread3D) {
  GenerateOptions o;  // the seed's Plasma64 setting: 65^3
  CheckPerlinRange(o);
  o.seed = 7;
  o.octaves = 8;
  o.dims = {80, 40, 30, 1};  // non-cubic
  CheckPerlinRange(o);
}

TEST(Perlin, ResolutionIndependentAndSmooth) {
  GenerateOptions o;
  o.dims = {33, 33, 33, 1};
  o.octaves = 2;
  CheckResolutionIndependentAndSmooth(o);
  o.dimension = 4;
  o.dims = {17, 17, 17, 17};
  o.octaves = 1;
  CheckResolutionIndependentAndSmooth(o);
}

TEST(Perlin, FourDWorksAndVariesAlongTime) {
  GenerateOptions o;
  o.dimension = 4;
  o.dims = {33, 33, 33, 17};
  CheckPerlinRange(o);
  const FieldGenerator g(o);
  size_t changed = 0;
  for (uint32_t x = 0; x < 33; ++x) changed += g.At(x, 5, 7, 0) != g.At(x, 5, 7, 16);
  EXPECT_GT(changed, 30u);
}

TEST(Sphere, IsTheDistanceFromTheCentre) {
  GenerateOptions o;
  o.kind = FieldKind::kSphere;
  o.dims = {9, 6, 5, 1};
  const FieldGenerator g(o);
  for (uint32_t z = 0; z < 5; ++z) {
    for (uint32_t y = 0; y < 6; ++y) {
      for (uint32_t x = 0; x < 9; ++x) {
        const double dx = x - 4.0, dy = y - 2.5, dz = z - 2.0;
        ASSERT_DOUBLE_EQ(g.At(x, y, z), std::sqrt(dx * dx + dy * dy + dz * dz));
      }
    }
  }
  EXPECT_EQ(g.At(4, 2, 2), 0.5);  // the centre (4, 2.5, 2) is between two samples
  o.dimension = 4;
  o.dims = {5, 5, 5, 3};
  const FieldGenerator g4(o);
  EXPECT_EQ(g4.At(2, 2, 2, 1), 0.0);
  EXPECT_DOUBLE_EQ(g4.At(0, 0, 0, 0), std::sqrt(4.0 + 4 + 4 + 1));
}

TEST(SineProduct, IsTheProductOfSines) {
  GenerateOptions o;
  o.kind = FieldKind::kSineProduct;
  o.dims = {17, 9, 13, 1};
  o.frequency = 1.5;
  const FieldGenerator g(o);
  const double two_pi_f = 2 * std::numbers::pi * 1.5;
  EXPECT_NEAR(g.At(3, 2, 5),
              std::sin(two_pi_f * 3 / 16) * std::sin(two_pi_f * 2 / 8) * std::sin(two_pi_f * 5 / 12),
              1e-15);
  EXPECT_NEAR(g.At(0, 4, 6), 0.0, 1e-15);  // sin(0) on the x = 0 face
  for (uint32_t x = 0; x < 17; ++x) {
    EXPECT_LE(std::fabs(g.At(x, 3, 7)), 1.0);
  }
}

TEST(MarschnerLobb, MatchesTheFormulaAndItsRange) {
  GenerateOptions o;
  o.kind = FieldKind::kMarschnerLobb;
  o.dims = {41, 41, 41, 1};
  const FieldGenerator g(o);
  // Centre: r = 0, rho_r = cos(2 pi 6) = 1, so (1 - 0 + 0.25 * 2) / 2.5.
  EXPECT_NEAR(g.At(20, 20, 20), 0.6, 1e-15);
  // A corner: x = y = -1, z = 1, r = sqrt 2.
  const double rho = std::cos(2 * std::numbers::pi * 6 * std::cos(std::numbers::pi * std::sqrt(2.0) / 2));
  EXPECT_NEAR(g.At(0, 0, 40), (1 - 1 + 0.25 * (1 + rho)) / 2.5, 1e-15);
  double lo = 1, hi = 0;
  for (uint32_t z = 0; z < 41; z += 2) {
    for (uint32_t y = 0; y < 41; y += 2) {
      for (uint32_t x = 0; x < 41; x += 2) {
        lo = std::min(lo, g.At(x, y, z));
        hi = std::max(hi, g.At(x, y, z));
      }
    }
  }
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 1.0);
  EXPECT_LT(lo, 0.1);
  EXPECT_GT(hi, 0.9);
  // 4D: t is a phase of the radial term; the ends of the time axis agree.
  o.dimension = 4;
  o.dims = {41, 41, 41, 5};
  const FieldGenerator g4(o);
  EXPECT_NEAR(g4.At(20, 20, 20, 0), 0.6, 1e-15);
  EXPECT_NEAR(g4.At(20, 20, 20, 2), (1 + 0.25 * (1 + std::cos(std::numbers::pi))) / 2.5, 1e-12);
  EXPECT_NEAR(g4.At(7, 30, 12, 0), g4.At(7, 30, 12, 4), 1e-12);
}

TEST(ConstantAndRamp, AreWhatTheySay) {
  GenerateOptions o;
  o.kind = FieldKind::kConstant;
  o.constant = -3.5;
  o.dims = {4, 5, 6, 1};
  for (double v : Generate(o)) ASSERT_EQ(v, -3.5);
  o.kind = FieldKind::kRamp;
  const FieldGenerator g(o);
  EXPECT_EQ(g.At(0, 0, 0), 0.0);
  EXPECT_EQ(g.At(3, 4, 5), 1.0);
  EXPECT_EQ(g.At(1, 2, 3), 0.5);
  o.dimension = 4;
  o.dims = {4, 5, 6, 3};
  const FieldGenerator g4(o);
  EXPECT_EQ(g4.At(3, 4, 5, 2), 1.0);
  EXPECT_EQ(g4.At(0, 0, 0, 2), 2.0 / 14);
}

TEST(FieldGenerator, FillEqualsAtAcrossRowsSlicesAndTimeSteps) {
  GenerateOptions o;
  o.dimension = 4;
  o.dims = {5, 4, 3, 3};
  const std::vector<double> all = Generate(o);
  const FieldGenerator g(o);
  for (uint64_t first : {0ull, 3ull, 19ull, 59ull, 121ull}) {
    std::vector<double> part(all.size() - first);
    g.Fill(first, part.size(), part.data());
    ASSERT_TRUE(SameBits(part, std::vector<double>(all.begin() + static_cast<long>(first), all.end())))
        << "from voxel " << first;
  }
}

// The atoms against what defines a truncated icosahedron, not against the
// formula that made them: 60 distinct points on one sphere, each with exactly
// three neighbours at the edge length and none closer (90 edges).
TEST(Buckyball, AtomsAreATruncatedIcosahedron) {
  const auto atoms = BuckyballAtoms();
  const double radius = std::sqrt(9 * std::numbers::phi + 10);
  int edges = 0;
  for (size_t i = 0; i < atoms.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_NEAR(std::hypot(atoms[i][0], atoms[i][1], atoms[i][2]), radius, 1e-12);
    int neighbours = 0;
    for (size_t j = 0; j < atoms.size(); ++j) {
      if (j == i) continue;
      const double d = std::hypot(atoms[i][0] - atoms[j][0], atoms[i][1] - atoms[j][1],
                                  atoms[i][2] - atoms[j][2]);
      EXPECT_GT(d, 2 - 1e-9) << "atoms " << i << " and " << j << " are too close";
      if (d < 2 + 1e-9) ++neighbours;
    }
    EXPECT_EQ(neighbours, 3);
    edges += neighbours;
  }
  EXPECT_EQ(edges / 2, 90);
}

// The field: hollow (0 at the centre and the corners), near 255 on the grid
// point closest to each atom, and on a cubic grid unchanged by the cyclic
// permutation of the axes (a symmetry of the atoms) and by x -> -x.
TEST(Buckyball, FieldIsAHollowSymmetricCage) {
  GenerateOptions o;
  o.kind = FieldKind::kBuckyball;
  o.dims = {33, 33, 33, 1};
  const FieldGenerator g(o);
  EXPECT_LT(g.At(16, 16, 16), 1e-6);
  EXPECT_LT(g.At(0, 0, 0), 1e-6);
  const double scale = 0.38 * 32 / std::sqrt(9 * std::numbers::phi + 10);
  for (const auto& a : BuckyballAtoms()) {
    const auto grid = [&](int i) { return static_cast<uint32_t>(std::lround(16 + a[i] * scale)); };
    EXPECT_GT(g.At(grid(0), grid(1), grid(2)), 150) << a[0] << "," << a[1] << "," << a[2];
  }
  double max = 0;
  for (uint32_t z = 0; z < 33; ++z) {
    for (uint32_t y = 0; y < 33; ++y) {
      for (uint32_t x = 0; x < 33; ++x) {
        const double v = g.At(x, y, z);
        max = std::max(max, v);
        ASSERT_NEAR(v, g.At(y, z, x), 1e-9) << x << "," << y << "," << z;
        ASSERT_NEAR(v, g.At(32 - x, y, z), 1e-9) << x << "," << y << "," << z;
      }
    }
  }
  EXPECT_GT(max, 200);
  EXPECT_LE(max, 255);
  // 4D: half a turn about z over the time axis brings the cage back.
  o.dimension = 4;
  o.dims = {33, 33, 33, 5};
  const FieldGenerator g4(o);
  for (uint32_t z = 0; z < 33; z += 4) {
    for (uint32_t y = 0; y < 33; y += 3) {
      for (uint32_t x = 0; x < 33; x += 2) {
        ASSERT_NEAR(g4.At(x, y, z, 0), g4.At(x, y, z, 4), 1e-9);
        ASSERT_NEAR(g4.At(x, y, z, 0), g.At(x, y, z), 1e-9);
      }
    }
  }
}

}  // namespace
}  // namespace simplexdb

namespace simplexdb {
namespace {

// A generated volume reads, over any range and through any number of
// readers, the generator's values at those voxels rounded to its type
// (integers rounded and clamped), computed independently here.
TEST(GeneratedVolume, ReadsTheGeneratorsValuesRoundedToItsType) {
  GenerateOptions g;
  g.dims = {13, 11, 9, 1};
  g.seed = 3;
  for (const VoxelType type : {VoxelType::kU8, VoxelType::kI16, VoxelType::kF32}) {
    SCOPED_TRACE(static_cast<int>(type));
    const Result<VolumeInfo> v = GeneratedVolume(g, type);
    ASSERT_TRUE(v.ok()) << v.status().ToString();
    EXPECT_TRUE(v->files.empty());
    const FieldGenerator gen(g);
    const uint64_t n = v->voxel_count();
    std::vector<double> want(n);
    gen.Fill(0, n, want.data());
    for (double& x : want) {
      if (type == VoxelType::kU8) x = std::clamp(std::nearbyint(x), 0.0, 255.0);
      if (type == VoxelType::kI16) x = std::clamp(std::nearbyint(x), -32768.0, 32767.0);
      if (type == VoxelType::kF32) x = static_cast<float>(x);
    }
    auto reader = VolumeReader::Open(*v);
    ASSERT_TRUE(reader.ok()) << reader.status().ToString();
    for (const auto& [first, count] : {std::pair<uint64_t, size_t>{0, n}, {17, 300}, {n - 5, 5}}) {
      std::vector<double> got(count);
      ASSERT_TRUE((*reader)->Read(first, count, got.data()).ok());
      for (size_t i = 0; i < count; ++i) ASSERT_EQ(got[i], want[first + i]) << first + i;
    }
  }
  g.octaves = 0;
  EXPECT_TRUE(GeneratedVolume(g, VoxelType::kU8).status().IsInvalidArgument());
}

}  // namespace
}  // namespace simplexdb
