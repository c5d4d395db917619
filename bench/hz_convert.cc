// hz_convert: makes a format-2 store from a format-1 store (built with
// `simplexdb import --quantization f32`, whose float32 errors keep the
// diamond maxima exact), for the format-2 benchmarks until `import` writes
// format 2 itself. Prints one JSON line: the output's bytes, blocks and
// seconds.
//
//   hz_convert IN.sdb OUT.sdb [u16|u8|f32] [zstd|none] [block_bits] [zstd_level]
//
// With SIMPLEXDB_HZ_FIELD_ONLY=1 in the environment every error is written
// as 0: the size of the field alone in format 2's blocks, for the size
// study (that store answers every query with the coarsest mesh).
#include <cstdio>
#include <cstdlib>
#include <string>

#include <nlohmann/json.hpp>

#include <memory>
#include <thread>
#include <vector>

#include "hierarchy/hz_order.h"
#include "storage/dense/dense_store.h"
#include "storage/dense/hz_builder.h"
#include "storage/dense/hz_writer.h"

namespace {

using namespace simplexdb;

// The field alone in format 2's blocks and order (every error 0).
template <int D>
Result<HzHeader> WriteFieldOnly(const DenseStore& f1, const std::string& out,
                                const HzBuildOptions& options) {
  const DenseHeader& f = f1.header();
  const HzOrder<D> order(f.domain_bits);
  HzHeader params;
  params.dimension = static_cast<uint8_t>(D);
  params.quantization = options.quantization;
  params.voxel_type = f.voxel_type;
  params.domain_bits = f.domain_bits;
  params.block_bits = static_cast<uint8_t>(options.block_bits);
  params.dims = f.dims;
  params.field_min = f.field_min;
  params.field_max = f.field_max;
  HzWriteOptions write;
  write.compression = options.compression;
  write.zstd_level = options.zstd_level;
  write.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::unique_ptr<DenseStore::Reader<D>>> readers(static_cast<size_t>(write.threads));
  return WriteHzStore(out, params, write,
                      [&](int w, uint64_t first, size_t count, double*, double* fields) -> Status {
                        auto& r = readers[static_cast<size_t>(w)];
                        if (!r) r = std::make_unique<DenseStore::Reader<D>>(f1);
                        for (size_t i = 0; i < count; ++i) {
                          std::array<int64_t, D> g{};
                          if (!order.Decode(first + i, g)) continue;
                          bool real = true;
                          for (int a = 0; a < D; ++a) real = real && g[a] < int64_t{f.dims[a]};
                          if (!real) continue;
                          SDB_ASSIGN_OR_RETURN(fields[i], r->Field(g));
                        }
                        return Status::OK();
                      });
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: hz_convert IN.sdb OUT.sdb [u16|u8|f32] [zstd|none] [block_bits] [zstd_level]\n");
    return 2;
  }
  HzBuildOptions options;
  options.memory_bytes = size_t{16} << 30;
  if (argc > 3) {
    const Result<Quantization> q = ParseQuantization(argv[3]);
    if (!q.ok()) {
      std::fprintf(stderr, "hz_convert: %s\n", q.status().ToString().c_str());
      return 2;
    }
    options.quantization = *q;
  }
  if (argc > 4) {
    const Result<Compression> c = ParseCompression(argv[4]);
    if (!c.ok()) {
      std::fprintf(stderr, "hz_convert: %s\n", c.status().ToString().c_str());
      return 2;
    }
    options.compression = *c;
  }
  if (argc > 5) options.block_bits = std::atoi(argv[5]);
  if (argc > 6) options.zstd_level = std::atoi(argv[6]);
  const auto in = DenseStore::Open(argv[1]);
  if (!in.ok()) {
    std::fprintf(stderr, "hz_convert: %s\n", in.status().ToString().c_str());
    return 1;
  }
  if (const char* e = std::getenv("SIMPLEXDB_HZ_FIELD_ONLY"); e && std::string(e) == "1") {
    const auto h = (*in)->dimension() == 3 ? WriteFieldOnly<3>(**in, argv[2], options)
                                           : WriteFieldOnly<4>(**in, argv[2], options);
    if (!h.ok()) {
      std::fprintf(stderr, "hz_convert: %s\n", h.status().ToString().c_str());
      return 1;
    }
    std::printf("{\"bytes\":%llu,\"field_only\":true}\n", static_cast<unsigned long long>(h->file_size));
    return 0;
  }
  const auto report = ConvertToHz(**in, argv[2], options);
  if (!report.ok()) {
    std::fprintf(stderr, "hz_convert: %s\n", report.status().ToString().c_str());
    return 1;
  }
  nlohmann::json j;
  j["bytes"] = report->header.file_size;
  j["stored_blocks"] = report->header.stored_blocks;
  j["virtual_blocks"] = report->header.virtual_blocks;
  j["grid_points"] = report->grid_points;
  j["nodes"] = report->nodes;
  j["seconds"] = report->seconds;
  std::printf("%s\n", j.dump().c_str());
  return 0;
}
