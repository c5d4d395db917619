// Sparse store format 2 (docs/format/sparse-store.md): the header and the
// one LMDB value per block of the hierarchical Z-order.
//
// The store keeps the diamonds (hierarchy/hz_order.h) that matter at its
// tolerance t: a diamond is kept when its error exceeds t or a kept
// diamond's simplices stand on its vertex (FinestDiamonds::VertexOffsets),
// so the kept set is closed under ancestors and every refinement of it is a
// conforming mesh. Everything else is dropped: a dropped vertex's value is
// the mean of its split edge's ends (rebuilt coarse octaves first), which
// the builder checked is within t of the input (equal to it at t = 0).
//
// Blocks are runs of 2^block_bits positions of the HZ order over the whole
// domain, the finest octave included. A block with no kept vertex has no
// entry. A block's value is stored in parts of at most kHzSparsePartBytes,
// under 12-byte keys: the block number, 8 bytes big-endian, then the part's
// number from 0, 4 bytes big-endian (parts that small lie inside LMDB's leaf
// pages, packed; a value of more than half a page would take whole overflow
// pages of its own). The value, its parts joined:
//
//   u32  raw_size           bytes of the frame's content
//   ...  zstd frame         the content below
//   u64  checksum           XXH3-64 of raw_size and the frame, seeded with
//                           the block number (a value moved to another key
//                           fails it)
//
// The content, little-endian:
//
//   u32  vertices           domain vertices among the block's positions
//   u32  kept               kept ones
//   u32  errors             kept ones below the finest octave
//   bitmap                  ceil(vertices / 8) bytes: bit i of byte i / 8
//                           for the block's i-th domain vertex in position
//                           order: kept
//   errors                  `errors` error codes of the header's
//                           quantization (1, 2 or 4 bytes), byte planes
//   residuals               `kept` values, byte planes: lossless
//                           (value_step 0), of the voxel type's width, a
//                           kept vertex's value minus its prediction
//                           (below), modulo 2^width for integer types, the
//                           difference of the order-preserving integer
//                           images for float types; at a value step s > 0,
//                           4 bytes, the zigzagged round((value - P) / s)
//                           (the value read back is P + s times it, within
//                           s / 2 of the input's)
//
// Prediction of a vertex v from coarser ones (its split edge's ends v -/+ d
// and the points v -/+ 3d lie on the coarser octaves' lattice): cubic,
// (9 (g(v-d) + g(v+d)) - g(v-3d) - g(v+3d)) / 16, when v -/+ 3d both lie in
// the real grid's box [0, dims - 1]; else the mean of the ends. Integer
// types round it to nearest (ties away from zero) before the residual; the
// 2^D domain corners are predicted 0. The finest octave's errors are not
// stored: a reader computes them from the rebuilt field and adds t.
//
// Thread safety: pure functions. Errors: the decoders return Corruption
// naming the file and the block.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/error/finest_diamonds.h"
#include "storage/error/quantization.h"
#include "storage/io/codec.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// The header's version: 2 was one LMDB value per block, refused.
inline constexpr uint32_t kHzSparseFormatVersion = 3;

// A block's value in parts: four of the largest, with their keys and LMDB's
// node headers and slots (22 bytes each), fill a 4 KiB page's 4080 bytes;
// a block's last, shorter part leaves on average half a part unused (parts
// of 2000 bytes made the real volumes' stores up to 12% larger; of 488, up
// to 4% larger in 3D and 2-6% smaller on the fMRI: bench/README.md).
inline constexpr size_t kHzSparsePartBytes = 998;
inline constexpr size_t kHzSparseKeyBytes = 12;
inline std::array<uint8_t, kHzSparseKeyBytes> HzSparseKey(uint64_t block, uint32_t part) {
  std::array<uint8_t, kHzSparseKeyBytes> k{};
  for (int i = 0; i < 8; ++i) k[i] = static_cast<uint8_t>(block >> (56 - 8 * i));
  for (int i = 0; i < 4; ++i) k[8 + i] = static_cast<uint8_t>(part >> (24 - 8 * i));
  return k;
}
// False when `key` is not a block part's key (its size).
inline bool ParseHzSparseKey(std::span<const uint8_t> key, uint64_t* block, uint32_t* part) {
  if (key.size() != kHzSparseKeyBytes) return false;
  *block = 0;
  *part = 0;
  for (int i = 0; i < 8; ++i) *block = *block << 8 | key[i];
  for (int i = 8; i < 12; ++i) *part = *part << 8 | key[i];
  return true;
}

struct HzSparseHeader {
  uint32_t version = kHzSparseFormatVersion;
  int dimension = 3;  // 3: HT, 4: HP
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  std::array<double, 4> spacing = {1, 1, 1, 1};  // the input's, per axis (metadata)
  int domain_bits = 1;  // the domain [0, 2^k]^D
  VoxelType voxel_type = VoxelType::kU8;
  Quantization quantization = Quantization::kU16;
  double quantum = 0;
  double field_min = 0, field_max = 0;
  double error_max = 0;  // the largest diamond error of the input
  double tolerance = 0;  // t, in the field's units
  // s: kept values are stored to within s / 2 (0: exactly, as the voxel type)
  double value_step = 0;
  int block_bits = 18;
  uint64_t blocks = 0;  // entries in "blocks"
  uint64_t kept = 0;    // kept vertices, the domain's corners included
  std::string source;

  uint64_t points() const {
    uint64_t n = 1;
    for (int a = 0; a < dimension; ++a) n *= dims[a];
    return n;
  }
};

// The header's key in the "meta" database (the blocks are in "blocks").
inline constexpr uint8_t kHzSparseHeaderKey[] = {'h', 'e', 'a', 'd', 'e', 'r'};

// The header's LMDB value: its JSON text and an XXH3-64 of the text.
std::vector<uint8_t> EncodeHzSparseHeader(const HzSparseHeader& h);
// Checks the checksum, the fields and their ranges. Errors: Corruption
// naming `file`; NotSupported for another version.
Result<HzSparseHeader> DecodeHzSparseHeader(std::span<const uint8_t> value, const std::string& file);

// A block's content (the frame's, decoded).
struct HzSparseBlock {
  uint32_t vertices = 0;
  std::vector<uint8_t> kept;        // bitmap, (vertices + 7) / 8 bytes
  std::vector<uint32_t> errors;     // codes, in position order
  std::vector<uint64_t> residuals;  // the width's low bits, in position order

  bool IsKept(uint32_t i) const { return (kept[i >> 3] >> (i & 7) & 1) != 0; }
};

// Byte widths: of an error code of `q` and of a kept value's residual.
size_t HzSparseErrorWidth(Quantization q);
size_t HzSparseResidualWidth(const HzSparseHeader& h);

// The step at which a store of tolerance t keeps its values: 2t (a kept
// value within t of the input, as a dropped one's), or 0 (exact) when t is
// 0, when the step is below an integer type's own step of 1, or when the
// field's magnitude over the step would not fit the 4-byte residual.
double HzSparseValueStep(VoxelType type, double tolerance, double field_min, double field_max);

// The largest difference between a value the store gives at a real grid
// point and the input's: t (a dropped vertex) or s / 2 (a kept one).
inline double HzSparseValueBound(const HzSparseHeader& h) { return std::max(h.tolerance, h.value_step / 2); }

// The value of block `block`. REQUIRES: the counts agree with the bitmap.
Result<std::vector<uint8_t>> EncodeHzSparseBlock(uint64_t block, const HzSparseBlock& b,
                                                 size_t error_width, size_t voxel_width,
                                                 ZstdCompressor& zstd);
// Checks the checksum, sizes and counts; `vertices` is what the block must
// hold (from the geometry). The caller checks the count of errors against
// the kept vertices' levels.
Result<HzSparseBlock> DecodeHzSparseBlock(uint64_t block, std::span<const uint8_t> value,
                                          uint32_t vertices, size_t error_width,
                                          size_t voxel_width, ZstdDecompressor& zstd,
                                          const std::string& file);

// The geometry and arithmetic the builder and the reader share: both must
// compute bit for bit the same predictions.

// The ends of vertex g's split edge (g not a domain corner), g -/+ d.
template <int D>
void HzSplitEnds(const std::array<int64_t, D>& g, std::array<int64_t, D>& lo,
                 std::array<int64_t, D>& hi) {
  const DiamondShape sh = ShapeOfVertex<D>(g);
  const auto& o = FinestDiamonds<D>::Get().SplitOffset(sh.odd, sh.parity);
  for (int a = 0; a < D; ++a) {
    lo[a] = g[a] - (int64_t{o[a]} << sh.scale_bits);
    hi[a] = g[a] + (int64_t{o[a]} << sh.scale_bits);
  }
}

// The prediction of vertex g (not a corner) from `value(point)` at coarser
// points: cubic along the split edge when g -/+ 3d lie in the real grid's
// box, else the ends' mean (`linear_only`: the mean, as a dropped vertex).
template <int D, class Value>
double HzPredict(const std::array<int64_t, D>& g, const std::array<int64_t, D>& dims, bool linear_only,
                 Value&& value) {
  std::array<int64_t, D> lo{}, hi{};
  HzSplitEnds<D>(g, lo, hi);
  const double a = value(lo), b = value(hi);
  if (linear_only) return (a + b) / 2;
  std::array<int64_t, D> lo3{}, hi3{};
  for (int i = 0; i < D; ++i) {
    lo3[i] = 3 * lo[i] - 2 * g[i];
    hi3[i] = 3 * hi[i] - 2 * g[i];
    if (lo3[i] < 0 || lo3[i] >= dims[i] || hi3[i] < 0 || hi3[i] >= dims[i]) return (a + b) / 2;
  }
  return (9 * (a + b) - value(lo3) - value(hi3)) / 16;
}

// A kept value's residual against prediction `p` (see the header comment)
// and the value back from it. `value` is of `type` (an integer for integer
// types); the residual keeps the width's low bits.
uint64_t HzResidual(VoxelType type, double value, double p);
double HzFromResidual(VoxelType type, uint64_t residual, double p);
// At a value step s > 0: the residual of `value` against `p` and, in
// `*read_back`, the value a reader gets from it (within s / 2 of `value`).
// REQUIRES: |value - p| / s below 2^30 (HzSparseValueStep's bound).
uint64_t HzStepResidual(double value, double p, double step, double* read_back);
double HzFromStepResidual(uint64_t residual, double p, double step);

// Calls f(position, g) for every domain vertex among positions [first,
// first + count) of `order`, in position order.
template <int D, class F>
void ForEachHzVertex(const HzOrder<D>& order, uint64_t first, uint64_t count, F&& f) {
  const uint64_t end = std::min(order.size(), first + count);
  std::array<int64_t, D> g{};
  for (uint64_t p = first; p < end; ++p) {
    if (order.Decode(p, g)) f(p, g);
  }
}

// False when block `b` (2^block_bits positions) holds no domain vertex for
// certain: a block inside one octave's segment whose Morton range of cubes
// lies past the domain's last cube on some axis. O(D).
template <int D>
bool HzBlockMayHoldVertices(int block_bits, uint64_t b) {
  const uint64_t first = b << block_bits;
  if (first < (uint64_t{1} << D)) return true;
  const int top = 63 - std::countl_zero(first);
  const int o = top / D - 1;
  if (block_bits > D * (o + 1)) return true;
  const auto u = internal::FromMorton<D>(first & ((uint64_t{1} << (D * (o + 1))) - 1));
  for (int a = 0; a < D; ++a) {
    if (u[a] > (int64_t{1} << o)) return false;
  }
  return true;
}

}  // namespace simplexdb
