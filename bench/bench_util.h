// Helpers shared by the benchmark suites: a scratch directory, Perlin
// volumes written once per run (fixed seeds), and running a command.
#pragma once

#include <stdlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/volume.h"
#include "util/status.h"

namespace simplexdb {

// The volume a benchmark tool names on its command line: a file import
// reads by itself, or a raw file with `dims_text` ("X,Y,Z[,T]") and
// `type_text` (a voxel type name), as `simplexdb import` takes them
// (InvalidArgument when only one of the two is given).
inline Result<VolumeInfo> OpenBenchVolume(const std::string& path, const std::string& dims_text,
                                          const std::string& type_text) {
  if (dims_text.empty() && type_text.empty()) return OpenVolume(path);
  if (dims_text.empty() || type_text.empty()) return Status::InvalidArgument("--dims and --type go together");
  std::array<uint32_t, 4> dims{1, 1, 1, 1};
  int dimension = 0;
  for (size_t at = 0; at <= dims_text.size() && dimension < 4;) {
    const size_t comma = std::min(dims_text.find(',', at), dims_text.size());
    dims[dimension++] = static_cast<uint32_t>(std::stoul(dims_text.substr(at, comma - at)));
    at = comma + 1;
  }
  SDB_ASSIGN_OR_RETURN(const VoxelType type, ParseVoxelType(type_text));
  return OpenRawVolume(path, dimension, dims, type, ByteOrder::kLittle, 0);
}

// A scratch directory for this run's volumes and stores, removed when the
// program exits normally (a query_bench run writes about 900 MB there).
inline const std::string& WorkDir() {
  struct Scratch {
    std::string dir;
    Scratch() {
      std::string t = std::filesystem::temp_directory_path().string() + "/simplexdb_bench_XXXXXX";
      if (mkdtemp(t.data()) == nullptr) {
        std::perror(t.c_str());
        std::exit(1);
      }
      dir = t;
    }
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  };
  static const Scratch scratch;
  return scratch.dir;
}

// A Perlin volume (uint8, like the seed's byte-valued data), written once.
// With `blob`, only a centred cube of a quarter of the side keeps its noise
// and every other point is 0: a mostly uniform volume (1/64 of it varies).
inline std::string PerlinVolume(int dimension, uint32_t side, bool blob = false) {
  const std::string path = WorkDir() + "/perlin" + std::to_string(dimension) + "d_" +
                           std::to_string(side) + (blob ? "_blob" : "") + ".nrrd";
  if (std::filesystem::exists(path)) return path;
  GenerateOptions g;
  g.dimension = dimension;
  g.dims = {side, side, side, dimension == 4 ? side : 1u};
  const FieldGenerator field(g);
  uint64_t n = uint64_t{side} * side * side * (dimension == 4 ? side : 1);
  std::vector<double> values(n);
  field.Fill(0, n, values.data());
  for (uint64_t i = 0; i < n; ++i) {
    values[i] = std::round(values[i]);
    if (!blob) continue;
    uint64_t rest = i;
    for (int c = 0; c < dimension; ++c) {
      const uint64_t x = rest % side;
      rest /= side;
      if (x < 3 * side / 8 || x >= 5 * side / 8) values[i] = 0;
    }
  }
  if (!WriteNrrd(path, dimension, g.dims, VoxelType::kU8, values).ok()) std::abort();
  return path;
}

// Runs a command and returns its standard output.
inline std::string Capture(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (p == nullptr) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  pclose(p);
  return out;
}

}  // namespace simplexdb
