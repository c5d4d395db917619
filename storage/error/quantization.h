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

}  // namespace simplexdb
