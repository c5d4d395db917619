#include "tools/cli_util.h"

#include "query/import_volume.h"
#include "storage/io/file.h"

#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <iostream>
#include <system_error>
#include <fstream>
#include <limits>
#include <cmath>
#include <cstdlib>

namespace simplexdb::tools {

std::string CheckOutput(const std::string& path, const std::vector<std::string>& inputs,
                        bool force) {
  OutputOptions options;
  options.force = force;
  options.inputs = inputs;
  Result<std::string> resolved = ResolveOutput(path, options);
  if (!resolved.ok()) Fail(resolved.status());
  return *std::move(resolved);
}

void AddForceOption(CLI::App* cmd, bool* force) {
  cmd->add_flag("--force", *force,
                "when the output is a symlink to a regular file, replace that file (atomically) "
                "and keep the link; without --force a symlink output is refused. An output that "
                "is an input, a device, a FIFO, a socket, a directory or a dangling symlink is "
                "always refused");
}

Status FinishStandardOutput(int earlier_errno) {
  std::cout.flush();
  errno = 0;
  const bool flush_failed = std::fflush(stdout) != 0;
  int err = errno;
  if (!flush_failed && !std::ferror(stdout) && !std::cout.fail()) return Status::OK();
  if (!flush_failed || err == 0) {
    // The failed write was during the command and its errno is gone. A write
    // of nothing reports the reason for a device (ENOSPC for /dev/full) or a
    // closed descriptor (EBADF), and writes nothing.
    errno = 0;
    err = write(STDOUT_FILENO, "", 0) < 0 ? errno : 0;
    if (err == 0) err = earlier_errno != 0 ? earlier_errno : EIO;
  }
  return Status::IOError("cannot write to standard output: " +
                         std::generic_category().message(err));
}

std::vector<double> ParseNumberList(std::string_view text, const char* option, size_t min_count,
                                    size_t max_count) {
  std::vector<double> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = text.find(',', start);
    const std::string item(text.substr(start, comma == std::string_view::npos ? std::string_view::npos
                                                                              : comma - start));
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v)) {
      throw CommandError(fmt::format("{}: '{}' is not a comma-separated list of numbers", option,
                                     text),
                         2);
    }
    out.push_back(v);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (out.size() < min_count || out.size() > max_count) {
    throw CommandError(fmt::format("{}: expected {} to {} numbers, got {} in '{}'", option,
                                   min_count, max_count, out.size(), text),
                       2);
  }
  return out;
}

double ParseAmount(std::string_view text, const char* option, double range) {
  const bool percent = !text.empty() && text.back() == '%';
  const std::string number(percent ? text.substr(0, text.size() - 1) : text);
  char* end = nullptr;
  const double v = std::strtod(number.c_str(), &end);
  if (number.empty() || end != number.c_str() + number.size() || !std::isfinite(v) || v < 0) {
    throw CommandError(fmt::format("{}: expected a number >= 0 such as 7.3 or 1%, not '{}'", option,
                                   text),
                       2);
  }
  return percent ? v / 100 * range : v;
}

std::array<uint32_t, 4> ParseDims(std::string_view text, int* dimension) {
  const std::vector<double> v = ParseNumberList(text, "--dims", 3, 4);
  std::array<uint32_t, 4> dims = {1, 1, 1, 1};
  for (size_t i = 0; i < v.size(); ++i) {
    if (v[i] < 2 || v[i] != std::floor(v[i]) || v[i] > 4294967295.0) {
      throw CommandError(fmt::format("--dims: {} is not a whole number of at least 2 (in '{}')",
                                     v[i], text),
                         2);
    }
    dims[i] = static_cast<uint32_t>(v[i]);
  }
  *dimension = static_cast<int>(v.size());
  return dims;
}

std::string FormatPlacement(int dimension, const std::array<double, 4>& spacing,
                            const std::array<double, 4>& origin) {
  const auto n = static_cast<size_t>(std::clamp(dimension, 0, 4));
  return fmt::format("spacing {}, origin ({})", fmt::join(spacing.begin(), spacing.begin() + n, " x "),
                     fmt::join(origin.begin(), origin.begin() + n, ", "));
}

std::string HumanBytes(uint64_t bytes) {
  static const char* kUnits[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024 && u < 4) {
    v /= 1024;
    ++u;
  }
  return u == 0 ? fmt::format("{} B", bytes) : fmt::format("{:.1f} {}", v, kUnits[u]);
}

uint64_t PeakResidentBytes() {
  rusage r{};
  getrusage(RUSAGE_SELF, &r);
  return static_cast<uint64_t>(r.ru_maxrss) * 1024;  // Linux reports KiB
}

void AddRawInputOptions(CLI::App* cmd, RawInputOptions* raw, const std::string& dims_help) {
  cmd->add_option("--dims", raw->dims, dims_help);
  cmd->add_option("--type", raw->type, "raw input: uint8|int8|uint16|int16|float32|float64");
  cmd->add_option("--endian", raw->endian, "raw input: little|big")->capture_default_str();
  cmd->add_option("--offset", raw->offset, "raw input: header bytes to skip")->capture_default_str();
  cmd->add_option("--spacing", raw->spacing,
                  "grid spacing X,Y,Z[,T]; a negative X, Y or Z flips that axis, as "
                  "--spacing=-2,2,2.2 (stored in the header; replaces the file's)");
  cmd->add_option("--origin", raw->origin,
                  "position of grid point 0, X,Y,Z[,T] (stored in the header; replaces the "
                  "file's)");
}

namespace {

// The volume the inputs describe, before --spacing and --origin.
VolumeInfo OpenInputsAsGiven(const std::vector<std::string>& inputs, const RawInputOptions& raw);

// --spacing and --origin, given for a volume of `dimension` axes.
void ApplyPlacement(const RawInputOptions& raw, VolumeInfo& v) {
  const auto parse = [&](const std::string& text, const char* option) {
    const std::vector<double> values = ParseNumberList(text, option, 3, 4);
    if (static_cast<int>(values.size()) != v.dimension) {
      throw CommandError(fmt::format("{}: {} numbers for a {}D volume ({}); give {}", option,
                                     values.size(), v.dimension,
                                     FormatDims(v.dimension, v.dims), v.dimension),
                         2);
    }
    return values;
  };
  if (!raw.spacing.empty()) {
    const std::vector<double> s = parse(raw.spacing, "--spacing");
    for (size_t a = 0; a < s.size(); ++a) {
      // x, y, z may be negative (a flipped axis); time runs forwards.
      if (a < 3 ? s[a] == 0 : !(s[a] > 0)) {
        throw CommandError(fmt::format("--spacing: {} is not {} (in '{}')", s[a],
                                       a < 3 ? "non-zero" : "positive, as time's must be",
                                       raw.spacing),
                           2);
      }
      v.spacing[a] = s[a];
    }
  }
  if (!raw.origin.empty()) {
    const std::vector<double> o = parse(raw.origin, "--origin");
    for (size_t a = 0; a < o.size(); ++a) v.origin[a] = o[a];
  }
}

}  // namespace

VolumeInfo OpenInputs(const std::vector<std::string>& inputs, const RawInputOptions& raw) {
  VolumeInfo v = OpenInputsAsGiven(inputs, raw);
  ApplyPlacement(raw, v);
  return v;
}

namespace {

VolumeInfo OpenInputsAsGiven(const std::vector<std::string>& inputs, const RawInputOptions& raw) {
  if (raw.dims.empty()) {
    if (!raw.type.empty() || raw.offset != 0) {
      throw CommandError("--type and --offset describe raw input and need --dims", 2);
    }
    Result<VolumeInfo> v = inputs.size() == 1 ? OpenVolume(inputs[0]) : OpenTimeSeries(inputs);
    if (!v.ok()) Fail(v.status());
    return *std::move(v);
  }
  if (raw.type.empty()) throw CommandError("raw input needs --type (e.g. --type uint8)", 2);
  Result<VoxelType> type = ParseVoxelType(raw.type);
  if (!type.ok()) throw CommandError("--type: " + std::string(type.status().message()), 2);
  if (raw.endian != "little" && raw.endian != "big") {
    throw CommandError("--endian: expected little or big, not '" + raw.endian + "'", 2);
  }
  const ByteOrder order = raw.endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
  int dimension = 0;
  const std::array<uint32_t, 4> dims = ParseDims(raw.dims, &dimension);
  if (inputs.size() == 1) {
    Result<VolumeInfo> v = OpenRawVolume(inputs[0], dimension, dims, *type, order, raw.offset);
    if (!v.ok()) Fail(v.status());
    return *std::move(v);
  }
  // A time series of raw 3D volumes: one 4D volume, t in the order given.
  if (dimension != 3) {
    throw CommandError("several raw inputs form a time series of 3D volumes: give --dims X,Y,Z",
                       2);
  }
  VolumeInfo series;
  for (const std::string& path : inputs) {
    Result<VolumeInfo> v = OpenRawVolume(path, 3, dims, *type, order, raw.offset);
    if (!v.ok()) Fail(v.status());
    if (series.files.empty()) series = *v;
    else series.files.push_back(path);
  }
  series.dimension = 4;
  series.dims[3] = static_cast<uint32_t>(inputs.size());
  series.description = fmt::format("time series of {} raw volumes ({}, ...)", inputs.size(),
                                   inputs[0]);
  return series;
}

}  // namespace

uint64_t AnonymousResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  uint64_t kib = 0;
  while (status >> key) {
    if (key == "RssAnon:" && status >> kib) return kib * 1024;
    status.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return 0;
}

void ProgressLine::Update(const std::string& text) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  std::fprintf(stderr, "\r\033[K%s", text.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressLine::Finish() {
  if (enabled_ && drawn_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  drawn_ = false;
}

std::unique_ptr<HzStore> OpenHzStore(const std::string& path) {
  Result<std::unique_ptr<HzStore>> s = HzStore::Open(path);
  if (!s.ok()) Fail(s.status());
  return *std::move(s);
}

std::unique_ptr<DenseStore> OpenDenseStore(const std::string& path) {
  Result<std::unique_ptr<DenseStore>> s = DenseStore::Open(path);
  if (!s.ok()) Fail(s.status());
  return *std::move(s);
}

std::function<void(const BuildProgress&)> ProgressTo(ProgressLine& line,
                                                         const std::string& output) {
  return [&line, output](const BuildProgress& p) { line.Update(DescribeProgress(output, p)); };
}

}  // namespace simplexdb::tools
