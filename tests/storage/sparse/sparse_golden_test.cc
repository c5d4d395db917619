// Stored reference files of the sparse store, format 2 (tests/storage/
// sparse/golden/*.sdb), so a change of its layout is a decision, not an
// accident:
//
// - a reference store keeps opening, verifying, and answering within its
//   tolerance of the brute force over the volume it was built from;
// - building that volume again writes the same entries: the same block
//   keys, each block's content the same bytes once its zstd frames are
//   decoded (the frames themselves may change with the zstd version), and the
//   same header but for its source name.
//
// To change the layout on purpose, regenerate and say so in
// docs/format/sparse-store.md (a reader must tell the old files apart):
//   SIMPLEXDB_REGENERATE_GOLDEN=1 build/release/tests/storage/sparse_tests --gtest_filter='SparseGolden*'
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <vector>

#include "storage/io/codec.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/golden_test_util.h"
#include "tests/storage/store_test_util.h"
#include "util/little_endian.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

struct Golden {
  const char* file;
  testing::GoldenVolume volume;
  Quantization quantization;
  double tolerance;  // in the field's units; > 0: values in steps of 2t
};

// Grids that do not fill their domains, both hierarchies, a lossless store
// and one whose values are stepped.
const Golden kGolden[] = {
    {"ht_7x6x5_u8_t40.sdb", {3, {7, 6, 5, 1}, VoxelType::kU8, 301}, Quantization::kU16, 40},
    {"hp_3x3x3x3_i16_lossless.sdb", {4, {3, 3, 3, 3}, VoxelType::kI16, 302}, Quantization::kU8, 0},
};

std::string GoldenPath(const Golden& g) { return std::string(SIMPLEXDB_SPARSE_GOLDEN_DIR) + "/" + g.file; }

Status Build(const Golden& g, const VolumeInfo& input, const std::string& out) {
  SparseBuildOptions options;
  options.quantization = g.quantization;
  options.tolerance = g.tolerance;
  options.block_bits = g.volume.dimension + 2;  // several blocks on a small grid
  options.threads = 1;
  return BuildSparseStore(input, out, options).status();
}

// The header (source cleared) and every block's decoded content, by block:
// its parts (keys in order) joined, then its zstd frames decoded.
struct Entries {
  std::vector<uint8_t> header;
  std::map<uint64_t, std::vector<uint8_t>> blocks;
};

Entries ReadEntries(const std::string& path) {
  Entries out;
  SparseHeader header;
  {  // Closed before the file is opened again (one LMDB environment per file and process).
    auto store = SparseStore::Open(path, {});
    EXPECT_TRUE(store.ok()) << store.status().ToString();
    if (!store.ok()) return out;
    header = (*store)->header();
    SparseHeader h = header;
    h.source.clear();
    out.header = EncodeSparseHeader(h);
  }
  auto env = lmdb::Env::Open(path, {});
  EXPECT_TRUE(env.ok()) << env.status().ToString();
  auto txn = lmdb::Txn::Begin(**env, /*read_only=*/true);
  auto dbi = txn->OpenDb(nullptr, false);
  auto cursor = lmdb::Cursor::Open(*txn, *dbi);
  std::map<uint64_t, std::vector<uint8_t>> values;
  MDB_val k, v;
  for (int rc = mdb_cursor_get(cursor->get(), &k, &v, MDB_FIRST); rc == MDB_SUCCESS;
       rc = mdb_cursor_get(cursor->get(), &k, &v, MDB_NEXT)) {
    const std::span<const uint8_t> key(static_cast<const uint8_t*>(k.mv_data), k.mv_size);
    if (IsSparseHeaderKey(key)) continue;
    uint64_t block = 0;
    uint32_t part = 0;
    EXPECT_TRUE(ParseSparseKey(key, &block, &part));
    const auto* bytes = static_cast<const uint8_t*>(v.mv_data);
    values[block].insert(values[block].end(), bytes, bytes + v.mv_size);
  }
  // A block's content: its counts, then its three sections decoded.
  ZstdDecompressor zstd;
  for (const auto& [block, value] : values) {
    if (value.size() < kSparseBlockPrefix + 8) {
      ADD_FAILURE() << path << ": block " << block << " of " << value.size() << " bytes";
      continue;
    }
    const uint32_t candidates = LoadLittle<uint32_t>(value.data() + 4), kept = LoadLittle<uint32_t>(value.data() + 8);
    const uint32_t errors = LoadLittle<uint32_t>(value.data() + 12);
    const size_t frame[2] = {LoadLittle<uint32_t>(value.data() + 16), LoadLittle<uint32_t>(value.data() + 20)};
    const size_t section[3] = {(candidates + size_t{7}) / 8, errors * SparseErrorWidth(header.quantization),
                               kept * SparseResidualWidth(header)};
    std::vector<uint8_t> content(value.begin(), value.begin() + 16);
    size_t at = kSparseBlockPrefix;
    for (int i = 0; i < 3; ++i) {
      const size_t bytes = i < 2 ? frame[i] : value.size() - 8 - at;
      std::vector<uint8_t> decoded(section[i]);
      if (bytes > 0) {
        EXPECT_TRUE(zstd.Decompress(std::span(value).subspan(at, bytes), decoded, path).ok());
      }
      content.insert(content.end(), decoded.begin(), decoded.end());
      at += bytes;
    }
    out.blocks[block] = std::move(content);
  }
  return out;
}

// Every value within the tolerance of the volume; every node's bound 0
// (dropped: its brute-force error within t) or at least its brute-force
// error.
template <int D>
void CheckAnswers(const SparseStore& store, const TestVolume& volume, double t) {
  SparseStore::Reader<D> reader(store);
  const int k = store.header().domain_bits;
  testing::ForEachRealPoint<D>(volume, [&](const IPoint<D>& p, uint64_t i) {
    if (::testing::Test::HasFatalFailure()) return;
    const Result<double> v = reader.Field(p);
    ASSERT_TRUE(v.ok()) << v.status().ToString();
    ASSERT_LE(std::abs(*v - volume.values[i]), t) << i;
  });
  testing::ForEachInternalCode<D>(D * k, [&](SimplexCode<D> c) {
    if (::testing::Test::HasFatalFailure()) return;
    const Result<double> bound = reader.ErrorBound(c);
    ASSERT_TRUE(bound.ok()) << bound.status().ToString();
    const double exact = static_cast<double>(testing::BruteForceError<D>(c, k, volume));
    ASSERT_LE(exact, *bound == 0 ? t + 1e-9 : *bound + 1e-9) << c.ToString();
  });
}

TEST(SparseGolden, ReferenceStoresStillReadAndRebuildIdentically) {
  for (const Golden& g : kGolden) {
    SCOPED_TRACE(g.file);
    const TempDir dir;
    const std::string fresh = dir / "fresh.sdb";
    ASSERT_TRUE(testing::BuildFreshGolden(g.volume, dir.path(), fresh, GoldenPath(g), [&](const auto& in, const auto& out) {
      return Build(g, in, out);
    }));
    // Read a copy: LMDB writes its lock file beside the store.
    const std::string reference = dir / "reference.sdb";
    std::filesystem::copy_file(GoldenPath(g), reference);
    auto store = SparseStore::Open(reference, {});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    ASSERT_TRUE((*store)->Verify().ok());
    EXPECT_EQ((*store)->header().value_step, 2 * g.tolerance);
    const TestVolume volume = g.volume.Make();
    if (volume.dimension == 3) {
      CheckAnswers<3>(**store, volume, g.tolerance);
    } else {
      CheckAnswers<4>(**store, volume, g.tolerance);
    }
    store->reset();
    const Entries want = ReadEntries(reference), got = ReadEntries(fresh);
    EXPECT_EQ(got.header, want.header) << "the header changed";
    EXPECT_GT(want.blocks.size(), 1u);
    ASSERT_EQ(got.blocks.size(), want.blocks.size()) << "other blocks: a layout change";
    for (const auto& [key, content] : want.blocks) {
      const auto it = got.blocks.find(key);
      ASSERT_NE(it, got.blocks.end()) << "block " << key << " is gone: a layout change";
      EXPECT_TRUE(it->second == content) << "block " << key << " changed: a layout change";
    }
  }
}

}  // namespace
}  // namespace simplexdb
