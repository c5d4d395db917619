// query/open_store.h: a store path becomes the right source (kind x
// dimension), and the query written once over it gives what the source made
// by hand gives.
#include "query/open_store.h"

#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <string>
#include <type_traits>

#include "query/refine.h"
#include "query/source.h"
#include "storage/io/lmdb.h"
#include "storage/dense/dense_builder.h"
#include "storage/sparse/sparse_builder.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// The read interface's concept: the stores' sources and the tests' own model
// it.
static_assert(ThresholdReadSource<DenseSource<3>, 3> && ThresholdReadSource<DenseSource<4>, 4>);
static_assert(OrderedReadSource<DenseSource<3>, 3> && OrderedReadSource<DenseSource<4>, 4>);
static_assert(ReadSource<SparseSource<3>, 3> && ReadSource<SparseSource<4>, 4>);
static_assert(ReadSource<testing::FullSource<3>, 3> && ReadSource<testing::FullSource<4>, 4>);
static_assert(!ThresholdReadSource<testing::FullSource<3>, 3>);
static_assert(!ReadSource<DenseSource<3>, 4> && !ReadSource<SparseSource<4>, 3>);  // one hierarchy each
static_assert(!ReadSource<int, 3>);

template <int D>
std::vector<uint64_t> DepthFirstLeaves(auto& source, double threshold) {
  Criteria<D> c;
  c.threshold = threshold;
  Refiner<D, std::remove_reference_t<decltype(source)>> refiner(source, c);
  Mesh<D> mesh;
  QueryStats stats;
  EXPECT_TRUE(refiner.Run({Algorithm::kDepthFirst}, mesh, stats).ok());
  return testing::Keys(mesh.Leaves());
}

// The stores of `volume` as import makes them, at dir/name.sdb (dense) and
// dir/name.lmdb (sparse, at tolerance t).
std::unique_ptr<DenseStore> ImportDense(const TestVolume& volume, const std::string& dir,
                                        const std::string& name) {
  return testing::BuildDense(volume, dir, name, DenseBuildOptions{});
}
std::unique_ptr<SparseStore> BuildSparse(const TestVolume& volume, const std::string& dir,
                                         const std::string& name, double t) {
  SparseBuildOptions options;
  options.tolerance = t;
  return testing::BuildSparse(volume, dir, name, options);
}

template <int D>
void CheckVisits(uint32_t side) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(D, {side, side, side, D == 4 ? side : 1}, VoxelType::kU8, 3);
  auto dense = ImportDense(volume, dir.path(), "d");
  // At a tolerance the sparse store's mesh is its own.
  auto sparse = BuildSparse(volume, dir.path(), "s", 2.0);
  const double threshold = (dense->header().field_max - dense->header().field_min) * 0.1;
  DenseSource<D> dense_direct(*dense);
  SparseSource<D> sparse_direct(*sparse);
  const std::vector<uint64_t> want_dense = DepthFirstLeaves<D>(dense_direct, threshold);
  const std::vector<uint64_t> want_sparse = DepthFirstLeaves<D>(sparse_direct, threshold);
  ASSERT_GT(want_dense.size(), size_t{SimplexCode<D>::kRoots});
  ASSERT_GT(want_sparse.size(), size_t{SimplexCode<D>::kRoots});

  for (const auto& [store_path, store_kind] : {std::pair{dir.path() + "/d.sdb", StoreKind::kDense},
                                               std::pair{dir.path() + "/s.lmdb", StoreKind::kSparse}}) {
    const std::string path = store_path;
    const StoreKind kind = store_kind;
    const std::vector<uint64_t>& want = kind == StoreKind::kDense ? want_dense : want_sparse;
    SCOPED_TRACE(path);
    EXPECT_EQ(ProbeStoreKind(path), kind);
    Result<AnyStore> store = AnyStore::Open(path);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    EXPECT_EQ(store->kind(), kind);
    EXPECT_EQ(store->dimension(), D);
    EXPECT_EQ(store->path(), path);
    EXPECT_EQ(store->dense() != nullptr, kind == StoreKind::kDense);
    EXPECT_EQ(store->sparse() != nullptr, kind == StoreKind::kSparse);
    int calls = 0;
    const Status s = store->Visit([&]<int E, class Source>(Source& source) -> Status {
      ++calls;
      EXPECT_EQ(E, D);
      EXPECT_EQ((std::is_same_v<Source, DenseSource<E>>), kind == StoreKind::kDense);
      EXPECT_EQ((std::is_same_v<Source, SparseSource<E>>), kind == StoreKind::kSparse);
      EXPECT_EQ(source.info().path, path);
      EXPECT_EQ(source.info().domain_bits, store->info().domain_bits);
      if constexpr (E == D) {
        EXPECT_EQ(DepthFirstLeaves<D>(source, threshold), want);
      }
      return Status::OK();
    });
    EXPECT_TRUE(s.ok()) << s.ToString();
    EXPECT_EQ(calls, 1);
    // The visitor's own status comes back; a void visitor is OK.
    EXPECT_TRUE(store->Visit([]<int E, class Source>(Source&) { return Status::Corruption("mine"); })
                    .IsCorruption());
    EXPECT_TRUE(store->Visit([]<int E, class Source>(Source&) {}).ok());
    // Moving the handle keeps the stores where they are.
    const DenseStore* d = store->dense();
    const SparseStore* sp = store->sparse();
    AnyStore moved = *std::move(store);
    EXPECT_EQ(moved.dense(), d);
    EXPECT_EQ(moved.sparse(), sp);
    // VisitStore opens, visits once and closes.
    calls = 0;
    EXPECT_TRUE(VisitStore(path, StoreOptions{}, [&]<int E, class Source>(Source&) { ++calls; }).ok());
    EXPECT_EQ(calls, 1);
  }
}

TEST(OpenStore, VisitsEveryKindWithItsSourceHt) { CheckVisits<3>(17); }
TEST(OpenStore, VisitsEveryKindWithItsSourceHp) { CheckVisits<4>(5); }

TEST(OpenStore, OptionsReachTheDenseStore) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 4);
  ImportDense(volume, dir.path(), "d");
  BuildSparse(volume, dir.path(), "s", 0);
  StoreOptions options;
  options.cache_bytes = 12345;
  Result<AnyStore> cached = AnyStore::Open(dir.path() + "/d.sdb", options);
  ASSERT_TRUE(cached.ok());
  ASSERT_NE(cached->dense()->cache(), nullptr);
  EXPECT_EQ(cached->dense()->cache()->capacity(), 12345u);
  options.in_memory = true;
  Result<AnyStore> in_memory = AnyStore::Open(dir.path() + "/d.sdb", options);
  ASSERT_TRUE(in_memory.ok());
  // Every block and brick decoded at open; the cache holds only the finest
  // errors computed from them, unbounded.
  const DenseStore::Stats opened = in_memory->dense()->stats();
  EXPECT_EQ(opened.blocks_decoded + opened.raw_checked,
            in_memory->dense()->stored_blocks() + in_memory->dense()->bricks());
  EXPECT_GT(in_memory->dense()->cache()->capacity(), options.cache_bytes);
  // A shared cache is the sparse store's too.
  StoreOptions shared;
  shared.cache = std::make_shared<BlockCache>(size_t{1} << 20);
  Result<AnyStore> sparse = AnyStore::Open(dir.path() + "/s.lmdb", shared);
  ASSERT_TRUE(sparse.ok()) << sparse.status().ToString();
  EXPECT_TRUE(sparse->Visit([]<int E, class Source>(Source& source) -> Status {
                      return source.Error(SimplexCode<E>::Root(0)).status();
                    })
                  .ok());
  EXPECT_GT(shared.cache->charge(), 0u);
  // The sparse store decodes blocks as read: in_memory is a mistake, said so.
  Result<AnyStore> lmdb = AnyStore::Open(dir.path() + "/s.lmdb", options);
  ASSERT_FALSE(lmdb.ok());
  EXPECT_TRUE(lmdb.status().IsInvalidArgument());
  EXPECT_NE(lmdb.status().message().find("s.lmdb"), std::string_view::npos);
}

TEST(OpenStore, SaysWhyAPathIsNotAStore) {
  TempDir dir;
  int calls = 0;
  const auto visitor = [&]<int E, class Source>(Source&) { ++calls; };
  const std::string missing = dir.path() + "/missing.sdb";
  const Status s = VisitStore(missing, StoreOptions{}, visitor);
  EXPECT_TRUE(s.IsNotFound()) << s.ToString();
  EXPECT_NE(s.message().find("missing.sdb"), std::string_view::npos);
  const std::string text = dir.path() + "/text.sdb";
  std::ofstream(text) << "not a store, not LMDB either\n";
  EXPECT_EQ(ProbeStoreKind(text), StoreKind::kDense);
  EXPECT_TRUE(VisitStore(text, StoreOptions{}, visitor).IsInvalidArgument());
  EXPECT_EQ(calls, 0);
}

// A store of format 1 (dense: one error per simplex; sparse: one LMDB
// entry per node) is refused, saying to import again. The dense one is a
// store of today with format 1's version number: format 1 had the same
// magic and version field (storage/dense/dense_format.h).
TEST(OpenStore, RefusesFormatOneSayingToImportAgain) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(3, {9, 9, 9, 1}, VoxelType::kU8, 5);
  ImportDense(volume, dir.path(), "f1");
  {
    std::fstream f(dir.path() + "/f1.sdb", std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(8);
    const char version_one[4] = {1, 0, 0, 0};  // little-endian
    f.write(version_one, 4);
    ASSERT_TRUE(f.good());
  }
  const Result<AnyStore> store = AnyStore::Open(dir.path() + "/f1.sdb");
  ASSERT_FALSE(store.ok());
  EXPECT_TRUE(store.status().IsNotSupported()) << store.status().ToString();
  EXPECT_NE(store.status().message().find("f1.sdb"), std::string_view::npos);
  EXPECT_NE(store.status().message().find("format-1"), std::string_view::npos);
  EXPECT_NE(store.status().message().find("import the volume again"), std::string_view::npos);
  {  // An LMDB file with format 1's databases.
    lmdb::Env::Options o;
    o.read_only = false;
    o.map_bytes = 1 << 20;
    auto env = *lmdb::Env::Open(dir.path() + "/s1.lmdb", o);
    auto txn = *lmdb::Txn::Begin(*env, false);
    ASSERT_TRUE(txn.OpenDb("meta", true).ok());
    ASSERT_TRUE(txn.OpenDb("errors", true).ok());
    ASSERT_TRUE(txn.OpenDb("field", true).ok());
    ASSERT_TRUE(txn.Commit().ok());
  }
  EXPECT_EQ(ProbeStoreKind(dir.path() + "/s1.lmdb"), StoreKind::kSparse);
  const Result<AnyStore> sparse = AnyStore::Open(dir.path() + "/s1.lmdb");
  ASSERT_FALSE(sparse.ok());
  EXPECT_TRUE(sparse.status().IsNotSupported()) << sparse.status().ToString();
  EXPECT_NE(sparse.status().message().find("s1.lmdb"), std::string_view::npos);
  EXPECT_NE(sparse.status().message().find("import the volume again"), std::string_view::npos);
}

// A NRRD's placement ("space origin:", "space directions:", the time
// axis's "spacings:" and "axis mins:") goes into every kind of store's
// header and comes out of AnyStore's SourceInfo: the values written here
// are the truth.
TEST(AnyStore, SourceInfoHasTheInputsSpacingAndOrigin) {
  TempDir dir;
  struct Case {
    int dimension;
    std::string fields;
    std::array<uint32_t, 4> dims;
    std::array<double, 4> spacing, origin;
  };
  const Case cases[] = {
      {3,
       "sizes: 9 7 5\nspace: left-posterior-superior\n"
       "space directions: (0.5,0,0) (0,0.75,0) (0,0,2.5)\nspace origin: (-10.25,20,3.5)\n",
       {9, 7, 5, 1}, {0.5, 0.75, 2.5, 1}, {-10.25, 20, 3.5, 0}},
      {4,
       "sizes: 5 5 5 3\nkinds: space space space time\nspace: 3D-right-handed\n"
       "space directions: (2,0,0) (0,2,0) (0,0,2.2) none\nspacings: nan nan nan 0.5\n"
       "axis mins: nan nan nan 7\nspace origin: (1,2,3)\n",
       {5, 5, 5, 3}, {2, 2, 2.2, 0.5}, {1, 2, 3, 7}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.dimension);
    uint64_t n = 1;
    for (uint32_t d : c.dims) n *= d;
    std::string voxels(n, '\0'), ones(n, '\1');
    for (uint64_t i = 0; i < n; ++i) voxels[i] = static_cast<char>(i * 37 % 251);
    const std::string name = dir.path() + "/v" + std::to_string(c.dimension);
    std::ofstream(name + ".nrrd", std::ios::binary)
        << "NRRD0004\ntype: uint8\ndimension: " << c.dimension << "\nencoding: raw\n"
        << c.fields << "\n" << voxels;
    std::ofstream(name + "-mask.nrrd", std::ios::binary)
        << "NRRD0004\ntype: uint8\ndimension: " << c.dimension << "\nencoding: raw\n"
        << c.fields << "\n" << ones;
    const Result<VolumeInfo> volume = OpenVolume(name + ".nrrd");
    ASSERT_TRUE(volume.ok()) << volume.status().ToString();
    ASSERT_TRUE(BuildDenseStore(*volume, name + ".sdb", DenseBuildOptions{}).ok());
    DenseBuildOptions masked;  // the format-1 engine's path
    masked.mask = *OpenVolume(name + "-mask.nrrd");
    ASSERT_TRUE(BuildDenseStore(*volume, name + "-masked.sdb", masked).ok());
    SparseBuildOptions sparse;
    sparse.tolerance = 3;
    ASSERT_TRUE(BuildSparseStore(*volume, name + ".lmdb", sparse).ok());
    for (const std::string& store : {name + ".sdb", name + "-masked.sdb", name + ".lmdb"}) {
      SCOPED_TRACE(store);
      const Result<AnyStore> opened = AnyStore::Open(store);
      ASSERT_TRUE(opened.ok()) << opened.status().ToString();
      EXPECT_EQ(opened->info().dims, c.dims);
      EXPECT_EQ(opened->info().spacing, c.spacing);
      EXPECT_EQ(opened->info().origin, c.origin);
    }
  }
}

}  // namespace
}  // namespace simplexdb
