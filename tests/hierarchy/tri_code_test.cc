// TriCode: layout, text form, tree navigation and key order.
#include "hierarchy/tri_code.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>
#include <type_traits>
#include <vector>

#include "tests/hierarchy/tri_reference.h"

namespace simplexdb {
namespace {

using testing::AllPolyhedra;
using testing::RandomCode;

template <class Tag>
class TriCodeTest : public testing::TriFixture<Tag> {};
TYPED_TEST_SUITE(TriCodeTest, AllPolyhedra);

TEST(TriCodeLayout, MaxLevelsAndSize) {
  // As deep as 64 bits allow with a 5-bit level: face + 2 * level + 5.
  EXPECT_EQ(IcosaCode::kMaxLevel, 27);
  EXPECT_EQ(OctaCode::kMaxLevel, 28);
  EXPECT_EQ(TetraCode::kMaxLevel, 28);
  static_assert(sizeof(IcosaCode) == 8 && sizeof(OctaCode) == 8 && sizeof(TetraCode) == 8);
  static_assert(std::is_trivially_copyable_v<IcosaCode>);
  static_assert(IcosaCode::kFaces == 20 && OctaCode::kFaces == 8 && TetraCode::kFaces == 4);
}

TEST(TriCodeLayout, TextFormIsFaceThenBitPairs) {
  // The seed's EXCODE2 (2.3): face 000010, then 01 00 01 01 00 01.
  const IcosaCode c = IcosaCode::Parse("2:010001010001").value();
  EXPECT_EQ(c.face(), 2);
  EXPECT_EQ(c.level(), 6);
  EXPECT_EQ(c.path(), 0b010001010001u);
  EXPECT_EQ(c.child_type_at(1), 0b01);
  EXPECT_EQ(c.child_type_at(2), 0b00);
  EXPECT_EQ(c.child_type(), 0b01);
  EXPECT_EQ(c.ToString(), "2:010001010001");
  EXPECT_EQ(IcosaCode::Face(19).ToString(), "19:");
  EXPECT_EQ(IcosaCode::None().ToString(), "none");
  EXPECT_FALSE(IcosaCode::None().is_valid());
  EXPECT_FALSE(OctaCode::None().is_valid());  // face 7 is valid, level 31 is not
  EXPECT_FALSE(TetraCode::None().is_valid());
}

TYPED_TEST(TriCodeTest, ParseRejectsBadTextWithAReason) {
  using Code = typename TestFixture::CodeType;
  for (const char* bad : {"", "2", "x:01", ":01", "2:012", "2:1a", "-1:00", "02:10", "00:",
                          "123:00", "99:", "1:0", "1:011"}) {
    SCOPED_TRACE(bad);
    const Result<Code> r = Code::Parse(bad);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(r.status().IsInvalidArgument());
    EXPECT_NE(r.status().message().find(bad), std::string_view::npos);
  }
  const Result<Code> out = Code::Parse(std::to_string(Code::kFaces) + ":");
  ASSERT_FALSE(out.ok());
  EXPECT_NE(out.status().message().find("out of range"), std::string_view::npos);
  const Result<Code> odd = Code::Parse("1:011");
  EXPECT_NE(odd.status().message().find("odd"), std::string_view::npos);
  const std::string deep = "1:" + std::string(2 * Code::kMaxLevel + 2, '0');
  const Result<Code> too_deep = Code::Parse(deep);
  ASSERT_FALSE(too_deep.ok());
  EXPECT_NE(too_deep.status().message().find("maximum level"), std::string_view::npos);
  EXPECT_TRUE(Code::Parse("1:" + std::string(2 * Code::kMaxLevel, '1')).ok());
}

TYPED_TEST(TriCodeTest, TextRoundTripsAndNavigationIsConsistent) {
  using Code = typename TestFixture::CodeType;
  constexpr Polyhedron P = TestFixture::kSolid;
  std::mt19937_64 rng(11);
  for (int i = 0; i < 20000; ++i) {
    const Code c = RandomCode<P>(rng, static_cast<int>(rng() % (Code::kMaxLevel + 1)));
    SCOPED_TRACE(c.ToString());
    ASSERT_TRUE(c.is_valid());
    ASSERT_EQ(Code::Parse(c.ToString()).value(), c);
    ASSERT_EQ(Code::FromKey(c.key()), c);
    ASSERT_EQ(Code::FromPath(c.face(), c.path(), c.level()), c);
    if (c.level() > 0) {
      const Code parent = c.parent();
      ASSERT_EQ(parent.level(), c.level() - 1);
      ASSERT_EQ(parent.child(c.child_type()), c);
      ASSERT_EQ(parent.path(), c.path() >> 2);
      ASSERT_TRUE(parent.is_ancestor_of(c));
      ASSERT_FALSE(c.is_ancestor_of(parent));
      ASSERT_EQ(c.ancestor(0), Code::Face(c.face()));
    }
    if (c.level() < Code::kMaxLevel) {
      for (int t = 0; t < 4; ++t) {
        const Code ch = c.child(t);
        ASSERT_TRUE(ch.is_valid());
        ASSERT_EQ(ch.child_type(), t);
        ASSERT_EQ(ch.parent(), c);
        ASSERT_EQ(ch.flipped(), c.flipped() != (t == 0b10)) << "only the center flips";
        ASSERT_TRUE(c.contains(ch));
      }
    }
    const int other = (c.face() + 1) % Code::kFaces;
    ASSERT_EQ(c.with_face(other).face(), other);
    ASSERT_EQ(c.with_face(other).path(), c.path());
  }
}

// Unsigned key order is depth-first preorder: node, then its children
// 00, 01, 10, 11, faces in order; a subtree is [range_min, range_max].
TYPED_TEST(TriCodeTest, KeyOrderIsPreorder) {
  using Code = typename TestFixture::CodeType;
  std::vector<Code> preorder;
  const std::function<void(Code)> walk = [&](Code c) {
    preorder.push_back(c);
    if (c.level() < 4) {
      for (int t = 0; t < 4; ++t) walk(c.child(t));
    }
  };
  for (int f = 0; f < Code::kFaces; ++f) walk(Code::Face(f));
  ASSERT_TRUE(std::is_sorted(preorder.begin(), preorder.end()));
  ASSERT_TRUE(std::adjacent_find(preorder.begin(), preorder.end()) == preorder.end());
  for (size_t i = 0; i < preorder.size(); i += 7) {
    const Code c = preorder[i];
    for (size_t j = 0; j < preorder.size(); j += 3) {
      const Code d = preorder[j];
      const bool in_range = c.range_min() <= d.key() && d.key() <= c.range_max();
      const bool descends = d.level() >= c.level() && d.ancestor(c.level()) == c;
      ASSERT_EQ(in_range, descends) << c << " " << d;
    }
  }
  // The deepest codes fit: the last child at the maximum level.
  Code deep = Code::Face(Code::kFaces - 1);
  while (deep.level() < Code::kMaxLevel) deep = deep.child(3);
  EXPECT_TRUE(deep.is_valid());
  EXPECT_EQ(deep.path(), (uint64_t{1} << (2 * Code::kMaxLevel)) - 1);
  EXPECT_LT(deep.key(), Code::None().key());
}

TYPED_TEST(TriCodeTest, IsValidRejectsStrayBits) {
  using Code = typename TestFixture::CodeType;
  const Code c = Code::FromPath(1, 0b0110, 2);
  // A path bit below the level: where child 01 of c differs from child 00.
  const uint64_t below = c.child(1).key() ^ c.child(0).key();
  EXPECT_FALSE(Code::FromKey(c.key() | below).is_valid());
  // Bit 5: the lowest path bit, or (tetrahedron) the spare bit.
  EXPECT_FALSE(Code::FromKey(c.key() | 32).is_valid());
  // A level beyond the maximum.
  EXPECT_FALSE(Code::FromKey((c.key() & ~uint64_t{31}) | (Code::kMaxLevel + 1)).is_valid());
  if (Code::kFaces == 20) {
    EXPECT_FALSE(Code::FromKey((c.key() & ((uint64_t{1} << 59) - 1)) | uint64_t{20} << 59)
                     .is_valid());
  }
}

}  // namespace
}  // namespace simplexdb
