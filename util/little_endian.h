// Little-endian loads and stores of unaligned integers and floats: the byte
// order of every SimplexDB file. One instruction each on little-endian
// hosts; a byte swap on big-endian ones.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace simplexdb {

static_assert(std::endian::native == std::endian::little ||
                  std::endian::native == std::endian::big,
              "mixed-endian machines are not supported");

// std::byteswap is C++23; compilers turn this loop into one bswap.
template <class U>
constexpr U ByteSwap(U v) noexcept {
  static_assert(std::is_unsigned_v<U>);
  U r = 0;
  for (size_t i = 0; i < sizeof(U); ++i) {
    r = static_cast<U>((r << 8) | (v & 0xFF));
    v = static_cast<U>(v >> 8);
  }
  return r;
}

// T: an unsigned integer, float or double.
template <class T>
inline T LoadLittle(const uint8_t* p) noexcept {
  if constexpr (std::is_floating_point_v<T>) {
    using U = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
    return std::bit_cast<T>(LoadLittle<U>(p));
  } else {
    T v;
    std::memcpy(&v, p, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) v = ByteSwap(v);
    return v;
  }
}

template <class T>
inline void StoreLittle(uint8_t* p, T v) noexcept {
  if constexpr (std::is_floating_point_v<T>) {
    using U = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
    StoreLittle<U>(p, std::bit_cast<U>(v));
  } else {
    if constexpr (std::endian::native == std::endian::big) v = ByteSwap(v);
    std::memcpy(p, &v, sizeof(T));
  }
}

}  // namespace simplexdb
