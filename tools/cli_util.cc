#include "tools/cli_util.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <system_error>

#include "ops/amount.h"
#include "ops/import.h"  // DescribeProgress
#include "storage/io/file.h"

namespace simplexdb::tools {

std::string CheckOutput(const std::string& path, const std::vector<std::string>& inputs,
                        bool force) {
  Result<std::string> resolved = ResolveOutput(path, {.force = force, .inputs = inputs});
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

void AddOutputOptions(CLI::App* cmd, std::string* output, bool* force, const std::string& help) {
  cmd->add_option("-o,--output", *output, help)->required();
  AddForceOption(cmd, force);
}

void AddQuietFlag(CLI::App* cmd, bool* quiet, const std::string& help) {
  cmd->add_flag("-q,--quiet", *quiet, help);
}

void AddReportFlags(CLI::App* cmd, bool* json, bool* quiet, const std::string& json_help) {
  cmd->add_flag("--json", *json, json_help);
  AddQuietFlag(cmd, quiet);
}

void AddThreadsOption(CLI::App* cmd, int* threads, const std::string& help) {
  cmd->add_option("--threads", *threads, help)->capture_default_str();
}

void AddMemoryOption(CLI::App* cmd, size_t* memory_mb, const std::string& help) {
  cmd->add_option("--memory-mb", *memory_mb, help)->capture_default_str();
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
    const Result<double> v = ParseDecimal(item, option);
    if (!v.ok()) {
      throw CommandError(fmt::format("{}: '{}' is not a comma-separated list of decimal numbers", option,
                                     text),
                         2);
    }
    out.push_back(*v);
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

const CLI::Validator& DecimalNumber() {
  static const CLI::Validator check(
      [](std::string& text) -> std::string {
        return ParseDecimal(text, "").ok() ? std::string() : "'" + text + "' is not a decimal number";
      },
      "DECIMAL");
  return check;
}

Amount ParseAmountOption(std::string_view text, const char* option) {
  return UsageValue(ParseAmount(text, option));
}

size_t MebibytesOption(size_t mib, const char* option) {
  if (mib > (std::numeric_limits<size_t>::max() >> 20)) {  // << 20 would wrap
    throw CommandError(fmt::format("{} {} is beyond this machine's address space", option, mib), 2);
  }
  return mib << 20;
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

void AddRawInputOptions(CLI::App* cmd, RawInputOptions* raw, const std::string& dims_help) {
  cmd->add_option("--dims", raw->dims, dims_help);
  cmd->add_option("--type", raw->type, "raw input: uint8|int8|uint16|int16|float32|float64");
  cmd->add_option("--endian", raw->endian, "raw input: little|big")->capture_default_str();
  cmd->add_option("--offset", raw->offset, "raw input: header bytes to skip")->capture_default_str();
}

VolumeInfo OpenInputs(const std::vector<std::string>& inputs, const RawInputOptions& raw) {
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

std::function<void(const BuildProgress&)> ProgressTo(ProgressLine& line,
                                                         const std::string& output) {
  return [&line, output](const BuildProgress& p) { line.Update(DescribeProgress(output, p)); };
}

AnyStore OpenQueriedStore(const std::string& path, bool in_memory, size_t cache_mb) {
  // A usage error (exit 2) before anything is opened, as --in-memory names
  // the option; AnyStore::Open would refuse it too.
  if (in_memory && ProbeStoreKind(path) == StoreKind::kSparse) {
    throw CommandError("--in-memory applies to dense stores; the LMDB store is read in place", 2);
  }
  StoreOptions options;
  options.in_memory = in_memory;
  options.cache_bytes = MebibytesOption(cache_mb, "--cache-mb");
  Result<AnyStore> store = AnyStore::Open(path, options);
  if (!store.ok()) Fail(store.status());
  return *std::move(store);
}

GenerateOptions ParseFieldOptions(const FieldArgs& field, std::string_view dims) {
  GenerateOptions options;
  Result<FieldKind> kind = ParseFieldKind(field.field);
  if (!kind.ok()) throw CommandError("--field: " + std::string(kind.status().message()), 2);
  options.kind = *kind;
  options.dims = ParseDims(dims, &options.dimension);
  options.seed = field.seed;
  options.octaves = field.octaves;
  options.frequency = field.frequency;
  options.constant = field.constant;
  if (Status s = ValidateGenerateOptions(options); !s.ok()) throw CommandError(std::string(s.message()), 2);
  return options;
}

}  // namespace simplexdb::tools
