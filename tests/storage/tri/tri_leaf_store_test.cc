// TriLeafStore: the seed's sorted leaf list (2.6) in LMDB. Random refine and
// coarsen sequences against an in-memory model (a sorted vector and the
// library's TriNeighborOfGreaterOrEqualSize over it), the tiling checked by
// Verify() after every step, reopened from disk; errors for bad input.
#include "storage/tri/tri_leaf_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <random>
#include <set>
#include <span>
#include <vector>

#include "tests/hierarchy/tri_reference.h"
#include "storage/io/lmdb.h"
#include "tests/storage/store_test_util.h"

namespace simplexdb {
namespace {

using testing::AllPolyhedra;
using testing::RandomCode;
using testing::TempDir;

template <class Tag>
class TriLeafStoreTest : public testing::TriFixture<Tag> {};
TYPED_TEST_SUITE(TriLeafStoreTest, AllPolyhedra);

// The model's leaf holding `c`, or None() when c is subdivided.
template <Polyhedron P>
TriCode<P> ModelLeaf(const std::set<TriCode<P>>& leaves, TriCode<P> c) {
  auto it = leaves.upper_bound(c);
  if (it == leaves.begin()) return TriCode<P>::None();
  --it;
  return it->contains(c) ? *it : TriCode<P>::None();
}

template <Polyhedron P>
void Refine(std::set<TriCode<P>>& leaves, TriCode<P> c) {
  const TriCode<P> leaf = ModelLeaf(leaves, c);
  if (leaf.is_none() || leaf == c) return;
  leaves.erase(leaf);
  for (int l = leaf.level() + 1; l <= c.level(); ++l) {
    for (int t = 0; t < 4; ++t) leaves.insert(c.ancestor(l - 1).child(t));
    if (l < c.level()) leaves.erase(c.ancestor(l));
  }
}

template <Polyhedron P>
void Coarsen(std::set<TriCode<P>>& leaves, TriCode<P> c) {
  if (!ModelLeaf(leaves, c).is_none()) return;
  leaves.erase(leaves.lower_bound(c), leaves.upper_bound(TriCode<P>::FromKey(c.range_max())));
  leaves.insert(c);
}

TYPED_TEST(TriLeafStoreTest, RandomEditsMatchTheModelAndPersist) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  TempDir dir;
  const std::string path = dir.path() + "/sphere.tri";
  auto store = TriLeafStore<P>::Create(path);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  std::set<Code> model;
  for (int f = 0; f < Code::kFaces; ++f) model.insert(Code::Face(f));
  std::mt19937_64 rng(41 + static_cast<int>(P));
  for (int step = 0; step < 300; ++step) {
    // Mostly refinements, some deep (to the maximum level); some coarsening.
    const int level = rng() % 10 == 0 ? Code::kMaxLevel : static_cast<int>(rng() % 7);
    const Code c = RandomCode<P>(rng, level);
    SCOPED_TRACE(::testing::Message() << "step " << step << " " << c);
    const bool coarsen = rng() % 4 == 0;
    const Code holder = ModelLeaf(model, c);
    const Status s = coarsen ? (*store)->Coarsen(c) : (*store)->Refine(c);
    const bool legal = coarsen ? (holder.is_none() || holder == c) : !holder.is_none();
    ASSERT_EQ(s.ok(), legal) << s.ToString();
    if (!legal) {
      EXPECT_TRUE(s.IsInvalidArgument());
      EXPECT_NE(s.message().find(c.ToString()), std::string_view::npos) << s.ToString();
    }
    if (coarsen) {
      Coarsen(model, c);
    } else {
      Refine(model, c);
    }
    if (step % 10 == 0) {
      ASSERT_TRUE((*store)->Verify().ok()) << (*store)->Verify().ToString();
    }
  }
  const std::vector<Code> expected(model.begin(), model.end());
  ASSERT_GT(expected.size(), 500u) << "the edits should leave a deep, uneven tree";
  ASSERT_EQ((*store)->Leaves().value(), expected);
  ASSERT_EQ((*store)->LeafCount().value(), expected.size());
  store = Result<std::unique_ptr<TriLeafStore<P>>>(Status::NotFound("closed"));  // close
  auto reopened = TriLeafStore<P>::Open(path, /*read_only=*/true);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  const TriLeafStore<P>& r = **reopened;
  ASSERT_EQ(r.Leaves().value(), expected);
  ASSERT_TRUE(r.Verify().ok());
  // 2.6 through the B-tree equals 2.6 over the sorted vector.
  size_t sizes[3] = {0, 0, 0};
  for (size_t i = 0; i < expected.size(); i += 1 + expected.size() / 500) {
    for (int d = 0; d < 3; ++d) {
      const auto way = static_cast<TriDirection>(d);
      const auto want =
          TriNeighborOfGreaterOrEqualSize<P>(std::span<const Code>(expected), expected[i], way);
      const auto got = r.Neighbor(expected[i], way);
      ASSERT_TRUE(got.ok()) << got.status().ToString();
      ASSERT_EQ(got->code, want.code) << expected[i];
      ASSERT_EQ(got->size, want.size) << expected[i];
      ++sizes[static_cast<int>(got->size)];
    }
    const Code below = expected[i].level() < Code::kMaxLevel ? expected[i].child(2) : expected[i];
    ASSERT_EQ(r.LeafContaining(below).value(), expected[i]);
    ASSERT_EQ(r.LeavesUnder(expected[i]).value(), std::vector<Code>{expected[i]});
    // The centroid's latitude and longitude locate the leaf.
    const LatLng ll = PointToLatLng(SphereCentroid(expected[i]));
    ASSERT_EQ(r.LeafAt(ll).value(), expected[i]) << ll.lat_degrees << "," << ll.lng_degrees;
  }
  EXPECT_GT(sizes[0], 0u);
  EXPECT_GT(sizes[1], 0u);
  EXPECT_GT(sizes[2], 0u);
  // Random points: the leaf found holds the point's deepest triangle.
  std::uniform_real_distribution<double> lat(-90, 90), lng(-180, 180);
  for (int i = 0; i < 2000; ++i) {
    const LatLng p{lat(rng), lng(rng)};
    const Code leaf = r.LeafAt(p).value();
    ASSERT_EQ(leaf, ModelLeaf(model, LatLngToCode<P>(p, Code::kMaxLevel)));
  }
  // Reads of a read-only store work; writes do not.
  const Status w = (*reopened)->Refine(expected.front().level() < Code::kMaxLevel
                                           ? expected.front().child(0)
                                           : expected.front());
  EXPECT_TRUE(w.IsInvalidArgument()) << w.ToString();
}

TYPED_TEST(TriLeafStoreTest, ErrorsNameTheFileAndTheReason) {
  constexpr Polyhedron P = TestFixture::kSolid;
  using Code = typename TestFixture::CodeType;
  TempDir dir;
  const std::string path = dir.path() + "/s.tri";
  EXPECT_TRUE(TriLeafStore<P>::Open(path, true).status().IsNotFound());
  auto store = TriLeafStore<P>::Create(path);
  ASSERT_TRUE(store.ok());
  EXPECT_TRUE(TriLeafStore<P>::Create(path).status().IsInvalidArgument());
  // A subdivided triangle is no leaf, and has no leaf holding it.
  ASSERT_TRUE((*store)->Refine(Code::FromPath(0, 0b1001, 2)).ok());
  const Status again = (*store)->Refine(Code::Face(0));
  EXPECT_TRUE(again.IsInvalidArgument());
  EXPECT_NE(again.message().find("subdivided"), std::string_view::npos) << again.ToString();
  EXPECT_TRUE((*store)->LeafContaining(Code::Face(0)).status().IsNotFound());
  EXPECT_TRUE((*store)->Neighbor(Code::Face(0), TriDirection::kLeft).status().IsInvalidArgument());
  const Status inside = (*store)->Coarsen(Code::FromPath(1, 0b01, 1));
  EXPECT_NE(inside.message().find("inside the leaf 1:"), std::string_view::npos)
      << inside.ToString();
  EXPECT_TRUE((*store)->Verify().ok());
  // Coarsening face 0 gives back the first store.
  ASSERT_TRUE((*store)->Coarsen(Code::Face(0)).ok());
  EXPECT_EQ((*store)->LeafCount().value(), static_cast<uint64_t>(Code::kFaces));
  // Another solid's store, and a file that is no leaf store.
  const std::string other = dir.path() + "/other.tri";
  if constexpr (P == Polyhedron::kIcosahedron) {
    ASSERT_TRUE(TriLeafStore<Polyhedron::kOctahedron>::Create(other).ok());
  } else {
    ASSERT_TRUE(TriLeafStore<Polyhedron::kIcosahedron>::Create(other).ok());
  }
  const Status wrong = TriLeafStore<P>::Open(other, true).status();
  EXPECT_TRUE(wrong.IsInvalidArgument()) << wrong.ToString();
  EXPECT_NE(wrong.message().find(other), std::string_view::npos);
  const std::string junk = dir.path() + "/junk.tri";
  std::ofstream(junk) << std::string(9000, 'x');
  EXPECT_FALSE(TriLeafStore<P>::Open(junk, true).ok());
}

// Verify() finds an overlap and a gap written behind the store's back.
TEST(TriLeafStore, VerifyFindsOverlapsAndGaps) {
  using Code = IcosaCode;
  TempDir dir;
  const std::string path = dir.path() + "/s.tri";
  ASSERT_TRUE(TriLeafStore<Polyhedron::kIcosahedron>::Create(path).ok());
  const auto edit = [&](Code code, bool put) {
    lmdb::Env::Options options;
    options.read_only = false;
    auto env = lmdb::Env::Open(path, options);
    ASSERT_TRUE(env.ok());
    auto txn = lmdb::Txn::Begin(**env, false);
    ASSERT_TRUE(txn.ok());
    const MDB_dbi dbi = txn->OpenDb("leaves", false).value();
    const auto key = lmdb::KeyBytes(code.key());
    if (put) {
      ASSERT_TRUE(txn->Put(dbi, key, {}).ok());
    } else {
      MDB_val k = lmdb::Val(key.data(), key.size());
      ASSERT_EQ(mdb_del(txn->get(), dbi, &k, nullptr), MDB_SUCCESS);
    }
    ASSERT_TRUE(txn->Commit().ok());
  };
  const auto verify = [&] {
    return TriLeafStore<Polyhedron::kIcosahedron>::Open(path, true).value()->Verify();
  };
  ASSERT_TRUE(verify().ok());
  edit(Code::Face(7).child(2), /*put=*/true);  // inside the leaf 7:
  Status s = verify();
  EXPECT_TRUE(s.IsCorruption()) << s.ToString();
  EXPECT_NE(s.message().find("7:10"), std::string_view::npos) << s.ToString();
  edit(Code::Face(7), /*put=*/false);  // 7:10 alone: gaps around it
  EXPECT_TRUE(verify().IsCorruption());
  edit(Code::Face(7).child(2), /*put=*/false);  // face 7 uncovered
  s = verify();
  EXPECT_TRUE(s.IsCorruption()) << s.ToString();
  edit(Code::Face(7), /*put=*/true);
  edit(Code::Face(19), /*put=*/false);  // the last face uncovered
  s = verify();
  EXPECT_NE(s.message().find("19:"), std::string_view::npos) << s.ToString();
}

}  // namespace
}  // namespace simplexdb
