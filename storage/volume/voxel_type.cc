#include "storage/volume/voxel_type.h"

#include <bit>
#include <cassert>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "util/little_endian.h"

namespace simplexdb {
namespace {

// Unsigned integers of each width: the bytes of a voxel are swapped in one.
template <size_t N> struct UintOfSize;
template <> struct UintOfSize<1> { using type = uint8_t; };
template <> struct UintOfSize<2> { using type = uint16_t; };
template <> struct UintOfSize<4> { using type = uint32_t; };
template <> struct UintOfSize<8> { using type = uint64_t; };

template <class T>
void DecodeAs(bool swap, const std::byte* bytes, size_t count, double* out) {
  using U = typename UintOfSize<sizeof(T)>::type;
  for (size_t i = 0; i < count; ++i) {
    U u;
    std::memcpy(&u, bytes + i * sizeof(T), sizeof(T));
    if (swap) u = ByteSwap(u);
    out[i] = static_cast<double>(std::bit_cast<T>(u));
  }
}

template <class T>
void EncodeAs(bool swap, const double* values, size_t count, std::byte* bytes) {
  using U = typename UintOfSize<sizeof(T)>::type;
  for (size_t i = 0; i < count; ++i) {
    U u = std::bit_cast<U>(static_cast<T>(values[i]));
    if (swap) u = ByteSwap(u);
    std::memcpy(bytes + i * sizeof(T), &u, sizeof(T));
  }
}

template <class T>
bool IsIntegerIn(double v) {
  return v == std::floor(v) &&
         v >= static_cast<double>(std::numeric_limits<T>::min()) &&
         v <= static_cast<double>(std::numeric_limits<T>::max());
}

// Lower case, outer spaces trimmed, inner runs of spaces and tabs collapsed
// to one space: "Unsigned  Short" -> "unsigned short".
std::string Normalize(std::string_view text) {
  std::string s;
  bool pending_space = false;
  for (char c : text) {
    if (c == ' ' || c == '\t') {
      pending_space = !s.empty();
      continue;
    }
    if (pending_space) s.push_back(' ');
    pending_space = false;
    s.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  return s;
}

struct Spelling {
  std::string_view name;
  VoxelType type;
};

// Our names, then the NRRD specification's spellings (section 5, "type").
constexpr Spelling kSpellings[] = {
    {"uint8", VoxelType::kU8},           {"uint8_t", VoxelType::kU8},
    {"uchar", VoxelType::kU8},           {"unsigned char", VoxelType::kU8},
    {"int8", VoxelType::kI8},            {"int8_t", VoxelType::kI8},
    {"signed char", VoxelType::kI8},     {"uint16", VoxelType::kU16},
    {"uint16_t", VoxelType::kU16},       {"ushort", VoxelType::kU16},
    {"unsigned short", VoxelType::kU16}, {"unsigned short int", VoxelType::kU16},
    {"int16", VoxelType::kI16},          {"int16_t", VoxelType::kI16},
    {"short", VoxelType::kI16},          {"short int", VoxelType::kI16},
    {"signed short", VoxelType::kI16},   {"signed short int", VoxelType::kI16},
    {"float32", VoxelType::kF32},        {"float", VoxelType::kF32},
    {"float64", VoxelType::kF64},        {"double", VoxelType::kF64},
};

// Types the NRRD specification names that SimplexDB does not read.
constexpr std::string_view kUnsupported[] = {
    "int",       "signed int",           "int32",
    "int32_t",   "uint",                 "unsigned int",
    "uint32",    "uint32_t",             "longlong",
    "long long", "long long int",        "signed long long",
    "signed long long int",              "int64",
    "int64_t",   "ulonglong",            "unsigned long long",
    "unsigned long long int",            "uint64",
    "uint64_t",  "block",
};

constexpr std::string_view kSupportedList =
    "uint8, int8, uint16, int16, float32 (float), float64 (double)";

}  // namespace

ByteOrder NativeByteOrder() noexcept {
  static_assert(std::endian::native == std::endian::little ||
                    std::endian::native == std::endian::big,
                "mixed-endian machines are not supported");
  return std::endian::native == std::endian::little ? ByteOrder::kLittle
                                                    : ByteOrder::kBig;
}

std::string_view ByteOrderName(ByteOrder order) noexcept {
  return order == ByteOrder::kBig ? "big" : "little";
}

bool IsValidVoxelType(VoxelType type) noexcept {
  const auto v = static_cast<uint8_t>(type);
  return v >= static_cast<uint8_t>(VoxelType::kU8) &&
         v <= static_cast<uint8_t>(VoxelType::kF64);
}

size_t VoxelSize(VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kU8:
    case VoxelType::kI8: return 1;
    case VoxelType::kU16:
    case VoxelType::kI16: return 2;
    case VoxelType::kF32: return 4;
    case VoxelType::kF64: return 8;
  }
  assert(false && "invalid VoxelType");
  return 0;
}

std::string_view VoxelTypeName(VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kU8: return "uint8";
    case VoxelType::kI8: return "int8";
    case VoxelType::kU16: return "uint16";
    case VoxelType::kI16: return "int16";
    case VoxelType::kF32: return "float32";
    case VoxelType::kF64: return "float64";
  }
  return "invalid";
}

std::string_view NrrdTypeName(VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kF32: return "float";
    case VoxelType::kF64: return "double";
    default: return VoxelTypeName(type);
  }
}

Result<VoxelType> ParseVoxelType(std::string_view name) {
  const std::string key = Normalize(name);
  for (const Spelling& s : kSpellings) {
    if (s.name == key) return s.type;
  }
  for (std::string_view u : kUnsupported) {
    if (u == key) {
      return Status::NotSupported("voxel type '" + std::string(name) +
                                  "' is not supported; supported: " +
                                  std::string(kSupportedList));
    }
  }
  return Status::InvalidArgument('\'' + std::string(name) +
                                 "' is not a voxel type; expected one of " +
                                 std::string(kSupportedList));
}

Result<VoxelType> VoxelTypeFromCode(uint8_t code) {
  const auto type = static_cast<VoxelType>(code);
  if (!IsValidVoxelType(type)) {
    return Status::InvalidArgument("voxel type code " + std::to_string(code) +
                                   " is not one of 1..6");
  }
  return type;
}

void DecodeVoxels(VoxelType type, ByteOrder order, const std::byte* bytes,
                  size_t count, double* out) noexcept {
  const bool swap = order != NativeByteOrder();
  WithVoxelCppType(type, [&](auto voxel) { DecodeAs<decltype(voxel)>(swap, bytes, count, out); });
}

bool IsRepresentable(VoxelType type, double value) noexcept {
  switch (type) {
    case VoxelType::kU8: return IsIntegerIn<uint8_t>(value);
    case VoxelType::kI8: return IsIntegerIn<int8_t>(value);
    case VoxelType::kU16: return IsIntegerIn<uint16_t>(value);
    case VoxelType::kI16: return IsIntegerIn<int16_t>(value);
    case VoxelType::kF32:
      return !std::isfinite(value) ||
             std::fabs(value) <= std::numeric_limits<float>::max();
    case VoxelType::kF64: return true;
  }
  return false;
}

void EncodeVoxels(VoxelType type, ByteOrder order, const double* values,
                  size_t count, std::byte* bytes) noexcept {
#ifndef NDEBUG
  for (size_t i = 0; i < count; ++i) assert(IsRepresentable(type, values[i]));
#endif
  const bool swap = order != NativeByteOrder();
  WithVoxelCppType(type, [&](auto voxel) { EncodeAs<decltype(voxel)>(swap, values, count, bytes); });
}

}  // namespace simplexdb
