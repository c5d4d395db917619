// libFuzzer target for the location code text form, as `simplexdb codes`
// and `inspect` read it line by line: SimplexCode<3> (HT), SimplexCode<4>
// (HP) and the three triangle quadtrees' TriCode::Parse (hierarchy/
// code_text.h underneath), and the JSON the tool writes for any line.
//
// Checks, besides no crash: an accepted text is a valid code whose text
// form is the input itself (the form is unique: no leading zeros, no other
// digits), its ancestors are valid and end at level 0; a rejected one has
// a message; the JSON of the line and of the reason dumps (any bytes).
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target codes_line_fuzz
//                  build/fuzz/tests/codes_line_fuzz -max_len=512 -timeout=10
//                    NEW_FOLDER tests/fuzz/corpus/codes_line
//   Replay (ctest): codes_line_fuzz_replay runs every saved input.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "hierarchy/simplex_code.h"
#include "hierarchy/tri_code.h"
#include "tools/cli_util.h"

namespace {

using simplexdb::Result;

[[noreturn]] void Broken(const char* what, std::string_view text) {
  std::fprintf(stderr, "codes_line_fuzz: %s for '%.*s'\n", what, static_cast<int>(text.size()),
               text.data());
  std::abort();
}

template <class Code>
void Check(std::string_view text) {
  const Result<Code> code = Code::Parse(text);
  nlohmann::json j;
  simplexdb::SetJsonBytes(j, "code", text);
  if (!code.ok()) {
    if (code.status().message().empty()) Broken("a rejection without a reason", text);
    j["error"] = simplexdb::ToValidUtf8(code.status().message());
    (void)j.dump();
    return;
  }
  if (!code->is_valid()) Broken("an accepted text gave an invalid code", text);
  if (code->ToString() != text) Broken("the text form does not round-trip", text);
  Code c = *code;
  while (c.level() > 0) {
    c = c.parent();
    if (!c.is_valid()) Broken("an ancestor is invalid", text);
  }
  j["level"] = code->level();
  (void)j.dump();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace simplexdb;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Check<SimplexCode<3>>(text);
  Check<SimplexCode<4>>(text);
  Check<IcosaCode>(text);
  Check<OctaCode>(text);
  Check<TetraCode>(text);
  return 0;
}
