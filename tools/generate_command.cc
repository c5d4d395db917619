// `simplexdb generate`: synthetic volumes (storage/volume/generate.h) written as
// NRRD, streamed in chunks so any size fits in little memory, on every core.
// `simplexdb to4d`: a 4D volume from a 3D one, subgrids becoming time
// (storage/volume/subgrid_time.h).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "storage/io/file.h"
#include "storage/volume/generate.h"
#include "storage/volume/nrrd_writer.h"
#include "storage/volume/subgrid_time.h"
#include "storage/volume/volume.h"
#include "storage/volume/voxel_type.h"
#include "tools/cli_util.h"
#include "tools/commands.h"
#include "util/out_of_memory.h"

namespace simplexdb::tools {
namespace {

struct GenerateArgs {
  FieldArgs f;
  std::string dims = "65,65,65";
  std::string type = "float32";
  std::string output;
  int threads = 0;
  bool quiet = false;
  bool force = false;
};

void RunGenerate(GenerateArgs a) {
  a.output = CheckOutput(a.output, {}, a.force);
  const GenerateOptions options = ParseFieldOptions(a.f, a.dims);
  Result<VoxelType> type = ParseVoxelType(a.type);
  if (!type.ok()) throw CommandError("--type: " + std::string(type.status().message()), 2);
  const FieldGenerator generator(options);

  std::string header = "NRRD0004\n";
  header += fmt::format("# simplexdb generate --field {} --seed {} --octaves {} --frequency {}\n",
                        a.f.field, a.f.seed, a.f.octaves, a.f.frequency);
  header += fmt::format("type: {}\ndimension: {}\nsizes:", NrrdTypeName(*type), options.dimension);
  for (int i = 0; i < options.dimension; ++i) header += fmt::format(" {}", options.dims[i]);
  header += "\nendian: little\nencoding: raw\nspacings:";
  for (int i = 0; i < options.dimension; ++i) header += " 1";
  header += "\n\n";

  Result<std::unique_ptr<AtomicFileWriter>> writer = AtomicFileWriter::Create(a.output);
  if (!writer.ok()) throw CommandError(std::string(writer.status().message()));
  AtomicFileWriter& out = **writer;
  const auto header_bytes = std::span<const uint8_t>(
      reinterpret_cast<const uint8_t*>(header.data()), header.size());
  if (Status s = out.WriteAt(0, header_bytes); !s.ok()) throw CommandError(std::string(s.message()));

  uint64_t total = 1;
  for (uint32_t d : options.dims) total *= d;
  const size_t vsize = VoxelSize(*type);
  out.Reserve(header.size() + total * vsize);
  constexpr uint64_t kChunk = uint64_t{1} << 20;
  const uint64_t chunks = (total + kChunk - 1) / kChunk;
  std::atomic<uint64_t> next{0}, done{0};
  std::atomic<bool> failed{false};
  std::string failure;
  std::mutex mu;
  const int threads = a.threads > 0 ? a.threads : std::max(1u, std::thread::hardware_concurrency());
  const auto fail = [&](std::string why) {
    std::lock_guard<std::mutex> lock(mu);
    if (!failed.exchange(true)) failure = std::move(why);
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(threads));
  const auto worker = [&] {
    std::vector<double> values;
    std::vector<uint8_t> bytes;
    for (uint64_t c; !failed && (c = next.fetch_add(1)) < chunks;) {
      const uint64_t first = c * kChunk;
      const size_t count = static_cast<size_t>(std::min(kChunk, total - first));
      try {  // out of a thread an exception would abort the process
        values.resize(count);
        bytes.resize(count * vsize);
      } catch (const std::bad_alloc&) {
        fail(std::string(NotEnoughMemory("a generated chunk of " + std::to_string(count) +
                                             " values",
                                         count * (sizeof(double) + vsize))
                             .message()));
        break;
      }
      generator.Fill(first, count, values.data());
      for (double& v : values) v = RepresentableValue(*type, v);
      EncodeVoxels(*type, ByteOrder::kLittle, values.data(), count,
                   reinterpret_cast<std::byte*>(bytes.data()));
      Status s = out.WriteAt(header.size() + first * vsize, bytes);
      if (!s.ok()) fail(std::string(s.message()));
      done.fetch_add(1);
    }
  };
  for (int w = 0; w < threads; ++w) {
    try {
      pool.emplace_back(worker);
    } catch (const std::exception&) {  // system_error or bad_alloc: no room for a thread
      fail(std::string(NotEnoughMemory("generator thread " + std::to_string(w + 1) + " of " +
                                           std::to_string(threads),
                                       "its stack")
                           .message()));
      break;
    }
  }
  ProgressLine line(!a.quiet);
  while (done.load() < chunks && !failed.load()) {
    line.Update(fmt::format("{}: {:.0f}%", a.output, 100.0 * done.load() / chunks));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  for (auto& t : pool) t.join();
  line.Finish();
  if (failed) throw CommandError(failure);
  if (Status s = out.Commit(); !s.ok()) throw CommandError(std::string(s.message()));
  if (!a.quiet) {
    fmt::print("{}: {} {} field ({} points, {}) written\n", a.output, a.f.field,
               FormatDims(options.dimension, options.dims), total, a.type);
  }
}

struct To4dArgs {
  std::string input, output;
  RawInputOptions raw;
  uint32_t subgrid = 4;
  uint32_t steps = 0;
  bool quiet = false;
  bool force = false;
};

void RunTo4d(To4dArgs a) {
  const VolumeInfo in = OpenInputs({a.input}, a.raw);
  std::vector<std::string> inputs = in.files;  // a detached header's data file too
  inputs.push_back(a.input);
  a.output = CheckOutput(a.output, inputs, a.force);
  uint32_t steps = a.steps;
  if (steps == 0) {  // a 4D cube when the subgrid holds enough points
    for (int i = 0; i < 3; ++i) steps = std::max(steps, SubgridAxis(in.dims[i], a.subgrid));
    steps = std::min(steps, a.subgrid * a.subgrid * a.subgrid);
  }
  Result<SubgridTimeVolume> out = SubgridsToTime(in, a.subgrid, steps);
  if (!out.ok()) {
    // Bad --subgrid/--steps are usage errors; no memory or a bad read are not.
    throw CommandError(std::string(out.status().message()),
                       out.status().IsInvalidArgument() ? 2 : 1);
  }
  if (Status s = WriteNrrd(a.output, 4, out->dims, in.type, out->values); !s.ok()) Fail(s);
  if (!a.quiet) {
    fmt::print("{}: {} from {} ({}), {}^3 subgrids as {} time steps\n", a.output,
               FormatDims(4, out->dims), a.input, FormatDims(3, in.dims), a.subgrid, steps);
  }
}

// `simplexdb to4d --help`.
constexpr const char* kTo4dHelp = R"(Make a 4D volume (NRRD) from a 3D one as the seed's section 4.7 made its 4D
Buckyball: the values of each SxSxS subgrid become the time axis of the point
standing for the subgrid: out(i,j,k,t) = in(S i + t%S, S j + (t/S)%S, S k + t/S^2),
clamped to the grid. Each axis of n points gives (n-1)/S + 1.
Example: simplexdb to4d bucky129.nrrd -o bucky4d.nrrd   (33^4, as in the seed))";

// `simplexdb generate --help`.
constexpr const char* kGenerateHelp = R"(Write a synthetic volume as NRRD, the same bits for the same seed on every
machine: Perlin noise (3D or 4D; the seed's Plasma64 is 65^3 Perlin noise)
and analytic fields. Any size: the volume is streamed to disk.
Example: simplexdb generate --field perlin --dims 65,65,65 -o plasma64.nrrd)";

}  // namespace

void RegisterTo4dCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<To4dArgs>(app, "to4d", kTo4dHelp, RunTo4d);
  cmd->add_option("input", a->input, "3D volume: NRRD or NIfTI-1, or raw with --dims and --type")
      ->required();
  AddOutputOptions(cmd, &a->output, &a->force, "the 4D NRRD file to write");
  cmd->add_option("--subgrid", a->subgrid, "S, the side of a subgrid")->capture_default_str();
  cmd->add_option("--steps", a->steps,
                  "time steps, 2..S^3 (default: the longest output axis, at most S^3)");
  AddRawInputOptions(cmd, &a->raw, "raw input: X,Y,Z (x fastest)");
  AddQuietFlag(cmd, &a->quiet, "no summary");
}

void RegisterGenerateCommand(CLI::App& app) {
  auto [cmd, a] = AddCommand<GenerateArgs>(app, "generate", kGenerateHelp, RunGenerate);
  AddOutputOptions(cmd, &a->output, &a->force, "the NRRD file to write");
  cmd->add_option("--field", a->f.field, "perlin|sphere|sines|marschner-lobb|constant|ramp|buckyball (C60, the seed's Buckyball)")
      ->capture_default_str();
  cmd->add_option("--dims", a->dims, "X,Y,Z or X,Y,Z,T")->capture_default_str();
  cmd->add_option("--type", a->type, "uint8|int8|uint16|int16|float32|float64 (integers are "
                                     "rounded and clamped)")
      ->capture_default_str();
  cmd->add_option("--seed", a->f.seed, "random seed")->capture_default_str();
  cmd->add_option("--octaves", a->f.octaves, "Perlin octaves")->capture_default_str();
  cmd->add_option("--frequency", a->f.frequency, "periods across the domain")->capture_default_str()->check(DecimalNumber());
  cmd->add_option("--constant", a->f.constant, "the value of --field constant")->capture_default_str()->check(DecimalNumber());
  AddThreadsOption(cmd, &a->threads);
  AddQuietFlag(cmd, &a->quiet);
}

}  // namespace simplexdb::tools
