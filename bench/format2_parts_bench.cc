// What the dense store's layout costs its reader per brick (docs/format/
// dense-store.md, "Field"), on Perlin noise rounded to 8 bits:
//
//   DecodeBrick/<h>      one grid brick (16^3 points, 8^4 in the HP) from its
//                        stored bytes (the coding EncodeBrick chose) to doubles
//   FinestBoxErrors/<h>  the finest diamond errors of one brick's vertices from
//                        a window of doubles around it (FinestBoxErrors)
//   DiamondErrors/<h>/s  what the builder spends on the diamonds of octave
//                        scale s (vertices multiples of 2^s, s = 0 finest)
//                        of a float32 field, one thread: the counter is the
//                        grid's points per second, so the figures of all
//                        scales add up (as inverse rates) to one pass of the
//                        builder's errors
//
// Both per brick; the counter gives the brick's grid points per second. A
// query that touches a brick of the finest octave pays both (and the window's
// neighbours, mostly cached), where format 2 today decodes one block of
// errors and field values.
//
//   build/release/bench/format2_parts_bench
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "storage/dense/brick_codec.h"
#include "storage/dense/field_bricks.h"
#include "storage/dense/dense_format.h"
#include "storage/error/diamond_errors.h"
#include "storage/error/finest_box_errors.h"
#include "storage/volume/generate.h"

namespace simplexdb {
namespace {

template <int D>
struct Setup {
  std::array<uint32_t, 4> dims{1, 1, 1, 1};
  int k = 0;
  int side_bits = D == 3 ? 4 : 3;
  std::vector<double> field;

  Setup() {
    const uint32_t n = D == 3 ? 129 : 33;
    GenerateOptions o;
    o.dimension = D;
    for (int a = 0; a < D; ++a) dims[a] = n;
    o.dims = dims;
    k = D == 3 ? 7 : 5;
    field.resize(size_t{n} * n * n * (D == 4 ? n : 1));
    FieldGenerator(o).Fill(0, field.size(), field.data());
    for (double& v : field) v = std::clamp(std::round(v), 0.0, 255.0);
  }
};

template <int D>
const Setup<D>& Get() {
  static const Setup<D> s;
  return s;
}

template <int D>
void DecodeBrickBench(benchmark::State& state) {
  const Setup<D>& s = Get<D>();
  const BrickGrid grid(D, s.dims, s.k, s.side_bits);
  ZstdCompressor zstd(3);
  ZstdDecompressor unzstd;
  std::vector<EncodedBrick> bricks;
  std::vector<BrickPlace> places;
  for (uint64_t b = grid.FirstBrick(0); b < grid.bricks(); ++b) {
    const BrickPlace p = grid.Place(b);
    if (BrickVoxels(D, p.extent) != grid.brick_voxels()) continue;  // full bricks only
    bricks.push_back(*EncodeBrick(grid, b, s.field.data(), VoxelType::kU8, &zstd));
    places.push_back(p);
  }
  std::vector<uint8_t> voxels(grid.brick_voxels());
  std::vector<double> values(grid.brick_voxels());
  size_t i = 0;
  for (auto _ : state) {
    const Status st = DecodeBrick(bricks[i].bytes, bricks[i].coding, VoxelType::kU8, D,
                                  places[i].extent, unzstd, voxels, "bench");
    DecodeVoxels(VoxelType::kU8, ByteOrder::kLittle, reinterpret_cast<const std::byte*>(voxels.data()),
                 voxels.size(), values.data());
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(values.data());
    i = (i + 1) % bricks.size();
  }
  state.counters["points_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * grid.brick_voxels()), benchmark::Counter::kIsRate);
}

template <int D>
void FinestBoxBench(benchmark::State& state) {
  const Setup<D>& s = Get<D>();
  const int64_t box = int64_t{1} << s.side_bits;
  const FinestBoxErrors<D> errors(box);
  const int64_t w = errors.window_side();
  std::array<int64_t, D> dims{}, strides{}, first{}, extent{};
  int64_t n = 1;
  for (int a = 0; a < D; ++a) {
    dims[a] = s.dims[a];
    strides[a] = n;
    n *= dims[a];
    first[a] = 2 * box;  // an interior box
    extent[a] = box;
  }
  std::vector<double> window(errors.window_points());
  for (uint64_t i = 0; i < window.size(); ++i) {
    int64_t index = 0;
    uint64_t rest = i;
    for (int a = 0; a < D; ++a) {
      index += (first[a] - 2 + static_cast<int64_t>(rest % static_cast<uint64_t>(w))) * strides[a];
      rest /= static_cast<uint64_t>(w);
    }
    window[i] = s.field[static_cast<size_t>(index)];
  }
  std::vector<double> out(size_t{1} << (D * s.side_bits));
  for (auto _ : state) {
    errors.Compute(first, extent, s.k, dims, window.data(), out.data());
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["points_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * out.size()), benchmark::Counter::kIsRate);
}

// Perlin noise as float32, not rounded (the stencils' and scans' double
// path), held as floats as the builder holds it. Scale 0: each grid
// brick's largest finest error, as the builder computes them; scales 1 and
// up: the table's work items of that scale.
template <int D>
void DiamondErrorsBench(benchmark::State& state) {
  const int s = static_cast<int>(state.range(0));
  const int64_t n = D == 3 ? 129 : 33;
  const int k = D == 3 ? 7 : 5;
  static const std::vector<float> field = [&] {
    GenerateOptions o;
    o.dimension = D;
    for (int a = 0; a < D; ++a) o.dims[a] = static_cast<uint32_t>(n);
    std::vector<double> f(static_cast<size_t>(std::pow(n, D)));
    FieldGenerator(o).Fill(0, f.size(), f.data());
    return std::vector<float>(f.begin(), f.end());
  }();
  std::array<int64_t, D> dims{};
  dims.fill(n);
  const auto [lo, hi] = std::minmax_element(field.begin(), field.end());
  DiamondErrors<D, float> errors(field.data(), dims, k, false, *hi - *lo, 1);
  errors.Allocate();
  // Items run coarse first, one slab of one scale each: those of scale s.
  std::vector<uint64_t> items;
  uint64_t item = 0;
  for (int scale = k - 1; scale >= 1; --scale) {
    const int64_t h = int64_t{1} << scale;
    for (int64_t j = 0; j * h <= (int64_t{1} << k) && j * h - 2 * h <= n - 1; ++j, ++item) {
      if (scale == s) items.push_back(item);
    }
  }
  const BrickGrid grid(D, {static_cast<uint32_t>(n), static_cast<uint32_t>(n),
                           static_cast<uint32_t>(n), D == 4 ? static_cast<uint32_t>(n) : 1u},
                       k, DenseDefaultBrickBits(D));
  for (auto _ : state) {
    if (s > 0) {
      for (const uint64_t i : items) errors.ComputeItem(0, i);
      continue;
    }
    double m = 0;
    for (uint64_t b = grid.FirstBrick(0); b < grid.bricks(); ++b) {
      const BrickGrid::Box box = grid.FinestBox(b);
      std::array<int64_t, D> first{}, extent{};
      for (int a = 0; a < D; ++a) first[a] = box.first[a], extent[a] = box.extent[a];
      m = std::max(m, errors.FinestBoxMax(first, extent));
    }
    benchmark::DoNotOptimize(m);
  }
  state.counters["points_per_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(field.size()),
      benchmark::Counter::kIsRate);
}

BENCHMARK(DecodeBrickBench<3>)->Name("DecodeBrick/ht");
BENCHMARK(DecodeBrickBench<4>)->Name("DecodeBrick/hp");
BENCHMARK(FinestBoxBench<3>)->Name("FinestBoxErrors/ht");
BENCHMARK(FinestBoxBench<4>)->Name("FinestBoxErrors/hp");
BENCHMARK(DiamondErrorsBench<3>)->Name("DiamondErrors/ht")->DenseRange(0, 6)->Unit(benchmark::kMillisecond);
BENCHMARK(DiamondErrorsBench<4>)->Name("DiamondErrors/hp")->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace simplexdb

BENCHMARK_MAIN();
