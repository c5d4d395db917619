// The dense store against independent truth: every node's error against
// the brute-force seed errors of its cluster (never below, within the
// quantization's step), every field value against the volume, which blocks
// exist against a count over every HZ position; volumes with missing values
// (NaN, or a mask) likewise, their errors as ErrorGivenAvailability gives
// them; stores of format 1 refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>

#include "hierarchy/hz_order.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/dense/dense_test_util.h"

namespace simplexdb {
namespace {

using testing::AllAnswers;
using testing::BuildStore;
using testing::ExpectDiamondErrors;
using testing::ExpectFields;
using testing::ForEachInternalCode;
using testing::TempDir;
using testing::TestVolume;

// The blocks stored are exactly block 0 and those holding a non-zero error,
// counted over every node; every brick of every lattice is stored.
template <int D>
void ExpectOnlyBlocksWithData(const DenseStore& store) {
  const DenseHeader& h = store.header();
  const HzOrder<D> order(h.domain_bits);
  DenseStore::Reader<D> reader(store);
  std::set<uint64_t> needed = {0};
  ForEachInternalCode<D>(h.leaf_level(), [&](SimplexCode<D> c) {
    const uint64_t p = order.PositionOf(c);
    if (p < h.error_positions() && *reader.ErrorBound(c) > 0) needed.insert(p >> h.block_bits);
  });
  EXPECT_EQ(h.stored_blocks, needed.size());
  for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
    ASSERT_EQ(store.StoredIndex(b).has_value(), needed.count(b) == 1) << b;
  }
  uint64_t bricks = 0;
  for (int s = 0; s < store.grid().lattices(); ++s) bricks += store.grid().Count(s);
  EXPECT_EQ(h.bricks, bricks);
}

// Builds `v` with float32 errors (blocks of 2^block_bits nodes when given)
// and checks every diamond error and field against brute force, then the
// store's checksums; with `padding`, also that only blocks with data are
// stored and that they are fewer than half the virtual blocks.
template <int D>
void ExpectF32Store(const TestVolume& v, std::optional<int> block_bits, bool padding) {
  TempDir dir;
  DenseBuildOptions o;
  o.quantization = Quantization::kF32;
  if (block_bits) o.block_bits = *block_bits;
  const auto store = BuildStore(v, dir, "v", o);
  ASSERT_NE(store, nullptr);
  ExpectDiamondErrors<D>(*store, v);
  ExpectFields<D>(*store, v);
  ASSERT_TRUE(store->Verify().ok());
  if (!padding) return;
  ExpectOnlyBlocksWithData<D>(*store);
  EXPECT_LT(store->header().stored_blocks, store->header().virtual_blocks / 2);
}

TEST(DenseStore, Ht17DiamondErrorsAndFields) {
  ExpectF32Store<3>(TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kU8, 1), std::nullopt, false);
}

TEST(DenseStore, Hp9DiamondErrorsAndFields) {
  ExpectF32Store<4>(TestVolume::Random(4, {9, 9, 9, 9}, VoxelType::kI16, 2), 6, false);
}

// Non-cubic grids: padding vertices whose diamonds reach real points keep
// their errors; blocks wholly in the padding are not stored. The real grid
// is 3% of the domain in HT, a tenth in HP: most virtual blocks are padding.
TEST(DenseStore, HtNonCubicKeepsOnlyBlocksWithData) {
  ExpectF32Store<3>(TestVolume::Random(3, {11, 6, 17, 1}, VoxelType::kF32, 3), 6, true);
}

TEST(DenseStore, HpShortFourthAxisKeepsOnlyBlocksWithData) {
  ExpectF32Store<4>(TestVolume::Random(4, {7, 5, 6, 3}, VoxelType::kU8, 4), 6, true);
}

// Quantized errors: never below the brute-force diamond error, within a
// quantum of it; raw and zstd blocks, and a store read in memory (every
// finest error computed at open), give the same answers, by node and by the
// threshold query's lookup (a threshold answer is the bound, or a brick's
// or block's maximum, at least the bound, when that is at most the
// threshold).
template <int D>
void ExpectQuantizedErrors(const TestVolume& v, const std::string& name) {
  SCOPED_TRACE(name);
  TempDir dir;
  for (const Quantization q : {Quantization::kU16, Quantization::kU8}) {
    SCOPED_TRACE(static_cast<int>(q));
    DenseBuildOptions zstd, raw;
    zstd.quantization = raw.quantization = q;
    raw.compression = Compression::kNone;
    const auto z = BuildStore(v, dir, "z", zstd);
    const auto r = BuildStore(v, dir, "r", raw);
    ASSERT_TRUE(z != nullptr && r != nullptr);
    ExpectDiamondErrors<D>(*z, v);
    DenseStore::Options in_memory;
    in_memory.in_memory = true;
    auto resident = DenseStore::Open(dir / "z.sdb", in_memory);
    ASSERT_TRUE(resident.ok()) << resident.status().message();
    ASSERT_TRUE((*resident)->Verify().ok());
    DenseStore::Reader<D> zr(*z), rr(*r), mr(**resident);
    ForEachInternalCode<D>(z->header().leaf_level(), [&](SimplexCode<D> c) {
      const double e = *zr.ErrorBound(c);
      ASSERT_EQ(e, *rr.ErrorBound(c)) << c.ToString();
      ASSERT_EQ(e, *mr.ErrorBound(c)) << c.ToString();
      for (const double t : {0.0, e / 2, e}) {
        for (DenseStore::Reader<D>* reader : {&zr, &mr}) {
          const double a = *reader->ErrorBoundForThreshold(c, t);
          ASSERT_GE(a, e) << c.ToString() << " threshold " << t;
          if (e > t) {
            ASSERT_EQ(a, e) << c.ToString() << " threshold " << t;
          } else {
            ASSERT_LE(a, t) << c.ToString() << " threshold " << t;
          }
        }
      }
    });
    ExpectFields<D>(*r, v);
    ASSERT_TRUE(r->Verify().ok());
  }
}

TEST(DenseStore, QuantizedErrorsRoundUpAndEncodingsAgree) {
  ExpectQuantizedErrors<3>(TestVolume::Random(3, {17, 13, 9, 1}, VoxelType::kU16, 5), "ht");
  ExpectQuantizedErrors<3>(TestVolume::Random(3, {21, 7, 12, 1}, VoxelType::kF32, 32), "ht_padded");
  // A domain whose every octave fits in block 0 (D k < block bits): the
  // finest octave's part of it is not stored.
  ExpectQuantizedErrors<3>(TestVolume::Random(3, {9, 8, 7, 1}, VoxelType::kF32, 36), "ht9");
  ExpectQuantizedErrors<4>(TestVolume::Random(4, {5, 4, 5, 3}, VoxelType::kU8, 37), "hp5");
  ExpectQuantizedErrors<4>(TestVolume::Random(4, {6, 9, 5, 3}, VoxelType::kF32, 34), "hp_short");
}

// A store of format 1 (the layout before 2026-11-26; tests/storage/dense/
// golden keeps two) is refused, naming the file and saying to import again.
TEST(DenseStore, FormatOneIsRefusedSayingToImportAgain) {
  for (const char* file : {"format1_ht_7x6x5_u8_u16.sdb", "format1_hp_3x3x3x3_i16_f32.sdb"}) {
    const std::string path = std::string(SIMPLEXDB_GOLDEN_DIR) + "/" + file;
    const auto old = DenseStore::Open(path);
    ASSERT_FALSE(old.ok()) << file;
    EXPECT_EQ(old.status().code(), Status::Code::kNotSupported);
    EXPECT_NE(old.status().message().find(path + ": a format-1 dense store"), std::string::npos)
        << old.status().message();
    EXPECT_NE(old.status().message().find("import the volume again"), std::string::npos);
  }
}

// A build leaves the store and nothing else: no scratch file, also for a
// volume with missing values.
TEST(DenseStore, BuildLeavesOnlyTheStore) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {12, 9, 14, 1}, VoxelType::kF32, 8);
  ASSERT_NE(BuildStore(v, dir, "v"), nullptr);
  testing::PunchHoles(v, 9, 2.5, 0);
  ASSERT_NE(BuildStore(v, dir, "w"), nullptr);
  EXPECT_EQ(testing::SortedNames(dir.path()),
            (std::vector<std::string>{"v.nrrd", "v.sdb", "w.nrrd", "w.sdb"}));
}

// A build in one window reads the field in chunks of 2^20 voxels on every
// worker; a value no store can hold is still reported as a one-thread read
// would: the first in file order (chunk 0 here, though chunk 2 holds one too
// and is shorter).
TEST(DenseStore, TheFirstBadValueInFileOrderIsReported) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {129, 129, 129, 1}, VoxelType::kF64, 38);
  v.values[1000000] = 1e39;                                      // (121, 11, 60)
  v.values[2100000] = std::numeric_limits<double>::infinity();  // (9, 25, 126)
  ASSERT_TRUE(v.WriteNrrd(dir / "v.nrrd").ok());
  DenseBuildOptions options;
  options.threads = 2;
  const auto built = BuildDenseStore(*OpenVolume(dir / "v.nrrd"), dir / "w.sdb", options);
  ASSERT_FALSE(built.ok());
  EXPECT_TRUE(built.status().IsInvalidArgument()) << built.status().ToString();
  EXPECT_NE(built.status().message().find("value 1e+39 at voxel (121, 11, 60) is beyond float32's range"),
            std::string_view::npos)
      << built.status().ToString();
  EXPECT_EQ(testing::SortedNames(dir.path()), (std::vector<std::string>{"v.nrrd"}));
}

// Missing values (NaN in a float volume): every node's error is
// ErrorGivenAvailability's (0 where no point has a value, the range where
// some point or vertex has none), every octave's stored; the field NaN
// where missing. HT and HP, holes and scattered points, f32 and u16.
template <int D>
void ExpectMissingValues(TestVolume v, const std::string& name, uint64_t seed, double radius) {
  SCOPED_TRACE(name);
  testing::PunchHoles(v, seed, radius, 23);
  TempDir dir;
  for (const Quantization q : {Quantization::kF32, Quantization::kU16}) {
    SCOPED_TRACE(static_cast<int>(q));
    DenseBuildOptions o;
    o.quantization = q;
    o.block_bits = 6;
    const auto store = BuildStore(v, dir, "v", o);
    ASSERT_NE(store, nullptr);
    EXPECT_TRUE(store->header().finest_stored());
    ExpectDiamondErrors<D>(*store, v);
    ExpectFields<D>(*store, v);
    ASSERT_TRUE(store->Verify().ok());
  }
}

TEST(DenseStore, MissingValuesHt) {
  ExpectMissingValues<3>(TestVolume::Random(3, {11, 13, 9, 1}, VoxelType::kF32, 35), "ht", 1, 2.5);
  ExpectMissingValues<3>(TestVolume::Random(3, {17, 9, 14, 1}, VoxelType::kF64, 39), "ht_f64", 2, 3.5);
}

TEST(DenseStore, MissingValuesHp) {
  ExpectMissingValues<4>(TestVolume::Random(4, {6, 5, 7, 4}, VoxelType::kF32, 40), "hp", 3, 1.5);
}

// Every value missing: a store of zeros that says so (range 0 to 0).
TEST(DenseStore, EveryValueMissing) {
  TempDir dir;
  TestVolume v = TestVolume::Random(3, {6, 5, 4, 1}, VoxelType::kF32, 44);
  for (double& x : v.values) x = std::nan("");
  const auto store = BuildStore(v, dir, "v");
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->header().field_min, 0);
  EXPECT_EQ(store->header().field_max, 0);
  EXPECT_EQ(store->header().error_max, 0);
  ExpectFields<3>(*store, v);
}

// A mask: an integer volume with the masked points missing, stored as
// float32, errors as for NaN at those points.
TEST(DenseStore, MaskMakesMissingValues) {
  TempDir dir;
  const TestVolume v = TestVolume::Random(3, {13, 10, 11, 1}, VoxelType::kU8, 45);
  TestVolume mask = TestVolume::Random(3, v.dims, VoxelType::kU8, 46);
  TestVolume masked = v;
  masked.type = VoxelType::kF32;
  for (size_t i = 0; i < mask.values.size(); ++i) {
    // Mostly kept; a slab and a few points masked (0), others 1 or 200.
    const bool drop = mask.values[i] < 20 || (i / 130) % 11 == 3;
    mask.values[i] = drop ? 0 : (mask.values[i] < 128 ? 1 : 200);
    if (drop) masked.values[i] = std::nan("");
  }
  DenseBuildOptions o;
  o.block_bits = 6;
  const auto store = BuildStore(v, dir, "v", o, &mask);
  ASSERT_NE(store, nullptr);
  EXPECT_EQ(store->header().voxel_type, VoxelType::kF32);
  EXPECT_TRUE(store->header().finest_stored());
  ExpectDiamondErrors<3>(*store, masked);
  ExpectFields<3>(*store, masked);

  // A mask of another grid is refused before anything is written.
  TestVolume small = TestVolume::Random(3, {13, 10, 10, 1}, VoxelType::kU8, 47);
  ASSERT_TRUE(small.WriteNrrd(dir / "small.nrrd").ok());
  o.mask = *OpenVolume(dir / "small.nrrd");
  const auto refused = BuildDenseStore(*OpenVolume(dir / "v.nrrd"), dir / "x.sdb", o);
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(refused.status().IsInvalidArgument()) << refused.status().ToString();
  EXPECT_NE(refused.status().message().find("13x10x10"), std::string_view::npos)
      << refused.status().message();
  EXPECT_FALSE(std::filesystem::exists(dir / "x.sdb"));
}

// A store's bytes depend on the volume and the options, not on the thread
// count: workers finish blocks and bricks in any order, the file holds them
// in the order the build asked for them. One window and several, 3D and
// 4D, with missing values; more workers than cores so that they interleave.
TEST(DenseStore, SameBytesAtAnyThreadCount) {
  TempDir dir;
  TestVolume holed = TestVolume::Random(3, {70, 66, 67, 1}, VoxelType::kF32, 48);
  testing::PunchHoles(holed, 10, 3.5, 49);
  const struct {
    const char* name;
    TestVolume volume;
    bool stream;
  } cases[] = {
      {"ht", TestVolume::Random(3, {70, 66, 67, 1}, VoxelType::kU16, 47), false},
      {"ht_streamed", TestVolume::Random(3, {70, 66, 67, 1}, VoxelType::kU16, 47), true},
      {"ht_missing", holed, false},
      {"ht_missing_streamed", holed, true},
      {"hp_streamed", TestVolume::Random(4, {12, 11, 10, 26}, VoxelType::kU8, 50), true},
      {"hp", TestVolume::Random(4, {12, 11, 10, 26}, VoxelType::kU8, 50), false},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string nrrd = dir / (std::string(c.name) + ".nrrd");
    ASSERT_TRUE(c.volume.WriteNrrd(nrrd).ok());
    std::vector<uint8_t> first;
    for (const int threads : {1, 2, 5}) {
      DenseBuildOptions o;
      o.block_bits = 6;
      o.threads = threads;
      o.stream = c.stream;
      const std::string out = dir / (std::string(c.name) + std::to_string(threads) + ".sdb");
      const auto report = BuildDenseStore(*OpenVolume(nrrd), out, o);
      ASSERT_TRUE(report.ok()) << report.status().message();
      EXPECT_EQ(report->windows > 1, c.stream) << report->windows << " windows";
      const std::vector<uint8_t> bytes = testing::ReadFileBytes(out);
      if (threads == 1) {
        first = bytes;
      } else {
        EXPECT_TRUE(bytes == first) << threads << " threads";
      }
    }
  }
}

}  // namespace
}  // namespace simplexdb
