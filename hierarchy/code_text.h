// What the location code types share (hierarchy/simplex_code.h,
// hierarchy/tri_code.h): the "T:bits" text form's root part, and the hash.
// Installed because those inline headers include it; what it defines lives
// in simplexdb::internal and is not an API.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "util/status.h"

namespace simplexdb::internal {

// The wording of one code type's parse errors.
struct CodeTextWords {
  std::string_view kind;        // "location code"
  std::string_view form;        // "expected T:bits, e.g. 2:10011"
  std::string_view root_index;  // "a root index"
  std::string_view root;        // "root"
};

struct CodeText {
  int root = 0;
  std::string_view bits;  // everything after ':'
};

// InvalidArgument naming `text` and `why`.
inline Status BadCodeText(std::string_view text, const CodeTextWords& words,
                          std::string_view why) {
  return Status::InvalidArgument('\'' + std::string(text) + "' is not a " +
                                 std::string(words.kind) + ": " + std::string(why));
}

// Splits "T:bits" and reads T, an index 0..roots-1 in decimal without
// leading zeros (so the text form of a code is unique).
inline Result<CodeText> ParseCodeText(std::string_view text, int roots,
                                      const CodeTextWords& words) {
  const size_t colon = text.find(':');
  if (colon == std::string_view::npos) return BadCodeText(text, words, words.form);
  const std::string_view top_text = text.substr(0, colon);
  const std::string expected_top = "expected " + std::string(words.root_index) + " 0.." +
                                   std::to_string(roots - 1) + " before ':'";
  if (top_text.empty() || top_text.size() > 2 ||
      (top_text.size() > 1 && top_text[0] == '0')) {
    return BadCodeText(text, words, expected_top);
  }
  int top = 0;
  for (char c : top_text) {
    if (c < '0' || c > '9') return BadCodeText(text, words, expected_top);
    top = top * 10 + (c - '0');
  }
  if (top >= roots) {
    return BadCodeText(text, words,
                       std::string(words.root) + " " + std::to_string(top) +
                           " is out of range 0.." + std::to_string(roots - 1));
  }
  return CodeText{top, text.substr(colon + 1)};
}

// The splitmix64 finalizer: keys differ mostly in high bits.
constexpr uint64_t MixKey(uint64_t x) {
  x ^= x >> 30;
  x *= 0xbf58476d1ce4e5b9ULL;
  x ^= x >> 27;
  x *= 0x94d049bb133111ebULL;
  x ^= x >> 31;
  return x;
}

}  // namespace simplexdb::internal
