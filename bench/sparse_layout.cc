// sparse_layout: what a sparse format-2 store (issue 17) would cost for a
// volume, before the store exists: one entry per block of the HZ order
// holding a bitmap of the kept diamonds, the kept non-finest diamonds'
// errors (u16) and the field at the kept vertices, predicted from the split
// edge's ends, in one zstd frame. Prints one JSON line per tolerance.
//
//   sparse_layout VOLUME [--dims X,Y,Z[,T] --type T] [--block-bits B]
//                 [--tolerance PERCENT]... [--zstd-level L]
//
// The rules measured (the store will follow them):
//   - A diamond is kept when its error exceeds the tolerance t or a kept
//     diamond's simplices stand on its vertex (FinestDiamonds::VertexOffsets):
//     the kept set is closed under ancestors, so it is a conforming mesh.
//   - A dropped vertex's value is reconstructed, coarse levels first, as the
//     mean of its split edge's ends (reconstructed or kept). The builder
//     checks every dropped real grid point: within t of its value (equal at
//     t = 0); a point that is not is kept, with what it stands on, and the
//     check runs again until none fails.
//   - A kept vertex's field is stored as its difference from that
//     prediction (integers modulo the voxel width, floats as the difference
//     of their bit patterns), byte-shuffled. The finest octave's errors are
//     not stored (a reader computes them from the reconstructed field, as
//     the dense store's reader does from its field).
//
// "entry_bytes" adds 8 bytes of checksum per entry; "lmdb_estimate_bytes"
// also LMDB's 18 bytes per entry (node header, key, slot) and a whole
// 4 KiB page per started page of a value too large for a leaf (> 2000
// bytes), an estimate of the file, not a measurement of one.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hierarchy/hz_order.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/finest_diamonds.h"
#include "storage/io/codec.h"
#include "storage/volume/volume.h"

namespace {

using namespace simplexdb;

struct Args {
  std::vector<double> tolerances;  // fractions of the range
  int block_bits = 15;
  int zstd_level = 3;
};

// The domain [0, 2^k]^D as an array, x fastest.
template <int D>
struct Domain {
  int k;
  int64_t side1;  // 2^k + 1
  uint64_t Index(const std::array<int64_t, D>& g) const {
    uint64_t i = 0;
    for (int a = D - 1; a >= 0; --a) i = i * static_cast<uint64_t>(side1) + static_cast<uint64_t>(g[a]);
    return i;
  }
  bool Inside(const std::array<int64_t, D>& g) const {
    for (int a = 0; a < D; ++a) {
      if (g[a] < 0 || g[a] >= side1) return false;
    }
    return true;
  }
};

// Calls f(g) for every vertex of creation level c.
template <int D, class F>
void ForEachLevelVertex(int k, int c, F&& f) {
  const int o = c / D, m = D - c % D, s = k - 1 - o;
  for (uint32_t odd = 1; odd < (1u << D); ++odd) {
    if (std::popcount(odd) != m) continue;
    std::array<int64_t, D> count{}, u{};
    for (int a = 0; a < D; ++a) count[a] = (odd >> a & 1) ? (int64_t{1} << o) : (int64_t{1} << o) + 1;
    while (true) {
      std::array<int64_t, D> g{};
      for (int a = 0; a < D; ++a) g[a] = (u[a] << (s + 1)) | (static_cast<int64_t>(odd >> a & 1) << s);
      f(g);
      int a = 0;
      for (; a < D; ++a) {
        if (++u[a] < count[a]) break;
        u[a] = 0;
      }
      if (a == D) break;
    }
  }
}

template <int D>
int Run(const VolumeInfo& v, const std::vector<double>& field, VoxelType type, const Args& args) {
  int k = 1;
  for (int a = 0; a < D; ++a) {
    while ((int64_t{1} << k) < int64_t{v.dims[a]} - 1) ++k;
  }
  const Domain<D> dom{k, (int64_t{1} << k) + 1};
  std::array<int64_t, D> dims{};
  for (int a = 0; a < D; ++a) dims[a] = v.dims[a];
  const double fmin = *std::min_element(field.begin(), field.end());
  const double fmax = *std::max_element(field.begin(), field.end());
  const double range = fmax - fmin;
  const bool exact = !IsFloatType(type);

  DiamondErrors<D, double> diamonds(field.data(), dims, k, exact, range, 1);
  diamonds.Allocate();
  for (uint64_t i = 0; i < diamonds.item_count(); ++i) diamonds.ComputeItem(0, i);
  diamonds.Finish();

  const HzOrder<D> order(k);
  uint64_t domain_points = 1;
  for (int a = 0; a < D; ++a) domain_points *= static_cast<uint64_t>(dom.side1);
  std::vector<float> err(domain_points, 0.0f);
  const auto F = [&](const std::array<int64_t, D>& g) {  // the field, clamped to the real grid
    uint64_t i = 0;
    for (int a = D - 1; a >= 0; --a) {
      i = i * static_cast<uint64_t>(dims[a]) + static_cast<uint64_t>(std::min(g[a], dims[a] - 1));
    }
    return field[i];
  };
  const auto real = [&](const std::array<int64_t, D>& g) {
    for (int a = 0; a < D; ++a) {
      if (g[a] >= dims[a]) return false;
    }
    return true;
  };
  for (int c = 0; c < order.levels(); ++c) {
    ForEachLevelVertex<D>(k, c, [&](const std::array<int64_t, D>& g) {
      // Rounded up to float: a bound of the double error.
      const double e = diamonds.At(g, order.PositionAtLevel(g, c));
      float f = static_cast<float>(e);
      if (static_cast<double>(f) < e) f = std::nextafter(f, 1e30f);
      err[dom.Index(g)] = f;
    });
  }
  const auto& shapes = FinestDiamonds<D>::Get();
  const auto ends = [&](const std::array<int64_t, D>& g, std::array<int64_t, D>& lo, std::array<int64_t, D>& hi) {
    const DiamondShape sh = ShapeOfVertex<D>(g);
    const auto& o = shapes.SplitOffset(sh.odd, sh.parity);
    for (int a = 0; a < D; ++a) {
      lo[a] = g[a] - (int64_t{o[a]} << sh.scale_bits);
      hi[a] = g[a] + (int64_t{o[a]} << sh.scale_bits);
    }
  };
  const size_t voxel_bytes = type == VoxelType::kU8 || type == VoxelType::kI8 ? 1
                             : type == VoxelType::kU16 || type == VoxelType::kI16 ? 2
                             : type == VoxelType::kF32 ? 4 : 8;
  const double quantum = range > 0 ? range * (1 + 1e-9) / 65535 : 1;

  for (double tol_fraction : args.tolerances) {
    const double t = tol_fraction * range;
    std::vector<uint8_t> kept(domain_points, 0), force(domain_points, 0);
    std::vector<double> g(domain_points, 0.0);
    int rounds = 0;
    uint64_t forced = 0;
    while (true) {
      ++rounds;
      std::fill(kept.begin(), kept.end(), 0);
      for (int c = order.levels() - 1; c >= 0; --c) {
        ForEachLevelVertex<D>(k, c, [&](const std::array<int64_t, D>& p) {
          const uint64_t i = dom.Index(p);
          if (!kept[i] && !force[i] && !(err[i] > t)) return;
          kept[i] = 1;
          const DiamondShape sh = ShapeOfVertex<D>(p);
          for (const auto& w : shapes.VertexOffsets(sh.odd, sh.parity)) {
            std::array<int64_t, D> q{};
            for (int a = 0; a < D; ++a) q[a] = p[a] + (int64_t{w[a]} << sh.scale_bits);
            if (dom.Inside(q)) kept[dom.Index(q)] = 1;
          }
        });
      }
      // Reconstruct, coarse first; corners are kept.
      for (uint64_t corner = 0; corner < (uint64_t{1} << D); ++corner) {
        std::array<int64_t, D> p{};
        for (int a = 0; a < D; ++a) p[a] = static_cast<int64_t>(corner >> a & 1) << k;
        g[dom.Index(p)] = F(p);
        kept[dom.Index(p)] = 1;
      }
      uint64_t bad = 0;
      for (int c = 0; c < order.levels(); ++c) {
        ForEachLevelVertex<D>(k, c, [&](const std::array<int64_t, D>& p) {
          const uint64_t i = dom.Index(p);
          if (kept[i]) {
            g[i] = F(p);
            return;
          }
          std::array<int64_t, D> lo{}, hi{};
          ends(p, lo, hi);
          g[i] = (g[dom.Index(lo)] + g[dom.Index(hi)]) / 2;
          if (!real(p)) return;
          const double d = std::abs(g[i] - F(p));
          if (t == 0 ? d != 0 : d > t) {
            force[i] = 1;
            ++bad;
          }
        });
      }
      forced += bad;
      if (bad == 0) break;
    }

    // Blocks of 2^block_bits positions; a vertex's slot in its block.
    ZstdCompressor zstd(args.zstd_level);
    const uint64_t block_positions = uint64_t{1} << args.block_bits;
    const int finest_first = D * (k - 1);
    uint64_t entries = 0, value_bytes = 0, lmdb_estimate = 0, kept_count = 0, kept_real = 0;
    uint64_t bitmap_raw = 0, error_raw = 0, field_raw = 0;
    std::vector<uint8_t> bitmap, errors, residuals, value;
    for (uint64_t first = 0; first < order.size(); first += block_positions) {
      bitmap.clear();
      errors.clear();
      residuals.clear();
      bool any_real = false;
      uint32_t bits = 0;
      int nbits = 0;
      const uint64_t end = std::min(order.size(), first + block_positions);
      for (uint64_t pos = first; pos < end; ++pos) {
        std::array<int64_t, D> p{};
        if (!order.Decode(pos, p)) continue;
        any_real = any_real || real(p);
        const uint64_t i = dom.Index(p);
        const int level = order.LevelAt(pos);
        bits |= static_cast<uint32_t>(kept[i]) << nbits;
        if (++nbits == 8) {
          bitmap.push_back(static_cast<uint8_t>(bits));
          bits = 0;
          nbits = 0;
        }
        if (!kept[i]) continue;
        ++kept_count;
        if (real(p)) ++kept_real;
        if (level >= 0 && level < finest_first) {
          const uint32_t code = err[i] <= 0 ? 0u
                                            : static_cast<uint32_t>(std::min(65535.0, std::ceil(err[i] / quantum)));
          errors.push_back(static_cast<uint8_t>(code));
          errors.push_back(static_cast<uint8_t>(code >> 8));
        }
        // The prediction: the split edge's ends (corners: 0).
        double pred = 0;
        if (level >= 0) {
          std::array<int64_t, D> lo{}, hi{};
          ends(p, lo, hi);
          pred = (g[dom.Index(lo)] + g[dom.Index(hi)]) / 2;
        }
        uint64_t r = 0;
        const double value_here = F(p);
        if (!IsFloatType(type)) {
          r = static_cast<uint64_t>(static_cast<int64_t>(value_here) - std::llround(pred));
        } else if (type == VoxelType::kF32) {
          uint32_t a, b;
          const float fa = static_cast<float>(value_here), fb = static_cast<float>(pred);
          std::memcpy(&a, &fa, 4);
          std::memcpy(&b, &fb, 4);
          r = a - b;
        } else {
          uint64_t a, b;
          std::memcpy(&a, &value_here, 8);
          std::memcpy(&b, &pred, 8);
          r = a - b;
        }
        for (size_t byte = 0; byte < voxel_bytes; ++byte) residuals.push_back(static_cast<uint8_t>(r >> (8 * byte)));
      }
      if (!any_real) continue;
      if (nbits > 0) bitmap.push_back(static_cast<uint8_t>(bits));
      // Byte planes: the low bytes of every value, then the next ones.
      const auto shuffle = [](const std::vector<uint8_t>& in, size_t width) {
        std::vector<uint8_t> out(in.size());
        const size_t n = in.size() / width;
        for (size_t j = 0; j < n; ++j) {
          for (size_t b = 0; b < width; ++b) out[b * n + j] = in[j * width + b];
        }
        return out;
      };
      value = bitmap;
      const auto e = shuffle(errors, 2);
      const auto r = shuffle(residuals, voxel_bytes);
      value.insert(value.end(), e.begin(), e.end());
      value.insert(value.end(), r.begin(), r.end());
      const Result<std::vector<uint8_t>> z = zstd.Compress(value);
      if (!z.ok()) {
        std::fprintf(stderr, "sparse_layout: %s\n", std::string(z.status().message()).c_str());
        return 1;
      }
      const uint64_t bytes = z->size() + 8;
      ++entries;
      value_bytes += bytes;
      lmdb_estimate += bytes <= 2000 ? bytes + 18 : 18 + ((bytes + 16 + 4095) / 4096) * 4096;
      bitmap_raw += bitmap.size();
      error_raw += errors.size();
      field_raw += residuals.size();
    }
    const double points = static_cast<double>(v.voxel_count());
    nlohmann::json j;
    j["tolerance_percent"] = tol_fraction * 100;
    j["points"] = v.voxel_count();
    j["domain_bits"] = k;
    j["block_bits"] = args.block_bits;
    j["check_rounds"] = rounds;
    j["kept_by_check"] = forced;
    j["kept_vertices"] = kept_count;
    j["kept_real_fraction"] = static_cast<double>(kept_real) / points;
    j["entries"] = entries;
    j["entry_bytes"] = value_bytes;
    j["entry_bpp"] = static_cast<double>(value_bytes) / points;
    j["lmdb_estimate_bpp"] = static_cast<double>(lmdb_estimate) / points;
    j["raw_bitmap_bpp"] = static_cast<double>(bitmap_raw) / points;
    j["raw_errors_bpp"] = static_cast<double>(error_raw) / points;
    j["raw_field_bpp"] = static_cast<double>(field_raw) / points;
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: sparse_layout VOLUME [--dims X,Y,Z[,T] --type T] [--block-bits B] "
                 "[--tolerance PERCENT]... [--zstd-level L]\n");
    return 2;
  }
  Args args;
  std::string dims_text, type_text;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--block-bits") == 0) args.block_bits = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--zstd-level") == 0) args.zstd_level = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--tolerance") == 0) args.tolerances.push_back(std::atof(argv[i + 1]) / 100);
    if (std::strcmp(argv[i], "--dims") == 0) dims_text = argv[i + 1];
    if (std::strcmp(argv[i], "--type") == 0) type_text = argv[i + 1];
  }
  if (args.tolerances.empty()) args.tolerances = {0.0, 0.01};
  Result<VolumeInfo> info = Status::InvalidArgument("--dims and --type go together");
  if (dims_text.empty() && type_text.empty()) {
    info = OpenVolume(argv[1]);
  } else if (!dims_text.empty() && !type_text.empty()) {
    std::array<uint32_t, 4> dims{1, 1, 1, 1};
    int dimension = 0;
    for (size_t at = 0; at <= dims_text.size() && dimension < 4;) {
      const size_t comma = std::min(dims_text.find(',', at), dims_text.size());
      dims[dimension++] = static_cast<uint32_t>(std::stoul(dims_text.substr(at, comma - at)));
      at = comma + 1;
    }
    const Result<VoxelType> type = ParseVoxelType(type_text);
    info = type.ok() ? OpenRawVolume(argv[1], dimension, dims, *type, ByteOrder::kLittle, 0)
                     : Result<VolumeInfo>(type.status());
  }
  if (!info.ok()) {
    std::fprintf(stderr, "sparse_layout: %s\n", std::string(info.status().message()).c_str());
    return 1;
  }
  const VolumeInfo& v = *info;
  const VoxelType type = v.scale == 1 && v.shift == 0 ? v.type : VoxelType::kF32;
  std::vector<double> field(v.voxel_count());
  auto reader = VolumeReader::Open(v);
  if (!reader.ok() || !(*reader)->Read(0, field.size(), field.data()).ok()) {
    std::fprintf(stderr, "sparse_layout: cannot read %s\n", argv[1]);
    return 1;
  }
  if (type == VoxelType::kF32) {
    for (double& x : field) x = static_cast<float>(x);
  }
  return v.dimension == 3 ? Run<3>(v, field, type, args) : Run<4>(v, field, type, args);
}
