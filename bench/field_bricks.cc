// field_bricks: what the field costs as bricks of each octave's lattice, the
// layout format 2 moves to (docs/format/dense-store-2.md, "The next
// layout"). For a volume, in bytes per grid point: the full-resolution grid
// alone and the whole pyramid (every octave's lattice, the coarse points
// kept again in each), each as zstd frames per brick, with and without the
// Lorenzo predictor of storage/dense/brick_codec.h, and the smaller of the
// two per brick (a brick records which it took). Prints one JSON line;
// bench/format2_sizes.py sets it beside the peers.
//
//   field_bricks VOLUME [--dims X,Y,Z[,T] --type T] [--brick-side N] [--zstd-level L]
//
// (--dims and --type for raw files, as import takes them; N: 16 in 3D, 8 in 4D.)
//
// The stored voxel type is the volume's; NIfTI values with a scaling are
// float32, as import stores them.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/dense/brick_codec.h"
#include "storage/io/codec.h"
#include "storage/volume/volume.h"

namespace {

using namespace simplexdb;

struct Sizes {
  uint64_t plain = 0;      // zstd of the voxels
  uint64_t predicted = 0;  // zstd of the Lorenzo residuals
  uint64_t best = 0;       // per brick, the smaller of the two
  uint64_t bricks = 0;
};

// Codes the lattice of stride `stride` (the points whose coordinates are
// multiples of it) of `field` in bricks of `side` points per axis.
Sizes CodeLattice(const std::vector<double>& field, const VolumeInfo& v, VoxelType type, int64_t stride,
                  uint32_t side, ZstdCompressor& zstd) {
  const int D = v.dimension;
  std::array<int64_t, 4> n{1, 1, 1, 1}, bricks{1, 1, 1, 1}, field_stride{1, 1, 1, 1};
  for (int a = 0; a < D; ++a) {
    n[a] = (int64_t{v.dims[a]} - 1) / stride + 1;
    bricks[a] = (n[a] + side - 1) / side;
  }
  for (int a = 1; a < 4; ++a) field_stride[a] = field_stride[a - 1] * v.dims[a - 1];
  const size_t width = VoxelSize(type);
  Sizes s;
  std::vector<double> values;
  std::vector<uint8_t> voxels, coded;
  for (int64_t b3 = 0; b3 < bricks[3]; ++b3)
    for (int64_t b2 = 0; b2 < bricks[2]; ++b2)
      for (int64_t b1 = 0; b1 < bricks[1]; ++b1)
        for (int64_t b0 = 0; b0 < bricks[0]; ++b0) {
          const std::array<int64_t, 4> b{b0, b1, b2, b3};
          std::array<uint32_t, 4> extent{1, 1, 1, 1};
          for (int a = 0; a < D; ++a) {
            extent[a] = static_cast<uint32_t>(std::min<int64_t>(side, n[a] - b[a] * side));
          }
          values.clear();
          for (uint32_t i3 = 0; i3 < extent[3]; ++i3)
            for (uint32_t i2 = 0; i2 < extent[2]; ++i2)
              for (uint32_t i1 = 0; i1 < extent[1]; ++i1)
                for (uint32_t i0 = 0; i0 < extent[0]; ++i0) {
                  const std::array<int64_t, 4> i{i0, i1, i2, i3};
                  int64_t index = 0;
                  for (int a = 0; a < 4; ++a) index += (b[a] * side + i[a]) * stride * field_stride[a];
                  values.push_back(field[static_cast<size_t>(index)]);
                }
          voxels.resize(values.size() * width);
          coded.resize(voxels.size());
          EncodeVoxels(type, ByteOrder::kLittle, values.data(), values.size(),
                       reinterpret_cast<std::byte*>(voxels.data()));
          PredictBrick(type, D, extent, voxels, coded);
          const size_t plain = zstd.Compress(voxels)->size();
          const size_t predicted = zstd.Compress(coded)->size();
          s.plain += plain;
          s.predicted += predicted;
          s.best += std::min(plain, predicted);
          ++s.bricks;
        }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: field_bricks VOLUME [--brick-side N] [--zstd-level L]\n");
    return 2;
  }
  uint32_t side = 0;
  int level = 3;
  std::string dims_text, type_text;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--brick-side") == 0) side = static_cast<uint32_t>(std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--zstd-level") == 0) level = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--dims") == 0) dims_text = argv[i + 1];
    if (std::strcmp(argv[i], "--type") == 0) type_text = argv[i + 1];
  }
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
    std::fprintf(stderr, "field_bricks: %s\n", std::string(info.status().message()).c_str());
    return 1;
  }
  const VolumeInfo& v = *info;
  if (side == 0) side = v.dimension == 3 ? 16 : 8;
  const VoxelType type = v.scale == 1 && v.shift == 0 ? v.type : VoxelType::kF32;
  std::vector<double> field(v.voxel_count());
  auto reader = VolumeReader::Open(v);
  if (!reader.ok() || !(*reader)->Read(0, field.size(), field.data()).ok()) {
    std::fprintf(stderr, "field_bricks: cannot read %s\n", argv[1]);
    return 1;
  }
  // Octaves: the lattice of stride 2^s for s = 0 (the grid) up to the
  // coarsest with two points on the longest axis.
  int k = 0;
  for (int a = 0; a < v.dimension; ++a) {
    while ((int64_t{1} << k) < int64_t{v.dims[a]} - 1) ++k;
  }
  ZstdCompressor zstd(level);
  nlohmann::json levels = nlohmann::json::array();
  Sizes grid, pyramid;
  for (int s = 0; s < k; ++s) {
    const Sizes l = CodeLattice(field, v, type, int64_t{1} << s, side, zstd);
    if (s == 0) grid = l;
    pyramid.plain += l.plain;
    pyramid.predicted += l.predicted;
    pyramid.best += l.best;
    pyramid.bricks += l.bricks;
    levels.push_back({{"stride", int64_t{1} << s}, {"plain", l.plain}, {"predicted", l.predicted},
                      {"best", l.best}});
  }
  const double points = static_cast<double>(v.voxel_count());
  nlohmann::json j;
  j["volume"] = argv[1];
  j["points"] = v.voxel_count();
  j["brick_side"] = side;
  j["zstd_level"] = level;
  j["grid_plain_bpp"] = grid.plain / points;
  j["grid_predicted_bpp"] = grid.predicted / points;
  j["pyramid_plain_bpp"] = pyramid.plain / points;
  j["pyramid_predicted_bpp"] = pyramid.predicted / points;
  j["grid_best_bpp"] = grid.best / points;
  j["pyramid_best_bpp"] = pyramid.best / points;
  j["pyramid_bricks"] = pyramid.bricks;
  j["levels"] = levels;
  std::printf("%s\n", j.dump().c_str());
  return 0;
}
