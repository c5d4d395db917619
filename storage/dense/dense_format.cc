#include "storage/dense/dense_format.h"

#include <cmath>
#include <cstring>
#include <utility>

#include "storage/io/checksum.h"
#include "util/utf8.h"

namespace simplexdb {

Result<Compression> ParseCompression(std::string_view name) {
  if (name == "none") return Compression::kNone;
  if (name == "zstd") return Compression::kZstd;
  return Status::InvalidArgument("unknown compression '" + std::string(name) +
                                 "': expected none or zstd");
}
namespace {

// Byte offsets of the header fields (docs/format/dense-store.md).
constexpr size_t kOffMagic = 0;
constexpr size_t kOffVersion = 8;
constexpr size_t kOffHeaderSize = 12;
constexpr size_t kOffDimension = 16;
constexpr size_t kOffQuantization = 17;
constexpr size_t kOffVoxelType = 18;
constexpr size_t kOffDomainBits = 19;
constexpr size_t kOffBlockBits = 20;
constexpr size_t kOffBrickBits = 21;
constexpr size_t kOffFlags = 22;
constexpr size_t kOffReserved = 23;  // 1 byte, zero
constexpr size_t kOffDims = 24;
constexpr size_t kOffSpacing = 40;
constexpr size_t kOffOrigin = 72;
// The header's doubles and 64-bit words by offset, written and read alike.
constexpr std::pair<size_t, double DenseHeader::*> kDoubleFields[] = {
    {104, &DenseHeader::field_min}, {112, &DenseHeader::field_max},   {120, &DenseHeader::error_max},
    {128, &DenseHeader::quantum},   {136, &DenseHeader::scale_slope}, {144, &DenseHeader::scale_intercept}};
constexpr std::pair<size_t, uint64_t DenseHeader::*> kWordFields[] = {
    {152, &DenseHeader::virtual_blocks},      {160, &DenseHeader::stored_blocks},
    {168, &DenseHeader::bitmap_offset},       {176, &DenseHeader::index_offset},
    {184, &DenseHeader::file_size},           {192, &DenseHeader::bitmap_checksum},
    {200, &DenseHeader::index_checksum},      {208, &DenseHeader::bricks},
    {216, &DenseHeader::brick_index_offset},  {224, &DenseHeader::brick_index_checksum}};
constexpr size_t kOffSourceLength = 232;  // u16
constexpr size_t kOffSource = 234;
constexpr size_t kOffChecksum = kDenseHeaderSize - 8;
static_assert(kOffSource + kDenseMaxSource <= kOffChecksum);

}  // namespace

std::array<uint8_t, kDenseHeaderSize> SerializeDenseHeader(const DenseHeader& h) {
  std::array<uint8_t, kDenseHeaderSize> b{};
  uint8_t* p = b.data();
  std::memcpy(p + kOffMagic, kDenseMagic.data(), kDenseMagic.size());
  StoreLittle<uint32_t>(p + kOffVersion, h.version);
  StoreLittle<uint32_t>(p + kOffHeaderSize, static_cast<uint32_t>(kDenseHeaderSize));
  p[kOffDimension] = h.dimension;
  p[kOffQuantization] = static_cast<uint8_t>(h.quantization);
  p[kOffVoxelType] = static_cast<uint8_t>(h.voxel_type);
  p[kOffDomainBits] = h.domain_bits;
  p[kOffBlockBits] = h.block_bits;
  p[kOffBrickBits] = h.brick_bits;
  p[kOffFlags] = h.flags;
  for (int i = 0; i < 4; ++i) {
    StoreLittle<uint32_t>(p + kOffDims + 4 * i, h.dims[i]);
    StoreLittle<double>(p + kOffSpacing + 8 * i, h.spacing[i]);
    StoreLittle<double>(p + kOffOrigin + 8 * i, h.origin[i]);
  }
  for (const auto& [offset, field] : kDoubleFields) StoreLittle<double>(p + offset, h.*field);
  for (const auto& [offset, field] : kWordFields) StoreLittle<uint64_t>(p + offset, h.*field);
  const size_t n = Utf8PrefixLength(h.source, kDenseMaxSource);
  StoreLittle<uint16_t>(p + kOffSourceLength, static_cast<uint16_t>(n));
  std::memcpy(p + kOffSource, h.source.data(), n);
  StoreLittle<uint64_t>(p + kOffChecksum, Checksum(std::span<const uint8_t>(p, kOffChecksum)));
  return b;
}

Result<DenseHeader> ParseDenseHeader(std::span<const uint8_t> bytes, std::string_view file) {
  const std::string where(file);
  const auto corrupt = [&](const std::string& why) {
    return Status::Corruption(where + ": header: " + why);
  };
  const uint8_t* b = bytes.data();
  if (bytes.size() < kDenseMagic.size() ||
      std::memcmp(b + kOffMagic, kDenseMagic.data(), kDenseMagic.size()) != 0) {
    return Status::InvalidArgument(where + ": not a SimplexDB dense store (bad magic)");
  }
  const auto too_short = [&] {
    return corrupt("the file is " + std::to_string(bytes.size()) +
                   " bytes, shorter than a header (" + std::to_string(kDenseHeaderSize) + ")");
  };
  DenseHeader h;
  // The version first, so an older store is named as such however short.
  if (bytes.size() < kOffVersion + 4) return too_short();
  h.version = LoadLittle<uint32_t>(b + kOffVersion);
  if (h.version == 1) {
    return Status::NotSupported(where +
                                ": a format-1 dense store, which this version no longer reads: "
                                "import the volume again to make a format-2 store");
  }
  if (h.version == 2) {
    return Status::NotSupported(where +
                                ": a format-2 store of version 2 (errors and field values in one "
                                "record), which this version no longer reads: import the volume "
                                "again");
  }
  if (h.version != kDenseFormatVersion) {
    return Status::NotSupported(where + ": format version " + std::to_string(h.version) +
                                "; this build reads version " + std::to_string(kDenseFormatVersion));
  }
  if (bytes.size() < kDenseHeaderSize) return too_short();
  if (LoadLittle<uint64_t>(b + kOffChecksum) !=
      Checksum(std::span<const uint8_t>(b, kOffChecksum))) {
    return corrupt("checksum mismatch");
  }
  if (LoadLittle<uint32_t>(b + kOffHeaderSize) != kDenseHeaderSize) {
    return corrupt("unexpected header size");
  }
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
  h.block_bits = b[kOffBlockBits];
  const int max_bits = h.dimension == 3 ? 18 : 13;  // the deepest leaf level a key holds
  if (h.domain_bits < 1 || h.domain_bits > max_bits) {
    return corrupt("domain bits " + std::to_string(h.domain_bits) + " out of range 1.." +
                   std::to_string(max_bits));
  }
  if (h.block_bits < 6 || h.block_bits > 20) {
    return corrupt("block bits " + std::to_string(h.block_bits) + " out of range 6..20");
  }
  h.brick_bits = b[kOffBrickBits];
  if (h.brick_bits < 1 || h.brick_bits > (h.dimension == 3 ? 6 : 4)) {
    return corrupt("brick bits " + std::to_string(h.brick_bits) + " out of range");
  }
  h.flags = b[kOffFlags];
  if ((h.flags & ~kDenseFinestStored) != 0) return corrupt("unknown flags " + std::to_string(h.flags));
  if (b[kOffReserved] != 0) return corrupt("reserved bytes are set");
  const uint64_t side = (uint64_t{1} << h.domain_bits) + 1;
  for (int i = 0; i < 4; ++i) {
    h.dims[i] = LoadLittle<uint32_t>(b + kOffDims + 4 * i);
    const bool used = i < h.dimension;
    if (used ? (h.dims[i] < 2 || h.dims[i] > side) : h.dims[i] != 1) {
      return corrupt("axis " + std::to_string(i) + " has " + std::to_string(h.dims[i]) +
                     " points, outside the domain of side " + std::to_string(side));
    }
    h.spacing[i] = LoadLittle<double>(b + kOffSpacing + 8 * i);
    h.origin[i] = LoadLittle<double>(b + kOffOrigin + 8 * i);
    // A space axis may be flipped (negative spacing); time runs forwards.
    const bool spacing_ok = i < 3 ? h.spacing[i] != 0 : h.spacing[i] > 0;
    if (!std::isfinite(h.spacing[i]) || !spacing_ok || !std::isfinite(h.origin[i])) {
      return corrupt("axis " + std::to_string(i) + ": spacing and origin must be finite, "
                     "spacing non-zero (positive for time)");
    }
  }
  for (const auto& [offset, field] : kDoubleFields) h.*field = LoadLittle<double>(b + offset);
  if (!std::isfinite(h.field_min) || !std::isfinite(h.field_max) || h.field_min > h.field_max) {
    return corrupt("field range is not a finite interval");
  }
  if (!std::isfinite(h.error_max) || h.error_max < 0 || !std::isfinite(h.quantum) ||
      h.quantum < 0 || (h.quantization != Quantization::kF32 && !(h.quantum > 0))) {
    return corrupt("error scale is not finite and positive");
  }
  if (!std::isfinite(h.scale_slope) || !std::isfinite(h.scale_intercept)) {
    return corrupt("scaling is not finite");
  }
  for (const auto& [offset, field] : kWordFields) h.*field = LoadLittle<uint64_t>(b + offset);
  // The positions with stored errors: every block but a lone first one is
  // full.
  const int position_bits = h.dimension * (h.domain_bits + (h.finest_stored() ? 1 : 0));
  const uint64_t expected_virtual =
      position_bits <= h.block_bits ? 1 : uint64_t{1} << (position_bits - h.block_bits);
  if (h.virtual_blocks != expected_virtual) {
    return corrupt(std::to_string(h.virtual_blocks) + " virtual blocks, expected " +
                   std::to_string(expected_virtual));
  }
  if (h.stored_blocks == 0 || h.stored_blocks > h.virtual_blocks ||
      h.bitmap_offset < kDenseHeaderSize || h.bitmap_offset > h.file_size ||
      h.index_offset != h.bitmap_offset + 8 * h.bitmap_words() ||
      h.brick_index_offset != h.index_offset + h.stored_blocks * kDenseIndexEntrySize ||
      h.bricks == 0 || h.bricks > h.file_size / kDenseIndexEntrySize ||
      h.file_size != h.brick_index_offset + h.bricks * kDenseIndexEntrySize) {
    return corrupt("block counts, offsets and file size disagree");
  }
  const uint16_t n = LoadLittle<uint16_t>(b + kOffSourceLength);
  if (n > kDenseMaxSource) return corrupt("source length " + std::to_string(n) + " too long");
  h.source.assign(reinterpret_cast<const char*>(b + kOffSource), n);
  for (size_t i = kOffSource + n; i < kOffChecksum; ++i) {
    if (b[i] != 0) return corrupt("reserved bytes are not zero");
  }
  return h;
}

void SerializeDenseIndexEntry(const DenseIndexEntry& e, uint8_t* out) {
  std::memset(out, 0, kDenseIndexEntrySize);
  StoreLittle<uint64_t>(out + 0, e.offset);
  StoreLittle<uint32_t>(out + 8, e.stored_size);
  out[12] = static_cast<uint8_t>(e.encoding);
  StoreLittle<uint64_t>(out + 16, e.checksum);
  StoreLittle<float>(out + 24, e.field_min);
  StoreLittle<float>(out + 28, e.field_max);
  StoreLittle<uint32_t>(out + 32, e.error_max);
}

}  // namespace simplexdb
