#include "storage/dense/format.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "storage/io/checksum.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

// Little-endian field access (util/little_endian.h), by width.
void Put8(uint8_t* p, uint8_t v) { p[0] = v; }
void Put16(uint8_t* p, uint16_t v) { StoreLittle(p, v); }
void Put32(uint8_t* p, uint32_t v) { StoreLittle(p, v); }
void Put64(uint8_t* p, uint64_t v) { StoreLittle(p, v); }
void PutF32(uint8_t* p, float v) { StoreLittle(p, v); }
void PutF64(uint8_t* p, double v) { StoreLittle(p, v); }
uint16_t Get16(const uint8_t* p) { return LoadLittle<uint16_t>(p); }
uint32_t Get32(const uint8_t* p) { return LoadLittle<uint32_t>(p); }
uint64_t Get64(const uint8_t* p) { return LoadLittle<uint64_t>(p); }
double GetF64(const uint8_t* p) { return LoadLittle<double>(p); }

// Byte offsets of the header fields (docs/format/dense-store.md).
constexpr size_t kOffMagic = 0;
constexpr size_t kOffVersion = 8;
constexpr size_t kOffHeaderSize = 12;
constexpr size_t kOffDimension = 16;
constexpr size_t kOffQuantization = 17;
constexpr size_t kOffVoxelType = 18;
constexpr size_t kOffDomainBits = 19;
constexpr size_t kOffLevelsPerBlock = 20;
constexpr size_t kOffBrickBits = 21;
constexpr size_t kOffReserved16 = 22;
constexpr size_t kOffDims = 24;
constexpr size_t kOffSpacing = 40;
constexpr size_t kOffFieldMin = 72;
constexpr size_t kOffFieldMax = 80;
constexpr size_t kOffErrorMax = 88;
constexpr size_t kOffQuantum = 96;
constexpr size_t kOffErrorBlocks = 104;
constexpr size_t kOffBricks = 112;
constexpr size_t kOffIndexOffset = 120;
constexpr size_t kOffFileSize = 128;
constexpr size_t kOffIndexChecksum = 136;
constexpr size_t kOffSourceLength = 144;
constexpr size_t kOffSource = 145;
constexpr size_t kMaxSource = 255;
constexpr size_t kOffChecksum = kHeaderSize - 8;              // 4088

}  // namespace

Result<Compression> ParseCompression(std::string_view name) {
  if (name == "none") return Compression::kNone;
  if (name == "zstd") return Compression::kZstd;
  return Status::InvalidArgument("unknown compression '" + std::string(name) +
                                 "': expected none or zstd");
}

float RoundDownToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

float RoundUpToFloat(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

std::array<uint8_t, kHeaderSize> SerializeHeader(const DenseHeader& h) {
  std::array<uint8_t, kHeaderSize> b{};
  std::memcpy(b.data() + kOffMagic, kDenseMagic.data(), kDenseMagic.size());
  Put32(b.data() + kOffVersion, h.version);
  Put32(b.data() + kOffHeaderSize, static_cast<uint32_t>(kHeaderSize));
  Put8(b.data() + kOffDimension, h.dimension);
  Put8(b.data() + kOffQuantization, static_cast<uint8_t>(h.quantization));
  Put8(b.data() + kOffVoxelType, static_cast<uint8_t>(h.voxel_type));
  Put8(b.data() + kOffDomainBits, h.domain_bits);
  Put8(b.data() + kOffLevelsPerBlock, h.levels_per_block);
  Put8(b.data() + kOffBrickBits, h.brick_bits);
  Put16(b.data() + kOffReserved16, 0);
  for (int i = 0; i < 4; ++i) Put32(b.data() + kOffDims + 4 * i, h.dims[i]);
  for (int i = 0; i < 4; ++i) PutF64(b.data() + kOffSpacing + 8 * i, h.spacing[i]);
  PutF64(b.data() + kOffFieldMin, h.field_min);
  PutF64(b.data() + kOffFieldMax, h.field_max);
  PutF64(b.data() + kOffErrorMax, h.error_max);
  PutF64(b.data() + kOffQuantum, h.quantum);
  Put64(b.data() + kOffErrorBlocks, h.error_block_count);
  Put64(b.data() + kOffBricks, h.brick_count);
  Put64(b.data() + kOffIndexOffset, h.index_offset);
  Put64(b.data() + kOffFileSize, h.file_size);
  Put64(b.data() + kOffIndexChecksum, h.index_checksum);
  // Never cut a multi-byte character in half: a valid UTF-8 source stays
  // valid (readers that need valid UTF-8, like JSON, then get all of it).
  const size_t n = Utf8PrefixLength(h.source, kMaxSource);
  Put8(b.data() + kOffSourceLength, static_cast<uint8_t>(n));
  std::memcpy(b.data() + kOffSource, h.source.data(), n);
  Put64(b.data() + kOffChecksum, Checksum(std::span<const uint8_t>(b.data(), kOffChecksum)));
  return b;
}

Result<DenseHeader> ParseHeader(std::span<const uint8_t> bytes, std::string_view file) {
  const std::string where(file);
  const auto corrupt = [&](const std::string& why) {
    return Status::Corruption(where + ": header: " + why);
  };
  const uint8_t* b = bytes.data();
  if (bytes.size() < kDenseMagic.size() ||
      std::memcmp(b + kOffMagic, kDenseMagic.data(), kDenseMagic.size()) != 0) {
    return Status::InvalidArgument(where + ": not a SimplexDB dense store (bad magic)");
  }
  if (bytes.size() < kHeaderSize) {
    return corrupt("the file is " + std::to_string(bytes.size()) +
                   " bytes, shorter than a header (" + std::to_string(kHeaderSize) + ")");
  }
  const uint64_t stored = Get64(b + kOffChecksum);
  if (stored != Checksum(std::span<const uint8_t>(b, kOffChecksum))) {
    return corrupt("checksum mismatch");
  }
  DenseHeader h;
  h.version = Get32(b + kOffVersion);
  if (h.version != kFormatVersion) {
    return Status::NotSupported(where + ": format version " + std::to_string(h.version) +
                                "; this build reads version " +
                                std::to_string(kFormatVersion));
  }
  if (Get32(b + kOffHeaderSize) != kHeaderSize) return corrupt("unexpected header size");
  h.dimension = b[kOffDimension];
  if (h.dimension != 3 && h.dimension != 4) {
    return corrupt("dimension " + std::to_string(h.dimension) + ", expected 3 or 4");
  }
  const uint8_t q = b[kOffQuantization];
  if (q < 1 || q > 3) return corrupt("unknown quantization " + std::to_string(q));
  h.quantization = static_cast<Quantization>(q);
  const uint8_t t = b[kOffVoxelType];
  if (t < 1 || t > 6) return corrupt("unknown voxel type " + std::to_string(t));
  h.voxel_type = static_cast<VoxelType>(t);
  h.domain_bits = b[kOffDomainBits];
  h.levels_per_block = b[kOffLevelsPerBlock];
  h.brick_bits = b[kOffBrickBits];
  // Deepest leaf level a key can hold: HT 55, HP 53.
  const int max_bits = h.dimension == 3 ? 18 : 13;
  if (h.domain_bits < 1 || h.domain_bits > max_bits) {
    return corrupt("domain bits " + std::to_string(h.domain_bits) + " out of range 1.." +
                   std::to_string(max_bits));
  }
  if (h.levels_per_block < 1 || h.levels_per_block > 24) {
    return corrupt("levels per block " + std::to_string(h.levels_per_block) +
                   " out of range 1..24");
  }
  if (h.brick_bits < 1 || h.brick_bits > 8) {
    return corrupt("brick bits " + std::to_string(h.brick_bits) + " out of range 1..8");
  }
  if (Get16(b + kOffReserved16) != 0) return corrupt("reserved bits are set");
  const uint64_t side = (uint64_t{1} << h.domain_bits) + 1;
  for (int i = 0; i < 4; ++i) {
    h.dims[i] = Get32(b + kOffDims + 4 * i);
    const bool used = i < h.dimension;
    if (used ? (h.dims[i] < 2 || h.dims[i] > side) : h.dims[i] != 1) {
      return corrupt("dimension " + std::to_string(i) + " is " + std::to_string(h.dims[i]) +
                     ", outside the domain of side " + std::to_string(side));
    }
  }
  for (int i = 0; i < 4; ++i) h.spacing[i] = GetF64(b + kOffSpacing + 8 * i);
  h.field_min = GetF64(b + kOffFieldMin);
  h.field_max = GetF64(b + kOffFieldMax);
  h.error_max = GetF64(b + kOffErrorMax);
  h.quantum = GetF64(b + kOffQuantum);
  if (!std::isfinite(h.field_min) || !std::isfinite(h.field_max) || h.field_min > h.field_max) {
    return corrupt("field range is not a finite interval");
  }
  if (!std::isfinite(h.error_max) || h.error_max < 0 || !std::isfinite(h.quantum) ||
      h.quantum < 0) {
    return corrupt("error scale is not finite and non-negative");
  }
  h.error_block_count = Get64(b + kOffErrorBlocks);
  h.brick_count = Get64(b + kOffBricks);
  h.index_offset = Get64(b + kOffIndexOffset);
  h.file_size = Get64(b + kOffFileSize);
  h.index_checksum = Get64(b + kOffIndexChecksum);
  if (h.index_offset < kHeaderSize || h.block_count() > (uint64_t{1} << 48) ||
      h.file_size != h.index_offset + h.block_count() * kIndexEntrySize) {
    return corrupt("index offset, block counts and file size disagree");
  }
  const uint8_t n = b[kOffSourceLength];
  h.source.assign(reinterpret_cast<const char*>(b + kOffSource), n);
  for (size_t i = kOffSource + n; i < kOffChecksum; ++i) {
    if (b[i] != 0) return corrupt("reserved bytes are not zero");
  }
  return h;
}

void SerializeIndexEntry(const IndexEntry& e, uint8_t* out) {
  std::memset(out, 0, kIndexEntrySize);
  Put64(out + 0, e.offset);
  Put32(out + 8, e.stored_size);
  Put32(out + 12, e.raw_size);
  Put64(out + 16, e.checksum);
  Put8(out + 24, static_cast<uint8_t>(e.encoding));
  PutF32(out + 28, e.field_min);
  PutF32(out + 32, e.field_max);
  PutF32(out + 36, e.error_max);
}

}  // namespace simplexdb
