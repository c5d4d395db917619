// A reader's anonymous memory stays within its cache budget plus a small
// constant, whatever the store's size: measured in a fresh process
// (memory_probe.cc) on a small store and on one with a large block index.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "storage/dense/dense_builder.h"
#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"
#include "tests/util/sanitizer.h"

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

// A dense store of a Perlin field (float32) of `dims`.
std::string BuildStore(const TempDir& dir, const std::string& name, int dimension,
                       std::array<uint32_t, 4> dims) {
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
  const auto built = BuildDenseStore(*OpenVolume(input), path, DenseBuildOptions{});
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return path;
}

TEST(StoreMemory, AnonymousMemoryStaysWithinTheCacheBudgetWhateverTheStoreSize) {
  if (testing::UnderAddressSanitizer()) {
    GTEST_SKIP() << "AddressSanitizer keeps freed memory in quarantine: RSS measures it, not us";
  }
  const TempDir dir;
  // HT and HP stores many times the budget once decoded: error blocks,
  // field bricks and the finest octave's errors computed per brick share
  // the one budget. And an HP slab whose padded domain is mostly padding
  // (a long block bitmap, few stored blocks).
  const std::string ht = BuildStore(dir, "ht129", 3, {129, 129, 129, 1});
  const std::string hp = BuildStore(dir, "hp33", 4, {33, 33, 33, 33});
  const std::string slab = BuildStore(dir, "hp_slab", 4, {257, 3, 3, 2});

  constexpr size_t kBudget = size_t{1} << 20;
  // What a reader holds whatever its budget and the store's size: the
  // thread-local zstd context, the hierarchy's stencil and diamond tables
  // (built on first use: about 3.5 MiB in the HP, measured), the finest
  // box's window. Measured with a budget of 0, and bounded.
  constexpr long kFixedKib = 6 << 10;
  // Beyond the budget: the blocks the reader holds and the allocator's
  // slack.
  constexpr long kSlackKib = 1 << 10;
  for (const std::string& store : {ht, hp, slab}) {
    SCOPED_TRACE(store);
    // Lookups that miss compute a brick's finest errors (about a
    // millisecond in the HP): a few thousand exercise the cache.
    const Probe fixed = RunProbe(store, 0, 5000);
    const Probe p = RunProbe(store, kBudget, 5000);
    ASSERT_GT(p.anon_before_kib, 0) << "no RssAnon in /proc/self/status";
    if (store != slab) {
      EXPECT_GT(p.blocks_decoded, 300u) << "the lookups barely exercised the cache";
    }
    const long fixed_kib = fixed.anon_after_kib - fixed.anon_before_kib;
    EXPECT_LE(fixed_kib, kFixedKib) << "a reader with no cache holds " << fixed_kib << " KiB";
    EXPECT_LE(p.anon_after_kib - p.anon_before_kib, fixed_kib + static_cast<long>(kBudget >> 10) + kSlackKib)
        << "anonymous memory grew from " << p.anon_before_kib << " KiB to " << p.anon_after_kib
        << " KiB with a cache budget of " << (kBudget >> 10) << " KiB; " << fixed_kib
        << " KiB with none";
  }
}

}  // namespace
}  // namespace simplexdb
