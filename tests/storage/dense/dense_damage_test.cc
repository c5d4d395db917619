// Damaged dense stores: bit flips, byte overwrites and truncations, each
// detected or harmless, never a crash or a read out of bounds (run under
// the sanitizers too).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "storage/dense/dense_store.h"
#include "tests/fuzz/dense_checksums.h"
#include "tests/storage/dense/dense_test_util.h"

namespace simplexdb {
namespace {

using testing::AllAnswers;
using testing::BuildStore;
using testing::ReadFileBytes;
using testing::TempDir;
using testing::TestVolume;

void WriteBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

// Bit flips, byte overwrites and truncations anywhere: each is detected
// (open, a lookup or Verify fails) or harmless (the same answers), and with
// its checksums repaired fails cleanly or answers. Run in the sanitizer
// build too: nothing may crash or read out of bounds.
// `computed`: the finest errors computed by the reader, else stored (the
// volume gets a few missing values).
template <int D>
void DamageCampaign(TestVolume volume, Compression compression, int block_bits, uint64_t seed,
                    int cases, bool computed) {
  TempDir dir;
  DenseBuildOptions o;
  o.compression = compression;
  o.block_bits = block_bits;
  if (!computed) {
    volume.type = VoxelType::kF32;
    for (size_t i = 0; i < volume.values.size(); i += 29) volume.values[i] = std::nan("");
  }
  ASSERT_NE(BuildStore(volume, dir, "good", o), nullptr);
  auto good = DenseStore::Open(dir / "good.sdb");
  ASSERT_TRUE(good.ok()) << good.status().message();
  ASSERT_EQ((*good)->header().finest_stored(), !computed);
  const auto truth = AllAnswers<D>(**good);
  ASSERT_TRUE(truth.has_value());
  const std::vector<uint8_t> bytes = ReadFileBytes(dir / "good.sdb");
  good->reset();
  std::mt19937_64 rng(seed);
  int detected = 0, harmless = 0;
  for (int i = 0; i < cases; ++i) {
    std::vector<uint8_t> damaged = bytes;
    size_t size = damaged.size();
    const int kind = static_cast<int>(rng() % 3);
    const size_t at = rng() % damaged.size();
    if (kind == 0) {
      damaged[at] ^= static_cast<uint8_t>(1u << (rng() % 8));
    } else if (kind == 1) {
      damaged[at] = static_cast<uint8_t>(rng());
    } else {
      size = at;
    }
    damaged.resize(size);
    // The same damage behind repaired checksums reaches the structural
    // checks: it may change answers, but must fail cleanly if at all.
    std::vector<uint8_t> repaired = damaged;
    fuzz::RepairDenseChecksums(repaired);
    const std::string path = dir / "damaged.sdb";
    WriteBytes(path, repaired);
    if (auto store = DenseStore::Open(path); store.ok()) {
      (void)AllAnswers<D>(**store);
      (void)(*store)->Verify();
    } else {
      ASSERT_NE(store.status().message().find(path), std::string_view::npos)
          << store.status().ToString();
    }
    WriteBytes(path, damaged);
    DenseStore::Options options;
    options.in_memory = i % 4 == 0;
    options.cache_bytes = 16 << 10;  // a few blocks: evictions too
    auto store = DenseStore::Open(path, options);
    if (!store.ok()) {
      const Status& s = store.status();
      ASSERT_TRUE(s.IsCorruption() || s.IsInvalidArgument() || s.IsNotSupported()) << s.ToString();
      ASSERT_NE(s.message().find(path), std::string_view::npos) << "the message must name the file";
      ++detected;
      continue;
    }
    const auto answers = AllAnswers<D>(**store);
    const bool verified = (*store)->Verify().ok();
    if (!answers) {
      ASSERT_FALSE(verified) << "case " << i << ": a lookup failed but Verify passed";
      ++detected;
      continue;
    }
    if (!verified) {
      ++detected;
      continue;
    }
    ASSERT_TRUE(testing::SameAnswers(*answers, *truth)) << "case " << i << ": kind " << kind << " at byte " << at;
    ++harmless;  // a flip in reserved or unused bytes
  }
  EXPECT_GT(detected, cases * 3 / 4) << harmless << " harmless";
}

// 4 x 300 damaged stores, HT and HP, zstd and raw, finest errors computed
// and stored.
TEST(DenseDamage, DamagedHtZstdIsDetectedOrHarmless) {
  DamageCampaign<3>(TestVolume::Random(3, {13, 11, 9, 1}, VoxelType::kU8, 7), Compression::kZstd,
                    6, 11, 300, true);
}
TEST(DenseDamage, DamagedHtRawIsDetectedOrHarmless) {
  DamageCampaign<3>(TestVolume::Random(3, {9, 7, 12, 1}, VoxelType::kI16, 8), Compression::kNone,
                    6, 12, 300, false);
}
TEST(DenseDamage, DamagedHpZstdIsDetectedOrHarmless) {
  DamageCampaign<4>(TestVolume::Random(4, {5, 5, 4, 5}, VoxelType::kF32, 9), Compression::kZstd,
                    8, 13, 300, false);
}
TEST(DenseDamage, DamagedHpRawIsDetectedOrHarmless) {
  DamageCampaign<4>(TestVolume::Random(4, {5, 3, 5, 4}, VoxelType::kU16, 10), Compression::kNone,
                    8, 14, 300, true);
}

}  // namespace
}  // namespace simplexdb
