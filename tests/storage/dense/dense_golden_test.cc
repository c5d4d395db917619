// Stored reference files of the dense store, format 2 (tests/storage/dense/
// golden/dense_*.sdb), so a change of its layout is a decision, not an accident:
//
// - a reference store keeps reading, verifying, and answering with the
//   diamond errors and field values the brute force gives for the volume it
//   was built from;
// - building that volume again (one thread, raw blocks and bricks: no
//   dependence on scheduling or on the zstd version) reproduces the file
//   byte for byte, but for the header's source name and checksum.
//
// To change the layout on purpose, bump kDenseFormatVersion, then regenerate:
//   SIMPLEXDB_REGENERATE_GOLDEN=1 build/release/tests/storage/dense_tests --gtest_filter='DenseGolden*'
#include <gtest/gtest.h>

#include <filesystem>
#include <unordered_map>

#include "hierarchy/cluster.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_format.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/golden_test_util.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::ReadFileBytes;
using testing::TempDir;
using testing::TestVolume;

struct Golden {
  const char* file;
  testing::GoldenVolume volume;
  Quantization quantization;
};

// Grids that do not fill their domains (the finest errors computed at the
// real grid's faces) and both hierarchies.
const Golden kGolden[] = {
    {"ht_7x6x5_u8_u16.sdb", {3, {7, 6, 5, 1}, VoxelType::kU8, 201}, Quantization::kU16},
    {"hp_3x3x3x3_i16_f32.sdb", {4, {3, 3, 3, 3}, VoxelType::kI16, 202}, Quantization::kF32},
};

std::string GoldenPath(const Golden& g) {
  return std::string(SIMPLEXDB_GOLDEN_DIR) + "/" + g.file;
}

Status Build(const Golden& g, const VolumeInfo& input, const std::string& out) {
  DenseBuildOptions options;
  options.quantization = g.quantization;
  options.compression = Compression::kNone;
  options.block_bits = 6;  // several blocks on a small grid
  options.threads = 1;
  return BuildDenseStore(input, out, options).status();
}

// Every node's error bound is its diamond's: the largest brute-force error
// of its cluster, rounded up by at most a quantum; every field value the
// volume's.
template <int D>
void CheckAnswers(const DenseStore& store, const TestVolume& volume) {
  DenseStore::Reader<D> reader(store);
  const DenseHeader& h = store.header();
  std::unordered_map<uint64_t, long double> exact;  // per node, computed once
  const auto error_of = [&](SimplexCode<D> m) {
    auto it = exact.find(m.key());
    if (it == exact.end()) {
      it = exact.emplace(m.key(), testing::BruteForceError<D>(m, h.domain_bits, volume)).first;
    }
    return it->second;
  };
  testing::ForEachInternalCode<D>(h.leaf_level(), [&](SimplexCode<D> c) {
    if (::testing::Test::HasFatalFailure()) return;
    long double truth = 0;
    for (const auto m : Cluster(c)) truth = std::max(truth, error_of(m));
    const Result<double> stored = reader.ErrorBound(c);
    ASSERT_TRUE(stored.ok()) << stored.status().ToString();
    ASSERT_GE(static_cast<long double>(*stored), truth) << c.ToString();
    ASSERT_LE(static_cast<long double>(*stored), truth * (1 + 1e-6L) + h.quantum + 1e-9L) << c.ToString();
  });
  testing::ForEachRealPoint<D>(volume, [&](const IPoint<D>& p, uint64_t i) {
    if (::testing::Test::HasFatalFailure()) return;
    ASSERT_EQ(*reader.Field(p), volume.values[i]);
  });
}

TEST(DenseGolden, ReferenceStoresStillReadAndRebuildIdentically) {
for (const Golden& g : kGolden) {
    SCOPED_TRACE(g.file);
    const TempDir dir;
    const std::string fresh = dir.path() + "/fresh.sdb";
    ASSERT_TRUE(testing::BuildFreshGolden(g.volume, dir.path(), fresh, GoldenPath(g), [&](const auto& in, const auto& out) {
      return Build(g, in, out);
    }));
    auto store = DenseStore::Open(GoldenPath(g));
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    ASSERT_TRUE((*store)->Verify().ok());
    const TestVolume volume = g.volume.Make();
    if (volume.dimension == 3) {
      CheckAnswers<3>(**store, volume);
    } else {
      CheckAnswers<4>(**store, volume);
    }
    // A fresh build writes the same bytes, but for the header's source.
    const std::vector<uint8_t> a = ReadFileBytes(GoldenPath(g)), b = ReadFileBytes(fresh);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_TRUE(std::equal(a.begin() + kDenseHeaderSize, a.end(), b.begin() + kDenseHeaderSize))
        << "blocks, bricks or indexes changed: a layout change needs a new version";
    DenseHeader ha = *ParseDenseHeader(a, g.file), hb = *ParseDenseHeader(b, "fresh");
    ha.source = hb.source = "";
    EXPECT_EQ(SerializeDenseHeader(ha), SerializeDenseHeader(hb)) << "the header changed";
  }
}

}  // namespace
}  // namespace simplexdb
