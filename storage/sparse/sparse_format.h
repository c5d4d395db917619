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
// entry. A block's value is stored in parts (SparsePartCutter) under
// 12-byte keys: the block number, 8 bytes big-endian, then the part's number
// from 0, 4 bytes big-endian; the header under the key "header", in the same
// (unnamed) LMDB database. The value, its parts joined:
//
//   u32  vertices           domain vertices among the block's positions
//   u32  candidates         those that may be kept (SparseMayBeKept);
//                           equal to `vertices`: a bit for every vertex
//   u32  kept               kept ones (at least 1)
//   u32  errors             kept ones below the finest octave
//   u32  bitmap frame bytes
//   u32  errors frame bytes (0 when `errors` is 0)
//   ...  three zstd frames, one per section below (each compresses better
//        alone: 1 to 6% smaller on the real volumes than one frame)
//   u64  checksum           XXH3-64 of everything before it, seeded with
//                           the block number (a value moved to another key
//                           fails it)
//
// The sections, decoded, little-endian:
//
//   bitmap                  ceil(candidates / 8) bytes: bit i of byte
//                           i / 8 for the block's i-th candidate in
//                           position order: kept
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
#include "storage/error/quantize.h"
#include "storage/io/codec.h"
#include "storage/volume/voxel_type.h"
#include "util/status.h"

namespace simplexdb {

// The header's version: 2 was one LMDB value per block; 3 kept the blocks
// and the header in two named databases, in parts of a fixed size. Both
// refused.
inline constexpr uint32_t kSparseFormatVersion = 4;

// Cuts the blocks' values into parts that fill LMDB's leaf pages when they
// are appended in key order. A leaf node takes 8 bytes, its key and its
// value, rounded up to even, plus a 2-byte slot, out of the page's room (its
// size less a 16-byte header); a value of more than about half the room
// goes to overflow pages of its own instead. Parts are therefore at most
// half the room less a node's overhead (2018 bytes in a 4 KiB page), and a
// block's first part takes what is left of the page its predecessor's last
// part ended in: no page is left part empty (fixed parts of 998 bytes left
// 1 to 8% of the real volumes' stores unused; bench/README.md). A reader
// takes parts of any size.
class SparsePartCutter {
 public:
  explicit SparsePartCutter(size_t page_bytes)
      : room_(page_bytes - 16), free_(room_), largest_(room_ / 2 - kNodeBytes) {}
  // The size of the next part of a value with `left` (> 0) bytes to go.
  size_t Next(size_t left) {
    // A part of under 32 bytes would cost more in its node than it fills.
    if (free_ < kNodeBytes + 32) free_ = room_;
    const size_t n = std::min({left, largest_, free_ - kNodeBytes});
    free_ -= ((20 + n + 1) & ~size_t{1}) + 2;
    return n;
  }

 private:
  static constexpr size_t kNodeBytes = 8 + 12 + 2;  // node header, key, slot
  size_t room_, free_, largest_;
};

inline constexpr size_t kSparseKeyBytes = 12;
// A block value's bytes before its frames: four counts, two frame sizes.
inline constexpr size_t kSparseBlockPrefix = 24;
inline std::array<uint8_t, kSparseKeyBytes> SparseKey(uint64_t block, uint32_t part) {
  std::array<uint8_t, kSparseKeyBytes> k{};
  for (int i = 0; i < 8; ++i) k[i] = static_cast<uint8_t>(block >> (56 - 8 * i));
  for (int i = 0; i < 4; ++i) k[8 + i] = static_cast<uint8_t>(part >> (24 - 8 * i));
  return k;
}
// False when `key` is not a block part's key (its size).
inline bool ParseSparseKey(std::span<const uint8_t> key, uint64_t* block, uint32_t* part) {
  if (key.size() != kSparseKeyBytes) return false;
  *block = 0;
  *part = 0;
  for (int i = 0; i < 8; ++i) *block = *block << 8 | key[i];
  for (int i = 8; i < 12; ++i) *part = *part << 8 | key[i];
  return true;
}

struct SparseHeader {
  uint32_t version = kSparseFormatVersion;
  int dimension = 3;  // 3: HT, 4: HP
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  std::array<double, 4> spacing = {1, 1, 1, 1};  // the input's, per axis (metadata)
  // Where grid point 0 is (metadata). Optional in the JSON: stores written
  // before 2026-11-27 have no "origin" and read as zeros.
  std::array<double, 4> origin = {0, 0, 0, 0};
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
  uint64_t blocks = 0;  // blocks stored (not parts)
  uint64_t kept = 0;    // kept vertices, the domain's corners included
  std::string source;

  uint64_t points() const {
    uint64_t n = 1;
    for (int a = 0; a < dimension; ++a) n *= dims[a];
    return n;
  }
};

// The header's key, after every block's in LMDB's order (a block key's
// first byte is 0 below 2^56 blocks).
inline constexpr uint8_t kSparseHeaderKey[] = {'h', 'e', 'a', 'd', 'e', 'r'};
inline bool IsSparseHeaderKey(std::span<const uint8_t> key) {
  return std::equal(key.begin(), key.end(), std::begin(kSparseHeaderKey), std::end(kSparseHeaderKey));
}

// The header's LMDB value: its JSON text and an XXH3-64 of the text.
std::vector<uint8_t> EncodeSparseHeader(const SparseHeader& h);
// Checks the checksum, the fields and their ranges. Errors: Corruption
// naming `file`; NotSupported for another version.
Result<SparseHeader> DecodeSparseHeader(std::span<const uint8_t> value, const std::string& file);

// A block's content (its frames, decoded).
struct SparseBlock {
  uint32_t vertices = 0;
  uint32_t candidates = 0;          // vertices SparseMayBeKept
  std::vector<uint8_t> kept;        // bitmap over the candidates, (candidates + 7) / 8 bytes
  std::vector<uint32_t> errors;     // codes, in position order
  std::vector<uint64_t> residuals;  // the width's low bits, in position order

  bool IsKept(uint32_t i) const { return (kept[i >> 3] >> (i & 7) & 1) != 0; }
};

// Whether vertex g of a store over [0, 2^k]^D may be kept, given
// `kept_at(q)` for the vertices it stands on: the domain's corners may (they
// are always kept); another vertex when every vertex of its diamond's
// simplices (FinestDiamonds::VertexOffsets, inside the domain; coarser
// than g) is kept, since the kept set is closed under them. The bitmap may
// have a bit for these candidates only: a vertex whose ancestor is dropped
// is dropped, and coding it anyway took 2.5 times the bytes. `kept_at` is
// asked in a fixed order and not after its first false: the split edge's
// ends first (among those vertices, and the likeliest to be dropped).
template <int D, class KeptAt>
bool SparseMayBeKept(const std::array<int64_t, D>& g, int k, KeptAt&& kept_at) {
  const int64_t side = int64_t{1} << k;
  bool corner = true;
  for (int a = 0; a < D; ++a) corner = corner && (g[a] == 0 || g[a] == side);
  if (corner) return true;
  const DiamondShape sh = ShapeOfVertex<D>(g);
  const auto& o = FinestDiamonds<D>::Get().SplitOffset(sh.odd, sh.parity);
  std::array<int64_t, D> lo{}, hi{};
  for (int a = 0; a < D; ++a) {
    lo[a] = g[a] - (int64_t{o[a]} << sh.scale_bits);
    hi[a] = g[a] + (int64_t{o[a]} << sh.scale_bits);
  }
  if (!kept_at(lo) || !kept_at(hi)) return false;
  for (const auto& w : FinestDiamonds<D>::Get().VertexOffsets(sh.odd, sh.parity)) {
    std::array<int64_t, D> q{};
    bool inside = true;
    for (int a = 0; a < D; ++a) {
      q[a] = g[a] + (int64_t{w[a]} << sh.scale_bits);
      inside = inside && q[a] >= 0 && q[a] <= side;
    }
    if (inside && !kept_at(q)) return false;
  }
  return true;
}

// Byte widths: of an error code of `q` and of a kept value's residual.
size_t SparseErrorWidth(Quantization q);
size_t SparseResidualWidth(const SparseHeader& h);

// The step at which a store of tolerance t keeps its values: 2t (a kept
// value within t of the input, as a dropped one's), or 0 (exact) when t is
// 0, when the step is below an integer type's own step of 1, or when the
// field's magnitude over the step would not fit the 4-byte residual.
double SparseValueStep(VoxelType type, double tolerance, double field_min, double field_max);

// The largest difference between a value the store gives at a real grid
// point and the input's: t (a dropped vertex) or s / 2 (a kept one).
inline double SparseValueBound(const SparseHeader& h) { return std::max(h.tolerance, h.value_step / 2); }

// The store's error codes. Lossless (t = 0) and with f32 errors: the
// quantizer's (storage/error/quantize.h), as the dense store's. At t > 0
// with u16 or u8 codes (quantum q >= t): codes 0 to 8 stand for 0, q, ...
// 8q; code 8 + j (j >= 1) for 8q 1.25^j, so errors above 8q are rounded up
// by at most 25%. A query at a multiple of q up to 8q refines as with exact
// errors, above it a little more; large codes, the ones that spread, are
// fewer (lidc2 at 1%: errors 218 against 276 KB, bench/README.md). Every
// code stands for at least the error it was made from.
class SparseErrorCoder {
 public:
  static constexpr uint32_t kLinearCodes = 8;
  explicit SparseErrorCoder(const SparseHeader& h);
  uint32_t Encode(double e) const;
  double Decode(uint32_t code) const {
    if (code <= kLinearCodes || steps_.empty()) return quantizer_.Decode(code);
    return code - kLinearCodes < steps_.size() ? steps_[code - kLinearCodes] : steps_.back();
  }
  const ErrorQuantizer& quantizer() const { return quantizer_; }

 private:
  ErrorQuantizer quantizer_;
  // steps_[j]: the value of code 8 + j (steps_[0] = 8q), by repeated
  // multiplication up to the first at or above the largest linear code's
  // value, within the quantization's largest code. Empty: linear codes
  // only.
  std::vector<double> steps_;
};

// The value of block `block`. REQUIRES: the counts agree with the bitmap.
Result<std::vector<uint8_t>> EncodeSparseBlock(uint64_t block, const SparseBlock& b,
                                               size_t error_width, size_t voxel_width,
                                               ZstdCompressor& zstd);
// Checks the checksum, sizes and counts; `vertices` is what the block must
// hold (from the geometry). The caller checks the count of candidates
// against the bitmap's walk and of errors against the kept vertices' levels.
Result<SparseBlock> DecodeSparseBlock(uint64_t block, std::span<const uint8_t> value,
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
// REQUIRES: |value - p| / s below 2^30 (SparseValueStep's bound).
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
