#include "hierarchy/simplex_code.h"

#include "hierarchy/geometry.h"

#include <gtest/gtest.h>

#include <functional>
#include <random>
#include <set>
#include <unordered_set>
#include <vector>

namespace simplexdb {
namespace {

template <class Code>
class SimplexCodeTest : public ::testing::Test {};
using CodeTypes = ::testing::Types<TetCode, PentaCode>;
TYPED_TEST_SUITE(SimplexCodeTest, CodeTypes);

template <class Code>
Code RandomCode(std::mt19937_64& rng, int max_level = Code::kMaxLevel) {
  const int top = static_cast<int>(rng() % Code::kRoots);
  const int level = static_cast<int>(rng() % (max_level + 1));
  const uint64_t path = level == 0 ? 0 : rng() >> (64 - level);
  return Code::FromPath(top, path, level);
}

TEST(SimplexCodeLayout, MaxLevelsAndSize) {
  EXPECT_EQ(TetCode::kMaxLevel, 55);
  EXPECT_EQ(PentaCode::kMaxLevel, 53);
  static_assert(sizeof(TetCode) == 8 && sizeof(PentaCode) == 8);
  static_assert(std::is_trivially_copyable_v<TetCode>);
}

TEST(SimplexCodeLayout, TextFormMatchesTheSeedsExample) {
  // The seed writes 210011: root 2, path 10011.
  const TetCode c = TetCode::Parse("2:10011").value();
  EXPECT_EQ(c.top(), 2);
  EXPECT_EQ(c.level(), 5);
  EXPECT_EQ(c.path(), 0b10011u);
  EXPECT_EQ(c.bit_at(1), 1);
  EXPECT_EQ(c.bit_at(2), 0);
  EXPECT_EQ(c.child_index(), 1);
  EXPECT_EQ(c.ToString(), "2:10011");
  EXPECT_EQ(TetCode::Root(2).ToString(), "2:");
  EXPECT_EQ(TetCode::None().ToString(), "none");
}

TYPED_TEST(SimplexCodeTest, ParseRejectsBadTextWithAReason) {
  using Code = TypeParam;
  for (const char* bad : {"", "2", "x:01", ":01", "2:012", "2:1a", "-1:0", "02:1", "00:",
                          "123:0", "99:"}) {
    SCOPED_TRACE(bad);
    const Result<Code> r = Code::Parse(bad);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(r.status().IsInvalidArgument());
    EXPECT_NE(r.status().message().find(bad), std::string_view::npos);
  }
  // Top out of range for this hierarchy.
  const std::string top = std::to_string(Code::kRoots) + ":0";
  EXPECT_FALSE(Code::Parse(top).ok());
  EXPECT_TRUE(Code::Parse(std::to_string(Code::kRoots - 1) + ":0").ok());
  // Too deep.
  EXPECT_TRUE(Code::Parse("0:" + std::string(Code::kMaxLevel, '1')).ok());
  EXPECT_FALSE(Code::Parse("0:" + std::string(Code::kMaxLevel + 1, '1')).ok());
}

TYPED_TEST(SimplexCodeTest, TextRoundTripOnRandomCodes) {
  using Code = TypeParam;
  std::mt19937_64 rng(1);
  for (int i = 0; i < 100000; ++i) {
    const Code c = RandomCode<Code>(rng);
    ASSERT_TRUE(c.is_valid());
    const Result<Code> back = Code::Parse(c.ToString());
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    ASSERT_EQ(*back, c) << c.ToString();
  }
}

TYPED_TEST(SimplexCodeTest, ValidityOfKeys) {
  using Code = TypeParam;
  EXPECT_FALSE(Code::None().is_valid());
  EXPECT_TRUE(Code::None().is_none());
  EXPECT_FALSE(Code::Root(0).is_none());
  // A path bit below the level makes a key invalid.
  const Code c = Code::FromPath(1, 0b101, 3);
  EXPECT_TRUE(c.is_valid());
  EXPECT_FALSE(Code::FromKey(c.key() | (uint64_t{1} << 20)).is_valid());
  // Level beyond the maximum.
  EXPECT_FALSE(Code::FromKey((c.key() & ~uint64_t{63}) | 63).is_valid());
  // Top beyond the roots.
  const uint64_t bad_top = uint64_t(Code::kRoots) << (64 - Code::kTopBits);
  EXPECT_FALSE(Code::FromKey(bad_top).is_valid());
}

#ifndef NDEBUG
// None() is what a neighbor query returns at the boundary; using it as a
// code is a programming error that debug builds catch.
TYPED_TEST(SimplexCodeTest, NoneIsNotACode) {
  using Code = TypeParam;
  EXPECT_DEATH((void)Code::None().parent(), "is_valid");
  EXPECT_DEATH((void)Code::None().path(), "is_valid");
  EXPECT_DEATH((void)Code::None().heap_index(), "is_valid");
  EXPECT_DEATH((void)Vertices(Code::None()), "is_valid");
}
#endif

TYPED_TEST(SimplexCodeTest, ParentChildSiblingAncestor) {
  using Code = TypeParam;
  std::mt19937_64 rng(2);
  for (int i = 0; i < 100000; ++i) {
    const Code c = RandomCode<Code>(rng, Code::kMaxLevel - 1);
    SCOPED_TRACE(c.ToString());
    for (int b = 0; b < 2; ++b) {
      const Code k = c.child(b);
      ASSERT_EQ(k.level(), c.level() + 1);
      ASSERT_EQ(k.parent(), c);
      ASSERT_EQ(k.child_index(), b);
      ASSERT_EQ(k.top(), c.top());
      ASSERT_EQ(k.path(), c.path() << 1 | uint64_t(b));
      ASSERT_EQ(k.sibling(), c.child(1 - b));
      ASSERT_TRUE(c.is_ancestor_of(k));
      ASSERT_TRUE(c.contains(k));
      ASSERT_FALSE(k.contains(c));
    }
    ASSERT_TRUE(c.contains(c));
    ASSERT_FALSE(c.is_ancestor_of(c));
    for (int l = 0; l <= c.level(); ++l) {
      const Code a = c.ancestor(l);
      ASSERT_EQ(a.level(), l);
      ASSERT_EQ(a.path(), c.path() >> (c.level() - l));
      ASSERT_TRUE(a.contains(c));
    }
    // Another root never contains it.
    ASSERT_FALSE(c.with_top((c.top() + 1) % Code::kRoots).contains(c));
  }
}

// Unsigned key order is depth-first preorder, over all roots: enumerate the
// tree recursively (preorder by definition) and compare.
TYPED_TEST(SimplexCodeTest, KeyOrderIsDepthFirstPreorder) {
  using Code = TypeParam;
  const int max_level = 10;
  std::vector<Code> preorder;
  std::function<void(Code)> rec = [&](Code c) {
    preorder.push_back(c);
    if (c.level() == max_level) return;
    rec(c.child(0));
    rec(c.child(1));
  };
  for (int top = 0; top < Code::kRoots; ++top) rec(Code::Root(top));
  for (size_t i = 1; i < preorder.size(); ++i) {
    ASSERT_LT(preorder[i - 1].key(), preorder[i].key())
        << preorder[i - 1].ToString() << " " << preorder[i].ToString();
  }
  // A subtree is exactly its key range.
  const Code sub = Code::FromPath(1, 0b0110, 4);
  for (const Code c : preorder) {
    const bool in_range = sub.range_min() <= c.key() && c.key() <= sub.range_max();
    ASSERT_EQ(in_range, sub.contains(c)) << c.ToString();
  }
}

TYPED_TEST(SimplexCodeTest, HeapIndexIsTheBinaryHeapNumbering) {
  using Code = TypeParam;
  const int max_level = 12;
  std::vector<bool> seen((size_t{2} << max_level) - 1, false);
  std::function<void(Code)> rec = [&](Code c) {
    const uint64_t i = c.heap_index();
    ASSERT_LT(i, seen.size());
    ASSERT_FALSE(seen[i]);
    seen[i] = true;
    if (c.level() > 0) {
      ASSERT_EQ((i - 1) / 2, c.parent().heap_index());
    }
    if (c.level() == max_level) return;
    ASSERT_EQ(c.child(0).heap_index(), 2 * i + 1);
    ASSERT_EQ(c.child(1).heap_index(), 2 * i + 2);
    rec(c.child(0));
    rec(c.child(1));
  };
  rec(Code::Root(Code::kRoots - 1));
  for (bool s : seen) ASSERT_TRUE(s);
}

TYPED_TEST(SimplexCodeTest, HashSeparatesCodes) {
  using Code = TypeParam;
  std::unordered_set<Code> set;
  std::set<uint64_t> keys;
  std::mt19937_64 rng(3);
  for (int i = 0; i < 50000; ++i) {
    const Code c = RandomCode<Code>(rng);
    set.insert(c);
    keys.insert(c.key());
  }
  EXPECT_EQ(set.size(), keys.size());
}

}  // namespace
}  // namespace simplexdb
