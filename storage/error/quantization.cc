#include "storage/error/quantization.h"

#include <string>

namespace simplexdb {

std::string_view QuantizationName(Quantization q) {
  switch (q) {
    case Quantization::kU16: return "u16";
    case Quantization::kU8: return "u8";
    case Quantization::kF32: return "f32";
  }
  return "unknown";
}

Result<Quantization> ParseQuantization(std::string_view name) {
  if (name == "u16") return Quantization::kU16;
  if (name == "u8") return Quantization::kU8;
  if (name == "f32") return Quantization::kF32;
  return Status::InvalidArgument("unknown quantization '" + std::string(name) +
                                 "': expected u16, u8 or f32");
}

size_t QuantizedSize(Quantization q) {
  switch (q) {
    case Quantization::kU16: return 2;
    case Quantization::kU8: return 1;
    case Quantization::kF32: return 4;
  }
  return 0;
}

}  // namespace simplexdb
