// Store format 2, the file: header, error blocks, field bricks, block
// presence bitmap and the two indexes (docs/format/dense-store.md is the
// specification; this header is its code).
//
// Errors: one per grid vertex (its diamond's), in the hierarchical Z-order
// of hierarchy/hz_order.h, in blocks of 2^block_bits entries. Stores built
// from the field in memory keep them for every octave but the finest (HZ
// positions below 2^(D k)): a reader computes the finest octave's from the
// field (storage/error/finest_box_errors.h), as the builder did. Stores
// built from a field with missing values (NaN, a mask) set kDenseFinestStored
// and keep every octave's.
//
// Field: every octave's lattice as bricks (storage/dense/field_bricks.h),
// 2^brick_bits points per axis, coarsest lattice first.
//
// Layout of a store file (all integers little-endian):
//
//   [0, 4096)                header (kDenseHeaderSize bytes; unused bytes zero)
//   [4096, bitmap_offset)    error blocks and bricks, back to back, in any order
//   [bitmap_offset, +8 W)    presence bitmap: W = ceil(virtual blocks / 64)
//                            words; bit b set when virtual block b is stored
//   [index_offset, +40 S)    block index: one entry per stored block, in
//                            block order
//   [brick_index_offset, end) brick index: one entry per brick, in brick order
//
// Virtual block b is the HZ positions [b * 2^block_bits, (b + 1) *
// 2^block_bits) of the positions with stored errors. Block 0 holds the
// corners and every octave whose segments are shorter than a block; every
// other block lies inside one segment (one level and odd-axis pattern), so
// it is a box of cubes of one level. Block 0 and every block holding a
// non-zero error are stored; a block not stored holds zeros.
//
// A decoded block is 2^block_bits error entries (u16, u8 or f32 bits, by
// the quantization); positions that are no vertex hold 0. A brick entry's
// error_max is the largest finest-octave error code of the vertices the
// brick owns (lattice 0, finest errors not stored; 0 otherwise): the finest
// vertex g belongs to the grid brick holding g clamped to the real grid.
//
// The first 8 bytes (kDenseMagic) and the version at offset 8 are those of
// every dense format since the first, so a store of a retired version is
// named as such (format 1, before 2026-11-26: one error per simplex; format
// 2's version 2: errors and field in one record) with what to do.
//
// Thread safety: plain values and pure functions.
// Errors: ParseDenseHeader returns InvalidArgument (bad magic: not a dense
// store), NotSupported (format 1, or format 2's version 2, with what to do;
// another version) or Corruption (checksum, a field out of range), naming
// the file; ParseCompression InvalidArgument naming the unknown word.
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

// How a block's or brick's bytes are stored (stable numbers: on disk).
enum class BlockEncoding : uint8_t {
  kRaw = 1,   // the entries as they are, little-endian, read in place
  kZstd = 2,  // one independent zstd frame (with its content checksum)
};

// How a builder stores blocks and bricks: raw, or zstd frames where they
// are smaller.
enum class Compression : uint8_t { kNone = 0, kZstd = 1 };
Result<Compression> ParseCompression(std::string_view name);  // "none", "zstd"

// Version 3: errors and field apart (version 2 kept both per record).
inline constexpr uint32_t kDenseFormatVersion = 3;
inline constexpr size_t kDenseHeaderSize = 4096;
inline constexpr size_t kDenseIndexEntrySize = 40;
inline constexpr size_t kDenseMaxSource = 1024;
// 4096 records: 12 KiB decoded for u16 errors and 8-bit voxels, a 16^3 box
// of cubes (8^4 in the HP) at the fine levels.
inline constexpr int kDenseDefaultBlockBits = 12;
// Bricks of 16^3 points in the HT, 8^4 in the HP: 4096 either way.
inline constexpr int DenseDefaultBrickBits(int dimension) { return dimension == 3 ? 4 : 3; }
// Header flags.
inline constexpr uint8_t kDenseFinestStored = 1;  // the finest octave's errors are in blocks

struct DenseHeader {
  uint32_t version = kDenseFormatVersion;
  uint8_t dimension = 3;  // 3: HT, 4: HP
  Quantization quantization = Quantization::kU16;
  VoxelType voxel_type = VoxelType::kU8;  // the stored field's type
  uint8_t domain_bits = 0;                // k: the domain has side 2^k
  uint8_t block_bits = kDenseDefaultBlockBits;
  uint8_t brick_bits = 4;                 // bricks of 2^brick_bits points per axis
  uint8_t flags = 0;                      // kDenseFinestStored
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};  // the real grid (unused axes 1)
  std::array<double, 4> spacing = {1, 1, 1, 1};
  std::array<double, 4> origin = {0, 0, 0, 0};
  double field_min = 0, field_max = 0;  // over the real grid, missing values skipped
  double error_max = 0;                 // the largest diamond error, before quantization
  double quantum = 0;                   // error units per code step (u16, u8)
  double scale_slope = 1, scale_intercept = 0;  // applied to the input's values (NIfTI)
  uint64_t virtual_blocks = 0;
  uint64_t stored_blocks = 0;
  uint64_t bitmap_offset = 0;
  uint64_t index_offset = 0;
  uint64_t file_size = 0;
  uint64_t bitmap_checksum = 0;  // XXH3-64 of the bitmap bytes
  uint64_t index_checksum = 0;   // XXH3-64 of the index bytes
  uint64_t bricks = 0;                // field bricks (BrickGrid::bricks())
  uint64_t brick_index_offset = 0;    // index_offset + 40 * stored_blocks
  uint64_t brick_index_checksum = 0;  // XXH3-64 of the brick index bytes
  std::string source;            // what the store was built from (<= kDenseMaxSource bytes)

  int leaf_level() const { return dimension * domain_bits; }
  bool finest_stored() const { return (flags & kDenseFinestStored) != 0; }
  // The HZ positions whose errors the blocks hold: all of them
  // (2^(D (k + 1))) or all but the finest octave's (2^(D k)).
  uint64_t error_positions() const {
    return uint64_t{1} << (dimension * (domain_bits + (finest_stored() ? 1 : 0)));
  }
  uint64_t block_records() const { return uint64_t{1} << block_bits; }
  uint64_t bitmap_words() const { return (virtual_blocks + 63) / 64; }
};

// Serializes into exactly kDenseHeaderSize bytes, checksum included (the
// source is cut between characters to kDenseMaxSource bytes).
std::array<uint8_t, kDenseHeaderSize> SerializeDenseHeader(const DenseHeader& h);

// Parses and checks a header: magic, version, checksum, ranges, and that the
// counts and offsets describe a file of file_size bytes.
Result<DenseHeader> ParseDenseHeader(std::span<const uint8_t> bytes, std::string_view file);

// One stored block or brick.
struct DenseIndexEntry {
  uint64_t offset = 0;       // in the file
  uint32_t stored_size = 0;  // bytes in the file
  // Blocks: BlockEncoding kRaw or kZstd; bricks: BrickCoding.
  uint8_t encoding = 1;
  uint64_t checksum = 0;     // XXH3-64 of the stored bytes
  float field_min = 0;       // bricks: the field over the brick, rounded outward
  float field_max = 0;       //   to float (0, 0 when every value is missing)
  uint32_t error_max = 0;    // the largest error code: a block's entries, a
                             //   brick's finest vertices (code or f32 bits)
};

void SerializeDenseIndexEntry(const DenseIndexEntry& e, uint8_t* out);  // kDenseIndexEntrySize bytes

inline DenseIndexEntry ParseDenseIndexEntry(const uint8_t* in) {
  DenseIndexEntry e;
  e.offset = LoadLittle<uint64_t>(in + 0);
  e.stored_size = LoadLittle<uint32_t>(in + 8);
  e.encoding = in[12];  // checked by the reader
  e.checksum = LoadLittle<uint64_t>(in + 16);
  e.field_min = LoadLittle<float>(in + 24);
  e.field_max = LoadLittle<float>(in + 28);
  e.error_max = LoadLittle<uint32_t>(in + 32);
  return e;
}

}  // namespace simplexdb
