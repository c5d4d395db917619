// The dense store end to end: built from volumes written here, its errors
// against brute force for every node, its lookups identical whether raw,
// compressed or in memory, its field equal to the input.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include "hierarchy/geometry.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

using testing::BruteForceError;
using testing::TempDir;
using testing::TestVolume;

struct Case {
  const char* name;
  int dimension;
  std::array<uint32_t, 4> dims;
  VoxelType type;
  int levels_per_block;
  bool missing = false;  // NaN (missing values) in a ball and on the far x face
};

// Every internal node's stored error bounds its true error from above, by
// less than one quantum (u16, u8) or one float step (f32).
template <int D>
void CheckEveryNode(const DenseStore& store, const TestVolume& volume) {
  DenseStore::Reader<D> reader(store);
  const DenseHeader& h = store.header();
  const double quantum = store.quantizer().quantum();
  const int leaf = h.leaf_level();
  size_t nodes = 0, nonzero = 0;
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (c.level() >= leaf) return;
    // With missing values: 0 where no point has a value, the field range
    // where some have none (ErrorGivenAvailability), the error otherwise.
    const auto [any_value, any_missing] = BruteForceAvailability<D>(c, h.domain_bits, volume);
    const long double truth = !any_value    ? 0
                              : any_missing ? static_cast<long double>(h.field_max - h.field_min)
                                            : BruteForceError<D>(c, h.domain_bits, volume);
    const Result<double> stored = reader.ErrorBound(c);
    ASSERT_TRUE(stored.ok()) << stored.status().ToString();
    SCOPED_TRACE(c.ToString());
    ASSERT_GE(static_cast<long double>(*stored), truth) << "the bound is below the true error";
    if (h.quantization == Quantization::kF32) {
      ASSERT_LE(*stored, static_cast<double>(truth) * (1 + 1e-6) + 1e-9);
    } else {
      ASSERT_LE(static_cast<long double>(*stored), truth + quantum * (1 + 1e-6));
    }
    if (truth == 0) {
      ASSERT_EQ(*stored, 0.0) << "zero error must stay zero";
    }
    ++nodes;
    nonzero += truth > 0;
    visit(c.child(0));
    visit(c.child(1));
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  EXPECT_EQ(nodes, store.header().error_block_count > 0
                       ? static_cast<size_t>(SimplexCode<D>::kRoots) * ((size_t{1} << leaf) - 1)
                       : 0u);
  // A random field leaves few nodes exact; padded grids have many nodes
  // wholly in the padding, with error 0.
  EXPECT_GT(nonzero, nodes / 20) << "a degenerate test field";
}

// NaN in a ball around (4, 5, 3[, 4]) of radius 3 and on the far x face.
void PunchHoles(TestVolume& volume) {
  for (uint64_t i = 0; i < volume.values.size(); ++i) {
    uint64_t rest = i;
    std::array<int64_t, 4> p{};
    for (int a = 0; a < 4; ++a) {
      p[a] = static_cast<int64_t>(rest % volume.dims[a]);
      rest /= volume.dims[a];
    }
    int64_t r2 = (p[0] - 4) * (p[0] - 4) + (p[1] - 5) * (p[1] - 5) + (p[2] - 3) * (p[2] - 3);
    if (volume.dimension == 4) r2 += (p[3] - 4) * (p[3] - 4);
    if (r2 <= 9 || p[0] == volume.dims[0] - 1) {
      volume.values[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
}

class DenseErrors : public ::testing::TestWithParam<std::tuple<Case, Quantization>> {};

TEST_P(DenseErrors, EqualBruteForceForEveryNode) {
  const auto& [c, q] = GetParam();
  const TempDir dir;
  TestVolume volume = TestVolume::Random(c.dimension, c.dims, c.type, 17);
  if (c.missing) PunchHoles(volume);
  const std::string input = dir.path() + "/in.nrrd";
  ASSERT_TRUE(volume.WriteNrrd(input).ok());
  Result<VolumeInfo> info = OpenVolume(input);
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  DenseBuildOptions options;
  options.quantization = q;
  options.levels_per_block = c.levels_per_block;
  options.threads = 2;
  const std::string store_path = dir.path() + "/store.sdb";
  const Result<DenseBuildReport> built = BuildDenseStore(*info, store_path, options);
  ASSERT_TRUE(built.ok()) << built.status().ToString();
  Result<std::unique_ptr<DenseStore>> store = DenseStore::Open(store_path);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  ASSERT_TRUE((*store)->Verify().ok());
  if (c.dimension == 3) {
    CheckEveryNode<3>(**store, volume);
  } else {
    CheckEveryNode<4>(**store, volume);
  }
}

const Case kCases[] = {
    {"ht9_u8", 3, {9, 9, 9, 1}, VoxelType::kU8, 14},
    {"ht17_i16", 3, {17, 17, 17, 1}, VoxelType::kI16, 14},
    {"ht17_f32_bands", 3, {17, 17, 17, 1}, VoxelType::kF32, 4},  // many bands: top partials
    {"ht_padded", 3, {7, 9, 5, 1}, VoxelType::kU16, 3},          // padding on two axes
    {"hp5_u8", 4, {5, 5, 5, 5}, VoxelType::kU8, 14},
    {"hp9_i16_bands", 4, {9, 9, 9, 9}, VoxelType::kI16, 5},
    {"hp_padded_f64", 4, {6, 5, 4, 3}, VoxelType::kF64, 4},
    {"ht_two_points", 3, {2, 2, 2, 1}, VoxelType::kU8, 14},  // k = 1, padded to 3^3
    {"ht17_f32_missing", 3, {17, 17, 17, 1}, VoxelType::kF32, 4, true},
    {"ht_padded_f64_missing", 3, {13, 9, 17, 1}, VoxelType::kF64, 3, true},
    {"hp9_f32_missing", 4, {9, 9, 9, 9}, VoxelType::kF32, 5, true},
};

INSTANTIATE_TEST_SUITE_P(
    Grids, DenseErrors,
    ::testing::Combine(::testing::ValuesIn(kCases),
                       ::testing::Values(Quantization::kU16, Quantization::kU8, Quantization::kF32)),
    [](const auto& param_info) {
      return std::string(std::get<0>(param_info.param).name) + "_" +
             std::string(QuantizationName(std::get<1>(param_info.param)));
    });

// Raw, compressed and in-memory stores of the same volume answer every
// lookup identically; the field equals the input, clamped in the padding.
template <int D>
void CheckSameAnswers(const std::vector<const DenseStore*>& stores, const TestVolume& volume) {
  std::vector<DenseStore::Reader<D>> readers;
  for (const DenseStore* s : stores) readers.emplace_back(*s);
  const DenseHeader& h = stores[0]->header();
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (c.level() > h.leaf_level()) return;
    const double first = *readers[0].ErrorBound(c);
    for (size_t i = 1; i < readers.size(); ++i) ASSERT_EQ(*readers[i].ErrorBound(c), first);
    visit(c.child(0));
    visit(c.child(1));
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  const int64_t side = int64_t{1} << h.domain_bits;
  std::array<int64_t, D> p{};
  while (true) {
    const double expected = volume.ClampedAt<D>(p);
    for (auto& r : readers) ASSERT_EQ(*r.Field(p), expected);
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

TEST(DenseStore, RawCompressedAndInMemoryAnswerIdentically) {
  for (const Case& c : {kCases[2], kCases[3], kCases[6]}) {
    SCOPED_TRACE(c.name);
    const TempDir dir;
    const TestVolume volume = TestVolume::Random(c.dimension, c.dims, c.type, 5);
    const std::string input = dir.path() + "/in.nrrd";
    ASSERT_TRUE(volume.WriteNrrd(input).ok());
    const VolumeInfo info = *OpenVolume(input);
    DenseBuildOptions options;
    options.levels_per_block = c.levels_per_block;
    options.compression = Compression::kNone;
    ASSERT_TRUE(BuildDenseStore(info, dir.path() + "/raw.sdb", options).ok());
    options.compression = Compression::kZstd;
    ASSERT_TRUE(BuildDenseStore(info, dir.path() + "/zstd.sdb", options).ok());
    auto raw = *DenseStore::Open(dir.path() + "/raw.sdb");
    auto zstd = *DenseStore::Open(dir.path() + "/zstd.sdb");
    DenseStore::Options in_memory;
    in_memory.in_memory = true;
    auto resident = *DenseStore::Open(dir.path() + "/zstd.sdb", in_memory);
    DenseStore::Options tiny;
    tiny.cache_bytes = 1;  // every lookup of a new block decodes again
    auto starved = *DenseStore::Open(dir.path() + "/zstd.sdb", tiny);
    const std::vector<const DenseStore*> all = {raw.get(), zstd.get(), resident.get(),
                                                starved.get()};
    if (c.dimension == 3) {
      CheckSameAnswers<3>(all, volume);
    } else {
      CheckSameAnswers<4>(all, volume);
    }
    // zstd frames are kept only where they are smaller than the raw bytes.
    uint64_t frames = 0;
    for (uint64_t b = 0; b < zstd->block_count(); ++b) {
      frames += zstd->entry(b).encoding == BlockEncoding::kZstd;
    }
    EXPECT_EQ(zstd->stats().blocks_decoded > 0, frames > 0);
    EXPECT_LE(std::filesystem::file_size(dir.path() + "/zstd.sdb"),
              std::filesystem::file_size(dir.path() + "/raw.sdb"));
  }
}

TEST(DenseStore, RejectsInfiniteInput) {
  const TempDir dir;
  TestVolume volume = TestVolume::Random(3, {5, 5, 5, 1}, VoxelType::kF32, 1);
  volume.values[42] = -std::numeric_limits<double>::infinity();  // (2, 3, 1)
  ASSERT_TRUE(volume.WriteNrrd(dir.path() + "/nan.nrrd").ok());
  const Result<DenseBuildReport> r =
      BuildDenseStore(*OpenVolume(dir.path() + "/nan.nrrd"), dir.path() + "/s.sdb", {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("(2, 3, 1) is infinite"), std::string_view::npos)
      << r.status().ToString();
  EXPECT_FALSE(std::filesystem::exists(dir.path() + "/s.sdb"));
  // Nothing left behind either.
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
  }
}

// A float32 store's block statistics cannot hold a float64 beyond float32's
// range: the build fails naming the file, value and voxel, before writing.
TEST(DenseStore, RejectsValuesBeyondFloat32) {
  const TempDir dir;
  struct Bad {
    int dimension;
    size_t at;
    double value;
    std::string expected;
  };
  const Bad cases[] = {
      {3, 42, 1e39, "value 1e+39 at voxel (2, 3, 1) is beyond float32's range"},
      {3, 124, -4e38, "value -4e+38 at voxel (4, 4, 4) is beyond float32's range"},
      // 4D (HP): x, y, z, t.
      {4, 3 + 4 * (1 + 4 * (2 + 4 * 1)), 1e300,
       "value 1e+300 at voxel (3, 1, 2, 1) is beyond float32's range"},
      {4, 5, std::numeric_limits<double>::infinity(), "value inf at voxel (1, 1, 0, 0) is infinite"},
  };
  for (const Bad& c : cases) {
    SCOPED_TRACE(c.expected);
    const std::array<uint32_t, 4> dims =
        c.dimension == 3 ? std::array<uint32_t, 4>{5, 5, 5, 1} : std::array<uint32_t, 4>{4, 4, 4, 2};
    TestVolume volume = TestVolume::Random(c.dimension, dims, VoxelType::kF64, 7);
    volume.values[c.at] = c.value;
    const std::string input = dir.path() + "/big.nrrd";
    ASSERT_TRUE(volume.WriteNrrd(input).ok());
    const Result<DenseBuildReport> r =
        BuildDenseStore(*OpenVolume(input), dir.path() + "/s.sdb", {});
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(r.status().IsInvalidArgument()) << r.status().ToString();
    EXPECT_NE(r.status().message().find("NRRD file " + input + ": " + c.expected),
              std::string_view::npos)
        << r.status().ToString();
    EXPECT_FALSE(std::filesystem::exists(dir.path() + "/s.sdb"));
    for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
      EXPECT_EQ(e.path().filename().string().find(".tmp."), std::string::npos) << e.path();
    }
  }
}

// The header holds 255 bytes of the source: a longer one is cut between
// characters, so a UTF-8 path stays UTF-8 (JSON output needs it).
TEST(DenseStore, SourceIsCutAtACharacterBoundary) {
  const TempDir dir;
  std::string name;
  for (int i = 0; i < 120; ++i) name += "\xC3\xA9";  // é
  const std::string path = dir.path() + "/" + name + ".nrrd";
  const TestVolume volume = TestVolume::Random(3, {5, 5, 5, 1}, VoxelType::kU8, 1);
  ASSERT_TRUE(volume.WriteNrrd(path).ok());
  // Both parities of where byte 255 falls.
  for (const std::string prefix : {"", "x"}) {
    SCOPED_TRACE("prefix '" + prefix + "'");
    Result<VolumeInfo> in = OpenVolume(path);
    ASSERT_TRUE(in.ok()) << in.status().ToString();
    in->description = prefix + in->description;
    const std::string store = dir.path() + "/s" + prefix + ".sdb";
    ASSERT_TRUE(BuildDenseStore(*in, store, {}).ok());
    const auto opened = DenseStore::Open(store);
    ASSERT_TRUE(opened.ok()) << opened.status().ToString();
    const std::string& source = (*opened)->header().source;
    EXPECT_TRUE(IsValidUtf8(source)) << source;
    EXPECT_GE(source.size(), 254u);
    EXPECT_LE(source.size(), 255u);
    EXPECT_EQ(source, in->description.substr(0, source.size()));
  }
}

// A mask is the same as NaN: an integer volume with a mask builds the store
// a float32 volume with NaN at the masked points builds (whose errors the
// brute-force test above checks), entry for entry.
TEST(DenseStore, AMaskEqualsNaNAtTheMaskedPoints) {
  const TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {17, 13, 11, 1}, VoxelType::kU8, 4);
  TestVolume mask = volume, nan = volume;
  mask.type = VoxelType::kU8;
  nan.type = VoxelType::kF32;
  for (size_t i = 0; i < volume.values.size(); ++i) {
    const bool hidden = (i % 17) > 12 || (i / (17 * 13)) == 4;  // a slab along x, a z plane
    mask.values[i] = hidden ? 0 : 1 + (i % 7);  // any nonzero value means "available"
    if (hidden) nan.values[i] = std::numeric_limits<double>::quiet_NaN();
  }
  ASSERT_TRUE(volume.WriteNrrd(dir.path() + "/v.nrrd").ok());
  ASSERT_TRUE(mask.WriteNrrd(dir.path() + "/m.nrrd").ok());
  ASSERT_TRUE(nan.WriteNrrd(dir.path() + "/n.nrrd").ok());
  DenseBuildOptions options;
  options.threads = 1;
  options.compression = Compression::kNone;
  ASSERT_TRUE(BuildDenseStore(*OpenVolume(dir.path() + "/n.nrrd"), dir.path() + "/n.sdb", options).ok());
  options.mask = *OpenVolume(dir.path() + "/m.nrrd");
  const auto built = BuildDenseStore(*OpenVolume(dir.path() + "/v.nrrd"), dir.path() + "/m.sdb", options);
  ASSERT_TRUE(built.ok()) << built.status().ToString();
  EXPECT_EQ(built->header.voxel_type, VoxelType::kF32);
  std::ifstream a(dir.path() + "/n.sdb", std::ios::binary), b(dir.path() + "/m.sdb", std::ios::binary);
  const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
  ASSERT_EQ(x.size(), y.size());
  // Everything after the header (which names the source) is the same.
  EXPECT_TRUE(x.compare(kHeaderSize, std::string::npos, y, kHeaderSize, std::string::npos) == 0);
  EXPECT_TRUE((*DenseStore::Open(dir.path() + "/m.sdb"))->Verify().ok());

  // A mask of another grid is refused, naming both.
  TestVolume other = TestVolume::Random(3, {17, 13, 10, 1}, VoxelType::kU8, 1);
  ASSERT_TRUE(other.WriteNrrd(dir.path() + "/o.nrrd").ok());
  options.mask = *OpenVolume(dir.path() + "/o.nrrd");
  const auto refused = BuildDenseStore(*OpenVolume(dir.path() + "/v.nrrd"), dir.path() + "/x.sdb", options);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("17x13x10"), std::string_view::npos) << refused.status().ToString();
  EXPECT_NE(refused.status().message().find("17x13x11"), std::string_view::npos) << refused.status().ToString();
  EXPECT_FALSE(std::filesystem::exists(dir.path() + "/x.sdb"));
}

}  // namespace
}  // namespace simplexdb
