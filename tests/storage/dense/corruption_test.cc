// Damaged stores: bit flips anywhere (header, index, blocks) and
// truncations. Every case must be detected (open, a lookup or Verify fails)
// or provably harmless (every lookup gives exactly the undamaged answer).
// Run in the sanitizer build too: nothing may crash or read out of bounds.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <random>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

std::vector<uint8_t> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void WriteFile(const std::string& path, const std::vector<uint8_t>& bytes, size_t size) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(size));
}

// Every answer a store gives: each node's error, each domain point's field.
// Empty optional: some lookup failed (the damage was detected).
template <int D>
std::optional<std::vector<double>> AllAnswers(const DenseStore& store) {
  DenseStore::Reader<D> reader(store);
  std::vector<double> out;
  bool failed = false;
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (failed || c.level() >= store.header().leaf_level()) return;
    const Result<double> e = reader.ErrorBound(c);
    if (!e.ok()) {
      failed = true;
      return;
    }
    out.push_back(*e);
    visit(c.child(0));
    visit(c.child(1));
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  const int64_t side = int64_t{1} << store.header().domain_bits;
  std::array<int64_t, D> p{};
  while (!failed) {
    const Result<double> f = reader.Field(p);
    if (!f.ok()) {
      failed = true;
      break;
    }
    out.push_back(*f);
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
  if (failed) return std::nullopt;
  return out;
}

struct Outcome {
  int detected_at_open = 0;
  int detected_by_lookup = 0;
  int detected_by_verify = 0;
  int harmless = 0;
};

// Opens the damaged copy and classifies the case; fails the test if the
// damage changes an answer without being detected.
template <int D>
void Classify(const std::string& path, const std::vector<double>& truth, bool in_memory,
              Outcome& o, const std::string& what) {
  DenseStore::Options options;
  options.in_memory = in_memory;
  options.cache_bytes = 64 << 10;
  Result<std::unique_ptr<DenseStore>> store = DenseStore::Open(path, options);
  if (!store.ok()) {
    const Status& s = store.status();
    ASSERT_TRUE(s.IsCorruption() || s.IsInvalidArgument() || s.IsNotSupported()) << s.ToString();
    ASSERT_NE(s.message().find(path), std::string_view::npos) << "the message must name the file";
    ++o.detected_at_open;
    return;
  }
  const std::optional<std::vector<double>> answers = AllAnswers<D>(**store);
  const bool verified = (*store)->Verify().ok();
  if (!answers) {
    ++o.detected_by_lookup;
    ASSERT_FALSE(verified) << what << ": a lookup failed but Verify passed";
    return;
  }
  if (*answers == truth) {
    verified ? ++o.harmless : ++o.detected_by_verify;
    return;
  }
  ASSERT_FALSE(verified) << what << ": answers changed and nothing detected it";
  ++o.detected_by_verify;
}

template <int D>
void RunCampaign(int dimension, std::array<uint32_t, 4> dims, Compression compression,
                 uint64_t seed, int flips, int truncations) {
  const TempDir dir;
  const TestVolume volume = TestVolume::Random(dimension, dims, VoxelType::kI16, seed);
  ASSERT_TRUE(volume.WriteNrrd(dir.path() + "/in.nrrd").ok());
  DenseBuildOptions options;
  options.levels_per_block = 4;  // many blocks of every kind
  options.compression = compression;
  const std::string good = dir.path() + "/good.sdb";
  ASSERT_TRUE(BuildDenseStore(*OpenVolume(dir.path() + "/in.nrrd"), good, options).ok());
  const std::vector<double> truth = *AllAnswers<D>(**DenseStore::Open(good));
  const std::vector<uint8_t> bytes = ReadFile(good);
  const DenseHeader header = *ParseHeader(bytes, good);
  std::mt19937_64 rng(seed);
  Outcome o;
  const std::string bad = dir.path() + "/bad.sdb";
  for (int i = 0; i < flips; ++i) {
    // A third each in the header, the index and the blocks.
    size_t at;
    switch (i % 3) {
      case 0: at = rng() % kHeaderSize; break;
      case 1: at = header.index_offset + rng() % (bytes.size() - header.index_offset); break;
      default: at = kHeaderSize + rng() % (header.index_offset - kHeaderSize); break;
    }
    std::vector<uint8_t> copy = bytes;
    copy[at] ^= static_cast<uint8_t>(1u << (rng() % 8));
    WriteFile(bad, copy, copy.size());
    const std::string what = "flip at byte " + std::to_string(at);
    SCOPED_TRACE(what);
    Classify<D>(bad, truth, /*in_memory=*/i % 5 == 0, o, what);
    if (::testing::Test::HasFatalFailure()) return;
  }
  for (int i = 0; i < truncations; ++i) {
    const size_t size = rng() % bytes.size();
    WriteFile(bad, bytes, size);
    const std::string what = "truncated to " + std::to_string(size);
    SCOPED_TRACE(what);
    Classify<D>(bad, truth, false, o, what);
    if (::testing::Test::HasFatalFailure()) return;
  }
  // Every byte is under a checksum: a flip is always detected somewhere,
  // and a truncated file never opens.
  EXPECT_EQ(o.harmless, 0);
  EXPECT_GE(o.detected_at_open, truncations);
  ::testing::Test::RecordProperty("detected_at_open", o.detected_at_open);
  ::testing::Test::RecordProperty("detected_by_lookup", o.detected_by_lookup);
  ::testing::Test::RecordProperty("detected_by_verify", o.detected_by_verify);
}

// 4 x 300 flips + 4 x 60 truncations: 1440 damaged stores.
TEST(Corruption, HtZstd) { RunCampaign<3>(3, {9, 9, 9, 1}, Compression::kZstd, 1, 300, 60); }
TEST(Corruption, HtRaw) { RunCampaign<3>(3, {7, 9, 5, 1}, Compression::kNone, 2, 300, 60); }
TEST(Corruption, HpZstd) { RunCampaign<4>(4, {5, 5, 5, 5}, Compression::kZstd, 3, 300, 60); }
TEST(Corruption, HpRaw) { RunCampaign<4>(4, {5, 4, 3, 5}, Compression::kNone, 4, 300, 60); }

// A store of another format version is refused as such, not as damage.
TEST(Corruption, OtherVersionAndForeignFiles) {
  const TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {5, 5, 5, 1}, VoxelType::kU8, 1);
  ASSERT_TRUE(volume.WriteNrrd(dir.path() + "/in.nrrd").ok());
  const std::string good = dir.path() + "/good.sdb";
  ASSERT_TRUE(BuildDenseStore(*OpenVolume(dir.path() + "/in.nrrd"), good, {}).ok());
  DenseHeader h = *ParseHeader(ReadFile(good), good);
  h.version = 2;
  std::vector<uint8_t> bytes = ReadFile(good);
  const auto header = SerializeHeader(h);
  std::copy(header.begin(), header.end(), bytes.begin());
  WriteFile(dir.path() + "/v2.sdb", bytes, bytes.size());
  Result<std::unique_ptr<DenseStore>> v2 = DenseStore::Open(dir.path() + "/v2.sdb");
  ASSERT_FALSE(v2.ok());
  EXPECT_TRUE(v2.status().IsNotSupported()) << v2.status().ToString();
  EXPECT_NE(v2.status().message().find("version 2"), std::string_view::npos);
  // The input volume itself is not a store.
  Result<std::unique_ptr<DenseStore>> nrrd = DenseStore::Open(dir.path() + "/in.nrrd");
  ASSERT_FALSE(nrrd.ok());
  EXPECT_NE(nrrd.status().message().find("in.nrrd"), std::string_view::npos);
  // A missing file.
  EXPECT_TRUE(DenseStore::Open(dir.path() + "/nope.sdb").status().IsNotFound());
  // An empty file is not a store; a store cut inside its header is damaged.
  WriteFile(dir.path() + "/empty.sdb", bytes, 0);
  EXPECT_TRUE(DenseStore::Open(dir.path() + "/empty.sdb").status().IsInvalidArgument());
  WriteFile(dir.path() + "/cut.sdb", bytes, 100);
  EXPECT_TRUE(DenseStore::Open(dir.path() + "/cut.sdb").status().IsCorruption());
}

}  // namespace
}  // namespace simplexdb
