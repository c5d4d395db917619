// A reader's anonymous memory stays within its cache budget plus a small
// constant, whatever the store's size: measured in a fresh process
// (memory_probe.cc) on a small store and on one with a large block index.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/dense/hz_builder.h"
#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;

struct Probe {
  long anon_before_kib = -1;
  long anon_after_kib = -1;
  unsigned long long blocks_decoded = 0;
};

Probe RunProbe(const std::string& store, size_t cache_bytes, int lookups) {
  const std::string cmd = std::string(SIMPLEXDB_MEMORY_PROBE) + " " + store + " " +
                          std::to_string(cache_bytes) + " " + std::to_string(lookups);
  Probe p;
  FILE* out = popen(cmd.c_str(), "r");
  if (out == nullptr) {
    ADD_FAILURE() << "cannot run " << cmd;
    return p;
  }
  const int fields = std::fscanf(out, "anon_before_kib=%ld anon_after_kib=%ld blocks_decoded=%llu",
                                 &p.anon_before_kib, &p.anon_after_kib, &p.blocks_decoded);
  EXPECT_EQ(pclose(out), 0) << cmd;
  EXPECT_EQ(fields, 3) << cmd;
  return p;
}

// levels_per_block 0: the dense store (format 2); otherwise the per-node
// engine's store (format 1) with that many levels per block.
std::string BuildStore(const TempDir& dir, const std::string& name, int dimension,
                       std::array<uint32_t, 4> dims, int levels_per_block) {
  GenerateOptions g;
  g.dimension = dimension;
  g.dims = dims;
  EXPECT_TRUE(ValidateGenerateOptions(g).ok());
  const FieldGenerator field(g);
  uint64_t points = 1;
  for (int c = 0; c < dimension; ++c) points *= dims[c];
  std::vector<double> values(points);
  field.Fill(0, values.size(), values.data());
  const std::string input = dir.path() + "/" + name + ".nrrd";
  EXPECT_TRUE(WriteNrrd(input, dimension, dims, VoxelType::kF32, values).ok());
  const std::string path = dir.path() + "/" + name + ".sdb";
  if (levels_per_block == 0) {
    const auto built = BuildHzStore(*OpenVolume(input), path, HzBuildOptions{});
    EXPECT_TRUE(built.ok()) << built.status().ToString();
    return path;
  }
  DenseBuildOptions options;
  options.levels_per_block = levels_per_block;
  const auto built = BuildDenseStore(*OpenVolume(input), path, options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return path;
}

TEST(StoreMemory, AnonymousMemoryStaysWithinTheCacheBudgetWhateverTheStoreSize) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer keeps freed memory in quarantine: RSS measures it, not us";
#endif
  const TempDir dir;
  // 1) An HT store of a few thousand compressed blocks, many times the
  //    budget once decoded.
  // 2) An HP store whose padded domain has 393,240 error blocks: its index
  //    alone (40 bytes an entry) is 15 MiB, fifteen times the budget.
  const std::string small = BuildStore(dir, "ht65", 3, {65, 65, 65, 1}, 9);
  const std::string wide = BuildStore(dir, "hp_slab", 4, {129, 3, 3, 2}, 14);
  // 3) The dense store (format 2), HT and HP: error blocks, field bricks and
  //    the finest octave's errors computed per brick share the one budget.
  const std::string hz_ht = BuildStore(dir, "hz_ht129", 3, {129, 129, 129, 1}, 0);
  const std::string hz_hp = BuildStore(dir, "hz_hp33", 4, {33, 33, 33, 33}, 0);
  const auto wide_store = DenseStore::Open(wide);
  ASSERT_TRUE(wide_store.ok());
  ASSERT_EQ((*wide_store)->block_count(), 393240u + 9u);

  constexpr size_t kBudget = size_t{1} << 20;
  // Thread-local zstd context, a few blocks held by the reader, one state
  // byte per block (384 KiB for the wide store), the allocator's slack.
  constexpr long kConstantKib = 4 << 10;
  for (const std::string& store : {small, wide, hz_ht, hz_hp}) {
    SCOPED_TRACE(store);
    // Format 2's lookups that miss compute a brick's finest errors (about
    // a millisecond in the HP): fewer of them exercise its cache as well.
    const bool format2 = store == hz_ht || store == hz_hp;
    const Probe p = RunProbe(store, kBudget, format2 ? 5000 : 300000);
    ASSERT_GT(p.anon_before_kib, 0) << "no RssAnon in /proc/self/status";
    EXPECT_GT(p.blocks_decoded, 300u) << "the lookups barely exercised the cache";
    EXPECT_LE(p.anon_after_kib - p.anon_before_kib, static_cast<long>(kBudget >> 10) + kConstantKib)
        << "anonymous memory grew from " << p.anon_before_kib << " KiB to " << p.anon_after_kib
        << " KiB with a cache budget of " << (kBudget >> 10) << " KiB";
  }
}

}  // namespace
}  // namespace simplexdb
