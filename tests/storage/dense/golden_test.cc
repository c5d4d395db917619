// Stored reference files of the dense format (tests/storage/dense/golden/), so a
// format change is a decision, not an accident:
//
// - a reference store keeps reading, with the errors and field values the
//   brute force gives for the volume it was built from;
// - building that volume again (one thread, raw blocks: no dependence on
//   scheduling or on the zstd version) reproduces its blocks and index byte
//   for byte, and its header but for the source name and checksum.
//
// To change the format on purpose, bump kFormatVersion, then regenerate:
//   SIMPLEXDB_REGENERATE_GOLDEN=1 build/release/tests/storage_tests --gtest_filter='Golden*'
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::ReadFileBytes;
using testing::TempDir;
using testing::TestVolume;

struct Golden {
  const char* file;
  int dimension;
  std::array<uint32_t, 4> dims;
  VoxelType type;
  Quantization quantization;
  int levels_per_block;
  uint64_t seed;
};

const Golden kGolden[] = {
    {"ht_7x6x5_u8_u16.sdb", 3, {7, 6, 5, 1}, VoxelType::kU8, Quantization::kU16, 3, 101},
    {"hp_3x3x3x3_i16_f32.sdb", 4, {3, 3, 3, 3}, VoxelType::kI16, Quantization::kF32, 3, 102},
};

std::string GoldenPath(const Golden& g) {
  return std::string(SIMPLEXDB_GOLDEN_DIR) + "/" + g.file;
}

Result<DenseBuildReport> Build(const Golden& g, const std::string& dir, const std::string& out) {
  const TestVolume volume = TestVolume::Random(g.dimension, g.dims, g.type, g.seed);
  EXPECT_TRUE(volume.WriteNrrd(dir + "/in.nrrd").ok());
  DenseBuildOptions options;
  options.quantization = g.quantization;
  options.compression = Compression::kNone;
  options.levels_per_block = g.levels_per_block;
  options.threads = 1;
  return BuildDenseStore(*OpenVolume(dir + "/in.nrrd"), out, options);
}

template <int D>
void CheckAnswers(const DenseStore& store, const TestVolume& volume) {
  DenseStore::Reader<D> reader(store);
  const double quantum = store.quantizer().quantum();
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (c.level() >= store.header().leaf_level()) return;
    const long double truth = testing::BruteForceError<D>(c, store.header().domain_bits, volume);
    const double stored = *reader.ErrorBound(c);
    ASSERT_GE(static_cast<long double>(stored), truth) << c.ToString();
    ASSERT_LE(static_cast<long double>(stored), truth * (1 + 1e-6) + quantum + 1e-9) << c.ToString();
    visit(c.child(0));
    visit(c.child(1));
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  std::array<int64_t, D> p{};
  for (uint64_t i = 0; i < volume.values.size(); ++i) {
    uint64_t rest = i;
    for (int c = 0; c < D; ++c) {
      p[c] = static_cast<int64_t>(rest % volume.dims[c]);
      rest /= volume.dims[c];
    }
    ASSERT_EQ(*reader.Field(p), volume.values[i]);
  }
}

TEST(Golden, ReferenceStoresStillReadAndRebuildIdentically) {
  const bool regenerate = std::getenv("SIMPLEXDB_REGENERATE_GOLDEN") != nullptr;
  for (const Golden& g : kGolden) {
    SCOPED_TRACE(g.file);
    const TempDir dir;
    const std::string fresh = dir.path() + "/fresh.sdb";
    ASSERT_TRUE(Build(g, dir.path(), fresh).ok());
    if (regenerate) {
      std::filesystem::copy_file(fresh, GoldenPath(g),
                                 std::filesystem::copy_options::overwrite_existing);
    }
    ASSERT_TRUE(std::filesystem::exists(GoldenPath(g))) << "missing reference file";
    // The reference store reads, verifies and answers as it should.
    auto store = DenseStore::Open(GoldenPath(g));
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    ASSERT_TRUE((*store)->Verify().ok());
    const TestVolume volume = TestVolume::Random(g.dimension, g.dims, g.type, g.seed);
    if (g.dimension == 3) {
      CheckAnswers<3>(**store, volume);
    } else {
      CheckAnswers<4>(**store, volume);
    }
    // A fresh build writes the same bytes, but for the header's source.
    const std::vector<uint8_t> a = ReadFileBytes(GoldenPath(g)), b = ReadFileBytes(fresh);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_TRUE(std::equal(a.begin() + kHeaderSize, a.end(), b.begin() + kHeaderSize))
        << "blocks or index changed: a format change needs a new version";
    DenseHeader ha = *ParseHeader(a, g.file), hb = *ParseHeader(b, "fresh");
    ha.source = hb.source = "";
    EXPECT_EQ(SerializeHeader(ha), SerializeHeader(hb)) << "the header changed";
  }
}

}  // namespace
}  // namespace simplexdb
