// Helpers for the store tests: temporary directories, small random volumes,
// and the seed's error computed by brute force, independent of the builder.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "hierarchy/geometry.h"
#include "hierarchy/simplex_code.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/error/simplex_scan.h"
#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"
#include "tests/util/brute_force_simplex.h"

namespace simplexdb::testing {

// Every value of the volume file at `path` (any format OpenVolume reads).
inline std::vector<double> ReadVolumeValues(const std::string& path) {
  const VolumeInfo info = *OpenVolume(path);
  auto reader = *VolumeReader::Open(info);
  std::vector<double> v(info.voxel_count());
  if (!reader->Read(0, v.size(), v.data()).ok()) v.clear();
  return v;
}

// The bytes of the file at `path` (empty when it cannot be read).
inline std::vector<uint8_t> ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

// The bytes of the file at `path` as a string (empty when it cannot be read).
inline std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Writes `bytes` to the file at `path`, replacing it.
inline void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  ASSERT_TRUE(out.good()) << path;
}

// A fresh directory, removed with everything in it at scope exit.
class TempDir {
 public:
  TempDir() {
    std::string t = std::filesystem::temp_directory_path().string() + "/simplexdb_test_XXXXXX";
    path_ = mkdtemp(t.data());
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  // path()/name.
  std::string operator/(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// The names of the entries of `dir`, sorted (what a test expects a folder
// to hold, temporaries included).
inline std::vector<std::string> SortedNames(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// A volume held in memory, x fastest.
struct TestVolume {
  int dimension = 3;
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  VoxelType type = VoxelType::kU8;
  std::vector<double> values;

  // Random values the type holds exactly (floats: dyadic fractions).
  static TestVolume Random(int dimension, std::array<uint32_t, 4> dims, VoxelType type,
                           uint64_t seed) {
    TestVolume v{dimension, dims, type, {}};
    std::mt19937_64 rng(seed);
    uint64_t n = 1;
    for (uint32_t d : dims) n *= d;
    v.values.resize(n);
    for (double& x : v.values) {
      const uint64_t r = rng();
      switch (type) {
        case VoxelType::kU8: x = static_cast<double>(r % 256); break;
        case VoxelType::kI8: x = static_cast<double>(static_cast<int>(r % 256) - 128); break;
        case VoxelType::kU16: x = static_cast<double>(r % 65536); break;
        case VoxelType::kI16: x = static_cast<double>(static_cast<int>(r % 6001) - 3000); break;
        case VoxelType::kF32:
        case VoxelType::kF64: x = static_cast<double>(static_cast<int>(r % 100001) - 50000) / 256.0; break;
      }
    }
    return v;
  }

  double At(const std::array<int64_t, 4>& p) const {
    uint64_t i = 0;
    for (int a = 3; a >= 0; --a) i = i * dims[a] + static_cast<uint64_t>(p[a]);
    return values[i];
  }

  // The value at real point p of a D-dimensional volume.
  template <int D>
  double ValueAt(const IPoint<D>& p) const {
    std::array<int64_t, 4> q = {0, 0, 0, 0};
    for (int a = 0; a < D; ++a) q[a] = p[a];
    return At(q);
  }

  // The box [0, hi] of the real points of a D-dimensional volume.
  template <int D>
  IPoint<D> RealHi() const {
    IPoint<D> hi{};
    for (int a = 0; a < D; ++a) hi[a] = int64_t{dims[a]} - 1;
    return hi;
  }

  // The value at a domain point: the nearest real point's (the padding).
  template <int D>
  double ClampedAt(const std::array<int64_t, D>& p) const {
    std::array<int64_t, 4> q = {0, 0, 0, 0};
    for (int a = 0; a < D; ++a) q[a] = std::clamp<int64_t>(p[a], 0, int64_t{dims[a]} - 1);
    return At(q);
  }

  Status WriteNrrd(const std::string& path) const {
    return ::simplexdb::WriteNrrd(path, dimension, dims, type, values);
  }
};

// Calls f(c) for every node above `leaf_level`, by root, level, then path.
template <int D>
void ForEachInternalCode(int leaf_level, const std::function<void(SimplexCode<D>)>& f) {
  for (int top = 0; top < SimplexCode<D>::kRoots; ++top) {
    for (int l = 0; l < leaf_level; ++l) {
      for (uint64_t p = 0; p < (uint64_t{1} << l); ++p) f(SimplexCode<D>::FromPath(top, p, l));
    }
  }
}

// Calls f(p, i) for every real point p of the D-dimensional `volume`, x
// fastest: i is p's index in volume.values.
template <int D, class F>
void ForEachRealPoint(const TestVolume& volume, F&& f) {
  uint64_t i = 0;
  ForEachBoxPoint<D>(IPoint<D>{}, volume.RealHi<D>(), [&](const IPoint<D>& p) { f(p, i++); });
}

// The seed's error of node `code` of a domain of side 2^k over `volume`,
// compared with the barycentric interpolation of the (clamped) vertex
// values, over the node's real grid points (tests/util/brute_force_simplex.h:
// points inside by signed volumes). Exact: test values are multiples of
// 1/256, so 256 * det * (value - interpolation) is an integer; one division
// at the end.
// REQUIRES: no NaN in the node's points or vertex values.
template <int D>
long double BruteForceError(SimplexCode<D> code, int k, const TestVolume& volume) {
  const auto scaled = [](double value) { return static_cast<Int128>(std::llround(value * 256)); };
  const GridSimplex<D> v = GridVertices<D>(code, k);
  std::array<Int128, D + 1> f{};
  for (int i = 0; i <= D; ++i) f[i] = scaled(volume.ClampedAt<D>(v[i]));
  return MaxInterpolationError<D>(v, f, IPoint<D>{}, volume.RealHi<D>(), [&](const IPoint<D>& p) {
           return scaled(volume.ValueAt<D>(p));
         }).Value(256);
}

// With NaN as a missing value: whether any real point of the node has a
// value, and whether any point or vertex has none.
template <int D>
std::pair<bool, bool> BruteForceAvailability(SimplexCode<D> code, int k, const TestVolume& volume) {
  const GridSimplex<D> v = GridVertices<D>(code, k);
  bool any_value = false, any_missing = false;
  ForEachPointInside<D>(v, IPoint<D>{}, volume.RealHi<D>(), [&](const IPoint<D>& p, const auto&, Int128) {
    (std::isnan(volume.ValueAt<D>(p)) ? any_missing : any_value) = true;
  });
  for (int i = 0; i <= D; ++i) any_missing = any_missing || std::isnan(volume.ClampedAt<D>(v[i]));
  return {any_value, any_missing};
}

}  // namespace simplexdb::testing
