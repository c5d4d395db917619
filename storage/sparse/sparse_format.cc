#include "storage/sparse/sparse_format.h"

#include <bit>
#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>

#include "hierarchy/simplex_code.h"
#include "storage/io/checksum.h"
#include "util/little_endian.h"

namespace simplexdb {
namespace {

constexpr const char* kFormatName = "simplexdb-sparse";

// Appends v little-endian (util/little_endian.h).
template <class T>
void Append(std::vector<uint8_t>& out, T v) {
  const size_t at = out.size();
  out.resize(at + sizeof(T));
  StoreLittle<T>(out.data() + at, v);
}

// n values of `width` bytes as byte planes: every value's byte 0, then 1...
void PutPlanes(std::vector<uint8_t>& out, std::span<const uint64_t> values, size_t width) {
  const size_t at = out.size();
  out.resize(at + values.size() * width);
  for (size_t b = 0; b < width; ++b) {
    uint8_t* plane = out.data() + at + b * values.size();
    for (size_t i = 0; i < values.size(); ++i) plane[i] = static_cast<uint8_t>(values[i] >> (8 * b));
  }
}
void GetPlanes(const uint8_t* in, size_t n, size_t width, uint64_t* values) {
  for (size_t i = 0; i < n; ++i) values[i] = 0;
  for (size_t b = 0; b < width; ++b) {
    const uint8_t* plane = in + b * n;
    for (size_t i = 0; i < n; ++i) values[i] |= uint64_t{plane[i]} << (8 * b);
  }
}

// The order-preserving integer image of a float's bits, and back.
template <class U>
U ToOrdered(U bits) {
  constexpr U sign = static_cast<U>(U{1} << (8 * sizeof(U) - 1));
  return (bits & sign) != 0 ? static_cast<U>(~bits) : static_cast<U>(bits | sign);
}
template <class U>
U FromOrdered(U u) {
  constexpr U sign = static_cast<U>(U{1} << (8 * sizeof(U) - 1));
  return (u & sign) != 0 ? static_cast<U>(u & ~sign) : static_cast<U>(~u);
}

}  // namespace

uint64_t HzResidual(VoxelType type, double value, double p) {
  switch (type) {
    case VoxelType::kF32: {
      const float v = static_cast<float>(value), q = static_cast<float>(p);
      const uint32_t a = ToOrdered(std::bit_cast<uint32_t>(v)), b = ToOrdered(std::bit_cast<uint32_t>(q));
      return static_cast<uint32_t>(a - b);
    }
    case VoxelType::kF64:
      return ToOrdered(std::bit_cast<uint64_t>(value)) - ToOrdered(std::bit_cast<uint64_t>(p));
    default: {
      const uint64_t mask = (uint64_t{1} << (8 * VoxelSize(type))) - 1;
      return static_cast<uint64_t>(static_cast<int64_t>(value) - std::llround(p)) & mask;
    }
  }
}

double HzFromResidual(VoxelType type, uint64_t residual, double p) {
  switch (type) {
    case VoxelType::kF32: {
      const uint32_t b = ToOrdered(std::bit_cast<uint32_t>(static_cast<float>(p)));
      return std::bit_cast<float>(FromOrdered(static_cast<uint32_t>(b + residual)));
    }
    case VoxelType::kF64:
      return std::bit_cast<double>(FromOrdered(ToOrdered(std::bit_cast<uint64_t>(p)) + residual));
    default: {
      const uint64_t sum = static_cast<uint64_t>(std::llround(p)) + residual;
      switch (type) {
        case VoxelType::kU8: return static_cast<uint8_t>(sum);
        case VoxelType::kI8: return static_cast<int8_t>(static_cast<uint8_t>(sum));
        case VoxelType::kU16: return static_cast<uint16_t>(sum);
        default: return static_cast<int16_t>(static_cast<uint16_t>(sum));
      }
    }
  }
}

uint64_t HzStepResidual(double value, double p, double step, double* read_back) {
  int64_t k = std::llround((value - p) / step);
  double back = p + step * static_cast<double>(k);
  // Rounding in (value - p) / s can land a hair past s / 2: one step back.
  if (std::abs(value - back) > step / 2) {
    k += value > back ? 1 : -1;
    back = p + step * static_cast<double>(k);
  }
  *read_back = back;
  const auto u = static_cast<uint32_t>(static_cast<int32_t>(k));
  return static_cast<uint32_t>(u << 1) ^ static_cast<uint32_t>(static_cast<int32_t>(k) >> 31);
}

double HzFromStepResidual(uint64_t residual, double p, double step) {
  const auto u = static_cast<uint32_t>(residual);
  const int64_t k = static_cast<int32_t>(u >> 1) ^ -static_cast<int32_t>(u & 1);
  return p + step * static_cast<double>(k);
}

double SparseValueStep(VoxelType type, double tolerance, double field_min, double field_max) {
  const double step = 2 * tolerance;
  if (!(step > 0) || !std::isfinite(step)) return 0;
  if (!IsFloatType(type) && step < 1) return 0;
  // A residual's magnitude is below (|value| + 2 (range + s)) / s: a
  // prediction is a mix of values within s / 2 of the field's range, with
  // weights summing to 1 whose negative ones sum to 1/8 (the corners are
  // predicted 0).
  const double largest = std::max(std::abs(field_min), std::abs(field_max)) + 2 * (field_max - field_min + step);
  return largest / step < 0x1p29 ? step : 0;
}

size_t SparseErrorWidth(Quantization q) { return QuantizedSize(q); }
size_t SparseResidualWidth(const SparseHeader& h) {
  return h.value_step > 0 ? sizeof(uint32_t) : VoxelSize(h.voxel_type);
}

std::vector<uint8_t> EncodeSparseHeader(const SparseHeader& h) {
  nlohmann::json j;
  j["format"] = kFormatName;
  j["version"] = h.version;
  j["hierarchy"] = h.dimension == 3 ? "ht" : "hp";
  j["dims"] = std::vector<uint32_t>(h.dims.begin(), h.dims.begin() + h.dimension);
  j["spacing"] = std::vector<double>(h.spacing.begin(), h.spacing.begin() + h.dimension);
  j["origin"] = std::vector<double>(h.origin.begin(), h.origin.begin() + h.dimension);
  j["domain_bits"] = h.domain_bits;
  j["voxel_type"] = std::string(VoxelTypeName(h.voxel_type));
  j["quantization"] = std::string(QuantizationName(h.quantization));
  j["quantum"] = h.quantum;
  j["field_min"] = h.field_min;
  j["field_max"] = h.field_max;
  j["error_max"] = h.error_max;
  j["tolerance"] = h.tolerance;
  j["value_step"] = h.value_step;
  j["block_bits"] = h.block_bits;
  j["blocks"] = h.blocks;
  j["kept"] = h.kept;
  j["source"] = h.source;
  // Bytes that are not UTF-8 (a path's) are stored as U+FFFD.
  const std::string text = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
  std::vector<uint8_t> out(text.begin(), text.end());
  Append<uint64_t>(out, Checksum(std::span<const uint8_t>(out.data(), text.size())));
  return out;
}

Result<SparseHeader> DecodeSparseHeader(std::span<const uint8_t> value, const std::string& file) {
  const auto bad = [&](const std::string& why) {
    return Status::Corruption(file + ": sparse store header: " + why);
  };
  if (value.size() < 8) return bad("shorter than its checksum");
  const std::span<const uint8_t> text = value.first(value.size() - 8);
  if (Checksum(text) != LoadLittle<uint64_t>(value.data() + text.size())) return bad("checksum mismatch");
  const nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) return bad("not a JSON object");
  if (j.value("format", "") != kFormatName) {
    return Status::InvalidArgument(file + ": an LMDB file, but not a SimplexDB sparse store");
  }
  SparseHeader h;
  try {
    h.version = j.at("version").get<uint32_t>();
    if (h.version != kSparseFormatVersion) {
      return Status::NotSupported(file + ": sparse store format version " + std::to_string(h.version) +
                                  "; this build reads version " +
                                  std::to_string(kSparseFormatVersion) + " (import the volume again)");
    }
    const std::string hierarchy = j.at("hierarchy").get<std::string>();
    if (hierarchy != "ht" && hierarchy != "hp") return bad("hierarchy '" + hierarchy + "'");
    h.dimension = hierarchy == "ht" ? 3 : 4;
    const auto dims = j.at("dims").get<std::vector<uint32_t>>();
    if (static_cast<int>(dims.size()) != h.dimension) return bad("dims do not match the hierarchy");
    for (int a = 0; a < h.dimension; ++a) h.dims[a] = dims[a];
    const auto spacing = j.at("spacing").get<std::vector<double>>();
    if (static_cast<int>(spacing.size()) != h.dimension) return bad("spacing does not match the hierarchy");
    for (int a = 0; a < h.dimension; ++a) {
      // A space axis may be flipped (negative spacing); time runs forwards.
      if (!std::isfinite(spacing[a]) || !(a < 3 ? spacing[a] != 0 : spacing[a] > 0)) {
        return bad("spacing must be finite and non-zero (positive for time)");
      }
      h.spacing[a] = spacing[a];
    }
    // Optional (an addition within version 4: older readers ignore it,
    // older stores lack it and read as zeros).
    if (j.contains("origin")) {
      const auto origin = j.at("origin").get<std::vector<double>>();
      if (static_cast<int>(origin.size()) != h.dimension) return bad("origin does not match the hierarchy");
      for (int a = 0; a < h.dimension; ++a) {
        if (!std::isfinite(origin[a])) return bad("origin must be finite");
        h.origin[a] = origin[a];
      }
    }
    h.domain_bits = j.at("domain_bits").get<int>();
    const int max_bits = h.dimension == 3 ? SimplexCode<3>::kMaxLevel / 3 : SimplexCode<4>::kMaxLevel / 4;
    if (h.domain_bits < 1 || h.domain_bits > max_bits) return bad("domain_bits out of range");
    for (int a = 0; a < h.dimension; ++a) {
      if (h.dims[a] < 1 || h.dims[a] > (uint64_t{1} << h.domain_bits) + 1) return bad("dims exceed the domain");
    }
    Result<VoxelType> type = ParseVoxelType(j.at("voxel_type").get<std::string>());
    if (!type.ok()) return bad(std::string(type.status().message()));
    h.voxel_type = *type;
    Result<Quantization> q = ParseQuantization(j.at("quantization").get<std::string>());
    if (!q.ok()) return bad(std::string(q.status().message()));
    h.quantization = *q;
    h.quantum = j.at("quantum").get<double>();
    h.field_min = j.at("field_min").get<double>();
    h.field_max = j.at("field_max").get<double>();
    h.error_max = j.at("error_max").get<double>();
    h.tolerance = j.at("tolerance").get<double>();
    h.value_step = j.at("value_step").get<double>();
    h.block_bits = j.at("block_bits").get<int>();
    h.blocks = j.at("blocks").get<uint64_t>();
    h.kept = j.at("kept").get<uint64_t>();
    h.source = j.at("source").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    return bad(e.what());
  }
  if (!(std::isfinite(h.field_min) && std::isfinite(h.field_max) && h.field_min <= h.field_max)) {
    return bad("field range");
  }
  if (!(std::isfinite(h.error_max) && h.error_max >= 0 && std::isfinite(h.tolerance) && h.tolerance >= 0 &&
        std::isfinite(h.quantum) && h.quantum >= 0)) {
    return bad("error range, tolerance or quantum");
  }
  if (h.value_step != SparseValueStep(h.voxel_type, h.tolerance, h.field_min, h.field_max)) {
    return bad("value_step " + std::to_string(h.value_step) + " for tolerance " + std::to_string(h.tolerance));
  }
  // Blocks hold at most 2^24 positions (a decoded block's arrays), at
  // least 2^D (the corners share block 0).
  if (h.block_bits < h.dimension || h.block_bits > 24) return bad("block_bits out of range");
  return h;
}

SparseErrorCoder::SparseErrorCoder(const SparseHeader& h)
    : quantizer_(h.quantization, h.quantum, h.field_max - h.field_min) {
  if (!(h.tolerance > 0) || h.quantization == Quantization::kF32 || !(h.quantum > 0)) return;
  // Up to the linear codes' largest value, so that every one has a step
  // at or above it.
  const uint32_t max_code = ErrorQuantizer::MaxCode(h.quantization);
  const double largest = quantizer_.Decode(max_code);
  steps_.push_back(kLinearCodes * h.quantum);
  while (steps_.back() < largest && kLinearCodes + steps_.size() <= max_code) {
    steps_.push_back(steps_.back() * 1.25);
  }
}

uint32_t SparseErrorCoder::Encode(double e) const {
  const uint32_t linear = quantizer_.Encode(e);
  if (linear <= kLinearCodes || steps_.empty()) return linear;
  // The least step not below the linear code's value (itself not below e).
  const double v = quantizer_.Decode(linear);
  const auto it = std::lower_bound(steps_.begin(), steps_.end(), v);
  const size_t j = it == steps_.end() ? steps_.size() - 1 : static_cast<size_t>(it - steps_.begin());
  return kLinearCodes + static_cast<uint32_t>(j);
}

Result<std::vector<uint8_t>> EncodeSparseBlock(uint64_t block, const SparseBlock& b,
                                               size_t error_width, size_t voxel_width,
                                               ZstdCompressor& zstd) {
  std::vector<uint8_t> errors, residuals;
  std::vector<uint64_t> wide(b.errors.begin(), b.errors.end());
  PutPlanes(errors, wide, error_width);
  PutPlanes(residuals, b.residuals, voxel_width);
  SDB_ASSIGN_OR_RETURN(const std::vector<uint8_t> bitmap_frame, zstd.Compress(b.kept));
  std::vector<uint8_t> errors_frame;
  if (!errors.empty()) {
    SDB_ASSIGN_OR_RETURN(errors_frame, zstd.Compress(errors));
  }
  SDB_ASSIGN_OR_RETURN(const std::vector<uint8_t> residuals_frame, zstd.Compress(residuals));
  std::vector<uint8_t> value;
  value.reserve(kSparseBlockPrefix + bitmap_frame.size() + errors_frame.size() + residuals_frame.size() + 8);
  Append<uint32_t>(value, b.vertices);
  Append<uint32_t>(value, b.candidates);
  Append<uint32_t>(value, static_cast<uint32_t>(b.residuals.size()));
  Append<uint32_t>(value, static_cast<uint32_t>(b.errors.size()));
  Append<uint32_t>(value, static_cast<uint32_t>(bitmap_frame.size()));
  Append<uint32_t>(value, static_cast<uint32_t>(errors_frame.size()));
  for (const std::vector<uint8_t>* frame : {&bitmap_frame, &std::as_const(errors_frame), &residuals_frame}) {
    value.insert(value.end(), frame->begin(), frame->end());
  }
  Append<uint64_t>(value, Checksum(value, block));
  return value;
}

Result<SparseBlock> DecodeSparseBlock(uint64_t block, std::span<const uint8_t> value,
                                      uint32_t vertices, size_t error_width,
                                      size_t voxel_width, ZstdDecompressor& zstd,
                                      const std::string& file) {
  const std::string what = file + ": block " + std::to_string(block);
  const auto bad = [&](const std::string& why) { return Status::Corruption(what + ": " + why); };
  if (value.size() < kSparseBlockPrefix + 8) return bad("value of " + std::to_string(value.size()) + " bytes");
  const std::span<const uint8_t> summed = value.first(value.size() - 8);
  if (Checksum(summed, block) != LoadLittle<uint64_t>(value.data() + summed.size())) return bad("checksum mismatch");
  SparseBlock b;
  b.vertices = LoadLittle<uint32_t>(value.data());
  b.candidates = LoadLittle<uint32_t>(value.data() + 4);
  const uint32_t kept = LoadLittle<uint32_t>(value.data() + 8), errors = LoadLittle<uint32_t>(value.data() + 12);
  const uint64_t bitmap_frame = LoadLittle<uint32_t>(value.data() + 16);
  const uint64_t errors_frame = LoadLittle<uint32_t>(value.data() + 20);
  if (b.vertices != vertices) {
    return bad("holds " + std::to_string(b.vertices) + " vertices; the block has " + std::to_string(vertices));
  }
  const uint64_t frames = summed.size() - kSparseBlockPrefix;
  if (b.candidates > vertices || kept == 0 || kept > b.candidates || errors > kept ||
      (errors == 0) != (errors_frame == 0) || bitmap_frame + errors_frame >= frames) {
    return bad("counts or sizes out of range");
  }
  const std::span<const uint8_t> all = summed.subspan(kSparseBlockPrefix);
  b.kept.resize((size_t{b.candidates} + 7) / 8);
  SDB_RETURN_IF_ERROR(zstd.Decompress(all.first(bitmap_frame), b.kept, what));
  uint64_t ones = 0;
  for (uint8_t byte : b.kept) ones += static_cast<uint64_t>(std::popcount(byte));
  if ((b.candidates & 7) != 0 && (b.kept.back() >> (b.candidates & 7)) != 0) return bad("bits past its candidates");
  if (ones != kept) return bad("bitmap of " + std::to_string(ones) + " kept, counted " + std::to_string(kept));
  std::vector<uint8_t> planes(size_t{kept} * std::max(error_width, voxel_width));
  std::vector<uint64_t> wide(errors);
  if (errors > 0) {
    const std::span<uint8_t> dst(planes.data(), size_t{errors} * error_width);
    SDB_RETURN_IF_ERROR(zstd.Decompress(all.subspan(bitmap_frame, errors_frame), dst, what));
    GetPlanes(planes.data(), errors, error_width, wide.data());
  }
  b.errors.assign(wide.begin(), wide.end());
  const std::span<uint8_t> dst(planes.data(), size_t{kept} * voxel_width);
  SDB_RETURN_IF_ERROR(zstd.Decompress(all.subspan(bitmap_frame + errors_frame), dst, what));
  b.residuals.resize(kept);
  GetPlanes(planes.data(), kept, voxel_width, b.residuals.data());
  return b;
}

}  // namespace simplexdb
