// Small helpers shared by the `simplexdb` subcommands.
#pragma once

#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "query/criteria.h"  // Amount
#include "query/open_store.h"
#include "storage/error/progress.h"
#include "storage/volume/generate.h"
#include "storage/volume/volume.h"
#include "parallel/mpi_session.h"
#include "tools/commands.h"
#include "util/status.h"
#include "util/utf8.h"

namespace simplexdb::tools {

// SetJsonBytes (a path or other bytes in JSON output) is in util/utf8.h.

// Throws `status` as a CommandError (exit 1), its message as the reason.
[[noreturn]] inline void Fail(const Status& status) {
  throw CommandError(std::string(status.message()), 1);
}

// An operation's check of its options (ops/): a failure is a usage error,
// thrown as a CommandError with exit 2 (the message names the option as
// the command spells it). OK: nothing.
inline void CheckUsage(const Status& status) {
  if (!status.ok()) throw CommandError(std::string(status.message()), 2);
}

// The value of `result`, or its error as a usage error (CheckUsage).
template <class T>
T UsageValue(Result<T> result) {
  CheckUsage(result.status());
  return *std::move(result);
}

// Runs `step` on every rank; an error on any rank (a CommandError or a
// failed status) stops every rank with the message of the lowest rank
// that failed (MpiSession::Agree), which main prints once, at rank 0.
template <class Step>
void Together(MpiSession& mpi, Step&& step) {
  Status mine;
  try {
    mine = step();
  } catch (const CommandError& e) {
    mine = e.exit_code() == 2 ? Status::InvalidArgument(e.what()) : Status::IOError(e.what());
  }
  const Status all = mpi.Agree(mine);
  if (!all.ok()) throw CommandError(std::string(all.message()), all.IsInvalidArgument() ? 2 : 1);
}

// "65,65,65" -> {65, 65, 65}; throws CommandError (exit 2) naming `option`
// and the text otherwise.
std::vector<double> ParseNumberList(std::string_view text, const char* option, size_t min_count,
                                    size_t max_count);

// An amount in field units: "7.3" (absolute) or "1%" (of the field's
// range): ops/amount.h's ParseAmount, a usage error (exit 2) naming
// `option` otherwise.
Amount ParseAmountOption(std::string_view text, const char* option);

// A size option in MiB ("--memory-mb N") in bytes; a usage error naming
// `option` when N MiB is beyond the address space.
size_t MebibytesOption(size_t mib, const char* option = "--memory-mb");

// Grid dimensions "X,Y,Z[,T]": every entry a whole number >= 2.
std::array<uint32_t, 4> ParseDims(std::string_view text, int* dimension);

// What `generate` and `import --field` take to describe a generated field.
struct FieldArgs {
  std::string field = "perlin";
  uint64_t seed = 1;
  int octaves = 4;
  double frequency = 4.0;
  double constant = 0.0;
};

// `field` and `dims` (--dims) as GenerateOptions (storage/volume/generate.h),
// checked: a usage error (exit 2) naming the bad option.
GenerateOptions ParseFieldOptions(const FieldArgs& field, std::string_view dims);

// How raw input is laid out (--dims, --type, --endian, --offset); empty
// dims: the inputs describe themselves (NRRD, NIfTI-1).
struct RawInputOptions {
  std::string dims;
  std::string type;
  std::string endian = "little";
  uint64_t offset = 0;
};

// Adds --dims, --type, --endian and --offset to `cmd`, bound to `raw`
// (which must outlive the command). `dims_help` says which grids the
// command takes.
void AddRawInputOptions(CLI::App* cmd, RawInputOptions* raw, const std::string& dims_help);

// Opens the input volume: one file, or several 3D files forming a time
// series (t in the order given). Throws CommandError (exit 2) for raw
// options that do not fit together, Fail()s with the reader's reason.
VolumeInfo OpenInputs(const std::vector<std::string>& inputs, const RawInputOptions& raw);

// A store's placement for `info`: "spacing 2 x 2 x 2.2, origin (117.855,
// -35.7229, -7.2488)", the used axes only, each number the shortest text
// that reads back exactly.
std::string FormatPlacement(int dimension, const std::array<double, 4>& spacing,
                            const std::array<double, 4>& origin);

// A one-line progress display on stderr, redrawn in place, only when stderr
// is a terminal (scripts see nothing). Throttled to a few updates a second.
class ProgressLine {
 public:
  explicit ProgressLine(bool enabled) : enabled_(enabled && isatty(2)) {}
  ~ProgressLine() { Finish(); }
  void Update(const std::string& text);
  void Finish();

 private:
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

// The path a command writes for its output `path`, checked before the
// command writes anything (ResolveOutput, storage/io/file.h):
// `path` itself, or with `force` the regular file the symlink `path` points
// to (replaced atomically; the link stays). Fail()s (exit 1, nothing
// touched) when `path` is one of `inputs` by any name, a device, a FIFO, a
// socket, a directory, a dangling symlink, or a symlink without `force`.
std::string CheckOutput(const std::string& path, const std::vector<std::string>& inputs,
                        bool force);

// The store a query reads (extract, isosurface): --in-memory on a sparse
// store is a usage error (exit 2), a store that does not open fails with 1;
// `cache_mb` is --cache-mb.
AnyStore OpenQueriedStore(const std::string& path, bool in_memory, size_t cache_mb);

// Adds --force, bound to `force`, with the one help text for it.
void AddForceOption(CLI::App* cmd, bool* force);

// A check for CLI11 options that hold numbers: the text must be a decimal
// number as ParseDecimal reads it (ops/amount.h). CLI11 itself reads
// numbers with strtod, which takes "0x10" for 16 and "inf" for infinity.
const CLI::Validator& DecimalNumber();

// Adds the required "-o,--output", bound to `output` and described by
// `help` (what the command writes there), and --force (AddForceOption):
// every command that writes a file takes both.
void AddOutputOptions(CLI::App* cmd, std::string* output, bool* force, const std::string& help);

// Adds "-q,--quiet", bound to `quiet`; `help` says what it silences.
void AddQuietFlag(CLI::App* cmd, bool* quiet, const std::string& help = "no progress or summary");

// Adds --json and -q/--quiet (AddQuietFlag's help), bound to `json` and
// `quiet`: a command that prints a report prints it as JSON, as text, or
// not at all. `json_help` says what the JSON holds.
void AddReportFlags(CLI::App* cmd, bool* json, bool* quiet,
                    const std::string& json_help = "print the report as JSON");

// Adds --threads (its default shown), bound to `threads`; 0 means one per
// core in every command. `help` says whose threads they are and what their
// count changes.
void AddThreadsOption(CLI::App* cmd, int* threads,
                      const std::string& help = "worker threads (0: one per core)");

// Adds --memory-mb (its default shown), bound to `memory_mb`, which the
// command turns into bytes with MebibytesOption. `help` says what the bound
// covers for the command.
void AddMemoryOption(CLI::App* cmd, size_t* memory_mb, const std::string& help);

// Adds the subcommand `name` with `help` to `app`, its options to be bound
// to the returned Args (default-constructed), and `run(args)` as its
// callback. The callback owns the Args, so the pointer stays valid as long
// as `app`: bind options to its fields right after the call.
template <class Args, class Run>
std::pair<CLI::App*, Args*> AddCommand(CLI::App& app, const std::string& name,
                                       const std::string& help, Run run) {
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(name, help);
  cmd->callback([args, run] { run(*args); });
  return {cmd, args.get()};
}

// Flushes stdout (std::cout writes through it) and returns the error of any
// write to it that failed: "cannot write to standard output: <reason>".
// The reason is the failed flush's errno; when the write failed during the
// command (stdio keeps no errno of its own), that of a write of nothing to
// stdout (a device, a closed descriptor), else `earlier_errno` (errno as the
// command left it), else EIO. OK when everything reached stdout.
// tools/main.cc calls it once, after the command ran, so no command checks
// its own prints.
Status FinishStandardOutput(int earlier_errno);

// A builder's progress callback that draws "OUTPUT: phase done/total (P%),
// S s" on `line`. `line` must outlive the callback.
std::function<void(const BuildProgress&)> ProgressTo(ProgressLine& line,
                                                         const std::string& output);

}  // namespace simplexdb::tools
