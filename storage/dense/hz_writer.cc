#include "storage/dense/hz_writer.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/dense/parallel_run.h"
#include "storage/error/quantize.h"
#include "storage/io/checksum.h"
#include "storage/io/codec.h"
#include "storage/io/file.h"
#include "util/little_endian.h"
#include "util/out_of_memory.h"

namespace simplexdb {
namespace {

// Whether virtual block `vblock` may hold a real vertex or a non-zero
// error: a block spanning several segments (block 0, and a few more when
// block_bits is not a multiple of D) always; another block is one box of
// cubes of one level and pattern, and its vertices' diamonds reach at most
// a cube's side from them.
template <int D>
bool MayHoldData(const HzHeader& h, uint64_t vblock) {
  if (vblock == 0) return true;
  const uint64_t first = vblock << h.block_bits;
  const int octave = (63 - std::countl_zero(first)) / D - 1;
  const uint64_t segment_size = uint64_t{1} << (D * (octave + 1));
  if (segment_size < h.block_records()) return true;
  const uint32_t odd = internal::kOddPatterns<D>.mask_of[(first >> (D * (octave + 1))) - 1];
  const auto lo = internal::FromMorton<D>(first & (segment_size - 1));
  const int s = h.domain_bits - 1 - octave;
  const int64_t side = int64_t{1} << h.domain_bits;
  for (int a = 0; a < D; ++a) {
    const int64_t g = (lo[a] << (s + 1)) | (static_cast<int64_t>(odd >> a & 1) << s);
    if (g > side) return false;  // holes only
    if (g > int64_t{h.dims[a]} - 1 + (int64_t{2} << s)) return false;
  }
  return true;
}

template <int D>
bool IsRealVertex(const HzOrder<D>& order, const HzHeader& h, uint64_t p) {
  std::array<int64_t, D> g{};
  if (!order.Decode(p, g)) return false;
  for (int a = 0; a < D; ++a) {
    if (g[a] >= int64_t{h.dims[a]}) return false;
  }
  return true;
}

struct Worker {
  std::vector<double> errors, fields;
  std::vector<uint8_t> raw;
  std::vector<std::byte> voxels;
  std::unique_ptr<ZstdCompressor> zstd;
};

template <int D>
Result<HzHeader> Write(const std::string& path, HzHeader h, const HzWriteOptions& options,
                       const HzFill& fill) {
  const auto start = std::chrono::steady_clock::now();
  const HzOrder<D> order(h.domain_bits);
  const int position_bits = D * (h.domain_bits + 1);
  h.version = kHzFormatVersion;
  h.virtual_blocks =
      position_bits <= h.block_bits ? 1 : uint64_t{1} << (position_bits - h.block_bits);
  const double range = h.field_max - h.field_min;
  h.quantum = ErrorQuantizer::QuantumFor(h.quantization, range);
  const ErrorQuantizer quantizer(h.quantization, h.quantum, range);
  const size_t n = h.block_records();
  const size_t error_size = QuantizedSize(h.quantization);
  const size_t voxel_size = VoxelSize(h.voxel_type);

  std::vector<uint64_t> candidates;
  std::vector<HzIndexEntry> entries;
  std::vector<uint8_t> kept;
  try {
    for (uint64_t b = 0; b < h.virtual_blocks; ++b) {
      if (MayHoldData<D>(h, b)) candidates.push_back(b);
    }
    entries.resize(candidates.size());
    kept.assign(candidates.size(), 0);
  } catch (const std::bad_alloc&) {
    return NotEnoughMemory(path + ": the block list", h.virtual_blocks * 8);
  }
  SDB_ASSIGN_OR_RETURN(auto writer, AtomicFileWriter::Create(path));
  writer->Reserve(kHzHeaderSize);

  std::vector<Worker> workers(static_cast<size_t>(options.threads));
  std::mutex max_mu;
  double error_max = 0;
  const auto work = [&](int w, uint64_t item) -> Status {
    Worker& wk = workers[static_cast<size_t>(w)];
    if (wk.errors.empty()) {
      wk.errors.resize(n);
      wk.fields.resize(n);
      wk.raw.resize(n * (error_size + voxel_size));
      wk.voxels.resize(n * voxel_size);
      if (options.compression == Compression::kZstd) {
        wk.zstd = std::make_unique<ZstdCompressor>(options.zstd_level);
      }
    }
    const uint64_t first = candidates[item] << h.block_bits;
    const size_t count =
        static_cast<size_t>(std::min<uint64_t>(n, order.size() > first ? order.size() - first : 0));
    std::fill(wk.errors.begin(), wk.errors.end(), 0.0);
    std::fill(wk.fields.begin(), wk.fields.end(), 0.0);
    if (count > 0) SDB_RETURN_IF_ERROR(fill(w, first, count, wk.errors.data(), wk.fields.data()));
    bool any_real = false, any_error = false;
    double fmin = std::numeric_limits<double>::infinity(), fmax = -fmin, emax = 0;
    uint32_t code_max = 0;
    for (size_t i = 0; i < n; ++i) {
      const double e = wk.errors[i];
      if (!(e >= 0) || !std::isfinite(e)) {
        return Status::InvalidArgument(path + ": the error at position " + std::to_string(first + i) +
                                       " is " + std::to_string(e));
      }
      const uint32_t code = options.errors_are_bounds ? quantizer.EncodeBound(e) : quantizer.Encode(e);
      any_error = any_error || code != 0;
      code_max = std::max(code_max, code);  // f32 bits of non-negative floats order as the floats
      emax = std::max(emax, e);
      switch (h.quantization) {
        case Quantization::kU16: StoreLittle<uint16_t>(wk.raw.data() + 2 * i, static_cast<uint16_t>(code)); break;
        case Quantization::kU8: wk.raw[i] = static_cast<uint8_t>(code); break;
        case Quantization::kF32: StoreLittle<uint32_t>(wk.raw.data() + 4 * i, code); break;
      }
      if (i < count && IsRealVertex<D>(order, h, first + i)) {
        any_real = true;
        const double f = wk.fields[i];
        if (!IsRepresentable(h.voxel_type, f)) {
          return Status::InvalidArgument(path + ": the field value " + std::to_string(f) +
                                         " at position " + std::to_string(first + i) +
                                         " is not a " + std::string(VoxelTypeName(h.voxel_type)));
        }
        if (!std::isnan(f)) {
          fmin = std::min(fmin, f);
          fmax = std::max(fmax, f);
        }
      } else {
        wk.fields[i] = 0;
      }
    }
    if (!any_real && !any_error) return Status::OK();  // not stored
    EncodeVoxels(h.voxel_type, ByteOrder::kLittle, wk.fields.data(), n, wk.voxels.data());
    std::memcpy(wk.raw.data() + n * error_size, wk.voxels.data(), n * voxel_size);
    HzIndexEntry& e = entries[item];
    std::vector<uint8_t> compressed;
    std::span<const uint8_t> stored(wk.raw);
    e.encoding = BlockEncoding::kRaw;
    if (wk.zstd) {
      SDB_ASSIGN_OR_RETURN(compressed, wk.zstd->Compress(wk.raw));
      if (compressed.size() < wk.raw.size()) {
        stored = compressed;
        e.encoding = BlockEncoding::kZstd;
      }
    }
    SDB_ASSIGN_OR_RETURN(e.offset, writer->Append(stored));
    e.stored_size = static_cast<uint32_t>(stored.size());
    e.checksum = Checksum(stored);
    e.field_min = any_real && fmin <= fmax ? RoundDownToFloat(fmin) : 0.0f;
    e.field_max = any_real && fmin <= fmax ? RoundUpToFloat(fmax) : 0.0f;
    e.error_max = code_max;
    kept[item] = 1;
    std::lock_guard<std::mutex> lock(max_mu);
    error_max = std::max(error_max, emax);
    return Status::OK();
  };
  SDB_RETURN_IF_ERROR(RunParallel(candidates.size(), options.threads, "blocks", start,
                                  options.progress, work));

  // Bitmap and index, in block order.
  std::vector<uint8_t> bitmap(8 * h.bitmap_words(), 0), index;
  uint64_t stored = 0;
  for (size_t i = 0; i < candidates.size(); ++i) stored += kept[i];
  index.resize(stored * kHzIndexEntrySize);
  uint64_t j = 0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (!kept[i]) continue;
    const uint64_t b = candidates[i];
    bitmap[b / 8] |= static_cast<uint8_t>(1u << (b % 8));  // little-endian words: bit b of the map
    SerializeHzIndexEntry(entries[i], index.data() + j++ * kHzIndexEntrySize);
  }
  h.stored_blocks = stored;
  h.error_max = error_max;
  SDB_ASSIGN_OR_RETURN(h.bitmap_offset, writer->Append(bitmap));
  SDB_ASSIGN_OR_RETURN(h.index_offset, writer->Append(index));
  h.file_size = writer->size();
  h.bitmap_checksum = Checksum(bitmap);
  h.index_checksum = Checksum(index);
  const auto header = SerializeHzHeader(h);
  SDB_RETURN_IF_ERROR(writer->WriteAt(0, header));
  SDB_RETURN_IF_ERROR(writer->Commit());
  return h;
}

}  // namespace

Result<HzHeader> WriteHzStore(const std::string& path, const HzHeader& params,
                              const HzWriteOptions& options, const HzFill& fill) {
  const int max_bits = params.dimension == 3 ? 18 : 13;
  if ((params.dimension != 3 && params.dimension != 4) || params.domain_bits < 1 ||
      params.domain_bits > max_bits || params.block_bits < 6 || params.block_bits > 20 ||
      options.threads < 1 || !(params.field_min <= params.field_max)) {
    return Status::InvalidArgument(path + ": store parameters out of range");
  }
  if (params.dimension == 3) return Write<3>(path, params, options, fill);
  return Write<4>(path, params, options, fill);
}

}  // namespace simplexdb
