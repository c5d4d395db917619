// Helpers for the store tests: temporary directories, small random volumes,
// and the seed's error computed by brute force, independent of the builder.
#pragma once

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
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

namespace simplexdb::testing {

// Determinant by cofactor expansion along the first row, in 128 bits: the
// reference for the library's closed-form adjugate and determinant.
template <int N>
Int128 Det(const std::array<std::array<int64_t, N>, N>& m) {
  if constexpr (N == 1) {
    return m[0][0];
  } else if constexpr (N == 2) {
    return m[0][0] * m[1][1] - m[0][1] * m[1][0];
  } else {
    Int128 det = 0;
    for (int c = 0; c < N; ++c) {
      std::array<std::array<int64_t, N - 1>, N - 1> minor{};
      for (int r = 1; r < N; ++r) {
        int cc = 0;
        for (int k = 0; k < N; ++k) {
          if (k != c) minor[r - 1][cc++] = m[r][k];
        }
      }
      const Int128 term = m[0][c] * Det<N - 1>(minor);
      det += (c % 2 == 0) ? term : -term;
    }
    return det;
  }
}

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

// Calls fn(p, weights, total) for every real grid point p in the closed
// simplex of node `code` (a domain of side 2^k): every real point of the
// node's bounding box is tested by signed volumes; weights[i] is total times
// p's barycentric coordinate for vertex i (integers). Also gives the grid
// vertices.
template <int D, class Fn>
void ForEachPointInside(SimplexCode<D> code, int k, const TestVolume& volume,
                        std::array<IPoint<D>, D + 1>* vertices, Fn&& fn) {
  const auto lattice = Vertices(code);
  std::array<IPoint<D>, D + 1>& v = *vertices;
  for (int i = 0; i <= D; ++i) {
    for (int c = 0; c < D; ++c) v[i][c] = lattice[i][c] >> (kCoordBits<D> - k);
  }
  const auto volume_with = [&](int i, const IPoint<D>& p) {
    auto w = v;
    if (i >= 0) w[i] = p;
    std::array<std::array<int64_t, D>, D> m{};
    for (int j = 0; j < D; ++j) {
      for (int c = 0; c < D; ++c) m[j][c] = w[j + 1][c] - w[0][c];
    }
    return Det<D>(m);
  };
  const Int128 total = volume_with(-1, v[0]);
  IPoint<D> lo = v[0], hi = v[0];
  for (const auto& q : v) {
    for (int c = 0; c < D; ++c) {
      lo[c] = std::min(lo[c], q[c]);
      hi[c] = std::max(hi[c], q[c]);
    }
  }
  for (int c = 0; c < D; ++c) {
    hi[c] = std::min<int64_t>(hi[c], volume.dims[c] - 1);
    if (lo[c] > hi[c]) return;  // no real point
  }
  IPoint<D> p = lo;
  while (true) {
    bool inside = true;
    std::array<Int128, D + 1> weights{};
    for (int i = 0; i <= D && inside; ++i) {
      weights[i] = volume_with(i, p);
      if (weights[i] != 0 && (weights[i] > 0) != (total > 0)) inside = false;
    }
    if (inside) fn(p, weights, total);
    int c = 0;
    for (; c < D; ++c) {
      if (p[c] < hi[c]) {
        ++p[c];
        break;
      }
      p[c] = lo[c];
    }
    if (c == D) break;
  }
}

// The seed's error of node `code` of a domain of side 2^k over `volume`,
// compared with the barycentric interpolation of the (clamped) vertex
// values. Exact: test values are multiples of 1/256, so 256 * det * (value -
// interpolation) is an integer; one division at the end.
// REQUIRES: no NaN in the node's points or vertex values.
template <int D>
long double BruteForceError(SimplexCode<D> code, int k, const TestVolume& volume) {
  const auto scaled = [](double value) { return static_cast<Int128>(std::llround(value * 256)); };
  std::array<IPoint<D>, D + 1> v{};
  Int128 worst = 0, det = 1;
  bool first = true;
  std::array<Int128, D + 1> f{};
  ForEachPointInside<D>(code, k, volume, &v, [&](const IPoint<D>& p, const auto& w, Int128 total) {
    if (first) {
      for (int i = 0; i <= D; ++i) f[i] = scaled(volume.ClampedAt<D>(v[i]));
      det = total;
      first = false;
    }
    Int128 interp = 0;  // det * 256 * interpolation
    for (int i = 0; i <= D; ++i) interp += w[i] * f[i];
    std::array<int64_t, 4> q = {0, 0, 0, 0};
    for (int c = 0; c < D; ++c) q[c] = p[c];
    const Int128 num = scaled(volume.At(q)) * total - interp;
    worst = std::max(worst, num < 0 ? -num : num);
  });
  const Int128 adet = det < 0 ? -det : det;
  return static_cast<long double>(worst) / (static_cast<long double>(adet) * 256);
}

// With NaN as a missing value: whether any real point of the node has a
// value, and whether any point or vertex has none.
template <int D>
std::pair<bool, bool> BruteForceAvailability(SimplexCode<D> code, int k, const TestVolume& volume) {
  std::array<IPoint<D>, D + 1> v{};
  bool any_value = false, any_missing = false;
  ForEachPointInside<D>(code, k, volume, &v, [&](const IPoint<D>& p, const auto&, Int128) {
    std::array<int64_t, 4> q = {0, 0, 0, 0};
    for (int c = 0; c < D; ++c) q[c] = p[c];
    (std::isnan(volume.At(q)) ? any_missing : any_value) = true;
  });
  for (int i = 0; i <= D; ++i) any_missing = any_missing || std::isnan(volume.ClampedAt<D>(v[i]));
  return {any_value, any_missing};
}

}  // namespace simplexdb::testing
