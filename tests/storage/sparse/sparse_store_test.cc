// The sparse (LMDB) store against independent truth: the dense store it was
// converted from, walked node by node by this test's own recursion (which
// nodes must be kept: exactly those with a bound above the tolerance in
// their subtree), and the volume itself (the field rebuilt from a lossy
// store stays within the tolerance of the data at every grid point).
#include <gtest/gtest.h>
#include <lmdb.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>

#include <sys/wait.h>
#include <unistd.h>

#include "hierarchy/geometry.h"
#include "storage/dense/dense_builder.h"
#include "storage/dense/dense_store.h"
#include "storage/io/lmdb.h"
#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "storage/sparse/vertex_set.h"
#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

struct Case {
  const char* name;
  int dimension;
  std::array<uint32_t, 4> dims;
  VoxelType type;
  Quantization quantization;
  // "random": noise everywhere; "blob": noise in a small box, one value
  // elsewhere; "linear": an exactly linear field; "holes": noise with NaN
  // (missing values) in a ball and on the far x face.
  const char* field;
};

TestVolume MakeVolume(const Case& c, uint64_t seed) {
  TestVolume v = TestVolume::Random(c.dimension, c.dims, c.type, seed);
  const std::string field = c.field;
  if (field == "random") return v;
  uint64_t n = v.values.size();
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t rest = i;
    std::array<int64_t, 4> p{};
    for (int a = 0; a < 4; ++a) {
      p[a] = static_cast<int64_t>(rest % c.dims[a]);
      rest /= c.dims[a];
    }
    if (field == "holes") {
      int64_t r2 = 0;
      for (int a = 0; a < c.dimension; ++a) r2 += (p[a] - 3) * (p[a] - 3);
      if (r2 <= 4 || p[0] == c.dims[0] - 1) v.values[i] = std::numeric_limits<double>::quiet_NaN();
    } else if (field == "linear") {
      v.values[i] = static_cast<double>(p[0] + 2 * p[1] + 3 * p[2] + 4 * p[3]);
    } else if (p[0] < 3 || p[0] > 5 || p[1] < 2 || p[1] > 4 || p[2] < 2 || p[2] > 5) {
      v.values[i] = 17;  // "blob": the box x 3..5, y 2..4, z 2..5 keeps its noise
    }
  }
  return v;
}

std::unique_ptr<DenseStore> BuildDense(const TestVolume& volume, Quantization q,
                                       const std::string& dir) {
  EXPECT_TRUE(volume.WriteNrrd(dir + "/in.nrrd").ok());
  DenseBuildOptions options;
  options.quantization = q;
  options.levels_per_block = 3;  // many blocks: exercises the block pruning
  options.threads = 1;
  auto built = BuildDenseStore(*OpenVolume(dir + "/in.nrrd"), dir + "/dense.sdb", options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return *DenseStore::Open(dir + "/dense.sdb");
}

// Equal, or both NaN (a missing value).
bool SameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

// The truth about one node, from the dense store alone.
template <int D>
struct Truth {
  // The largest stored bound in the subtree of every internal node.
  static double SubtreeMax(DenseStore::Reader<D>& dense, SimplexCode<D> c, int leaf) {
    if (c.level() >= leaf) return 0;
    return std::max({*dense.ErrorBound(c), SubtreeMax(dense, c.child(0), leaf),
                     SubtreeMax(dense, c.child(1), leaf)});
  }
};

// Checks every node of the complete hierarchy: kept exactly when its
// subtree holds a bound above the tolerance, with the dense store's stored
// value; every vertex a kept node needs is stored with the dense store's
// value, and nothing else is.
template <int D>
void CheckAgainstDense(const DenseStore& dense, const SparseStore& sparse, double tolerance) {
  DenseStore::Reader<D> d(dense);
  auto s = *SparseStore::Reader<D>::Create(sparse);
  const int leaf = dense.header().leaf_level();
  const int k = dense.header().domain_bits;
  uint64_t kept = 0;
  std::set<uint64_t> needed;
  for (const auto& corner : DomainCorners<D>(k)) needed.insert(SparseStore::VertexKey<D>(corner, k));
  std::function<void(SimplexCode<D>)> visit = [&](SimplexCode<D> c) {
    if (c.level() >= leaf) return;
    const bool keep = Truth<D>::SubtreeMax(d, c, leaf) > tolerance;
    const auto found = *s.FindStored(c);
    ASSERT_EQ(found.has_value(), keep) << c.ToString();
    if (!keep) return;
    ++kept;
    ASSERT_EQ(*found, *d.StoredError(c)) << c.ToString();
    // The vertex the split creates: the midpoint of the split edge, by
    // this test's own geometry (Vertices() from the code).
    const auto v = Vertices<D>(c);
    const auto edge = SplitEdge<D>(c);
    std::array<int64_t, D> mid;
    for (int a = 0; a < D; ++a) {
      mid[a] = ((int64_t{v[edge[0]][a]} + v[edge[1]][a]) / 2) >> (kCoordBits<D> - k);
    }
    needed.insert(SparseStore::VertexKey<D>(mid, k));
    visit(c.child(0));
    visit(c.child(1));
  };
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) visit(SimplexCode<D>::Root(top));
  EXPECT_EQ(kept, sparse.header().nodes);
  // Every domain vertex: stored exactly when needed, with the dense value.
  const uint64_t side = (uint64_t{1} << k) + 1;
  uint64_t points = 1;
  for (int a = 0; a < D; ++a) points *= side;
  for (uint64_t key = 0; key < points; ++key) {
    std::array<int64_t, D> p;
    uint64_t rest = key;
    for (int a = 0; a < D; ++a) {
      p[a] = static_cast<int64_t>(rest % side);
      rest /= side;
    }
    const auto value = *s.Field(p);
    ASSERT_EQ(value.has_value(), needed.count(key) == 1) << key;
    if (value) {
      ASSERT_TRUE(SameValue(*value, *d.Field(p))) << key;
    }
  }
  EXPECT_EQ(needed.size(), sparse.header().vertices);
}

template <int D>
void CheckRebuiltField(const DenseStore& rebuilt, const TestVolume& volume, double tolerance) {
  DenseStore::Reader<D> r(rebuilt);
  const bool integral = volume.type != VoxelType::kF32 && volume.type != VoxelType::kF64;
  const double slack = tolerance + (integral && tolerance > 0 ? 0.5 : 0.0);
  std::array<int64_t, D> p{};
  for (uint64_t i = 0; i < volume.values.size(); ++i) {
    uint64_t rest = i;
    for (int a = 0; a < D; ++a) {
      p[a] = static_cast<int64_t>(rest % volume.dims[a]);
      rest /= volume.dims[a];
    }
    const double got = *r.Field(p);
    if (std::isnan(volume.values[i]) || tolerance == 0) {
      ASSERT_TRUE(SameValue(got, volume.values[i])) << "grid point " << i;
    } else {
      ASSERT_LE(std::abs(got - volume.values[i]), slack * (1 + 1e-12)) << "grid point " << i;
    }
  }
}

class SparseConvert : public ::testing::TestWithParam<std::tuple<Case, double>> {};

TEST_P(SparseConvert, KeepsExactlyTheSubtreesAboveTheToleranceAndRebuildsTheField) {
  const auto& [c, relative] = GetParam();
  const TempDir dir;
  const TestVolume volume = MakeVolume(c, 7);
  const auto dense = BuildDense(volume, c.quantization, dir.path());
  const double range = dense->header().field_max - dense->header().field_min;
  SparseBuildOptions options;
  options.tolerance = relative * range;
  options.initial_map_bytes = 64 << 10;  // small: the map must grow
  const auto report = ConvertDenseToSparse(*dense, dir.path() + "/s.lmdb", options);
  ASSERT_TRUE(report.ok()) << report.status().ToString();
  const auto sparse = SparseStore::Open(dir.path() + "/s.lmdb");
  ASSERT_TRUE(sparse.ok()) << sparse.status().ToString();
  const Status verified = (*sparse)->Verify();
  ASSERT_TRUE(verified.ok()) << verified.ToString();
  EXPECT_EQ((*sparse)->header().tolerance, options.tolerance);
  if (c.dimension == 3) {
    CheckAgainstDense<3>(*dense, **sparse, options.tolerance);
  } else {
    CheckAgainstDense<4>(*dense, **sparse, options.tolerance);
  }
  if (std::string(c.field) == "linear") {
    EXPECT_EQ((*sparse)->header().nodes, 0u) << "a linear field needs no refinement";
  }
  // Back to dense: the field within the tolerance of the data (exact when
  // lossless), and when lossless, every error bound as before.
  DenseBuildOptions back;
  back.threads = 1;
  back.levels_per_block = 3;
  const auto rebuilt_report = ConvertSparseToDense(**sparse, dir.path() + "/back.sdb", back);
  ASSERT_TRUE(rebuilt_report.ok()) << rebuilt_report.status().ToString();
  const auto rebuilt = *DenseStore::Open(dir.path() + "/back.sdb");
  if (c.dimension == 3) {
    CheckRebuiltField<3>(*rebuilt, volume, options.tolerance);
  } else {
    CheckRebuiltField<4>(*rebuilt, volume, options.tolerance);
  }
  if (options.tolerance == 0) {
    // Same volume, same options: the same blocks and index, byte for byte.
    std::ifstream a(dir.path() + "/dense.sdb", std::ios::binary), b(dir.path() + "/back.sdb", std::ios::binary);
    const std::string x((std::istreambuf_iterator<char>(a)), {}), y((std::istreambuf_iterator<char>(b)), {});
    ASSERT_EQ(x.size(), y.size());
    EXPECT_TRUE(x.compare(kHeaderSize, std::string::npos, y, kHeaderSize, std::string::npos) == 0);
  }
}

const Case kCases[] = {
    {"ht9_random_u8_u16", 3, {9, 9, 9, 1}, VoxelType::kU8, Quantization::kU16, "random"},
    {"ht17_blob_i16_u8", 3, {17, 17, 17, 1}, VoxelType::kI16, Quantization::kU8, "blob"},
    {"ht_padded_blob_f32", 3, {11, 9, 7, 1}, VoxelType::kF32, Quantization::kF32, "blob"},
    {"ht17_linear_u16", 3, {17, 17, 17, 1}, VoxelType::kU16, Quantization::kU16, "linear"},
    {"hp5_random_u8_u16", 4, {5, 5, 5, 5}, VoxelType::kU8, Quantization::kU16, "random"},
    {"hp9_blob_u8_u16", 4, {9, 9, 9, 9}, VoxelType::kU8, Quantization::kU16, "blob"},
    {"hp_padded_blob_i16_u8", 4, {7, 6, 5, 3}, VoxelType::kI16, Quantization::kU8, "blob"},
    {"ht17_holes_f32_u16", 3, {17, 17, 17, 1}, VoxelType::kF32, Quantization::kU16, "holes"},
    {"hp_padded_holes_f64_u8", 4, {7, 6, 5, 3}, VoxelType::kF64, Quantization::kU8, "holes"},
};

INSTANTIATE_TEST_SUITE_P(
    Grids, SparseConvert, ::testing::Combine(::testing::ValuesIn(kCases), ::testing::Values(0.0, 0.05, 0.3)),
    [](const auto& param_info) {
      const double relative = std::get<1>(param_info.param);
      return std::string(std::get<0>(param_info.param).name) +
             (relative == 0 ? "_lossless" : relative < 0.1 ? "_t5pct" : "_t30pct");
    });

// Where the field is missing (NaN) nothing is stored: every present node
// has a value at some point (brute force over its points), and a node with
// values and holes is present (the field range is its error), so the holes'
// boundary is resolved to the finest level.
// The header is JSON, the source a path's bytes: bytes that are not UTF-8
// are written as U+FFFD instead of failing the conversion.
TEST(SparseStore, HeaderWithASourceThatIsNotUtf8RoundTrips) {
  SparseHeader h;
  h.dims = {5, 5, 5, 1};
  h.domain_bits = 2;
  h.quantum = 1;
  h.source = "dense store a.sdb (raw file bad\xff" "name.raw)";
  std::string text;
  ASSERT_NO_THROW(text = SerializeSparseHeader(h));
  const Result<SparseHeader> back = ParseSparseHeader(text, "x");
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->source, "dense store a.sdb (raw file bad\xEF\xBF\xBDname.raw)");
}

TEST(SparseStore, MissingRegionsStoreNothing) {
  const TempDir dir;
  const Case c{"holes", 3, {17, 17, 17, 1}, VoxelType::kF32, Quantization::kU16, "holes"};
  const TestVolume volume = MakeVolume(c, 3);
  const auto dense = BuildDense(volume, Quantization::kU16, dir.path());
  ASSERT_TRUE(ConvertDenseToSparse(*dense, dir.path() + "/s.lmdb", {}).ok());
  const auto sparse = *SparseStore::Open(dir.path() + "/s.lmdb");
  auto reader = *SparseStore::Reader<3>::Create(*sparse);
  const int k = sparse->header().domain_bits, leaf = sparse->header().leaf_level();
  uint64_t empty = 0, mixed = 0, present = 0;
  std::function<void(SimplexCode<3>)> visit = [&](SimplexCode<3> code) {
    if (code.level() >= leaf) return;
    const auto [any_value, any_missing] = testing::BruteForceAvailability<3>(code, k, volume);
    const bool stored = (*reader.FindStored(code)).has_value();
    present += stored;
    if (!any_value) {
      ++empty;
      ASSERT_FALSE(stored) << code.ToString() << " has no value, yet is stored";
      return;
    }
    if (any_missing) {
      ++mixed;
      ASSERT_TRUE(stored) << code.ToString() << " is partly missing, yet absent";
    }
    visit(code.child(0));
    visit(code.child(1));
  };
  for (int top = 0; top < 6; ++top) visit(SimplexCode<3>::Root(top));
  EXPECT_GT(empty, 10u);  // the largest empty nodes (their subtrees are not visited)
  EXPECT_GT(mixed, 100u);
  EXPECT_EQ(present, sparse->header().nodes);
}

// Builds a small sparse store for the tests below.
std::string BuildSparse(const TempDir& dir, const TestVolume& volume) {
  const auto dense = BuildDense(volume, Quantization::kU16, dir.path());
  SparseBuildOptions options;
  EXPECT_TRUE(ConvertDenseToSparse(*dense, dir.path() + "/s.lmdb", options).ok());
  return dir.path() + "/s.lmdb";
}

TEST(SparseStore, PrefetchedLookupsAnswerAsBTreeLookups) {
  const TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {17, 17, 17, 1}, VoxelType::kU8, 3);
  const auto store = *SparseStore::Open(BuildSparse(dir, volume));
  auto plain = *SparseStore::Reader<3>::Create(*store);
  auto fetched = *SparseStore::Reader<3>::Create(*store);
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 200; ++trial) {
    // A random subtree, prefetched whole or cut short.
    SimplexCode<3> root = SimplexCode<3>::Root(static_cast<int>(rng() % 6));
    const int depth = static_cast<int>(rng() % 8);
    for (int l = 0; l < depth; ++l) root = root.child(static_cast<int>(rng() & 1));
    const size_t cap = trial % 2 == 0 ? size_t{1} << 20 : 1 + rng() % 50;
    ASSERT_TRUE(fetched.Prefetch(root, cap).ok());
    std::function<void(SimplexCode<3>)> visit = [&](SimplexCode<3> c) {
      if (c.level() > store->header().leaf_level()) return;
      ASSERT_EQ(*fetched.FindStored(c), *plain.FindStored(c)) << c.ToString();
      visit(c.child(0));
      visit(c.child(1));
    };
    visit(root);
    // Outside the subtree as well.
    const SimplexCode<3> other = SimplexCode<3>::Root(static_cast<int>(rng() % 6)).child(1);
    ASSERT_EQ(*fetched.FindStored(other), *plain.FindStored(other));
  }
  EXPECT_GT(fetched.stats().prefetch_hits, 0u);
  EXPECT_GT(fetched.stats().prefetched, 0u);
  EXPECT_EQ(plain.stats().prefetch_hits, 0u);
}

TEST(SparseStore, ReadersKeepTheirSnapshotUntilRefresh) {
  const TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 4);
  const std::string path = BuildSparse(dir, volume);
  const auto store = *SparseStore::Open(path);
  auto reader = *SparseStore::Reader<3>::Create(*store);
  const SimplexCode<3> root = SimplexCode<3>::Root(0);
  const auto before = *reader.FindStored(root);
  ASSERT_TRUE(before.has_value());
  {
    // Another process's writer (here: another environment) changes the root.
    lmdb::Env::Options o;
    o.read_only = false;
    auto env = *lmdb::Env::Open(path, o);
    auto txn = *lmdb::Txn::Begin(*env, false);
    const MDB_dbi errors = *txn.OpenDb("errors", false);
    const uint8_t value[2] = {0x34, 0x12};
    ASSERT_TRUE(txn.Put(errors, lmdb::KeyBytes(root.key()), value).ok());
    ASSERT_TRUE(txn.Commit().ok());
  }
  EXPECT_EQ(*reader.FindStored(root), before) << "the snapshot changed under the reader";
  ASSERT_TRUE(reader.Refresh().ok());
  EXPECT_EQ(*reader.FindStored(root), std::optional<uint32_t>(0x1234));
  // And Verify sees that the content no longer matches its checksum.
  const Status s = store->Verify();
  EXPECT_EQ(s.code(), Status::Code::kCorruption) << s.ToString();
}

// Opens `path` and runs Verify; returns the first failure.
Status OpenAndVerify(const std::string& path) {
  auto store = SparseStore::Open(path);
  if (!store.ok()) return store.status();
  return (*store)->Verify();
}

// Changes the store with a raw LMDB write transaction.
void Edit(const std::string& path, const std::function<void(lmdb::Txn&, MDB_dbi, MDB_dbi)>& edit) {
  lmdb::Env::Options o;
  o.read_only = false;
  auto env = *lmdb::Env::Open(path, o);
  auto txn = *lmdb::Txn::Begin(*env, false);
  const MDB_dbi errors = *txn.OpenDb("errors", false), field = *txn.OpenDb("field", false);
  edit(txn, errors, field);
  ASSERT_TRUE(txn.Commit().ok());
}

TEST(SparseStore, DamagedStoresFailVerifyNamingTheProblem) {
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 6);
  const auto expect_failure = [&](const char* what, const std::string& needle,
                                  const std::function<void(lmdb::Txn&, MDB_dbi, MDB_dbi)>& edit) {
    SCOPED_TRACE(what);
    const TempDir dir;
    const std::string path = BuildSparse(dir, volume);
    ASSERT_TRUE(OpenAndVerify(path).ok());
    Edit(path, edit);
    const Status s = OpenAndVerify(path);
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find(needle), std::string_view::npos) << s.ToString();
  };
  const SimplexCode<3> inner = SimplexCode<3>::Root(2).child(1);
  expect_failure("a node without its parent", "its parent is not", [&](lmdb::Txn& t, MDB_dbi e, MDB_dbi) {
    auto key = lmdb::KeyBytes(inner.key());
    MDB_val k = lmdb::Val(key.data(), 8);
    ASSERT_EQ(mdb_del(t.get(), e, &k, nullptr), 0);
  });
  expect_failure("a value of the wrong size", "bytes", [&](lmdb::Txn& t, MDB_dbi e, MDB_dbi) {
    const uint8_t v[3] = {1, 2, 3};
    ASSERT_TRUE(t.Put(e, lmdb::KeyBytes(inner.key()), v).ok());
  });
  expect_failure("a key that is no code", "invalid", [&](lmdb::Txn& t, MDB_dbi e, MDB_dbi) {
    const uint8_t v[2] = {1, 0};
    ASSERT_TRUE(t.Put(e, lmdb::KeyBytes(~uint64_t{0} - 1), v).ok());
  });
  expect_failure("a stray vertex", "no present node has it", [&](lmdb::Txn& t, MDB_dbi, MDB_dbi f) {
    const uint8_t v[1] = {3};
    ASSERT_TRUE(t.Put(f, lmdb::KeyBytes(9 * 9 * 9), v).ok());  // past the last domain vertex
  });
  expect_failure("a changed field value", "checksum", [&](lmdb::Txn& t, MDB_dbi, MDB_dbi f) {
    MDB_cursor* c;
    ASSERT_EQ(mdb_cursor_open(t.get(), f, &c), 0);
    MDB_val k, v;
    ASSERT_EQ(mdb_cursor_get(c, &k, &v, MDB_LAST), 0);
    uint8_t changed = static_cast<uint8_t>(*static_cast<uint8_t*>(v.mv_data) ^ 1);
    std::array<uint8_t, 8> key;
    std::memcpy(key.data(), k.mv_data, 8);
    mdb_cursor_close(c);
    ASSERT_TRUE(t.Put(f, key, {&changed, 1}).ok());
  });
}

TEST(SparseStore, ForeignAndBrokenFilesGiveClearErrors) {
  const TempDir dir;
  // Not LMDB at all.
  {
    std::ofstream(dir.path() + "/text.lmdb") << "hello, this is not a database\n";
    const auto s = SparseStore::Open(dir.path() + "/text.lmdb");
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.status().code(), Status::Code::kInvalidArgument);
    EXPECT_NE(s.status().message().find("not an LMDB file"), std::string_view::npos);
  }
  // Another program's LMDB file.
  {
    const std::string path = dir.path() + "/other.lmdb";
    lmdb::Env::Options o;
    o.read_only = false;
    o.map_bytes = 1 << 20;
    {
      auto env = *lmdb::Env::Open(path, o);
      auto txn = *lmdb::Txn::Begin(*env, false);
      const MDB_dbi db = *txn.OpenDb("accounts", true);
      const uint8_t v[1] = {1};
      ASSERT_TRUE(txn.Put(db, lmdb::KeyBytes(1), v).ok());
      ASSERT_TRUE(txn.Commit().ok());
      ASSERT_TRUE(env->Sync().ok());
    }
    const auto s = SparseStore::Open(path);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.status().code(), Status::Code::kInvalidArgument);
    EXPECT_NE(s.status().message().find("not a SimplexDB sparse store"), std::string_view::npos)
        << s.status().ToString();
  }
  // A store cut short, and one whose meta pages are overwritten.
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 8);
  const std::string good = BuildSparse(dir, volume);
  const uint64_t size = std::filesystem::file_size(good);
  for (const uint64_t keep : {uint64_t{100}, uint64_t{4096}, uint64_t{8192}, size / 2}) {
    const std::string cut = dir.path() + "/cut" + std::to_string(keep) + ".lmdb";
    std::filesystem::copy_file(good, cut);
    std::filesystem::resize_file(cut, keep);
    const Status s = OpenAndVerify(cut);
    EXPECT_FALSE(s.ok()) << "cut to " << keep << " bytes";
  }
  {
    const std::string zeroed = dir.path() + "/zeroed.lmdb";
    std::filesystem::copy_file(good, zeroed);
    std::fstream f(zeroed, std::ios::in | std::ios::out | std::ios::binary);
    const std::string zeros(8192, '\0');
    f.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
    f.close();
    const auto s = SparseStore::Open(zeroed);
    ASSERT_FALSE(s.ok());
    EXPECT_EQ(s.status().code(), Status::Code::kInvalidArgument) << s.status().ToString();
  }
}

TEST(SparseStore, AKilledConversionLeavesNothingUnderTheFinalName) {
  const TempDir dir;
  // 65^3: 1.5 million nodes, so the walk reports progress part-way.
  const TestVolume volume = TestVolume::Random(3, {65, 65, 65, 1}, VoxelType::kU8, 9);
  const auto dense = BuildDense(volume, Quantization::kU16, dir.path());
  const std::string out = dir.path() + "/s.lmdb";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    SparseBuildOptions options;
    // Die at the first report before the end, with entries already written.
    options.progress = [](const BuildProgress& p) {
      if (p.done < p.total) _exit(3);
    };
    (void)ConvertDenseToSparse(*dense, out, options);
    _exit(0);
  }
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  ASSERT_EQ(WEXITSTATUS(status), 3) << "the conversion ended before it could be killed";
  EXPECT_FALSE(std::filesystem::exists(out)) << "a partial store under the final name";
  // The next conversion succeeds, and clears the dead process's temporary.
  SparseBuildOptions options;
  ASSERT_TRUE(ConvertDenseToSparse(*dense, out, options).ok());
  EXPECT_TRUE(OpenAndVerify(out).ok());
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(e.path().string().find(".tmp."), std::string::npos) << e.path();
  }
}

}  // namespace
}  // namespace simplexdb
