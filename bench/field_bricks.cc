// field_bricks: what the field costs as bricks of each octave's lattice, the
// layout of the dense store (docs/format/dense-store.md, "Field"). For a
// volume, in bytes per grid point: the full-resolution grid
// alone and the whole pyramid (every octave's lattice, the coarse points
// kept again in each), each as zstd frames per brick, with and without the
// Lorenzo predictor of storage/dense/brick_codec.h, and the smaller of the
// two per brick (a brick records which it took). Prints one JSON line;
// bench/format2_sizes.py sets it beside the peers.
//
//   field_bricks VOLUME [--dims X,Y,Z[,T] --type T] [--brick-side N] [--zstd-level L]
//
// (--dims and --type for raw files, as import takes them; N, a power of two:
// 16 in 3D, 8 in 4D.)
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

#include "storage/dense/field_bricks.h"
#include "storage/io/codec.h"
#include "bench/bench_util.h"
#include "storage/volume/volume.h"

namespace {

using namespace simplexdb;

struct Sizes {
  uint64_t plain = 0;      // zstd of the voxels
  uint64_t predicted = 0;  // zstd of the Lorenzo residuals
  uint64_t best = 0;       // per brick, the smallest coding (EncodeBrick's choice)
  uint64_t bricks = 0;
};

Result<Sizes> CodeLattice(const BrickGrid& grid, int s, const std::vector<double>& field,
                          VoxelType type, ZstdCompressor& zstd) {
  Sizes sizes;
  for (uint64_t b = grid.FirstBrick(s); b < grid.FirstBrick(s) + grid.Count(s); ++b) {
    SDB_ASSIGN_OR_RETURN(const EncodedBrick best, EncodeBrick(grid, b, field.data(), type, &zstd));
    SDB_ASSIGN_OR_RETURN(const EncodedBrick plain,
                         EncodeBrick(grid, b, field.data(), type, &zstd, BrickCoding::kZstd));
    SDB_ASSIGN_OR_RETURN(const EncodedBrick predicted,
                         EncodeBrick(grid, b, field.data(), type, &zstd, BrickCoding::kZstdPredicted));
    sizes.best += best.bytes.size();
    sizes.plain += plain.bytes.size();
    sizes.predicted += predicted.bytes.size();
    ++sizes.bricks;
  }
  return sizes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: field_bricks VOLUME [--dims X,Y,Z[,T] --type T] [--brick-side N] "
                 "[--zstd-level L]\n");
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
  const Result<VolumeInfo> info = OpenBenchVolume(argv[1], dims_text, type_text);
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
  // coarsest, of the domain's side 2^k.
  int k = 0;
  for (int a = 0; a < v.dimension; ++a) {
    while ((int64_t{1} << k) < int64_t{v.dims[a]} - 1) ++k;
  }
  int side_bits = 0;
  while ((1u << side_bits) < side) ++side_bits;
  const BrickGrid grid(v.dimension, v.dims, k, side_bits);
  ZstdCompressor zstd(level);
  nlohmann::json levels = nlohmann::json::array();
  Sizes full, pyramid;
  for (int s = 0; s < grid.lattices(); ++s) {
    const Result<Sizes> l = CodeLattice(grid, s, field, type, zstd);
    if (!l.ok()) {
      std::fprintf(stderr, "field_bricks: %s\n", std::string(l.status().message()).c_str());
      return 1;
    }
    if (s == 0) full = *l;
    pyramid.plain += l->plain;
    pyramid.predicted += l->predicted;
    pyramid.best += l->best;
    pyramid.bricks += l->bricks;
    levels.push_back({{"stride", int64_t{1} << s}, {"plain", l->plain}, {"predicted", l->predicted},
                      {"best", l->best}, {"bricks", l->bricks}});
  }
  const double points = static_cast<double>(v.voxel_count());
  nlohmann::json j;
  j["volume"] = argv[1];
  j["points"] = v.voxel_count();
  j["brick_side"] = side;
  j["zstd_level"] = level;
  j["grid_plain_bpp"] = full.plain / points;
  j["grid_predicted_bpp"] = full.predicted / points;
  j["pyramid_plain_bpp"] = pyramid.plain / points;
  j["pyramid_predicted_bpp"] = pyramid.predicted / points;
  j["grid_best_bpp"] = full.best / points;
  j["pyramid_best_bpp"] = pyramid.best / points;
  j["pyramid_bricks"] = pyramid.bricks;
  j["levels"] = levels;
  std::printf("%s\n", j.dump().c_str());
  return 0;
}
