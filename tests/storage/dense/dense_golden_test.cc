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

#include <cstdlib>
#include <filesystem>
#include <unordered_map>

#include "hierarchy/cluster.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_format.h"
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
  uint64_t seed;
};

// Grids that do not fill their domains (the finest errors computed at the
// real grid's faces) and both hierarchies.
const Golden kGolden[] = {
    {"ht_7x6x5_u8_u16.sdb", 3, {7, 6, 5, 1}, VoxelType::kU8, Quantization::kU16, 201},
    {"hp_3x3x3x3_i16_f32.sdb", 4, {3, 3, 3, 3}, VoxelType::kI16, Quantization::kF32, 202},
};

std::string GoldenPath(const Golden& g) {
  return std::string(SIMPLEXDB_GOLDEN_DIR) + "/" + g.file;
}

Status Build(const Golden& g, const std::string& dir, const std::string& out) {
  const TestVolume volume = TestVolume::Random(g.dimension, g.dims, g.type, g.seed);
  SDB_RETURN_IF_ERROR(volume.WriteNrrd(dir + "/in.nrrd"));
  DenseBuildOptions options;
  options.quantization = g.quantization;
  options.compression = Compression::kNone;
  options.block_bits = 6;  // several blocks on a small grid
  options.threads = 1;
  SDB_ASSIGN_OR_RETURN(const VolumeInfo input, OpenVolume(dir + "/in.nrrd"));
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
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < h.leaf_level(); ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) {
        const SimplexCode<D> c = SimplexCode<D>::FromPath(top, p, l);
        long double truth = 0;
        for (const auto m : Cluster(c)) truth = std::max(truth, error_of(m));
        const Result<double> stored = reader.ErrorBound(c);
        ASSERT_TRUE(stored.ok()) << stored.status().ToString();
        ASSERT_GE(static_cast<long double>(*stored), truth) << c.ToString();
        ASSERT_LE(static_cast<long double>(*stored), truth * (1 + 1e-6L) + h.quantum + 1e-9L)
            << c.ToString();
      }
    }
  }
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

TEST(DenseGolden, ReferenceStoresStillReadAndRebuildIdentically) {
  const bool regenerate = std::getenv("SIMPLEXDB_REGENERATE_GOLDEN") != nullptr;
  for (const Golden& g : kGolden) {
    SCOPED_TRACE(g.file);
    const TempDir dir;
    const std::string fresh = dir.path() + "/fresh.sdb";
    const Status built = Build(g, dir.path(), fresh);
    ASSERT_TRUE(built.ok()) << built.ToString();
    if (regenerate) {
      std::filesystem::copy_file(fresh, GoldenPath(g),
                                 std::filesystem::copy_options::overwrite_existing);
    }
    ASSERT_TRUE(std::filesystem::exists(GoldenPath(g))) << "missing reference file";
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
    ASSERT_TRUE(std::equal(a.begin() + kDenseHeaderSize, a.end(), b.begin() + kDenseHeaderSize))
        << "blocks, bricks or indexes changed: a layout change needs a new version";
    DenseHeader ha = *ParseDenseHeader(a, g.file), hb = *ParseDenseHeader(b, "fresh");
    ha.source = hb.source = "";
    EXPECT_EQ(SerializeDenseHeader(ha), SerializeDenseHeader(hb)) << "the header changed";
  }
}

}  // namespace
}  // namespace simplexdb
