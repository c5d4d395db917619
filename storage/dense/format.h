// The dense store's file format: header, block index entries, enums, and
// their (de)serialization. The specification is docs/format/dense-store.md;
// this header is its code. Change both together, and bump kFormatVersion
// for any change a reader of the old version could misread.
//
// Layout of a store file (all integers little-endian):
//
//   [0, 4096)            header (kHeaderSize bytes; unused bytes are zero)
//   [4096, index_offset) blocks: error blocks, then field bricks, packed
//                        back to back (no alignment gaps)
//   [index_offset, end)  block index: block_count entries of 40 bytes
//
// Every byte is covered by a checksum: the header's own (its last 8 bytes),
// the index's (in the header), each block's (in its index entry). The file
// is written under a temporary name and renamed when complete, so a reader
// never sees a partial store under the real name.
//
// Thread safety: plain values and pure functions; no shared state.
// Errors: ParseHeader returns InvalidArgument (not a dense store: bad
// magic), NotSupported (another format version) or Corruption (a checksum
// or a field out of range, naming it); ParseQuantization and
// ParseCompression return InvalidArgument naming the unknown word.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "storage/error/quantization.h"
#include "storage/volume/voxel_type.h"
#include "util/little_endian.h"
#include "util/status.h"

namespace simplexdb {

inline constexpr std::array<char, 8> kDenseMagic = {'S', 'I', 'M', 'P', 'L', 'X', 'D', 'B'};
inline constexpr uint32_t kFormatVersion = 1;
inline constexpr size_t kHeaderSize = 4096;
inline constexpr size_t kIndexEntrySize = 40;

// How errors are stored: Quantization (storage/error/quantization.h).

// How a block's bytes are stored (stable numbers: they are on disk).
enum class BlockEncoding : uint8_t {
  kZero = 0,  // every entry is zero; no bytes are stored
  kRaw = 1,   // the entries as they are, little-endian, read in place
  kZstd = 2,  // one independent zstd frame (with its content checksum)
};

enum class Compression : uint8_t { kNone = 0, kZstd = 1 };
Result<Compression> ParseCompression(std::string_view name);  // "none", "zstd"

// The header's fields. Offsets in the file are given in the specification.
struct DenseHeader {
  uint32_t version = kFormatVersion;
  uint8_t dimension = 3;            // 3: HT, 4: HP
  Quantization quantization = Quantization::kU16;
  VoxelType voxel_type = VoxelType::kU8;
  uint8_t domain_bits = 0;          // k: the domain is a cube of side 2^k
  uint8_t levels_per_block = 14;    // B: levels per error block
  uint8_t brick_bits = 5;           // field bricks have side 2^brick_bits
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};  // the real grid (x fastest)
  std::array<double, 4> spacing = {1, 1, 1, 1};  // metadata
  double field_min = 0, field_max = 0;
  double error_max = 0;             // the largest error, before quantization
  double quantum = 0;               // error units per code step (u16, u8)
  uint64_t error_block_count = 0;
  uint64_t brick_count = 0;
  uint64_t index_offset = 0;
  uint64_t file_size = 0;           // the whole file: truncation shows here
  uint64_t index_checksum = 0;      // XXH3-64 of the index bytes
  std::string source;               // what the store was built from (<= 255 bytes)

  int leaf_level() const { return dimension * domain_bits; }
  uint64_t block_count() const { return error_block_count + brick_count; }
};

// Serializes into exactly kHeaderSize bytes, checksum included.
std::array<uint8_t, kHeaderSize> SerializeHeader(const DenseHeader& h);

// Parses and checks a header: magic, version, checksum, and that every
// field is in range. `file` names the store in messages.
Result<DenseHeader> ParseHeader(std::span<const uint8_t> bytes, std::string_view file);

// One block index entry.
struct IndexEntry {
  uint64_t offset = 0;        // in the file
  uint32_t stored_size = 0;   // bytes in the file (0 for kZero)
  uint32_t raw_size = 0;      // bytes once decoded
  uint64_t checksum = 0;      // XXH3-64 of the stored bytes
  BlockEncoding encoding = BlockEncoding::kZero;
  float field_min = 0;        // the field over the block's region, rounded
  float field_max = 0;        //   outward to float
  float error_max = 0;        // error blocks: the largest error, rounded up
};

void SerializeIndexEntry(const IndexEntry& e, uint8_t* out);  // kIndexEntrySize bytes

// Inline: readers parse entries from the mapping on every block switch.
inline IndexEntry ParseIndexEntry(const uint8_t* in) {
  IndexEntry e;
  e.offset = LoadLittle<uint64_t>(in + 0);
  e.stored_size = LoadLittle<uint32_t>(in + 8);
  e.raw_size = LoadLittle<uint32_t>(in + 12);
  e.checksum = LoadLittle<uint64_t>(in + 16);
  e.encoding = static_cast<BlockEncoding>(in[24]);  // checked by the reader
  e.field_min = LoadLittle<float>(in + 28);
  e.field_max = LoadLittle<float>(in + 32);
  e.error_max = LoadLittle<float>(in + 36);
  return e;
}

// Float bounds that contain a double: a <= RoundDown(a), RoundUp(a) >= a.
float RoundDownToFloat(double v);
float RoundUpToFloat(double v);

}  // namespace simplexdb
