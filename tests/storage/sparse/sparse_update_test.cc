// Updating a box of a sparse store in place, against independent truth: a
// fresh import of the new volume (dense build + conversion, a different
// code path) must hold exactly the same entries; Verify() must pass; and
// readers in another process's view must see the old store or the new one
// in every snapshot, never a mix (checked entry by entry against the
// header of the same snapshot).
#include <gtest/gtest.h>
#include <lmdb.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/sparse/sparse_update.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// Builds a sparse store from `volume` the way `import --sparse` does.
std::string Import(const TestVolume& volume, const std::string& dir, const std::string& name,
                   double relative_tolerance) {
  const std::string nrrd = dir + "/" + name + ".nrrd";
  EXPECT_TRUE(volume.WriteNrrd(nrrd).ok());
  DenseBuildOptions options;
  options.threads = 1;
  options.levels_per_block = 3;
  const std::string dense_path = dir + "/" + name + ".sdb";
  auto built = BuildDenseStore(*OpenVolume(nrrd), dense_path, options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  const auto dense = *DenseStore::Open(dense_path);
  SparseBuildOptions sparse;
  sparse.tolerance = relative_tolerance * (dense->header().field_max - dense->header().field_min);
  const std::string out = dir + "/" + name + ".lmdb";
  auto converted = ConvertDenseToSparse(*dense, out, sparse);
  EXPECT_TRUE(converted.ok()) << converted.status().ToString();
  return out;
}

using Entries = std::vector<std::pair<uint64_t, std::vector<uint8_t>>>;

struct Snapshot {
  SparseHeader header;
  Entries errors, field;
  uint64_t sum = 0;  // over the entries, computed here
};

Entries ReadAll(lmdb::Txn& txn, MDB_dbi dbi, int db, uint64_t* sum) {
  Entries out;
  auto cursor = *lmdb::Cursor::Open(txn, dbi);
  MDB_val k, v;
  for (int rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_FIRST); rc == MDB_SUCCESS;
       rc = mdb_cursor_get(cursor.get(), &k, &v, MDB_NEXT)) {
    const auto* b = static_cast<const uint8_t*>(v.mv_data);
    out.emplace_back(lmdb::KeyValue(k), std::vector<uint8_t>(b, b + v.mv_size));
    *sum += SparseEntryHash(db, {static_cast<const uint8_t*>(k.mv_data), k.mv_size},
                            {b, v.mv_size});
  }
  return out;
}

// One consistent snapshot of a store: its header and every entry.
Snapshot Read(const SparseStore& store) {
  Snapshot s;
  auto txn = *lmdb::Txn::Begin(store.env(), /*read_only=*/true);
  const MDB_dbi meta = *txn.OpenDb("meta", false);
  bool found = false;
  const uint8_t key[] = {'h', 'e', 'a', 'd', 'e', 'r'};
  const auto text = *txn.Get(meta, key, &found);
  EXPECT_TRUE(found);
  s.header = *ParseSparseHeader({reinterpret_cast<const char*>(text.data()), text.size()}, "");
  s.errors = ReadAll(txn, store.errors_db(), kErrorsDb, &s.sum);
  s.field = ReadAll(txn, store.field_db(), kFieldDb, &s.sum);
  return s;
}

Snapshot ReadPath(const std::string& path) { return Read(**SparseStore::Open(path)); }

// `volume` with new values inside the box, drawn from the volume's own
// range. The volume holds its extremes at its first and last points, which
// keep them, so the field range (and with it the error quantum) stays the
// same; the test boxes leave those points out, or take in the whole grid.
// The smallest and largest value, skipping NaN (missing values).
std::pair<double, double> Range(const std::vector<double>& values) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const double v : values) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return {lo, hi};
}

TestVolume Changed(const TestVolume& volume, const GridBox& box, uint64_t seed,
                   const char* how) {
  TestVolume out = volume;
  const auto [lo, hi] = Range(volume.values);
  std::mt19937_64 rng(seed);
  const std::string mode = how;
  for (uint64_t i = 0; i < out.values.size(); ++i) {
    uint64_t rest = i;
    std::array<int64_t, 4> p{};
    bool inside = true;
    for (int a = 0; a < 4; ++a) {
      p[a] = static_cast<int64_t>(rest % volume.dims[a]);
      rest /= volume.dims[a];
      if (a < volume.dimension) inside = inside && p[a] >= box.lo[a] && p[a] <= box.hi[a];
    }
    if (!inside) continue;
    if (mode == "flat") {
      out.values[i] = lo;  // a uniform patch: nodes vanish
    } else if (mode == "holes" && (i % 3 != 0)) {
      out.values[i] = std::numeric_limits<double>::quiet_NaN();  // missing values
    } else {
      const double t = static_cast<double>(rng() % 1000) / 999.0;
      out.values[i] = std::round(lo + t * (hi - lo));
    }
  }
  out.values.front() = lo;
  out.values.back() = hi;
  return out;
}

struct Case {
  const char* name;
  int dimension;
  std::array<uint32_t, 4> dims;
  VoxelType type;
  double tolerance;  // relative to the field range
  // "random", "blob" (noise in a corner, 17 elsewhere) or "holes" (random,
  // NaN in the middle)
  const char* before;
  const char* change;  // "noise", "flat" or "holes" (NaN at two of three points)
  GridBox box;
};

TestVolume MakeVolume(const Case& c) {
  TestVolume v = TestVolume::Random(c.dimension, c.dims, c.type, 11);
  if (std::string(c.before) == "blob") {
    for (uint64_t i = 0; i < v.values.size(); ++i) {
      uint64_t rest = i;
      bool corner = true;
      for (int a = 0; a < c.dimension; ++a) {
        corner = corner && (rest % c.dims[a]) < 5;
        rest /= c.dims[a];
      }
      if (!corner) v.values[i] = 17;
    }
  }
  if (std::string(c.before) == "holes") {
    for (uint64_t i = 0; i < v.values.size(); ++i) {
      uint64_t rest = i;
      int64_t r2 = 0;
      for (int a = 0; a < c.dimension; ++a) {
        const int64_t x = static_cast<int64_t>(rest % c.dims[a]) - 8;
        r2 += x * x;
        rest /= c.dims[a];
      }
      if (r2 <= 12) v.values[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  // The range's extremes at the first and the last point (see Changed).
  const auto [min, max] = Range(v.values);
  v.values.front() = min;
  v.values.back() = max;
  return v;
}

const Case kCases[] = {
    {"ht17_u8_lossless", 3, {17, 17, 17, 1}, VoxelType::kU8, 0, "random", "noise",
     {{3, 4, 5, 0}, {9, 8, 12, 0}}},
    {"ht17_u8_flat_patch", 3, {17, 17, 17, 1}, VoxelType::kU8, 0, "random", "flat",
     {{2, 2, 2, 0}, {12, 13, 11, 0}}},
    {"ht_padded_i16_far_face", 3, {17, 13, 11, 1}, VoxelType::kI16, 0, "random", "noise",
     {{6, 9, 4, 0}, {16, 12, 10, 0}}},
    {"ht17_blob_lossy_new_noise", 3, {17, 17, 17, 1}, VoxelType::kU8, 0.05, "blob", "noise",
     {{9, 10, 8, 0}, {14, 15, 13, 0}}},
    {"ht17_lossy_flat", 3, {17, 17, 17, 1}, VoxelType::kU16, 0.3, "random", "flat",
     {{0, 0, 1, 0}, {16, 16, 8, 0}}},
    {"ht17_lossy_small_box", 3, {17, 17, 17, 1}, VoxelType::kU8, 0.1, "random", "noise",
     {{7, 7, 7, 0}, {8, 9, 8, 0}}},
    {"ht17_lossy_flat_small_box", 3, {17, 17, 17, 1}, VoxelType::kU8, 0.2, "random", "flat",
     {{3, 4, 5, 0}, {5, 6, 6, 0}}},
    // At high tolerances a node's own error can be within the tolerance
    // while a child's subtree (away from the box) is not: it stays for the
    // child's sake. Boxes found by searching for that case.
    {"ht17_lossy_70pct_kept_for_a_child", 3, {17, 17, 17, 1}, VoxelType::kU8, 0.7, "random",
     "flat", {{8, 8, 4, 0}, {8, 9, 4, 0}}},
    {"ht17_lossy_60pct_kept_for_a_child", 3, {17, 17, 17, 1}, VoxelType::kU8, 0.6, "random",
     "flat", {{11, 3, 12, 0}, {12, 4, 13, 0}}},
    {"ht17_whole_grid", 3, {17, 17, 17, 1}, VoxelType::kU8, 0, "random", "noise",
     {{0, 0, 0, 0}, {16, 16, 16, 0}}},
    {"ht17_f32_holes_appear", 3, {17, 17, 17, 1}, VoxelType::kF32, 0, "random", "holes",
     {{2, 3, 4, 0}, {9, 10, 8, 0}}},
    {"ht17_f32_holes_filled_lossy", 3, {17, 17, 17, 1}, VoxelType::kF32, 0.1, "holes", "noise",
     {{5, 6, 5, 0}, {11, 10, 12, 0}}},
    {"hp9_f64_holes_appear", 4, {9, 9, 9, 9}, VoxelType::kF64, 0, "random", "holes",
     {{1, 2, 3, 2}, {5, 6, 6, 5}}},
    {"hp9_u8_lossless", 4, {9, 9, 9, 9}, VoxelType::kU8, 0, "random", "noise",
     {{2, 3, 1, 4}, {5, 6, 4, 7}}},
    {"hp_padded_flat", 4, {9, 7, 9, 6}, VoxelType::kU8, 0, "random", "flat",
     {{1, 2, 3, 1}, {6, 6, 7, 5}}},
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class SparseUpdate : public ::testing::TestWithParam<Case> {};

TEST_P(SparseUpdate, EqualsAFreshImportOfTheNewVolume) {
  const Case& c = GetParam();
  const TempDir dir;
  const TestVolume before = MakeVolume(c);
  const TestVolume after = Changed(before, c.box, 21, c.change);
  const std::string store = Import(before, dir.path(), "before", c.tolerance);
  const std::string fresh = Import(after, dir.path(), "after", c.tolerance);
  const Snapshot old = ReadPath(store);
  const Snapshot want = ReadPath(fresh);
  ASSERT_EQ(old.header.quantum, want.header.quantum) << "the test must keep the field range";

  const auto report = UpdateSparseStore(store, *OpenVolume(dir.path() + "/after.nrrd"), c.box);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  EXPECT_GT(report->nodes_recomputed, 0u);
  const Snapshot got = ReadPath(store);
  EXPECT_EQ(got.errors, want.errors);
  EXPECT_EQ(got.field, want.field);
  EXPECT_EQ(got.header.nodes, want.header.nodes);
  EXPECT_EQ(got.header.vertices, want.header.vertices);
  EXPECT_EQ(got.header.content_sum, want.header.content_sum);
  EXPECT_EQ(got.sum, got.header.content_sum);
  // The error bound: exact, or rounded up by less than one quantum.
  EXPECT_GE(got.header.error_max, want.header.error_max);
  EXPECT_LE(got.header.error_max, want.header.error_max + want.header.quantum);
  // The report counts what changed.
  EXPECT_EQ(report->header.nodes, got.header.nodes);
  EXPECT_EQ(static_cast<int64_t>(got.header.nodes) - static_cast<int64_t>(old.header.nodes),
            static_cast<int64_t>(got.errors.size()) - static_cast<int64_t>(old.errors.size()));
  EXPECT_TRUE((*SparseStore::Open(store))->Verify().ok());
  // The test changes something in every case.
  EXPECT_NE(old.header.content_sum, got.header.content_sum);
}

INSTANTIATE_TEST_SUITE_P(Cases, SparseUpdate, ::testing::ValuesIn(kCases),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

TEST(SparseUpdate, ReadersSeeTheOldStoreOrTheNewOneNeverAMix) {
  const TempDir dir;
  const Case c = kCases[1];  // a flat patch: many nodes and vertices vanish
  const TestVolume before = MakeVolume(c);
  const TestVolume after = Changed(before, c.box, 21, c.change);
  ASSERT_TRUE(after.WriteNrrd(dir.path() + "/after.nrrd").ok());
  const std::string store = Import(before, dir.path(), "before", 0);
  // The outcome, from an update of a copy.
  const std::string copy = dir.path() + "/copy.lmdb";
  std::filesystem::copy_file(store, copy);
  ASSERT_TRUE(UpdateSparseStore(copy, *OpenVolume(dir.path() + "/after.nrrd"), c.box).ok());
  const uint64_t old_sum = ReadPath(store).header.content_sum;
  const uint64_t new_sum = ReadPath(copy).header.content_sum;
  ASSERT_NE(old_sum, new_sum);

  const auto reader_store = *SparseStore::Open(store);
  auto held = *lmdb::Txn::Begin(reader_store->env(), true);  // a snapshot kept throughout
  // Another process updates the store while this one reads snapshots.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const auto r = UpdateSparseStore(store, *OpenVolume(dir.path() + "/after.nrrd"), c.box);
    _exit(r.ok() ? 0 : 1);
  }
  int snapshots = 0, old_seen = 0, new_seen = 0;
  int status = 0;
  while (true) {
    const bool done = waitpid(child, &status, WNOHANG) == child;
    const Snapshot s = Read(*reader_store);
    ASSERT_EQ(s.sum, s.header.content_sum) << "a snapshot mixes two versions";
    ASSERT_TRUE(s.sum == old_sum || s.sum == new_sum);
    ++snapshots;
    (s.sum == old_sum ? old_seen : new_seen)++;
    if (done) break;
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_GT(new_seen, 0) << "the last snapshot, after the update, must be the new store";
  // The snapshot held from before still reads the old store.
  uint64_t sum = 0;
  ReadAll(held, reader_store->errors_db(), kErrorsDb, &sum);
  ReadAll(held, reader_store->field_db(), kFieldDb, &sum);
  EXPECT_EQ(sum, old_sum);
  RecordProperty("snapshots", snapshots);
  RecordProperty("old_seen", old_seen);
}

TEST(SparseUpdate, BadInputIsRefusedWithNothingWritten) {
  const TempDir dir;
  const Case c = kCases[0];
  TestVolume before = MakeVolume(c);
  for (double& v : before.values) v = 10 + std::fmod(v, 190);  // room above and below
  const std::string store = Import(before, dir.path(), "before", 0);
  const uint64_t sum = ReadPath(store).header.content_sum;
  const auto message = [](const Result<SparseUpdateReport>& r) {
    return std::string(r.status().message());
  };

  // Another grid.
  TestVolume other = TestVolume::Random(3, {17, 17, 9, 1}, VoxelType::kU8, 1);
  ASSERT_TRUE(other.WriteNrrd(dir.path() + "/other.nrrd").ok());
  auto r = UpdateSparseStore(store, *OpenVolume(dir.path() + "/other.nrrd"), c.box);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(message(r).find("17x17x9"), std::string::npos) << message(r);
  EXPECT_NE(message(r).find("17x17x17"), std::string::npos) << message(r);

  // A box outside the grid.
  ASSERT_TRUE(before.WriteNrrd(dir.path() + "/same.nrrd").ok());
  r = UpdateSparseStore(store, *OpenVolume(dir.path() + "/same.nrrd"), GridBox{{0, 0, 0, 0}, {4, 17, 3, 0}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(message(r).find("axis y"), std::string::npos) << message(r);

  // Values outside the store's field range (it fixes the quantum).
  TestVolume wide = before;
  const double hi = *std::max_element(before.values.begin(), before.values.end());
  const double lo = *std::min_element(before.values.begin(), before.values.end());
  ASSERT_LT(hi, 255);
  ASSERT_GT(lo, 0);
  wide.values[5 + 17 * (5 + 17 * 5)] = 255;
  ASSERT_TRUE(wide.WriteNrrd(dir.path() + "/wide.nrrd").ok());
  r = UpdateSparseStore(store, *OpenVolume(dir.path() + "/wide.nrrd"), GridBox{{4, 4, 4, 0}, {6, 6, 6, 0}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(message(r).find("field range"), std::string::npos) << message(r);
  EXPECT_NE(message(r).find("(5,5,5)"), std::string::npos) << message(r);

  EXPECT_EQ(ReadPath(store).header.content_sum, sum) << "a refused update wrote something";
  EXPECT_TRUE((*SparseStore::Open(store))->Verify().ok());
}

// A store imported with a mask, updated with a new volume and a new mask:
// the same entries as importing both anew.
TEST(SparseUpdate, WithAMaskEqualsAFreshImport) {
  const TempDir dir;
  const GridBox box{{3, 2, 4, 0}, {11, 9, 10, 0}};
  const TestVolume before = MakeVolume(kCases[0]);
  const TestVolume after = Changed(before, box, 5, "noise");
  TestVolume mask_before = before, mask_after = before;
  for (size_t i = 0; i < before.values.size(); ++i) {
    const int64_t x = i % 17, y = (i / 17) % 17, z = i / (17 * 17);
    const bool inside = x >= box.lo[0] && x <= box.hi[0] && y >= box.lo[1] && y <= box.hi[1] &&
                        z >= box.lo[2] && z <= box.hi[2];
    mask_before.values[i] = (x + y + z) % 5 == 0 ? 0 : 1;
    // Inside the box the mask changes too: a slab is hidden, the rest shown.
    mask_after.values[i] = inside ? (y < 5 ? 0 : 1) : mask_before.values[i];
  }
  // The extremes (first and last point) stay available, keeping the range.
  mask_before.values.front() = mask_before.values.back() = 1;
  mask_after.values.front() = mask_after.values.back() = 1;
  const auto build = [&](const TestVolume& v, const TestVolume& m, const std::string& name) {
    EXPECT_TRUE(v.WriteNrrd(dir.path() + "/" + name + ".nrrd").ok());
    EXPECT_TRUE(m.WriteNrrd(dir.path() + "/" + name + "-mask.nrrd").ok());
    DenseBuildOptions options;
    options.threads = 1;
    options.mask = *OpenVolume(dir.path() + "/" + name + "-mask.nrrd");
    EXPECT_TRUE(BuildDenseStore(*OpenVolume(dir.path() + "/" + name + ".nrrd"),
                                dir.path() + "/" + name + ".sdb", options).ok());
    const auto dense = *DenseStore::Open(dir.path() + "/" + name + ".sdb");
    EXPECT_TRUE(ConvertDenseToSparse(*dense, dir.path() + "/" + name + ".lmdb", {}).ok());
    return dir.path() + "/" + name + ".lmdb";
  };
  const std::string store = build(before, mask_before, "before");
  const std::string fresh = build(after, mask_after, "after");
  ASSERT_EQ(ReadPath(store).header.voxel_type, VoxelType::kF32);
  ASSERT_EQ(ReadPath(store).header.quantum, ReadPath(fresh).header.quantum);
  SparseUpdateOptions options;
  options.mask = *OpenVolume(dir.path() + "/after-mask.nrrd");
  const auto r = UpdateSparseStore(store, *OpenVolume(dir.path() + "/after.nrrd"), box, options);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Snapshot got = ReadPath(store), want = ReadPath(fresh);
  EXPECT_EQ(got.errors, want.errors);
  EXPECT_EQ(got.field, want.field);
  EXPECT_EQ(got.header.content_sum, want.header.content_sum);
  EXPECT_TRUE((*SparseStore::Open(store))->Verify().ok());
  // Without the mask the volume is uint8, the store float32: refused.
  const auto refused = UpdateSparseStore(store, *OpenVolume(dir.path() + "/after.nrrd"), box);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("float32"), std::string_view::npos)
      << refused.status().ToString();
}

}  // namespace
}  // namespace simplexdb
