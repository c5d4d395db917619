// libFuzzer target for raw input as the command line describes it
// (tools/cli_util.cc OpenInputs: --dims, --type, --endian, --offset, one
// file or a time series of several) and the raw reader behind it
// (storage/volume/raw_reader.cc).
//
// An input is four option lines, then the file's bytes:
//   DIMS \n TYPE \n ENDIAN \n OFFSET \n BYTES...
// The file is given once, or three times (a time series) when OFFSET ends
// in 's'. Bad options must end in CommandError (the exit codes the tool
// gives); an accepted volume is read through. No other exception, no crash.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target raw_options_fuzz
//                  build/fuzz/tests/raw_options_fuzz -max_len=4096 -timeout=10
//                    -rss_limit_mb=2048 NEW_FOLDER tests/fuzz/corpus/raw_options
//   Replay (ctest): raw_options_fuzz_replay runs every saved input.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "tests/fuzz/fuzz_input_file.h"
#include "tools/cli_util.h"

namespace {

// The next line of `rest` (without '\n'); all of it when there is none.
std::string_view NextLine(std::string_view& rest) {
  const size_t end = rest.find('\n');
  const std::string_view line = rest.substr(0, end);
  rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
  return line;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace simplexdb;
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  tools::RawInputOptions raw;
  raw.dims = std::string(NextLine(rest));
  raw.type = std::string(NextLine(rest));
  raw.endian = std::string(NextLine(rest));
  std::string_view offset = NextLine(rest);
  const bool series = !offset.empty() && offset.back() == 's';
  if (series) offset.remove_suffix(1);
  // --offset is a uint64_t option: CLI11 parses the text before OpenInputs
  // sees it; digits beyond 19 wrap here as they could not there.
  for (char c : offset) {
    if (c >= '0' && c <= '9') raw.offset = raw.offset * 10 + static_cast<uint64_t>(c - '0');
  }
  const std::string path = fuzz::WriteInput(
      "in.raw", reinterpret_cast<const uint8_t*>(rest.data()), rest.size());
  const std::vector<std::string> inputs =
      series ? std::vector<std::string>{path, path, path} : std::vector<std::string>{path};
  try {
    fuzz::ReadAll(tools::OpenInputs(inputs, raw));
  } catch (const tools::CommandError&) {
    // A usage error or the reader's reason: what the tool reports.
  }
  return 0;
}
