// Voxel types and byte orders of input volumes, and the conversion between
// their bytes and doubles.
//
// The numeric values of VoxelType are stored on disk (store headers): they
// are stable. Never renumber an enumerator; add new ones at the end.
//
// Every value of the six types is exactly representable as a double, so
// DecodeVoxels is lossless and EncodeVoxels(DecodeVoxels(b)) gives back b.
//
// Errors: ParseVoxelType and VoxelTypeFromCode return NotSupported or
// InvalidArgument as said below; nothing else fails (breaking a REQUIRES:
// line is a programming error, asserted where cheap, not a Status).
//
// Thread safety: pure functions.
//
// Lifetimes: the string_views returned (ByteOrderName, VoxelTypeName,
// NrrdTypeName) point at static storage and live as long as the program.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "util/status.h"

namespace simplexdb {

enum class VoxelType : uint8_t {
  kU8 = 1,
  kI8 = 2,
  kU16 = 3,
  kI16 = 4,
  kF32 = 5,
  kF64 = 6,
};

enum class ByteOrder : uint8_t { kLittle = 0, kBig = 1 };

// The byte order of this machine.
ByteOrder NativeByteOrder() noexcept;

// "little" or "big".
std::string_view ByteOrderName(ByteOrder order) noexcept;

// True for the six enumerators above (a VoxelType read from disk or cast
// from an integer may be anything).
bool IsValidVoxelType(VoxelType type) noexcept;

// float32 and float64: the types that hold NaN (a missing value), and whose
// errors are computed in floating point; the others are integers.
constexpr bool IsFloatType(VoxelType type) noexcept {
  return type == VoxelType::kF32 || type == VoxelType::kF64;
}

// 1, 2, 4 or 8 bytes. REQUIRES: IsValidVoxelType(type).
size_t VoxelSize(VoxelType type) noexcept;

// "uint8", "int8", "uint16", "int16", "float32", "float64"; "invalid" for
// anything else (so messages can name a bad value).
std::string_view VoxelTypeName(VoxelType type) noexcept;

// The name NRRD writers use in "type:" ("float" and "double" for the
// floating-point types: NRRD has no "float32"). REQUIRES: valid type.
std::string_view NrrdTypeName(VoxelType type) noexcept;

// The type a name stands for. Accepts, ignoring case and repeated spaces:
// our names above, and every spelling the NRRD specification lists for the
// six types ("uchar", "unsigned char", "uint8_t", "short", "signed short
// int", "float", "double", ...). Known types SimplexDB does not read (32- and
// 64-bit integers, NRRD "block") fail with NotSupported naming the type;
// anything else with InvalidArgument. The message names the text, not a
// file: callers that parse a file prefix its name.
Result<VoxelType> ParseVoxelType(std::string_view name);

// The type with the stable on-disk number `code`; InvalidArgument otherwise.
Result<VoxelType> VoxelTypeFromCode(uint8_t code);

// Converts `count` voxels stored in `bytes` (in `order`) to doubles.
// Exact for every type. O(count).
// REQUIRES: IsValidVoxelType(type); `bytes` holds count * VoxelSize(type)
// bytes; `out` holds count doubles. No alignment requirement.
void DecodeVoxels(VoxelType type, ByteOrder order, const std::byte* bytes,
                  size_t count, double* out) noexcept;

// True when `value` can be stored as `type` by EncodeVoxels: an integer in
// range for the integer types; any value for float64; for float32 any value
// within float range, NaN or infinity (finite values round to nearest).
bool IsRepresentable(VoxelType type, double value) noexcept;

// Converts `count` doubles to `type` in `order`, the inverse of
// DecodeVoxels. O(count).
// REQUIRES: IsValidVoxelType(type); IsRepresentable(type, values[i]) for
// every i (checked by assertion; converting an out-of-range double to an
// integer is undefined behaviour); `bytes` holds count * VoxelSize(type).
void EncodeVoxels(VoxelType type, ByteOrder order, const double* values,
                  size_t count, std::byte* bytes) noexcept;

// The C++ types of the six voxel types, for code templated on the type a
// field is held in (X(T) once per type: explicit instantiations).
#define SDB_FOR_EACH_VOXEL_CPP_TYPE(X) X(uint8_t) X(int8_t) X(uint16_t) X(int16_t) X(float) X(double)

// Returns f(T{}) for T the C++ type of `type`'s voxels (uint8_t ... double).
// REQUIRES: IsValidVoxelType(type).
template <class F>
decltype(auto) WithVoxelCppType(VoxelType type, F&& f) {
  switch (type) {
    case VoxelType::kU8: return f(uint8_t{});
    case VoxelType::kI8: return f(int8_t{});
    case VoxelType::kU16: return f(uint16_t{});
    case VoxelType::kI16: return f(int16_t{});
    case VoxelType::kF32: return f(float{});
    case VoxelType::kF64: break;
  }
  return f(double{});
}

}  // namespace simplexdb
