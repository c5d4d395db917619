// sparse_layout: the sparse store of format 2 (storage/sparse/
// sparse_format.h) built from a volume at each tolerance asked for; one
// JSON line each with the file's size per grid point, the kept fraction,
// the blocks, the build's time and peak work, and the time to verify it
// (every block read). bench/README.md ("Sparse store format 2") sets them
// beside the dense store of format 2.
//
//   sparse_layout VOLUME OUT_DIR [--dims X,Y,Z[,T] --type T] [--block-bits B]
//                 [--tolerance PERCENT]... [--zstd-level L]
//
// PERCENT is of the field's range (0: lossless; default 0 and 1).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/sparse/sparse_builder.h"
#include "storage/sparse/sparse_store.h"
#include "bench/bench_util.h"
#include "storage/volume/volume.h"

int main(int argc, char** argv) {
  using namespace simplexdb;
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: sparse_layout VOLUME OUT_DIR [--dims X,Y,Z[,T] --type T] [--block-bits B] "
                 "[--tolerance PERCENT]... [--zstd-level L]\n");
    return 2;
  }
  std::vector<double> percents;
  int block_bits = 0, level = 0;  // 0: the builder's default
  std::string dims_text, type_text;
  for (int i = 3; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--block-bits") == 0) block_bits = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--zstd-level") == 0) level = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--tolerance") == 0) percents.push_back(std::atof(argv[i + 1]));
    if (std::strcmp(argv[i], "--dims") == 0) dims_text = argv[i + 1];
    if (std::strcmp(argv[i], "--type") == 0) type_text = argv[i + 1];
  }
  if (percents.empty()) percents = {0.0, 1.0};
  const Result<VolumeInfo> info = OpenBenchVolume(argv[1], dims_text, type_text);
  if (!info.ok()) {
    std::fprintf(stderr, "sparse_layout: %s\n", std::string(info.status().message()).c_str());
    return 1;
  }
  const std::string out = std::string(argv[2]) + "/sparse_layout.sdb";
  for (const double percent : percents) {
    SparseBuildOptions o;
    o.block_bits = block_bits;
    if (level > 0) o.zstd_level = level;
    o.tolerance = percent;
    o.tolerance_percent = true;
    const Result<SparseBuildReport> built = BuildSparseStore(*info, out, o);
    if (!built.ok()) {
      std::fprintf(stderr, "sparse_layout: %s\n", std::string(built.status().message()).c_str());
      return 1;
    }
    const auto start = std::chrono::steady_clock::now();
    auto store = SparseStore::Open(out, {});
    const Status verified = store.ok() ? (*store)->Verify() : store.status();
    const double verify_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!verified.ok()) {
      std::fprintf(stderr, "sparse_layout: %s\n", std::string(verified.message()).c_str());
      return 1;
    }
    const SparseHeader& h = built->header;
    const double points = static_cast<double>(h.points());
    nlohmann::json j;
    j["volume"] = argv[1];
    j["tolerance_percent"] = percent;
    j["tolerance"] = h.tolerance;
    j["points"] = h.points();
    j["block_bits"] = h.block_bits;
    j["blocks"] = h.blocks;
    j["kept"] = h.kept;
    j["kept_per_point"] = static_cast<double>(h.kept) / points;
    j["file_bytes"] = built->file_bytes;
    j["bytes_per_point"] = static_cast<double>(built->file_bytes) / points;
    j["build_seconds"] = built->seconds;
    j["check_rounds"] = built->rounds;
    j["kept_by_check"] = built->kept_by_check;
    j["verify_seconds"] = verify_s;
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }
  return 0;
}
