// How a store keeps its errors: the quantization's vocabulary (its on-disk
// numbers, names and entry sizes), shared by the dense and the sparse store.
// The quantizer itself (rounding errors up to codes) is
// storage/error/quantize.h.
//
// Thread safety: values and pure functions; all reentrant.
// Lifetimes: QuantizationName returns a view of a static string.
// Errors: ParseQuantization returns InvalidArgument naming the bad name and
// the accepted ones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "util/little_endian.h"
#include "util/status.h"

namespace simplexdb {

// How errors are stored (stable numbers: they are on disk, in the dense
// store's header and the sparse store's JSON header by name).
enum class Quantization : uint8_t { kU16 = 1, kU8 = 2, kF32 = 3 };

// "u16", "u8", "f32" ("unknown" for a number outside the enum).
std::string_view QuantizationName(Quantization q);

// The inverse of QuantizationName. InvalidArgument "unknown quantization
// 'x': expected u16, u8 or f32" for any other name.
Result<Quantization> ParseQuantization(std::string_view name);

// Bytes per stored error: 2, 1, 4 (0 for a number outside the enum).
size_t QuantizedSize(Quantization q);

// Error code `slot` of an array of them in quantization q (little-endian,
// QuantizedSize(q) bytes each): read, and written (code fits q).
inline uint32_t LoadErrorCode(Quantization q, const uint8_t* codes, size_t slot) {
  switch (q) {
    case Quantization::kU16: return LoadLittle<uint16_t>(codes + 2 * slot);
    case Quantization::kU8: return codes[slot];
    case Quantization::kF32: return LoadLittle<uint32_t>(codes + 4 * slot);
  }
  return 0;
}
inline void StoreErrorCode(Quantization q, uint8_t* codes, size_t slot, uint32_t code) {
  switch (q) {
    case Quantization::kU16: StoreLittle<uint16_t>(codes + 2 * slot, static_cast<uint16_t>(code)); break;
    case Quantization::kU8: codes[slot] = static_cast<uint8_t>(code); break;
    case Quantization::kF32: StoreLittle<uint32_t>(codes + 4 * slot, code); break;
  }
}

}  // namespace simplexdb
