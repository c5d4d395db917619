// query/open_store.h: a store path becomes the right source (kind x
// dimension), and the query written once over it gives what the source made
// by hand gives.
#include "query/open_store.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <type_traits>

#include "query/refine.h"
#include "query/source.h"
#include "tests/query/query_test_util.h"

namespace simplexdb {
namespace {

using testing::TempDir;
using testing::TestVolume;

// The read interface's concept: the stores' sources and the tests' own model
// it; only the dense source answers threshold tests from its index.
static_assert(ThresholdReadSource<DenseSource<3>, 3> && ThresholdReadSource<DenseSource<4>, 4>);
static_assert(ReadSource<SparseSource<3>, 3> && !ThresholdReadSource<SparseSource<3>, 3>);
static_assert(ReadSource<testing::FullSource<3>, 3> && ReadSource<testing::FullSource<4>, 4>);
static_assert(!ReadSource<DenseSource<3>, 4>);  // a source serves one hierarchy
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

template <int D>
void CheckVisits(uint32_t side) {
  TempDir dir;
  const TestVolume volume = TestVolume::Random(D, {side, side, side, D == 4 ? side : 1}, VoxelType::kU8, 3);
  auto dense = testing::BuildDense(volume, dir.path(), "d");
  auto sparse = testing::BuildSparse(*dense, dir.path() + "/s.lmdb", 0);
  const double threshold = (dense->header().field_max - dense->header().field_min) * 0.1;
  DenseSource<D> direct(*dense);
  const std::vector<uint64_t> want = DepthFirstLeaves<D>(direct, threshold);
  ASSERT_GT(want.size(), size_t{SimplexCode<D>::kRoots});

  for (const auto& [store_path, store_kind] : {std::pair{dir.path() + "/d.sdb", StoreKind::kDense},
                                               std::pair{dir.path() + "/s.lmdb", StoreKind::kSparse}}) {
    const std::string path = store_path;
    const StoreKind kind = store_kind;
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
  auto dense = testing::BuildDense(volume, dir.path(), "d");
  auto sparse = testing::BuildSparse(*dense, dir.path() + "/s.lmdb", 0);
  StoreOptions options;
  options.cache_bytes = 12345;
  Result<AnyStore> cached = AnyStore::Open(dir.path() + "/d.sdb", options);
  ASSERT_TRUE(cached.ok());
  ASSERT_NE(cached->dense()->cache(), nullptr);
  EXPECT_EQ(cached->dense()->cache()->capacity(), 12345u);
  options.in_memory = true;
  Result<AnyStore> in_memory = AnyStore::Open(dir.path() + "/d.sdb", options);
  ASSERT_TRUE(in_memory.ok());
  EXPECT_EQ(in_memory->dense()->cache(), nullptr);
  // The LMDB store is read in place: in_memory is a mistake, said so.
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

}  // namespace
}  // namespace simplexdb
