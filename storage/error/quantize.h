// Conservative error quantization: a stored error is never below the true
// error, so a query that accepts a simplex by its stored error never
// accepts one whose true error exceeds the bound.
//
//   u16, u8: code = ceil(e / quantum), quantum = field range / (2^bits - 1)
//            (an error never exceeds the field range: the field and its
//            interpolant both lie within it), with a margin for the rounding
//            of the error's own computation.
//   f32:     the float nearest to e, moved up if it is below e.
//
// Zero stays exactly zero in every mode (the sparse store relies on it).
// The quantization's vocabulary (enum, names, sizes) is
// storage/error/quantization.h.
//
// Thread safety: an ErrorQuantizer is immutable after construction; any
// number of threads may share one.
// Lifetimes: a value type; nothing it returns refers to it.
// Errors: none are returned. Encode maps e <= 0 to 0 and saturates a u16
// or u8 error past the field range at MaxCode; an error is never NaN (the
// engine records missing values as 0 or the range, never NaN).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "storage/error/quantization.h"

namespace simplexdb {

// Float bounds of a double: RoundDownToFloat(v) <= v <= RoundUpToFloat(v),
// each the nearest float on its side. O(1).
inline float RoundDownToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}
inline float RoundUpToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

class ErrorQuantizer {
 public:
  // The quantum a store of `range` (field max - min) uses. Slightly more
  // than range / max_code, so the largest code covers the whole range even
  // after rounding.
  static double QuantumFor(Quantization q, double range) {
    if (q == Quantization::kF32 || range <= 0) return q == Quantization::kF32 ? 0.0 : 1.0;
    return range * (1 + 1e-9) / MaxCode(q);
  }

  ErrorQuantizer(Quantization q, double quantum, double range)
      : q_(q), quantum_(quantum), margin_(kRelativeMargin * std::max(range, 0.0)) {}

  Quantization quantization() const { return q_; }
  double quantum() const { return quantum_; }

  // The stored form of error `e` (>= 0), as the bits of the stored entry
  // (u16 and u8 codes; f32 bits).
  uint32_t Encode(double e) const {
    if (e <= 0) return 0;
    const double padded = e + margin_;
    if (q_ == Quantization::kF32) return BitsOf(RoundUpToFloat(padded));
    double code = std::ceil(padded / quantum_);
    if (code * quantum_ < padded) code += 1;  // guard the division's rounding
    return static_cast<uint32_t>(std::min(code, static_cast<double>(MaxCode(q_))));
  }

  // The stored form of `bound`, a value that is already an upper bound of
  // an error (decoded from another store): the least code whose value is
  // not below it, with no margin (re-encoding a decoded value gives it
  // back).
  uint32_t EncodeBound(double bound) const {
    if (bound <= 0) return 0;
    if (q_ == Quantization::kF32) return BitsOf(RoundUpToFloat(bound));
    double code = std::ceil(bound / quantum_);
    if (code * quantum_ < bound) {
      code += 1;
    } else if (code >= 1 && (code - 1) * quantum_ >= bound) {
      code -= 1;
    }
    return static_cast<uint32_t>(std::min(code, static_cast<double>(MaxCode(q_))));
  }

  // The error bound a stored entry stands for.
  double Decode(uint32_t stored) const {
    if (q_ == Quantization::kF32) return std::bit_cast<float>(stored);
    return stored * quantum_;
  }

  static uint32_t MaxCode(Quantization q) {
    return q == Quantization::kU16 ? 65535u : q == Quantization::kU8 ? 255u : 0u;
  }

  // Errors are computed in double precision; their rounding is far below
  // this fraction of the field range, which is added before rounding up.
  static constexpr double kRelativeMargin = 1e-12;

 private:
  static uint32_t BitsOf(float f) { return std::bit_cast<uint32_t>(f); }

  Quantization q_;
  double quantum_;
  double margin_;
};

}  // namespace simplexdb
