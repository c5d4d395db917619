#include "util/utf8.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include <nlohmann/json.hpp>

namespace simplexdb {
namespace {

TEST(Utf8, SequenceLengthFollowsTheUnicodeTable) {
  EXPECT_EQ(Utf8SequenceLength("a"), 1u);
  EXPECT_EQ(Utf8SequenceLength(std::string_view("\0", 1)), 1u);
  EXPECT_EQ(Utf8SequenceLength("\xC3\xA9"), 2u);          // é
  EXPECT_EQ(Utf8SequenceLength("\xE2\x82\xAC"), 3u);      // €
  EXPECT_EQ(Utf8SequenceLength("\xF0\x9F\x98\x80"), 4u);  // U+1F600
  EXPECT_EQ(Utf8SequenceLength("\xF4\x8F\xBF\xBF"), 4u);  // U+10FFFF
  EXPECT_EQ(Utf8SequenceLength(""), 0u);
  EXPECT_EQ(Utf8SequenceLength("\x80"), 0u);              // a lone continuation
  EXPECT_EQ(Utf8SequenceLength("\xC3"), 0u);              // cut short
  EXPECT_EQ(Utf8SequenceLength("\xC0\xAF"), 0u);          // overlong '/'
  EXPECT_EQ(Utf8SequenceLength("\xE0\x80\xAF"), 0u);      // overlong
  EXPECT_EQ(Utf8SequenceLength("\xED\xA0\x80"), 0u);      // a surrogate
  EXPECT_EQ(Utf8SequenceLength("\xF4\x90\x80\x80"), 0u);  // above U+10FFFF
  EXPECT_EQ(Utf8SequenceLength("\xFF"), 0u);
  EXPECT_EQ(Utf8SequenceLength("\xC3\x28"), 0u);          // bad continuation
}

TEST(Utf8, PrefixNeverEndsInsideACharacter) {
  const std::string s = "ab\xC3\xA9\xE2\x82\xAC";  // a b é €
  EXPECT_EQ(Utf8PrefixLength(s, 100), s.size());
  EXPECT_EQ(Utf8PrefixLength(s, 7), 7u);
  EXPECT_EQ(Utf8PrefixLength(s, 6), 4u);
  EXPECT_EQ(Utf8PrefixLength(s, 5), 4u);
  EXPECT_EQ(Utf8PrefixLength(s, 4), 4u);
  EXPECT_EQ(Utf8PrefixLength(s, 3), 2u);
  EXPECT_EQ(Utf8PrefixLength(s, 0), 0u);
  // Invalid bytes are one byte each: kept, never made worse.
  EXPECT_EQ(Utf8PrefixLength("a\xFF\xFF" "b", 2), 2u);
}

TEST(Utf8, ReplacementMakesValidJsonAndHexKeepsTheBytes) {
  EXPECT_EQ(ToValidUtf8("a\xFF" "b\xC3\xA9"), "a\xEF\xBF\xBD" "b\xC3\xA9");
  EXPECT_EQ(ToValidUtf8("\xC3"), "\xEF\xBF\xBD");
  EXPECT_EQ(HexBytes(std::string_view("a\xFF\0", 3)), "61ff00");
  // Random bytes: always valid after replacement, valid prefixes of valid
  // strings stay valid, and nlohmann::json dumps the result.
  std::mt19937 rng(20);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string s(rng() % 40, '\0');
    for (char& c : s) c = static_cast<char>(rng() % 7 == 0 ? 0xC3 : rng());
    SCOPED_TRACE(HexBytes(s));
    const std::string v = ToValidUtf8(s);
    ASSERT_TRUE(IsValidUtf8(v));
    EXPECT_EQ(IsValidUtf8(s), v == s);
    const size_t cut = Utf8PrefixLength(v, rng() % 40);
    EXPECT_TRUE(IsValidUtf8(std::string_view(v).substr(0, cut)));
    EXPECT_NO_THROW((void)nlohmann::json(v).dump());
  }
}

}  // namespace
}  // namespace simplexdb
