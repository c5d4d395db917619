// util/little_endian.h against byte sequences written out by hand.
#include "util/little_endian.h"

#include <gtest/gtest.h>

#include <array>

namespace simplexdb {
namespace {

TEST(LittleEndian, LoadsLeastSignificantByteFirst) {
  const std::array<uint8_t, 9> b = {0xEF, 0xCD, 0xAB, 0x89, 0x67, 0x45, 0x23, 0x01, 0xFF};
  EXPECT_EQ(LoadLittle<uint16_t>(b.data()), 0xCDEFu);
  EXPECT_EQ(LoadLittle<uint32_t>(b.data()), 0x89ABCDEFu);
  EXPECT_EQ(LoadLittle<uint64_t>(b.data()), 0x0123456789ABCDEFull);
  // Unaligned.
  EXPECT_EQ(LoadLittle<uint64_t>(b.data() + 1), 0xFF0123456789ABCDull);
}

TEST(LittleEndian, FloatsByTheirIeeeBits) {
  const std::array<uint8_t, 4> one_f = {0x00, 0x00, 0x80, 0x3F};  // 1.0f
  const std::array<uint8_t, 8> minus_two = {0, 0, 0, 0, 0, 0, 0x00, 0xC0};  // -2.0
  EXPECT_EQ(LoadLittle<float>(one_f.data()), 1.0f);
  EXPECT_EQ(LoadLittle<double>(minus_two.data()), -2.0);
}

TEST(LittleEndian, StoresWhatLoadsRead) {
  std::array<uint8_t, 8> b{};
  StoreLittle<uint32_t>(b.data(), 0x01020304u);
  EXPECT_EQ(b[0], 0x04);
  EXPECT_EQ(b[3], 0x01);
  StoreLittle(b.data(), 0.5);  // 0x3FE0000000000000
  EXPECT_EQ(b[7], 0x3F);
  EXPECT_EQ(b[6], 0xE0);
  EXPECT_EQ(b[0], 0x00);
  StoreLittle(b.data(), -3.25f);
  EXPECT_EQ(LoadLittle<float>(b.data()), -3.25f);
}

TEST(LittleEndian, ByteSwapReversesBytes) {
  static_assert(ByteSwap<uint16_t>(0x1234) == 0x3412);
  static_assert(ByteSwap<uint32_t>(0x01020304u) == 0x04030201u);
  static_assert(ByteSwap<uint64_t>(0x0102030405060708ull) == 0x0807060504030201ull);
  EXPECT_EQ(ByteSwap<uint8_t>(0xAB), 0xAB);
}

}  // namespace
}  // namespace simplexdb
