// UTF-8 checks for text that comes from outside (file names, store headers,
// stdin) and goes into places that need valid UTF-8 (JSON) or a fixed size
// (the dense header's 255-byte source field). Paths on POSIX are bytes, not
// text: these helpers never fail, they say what is valid and where to cut.
//
// Well-formed UTF-8 is the Unicode definition (Table 3-7): no overlong
// forms, no surrogates (U+D800..U+DFFF), nothing above U+10FFFF.
//
// Thread safety: pure functions. Cost: O(n) in the bytes looked at.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace simplexdb {

// The length (1..4) of the well-formed UTF-8 sequence at the start of `s`,
// or 0 if `s` does not start with one (an invalid byte, or a sequence cut
// short by the end of `s`).
constexpr size_t Utf8SequenceLength(std::string_view s) noexcept {
  if (s.empty()) return 0;
  const auto b = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char c = b(0);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;  // no overlong forms
    if (c == 0xED) hi = 0x9F;  // no surrogates
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;  // no overlong forms
    if (c == 0xF4) hi = 0x8F;  // nothing above U+10FFFF
  } else {
    return 0;  // a continuation byte, C0, C1 or F5..FF
  }
  if (s.size() < n || b(1) < lo || b(1) > hi) return 0;
  for (size_t i = 2; i < n; ++i) {
    if (b(i) < 0x80 || b(i) > 0xBF) return 0;
  }
  return n;
}

constexpr bool IsValidUtf8(std::string_view s) noexcept {
  while (!s.empty()) {
    const size_t n = Utf8SequenceLength(s);
    if (n == 0) return false;
    s.remove_prefix(n);
  }
  return true;
}

// The length of the longest prefix of `s` of at most `max_bytes` bytes that
// does not end inside a well-formed multi-byte sequence. Invalid bytes count
// as one byte each (they are kept, not judged). So a valid string cut there
// stays valid, and an invalid one gets no new invalid bytes.
constexpr size_t Utf8PrefixLength(std::string_view s, size_t max_bytes) noexcept {
  if (s.size() <= max_bytes) return s.size();
  size_t i = 0;
  while (i < max_bytes) {
    const size_t n = Utf8SequenceLength(s.substr(i));
    const size_t step = n == 0 ? 1 : n;
    if (i + step > max_bytes) break;
    i += step;
  }
  return i;
}

// `s` with each byte that is not part of a well-formed sequence replaced by
// U+FFFD (the replacement character). Lossy: the caller keeps the raw bytes
// where they matter (see HexBytes).
inline std::string ToValidUtf8(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  while (!s.empty()) {
    const size_t n = Utf8SequenceLength(s);
    if (n == 0) {
      out += "\xEF\xBF\xBD";
      s.remove_prefix(1);
    } else {
      out.append(s.substr(0, n));
      s.remove_prefix(n);
    }
  }
  return out;
}

// Two lowercase hex digits per byte: "a\xff" -> "61ff".
inline std::string HexBytes(std::string_view s) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * s.size());
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    out += kDigits[c >> 4];
    out += kDigits[c & 0xF];
  }
  return out;
}

// Sets j[key] to `bytes` (a path, a store's source, a line of stdin) in
// JSON output. JSON text is UTF-8 and a POSIX path is any bytes, so when
// `bytes` is not valid UTF-8 j[key] holds it with each invalid byte replaced
// by U+FFFD (readable) and j[key + "_hex"] holds all of its bytes in hex
// (exact: the value to reuse). Valid UTF-8 is stored as is, with no "_hex".
// A template over the JSON type so util/ needs no JSON library; query/ (a
// store's info) and tools/ (every command's --json) both write through it.
template <class Json>
void SetJsonBytes(Json& j, const std::string& key, std::string_view bytes) {
  if (IsValidUtf8(bytes)) {
    j[key] = std::string(bytes);
  } else {
    j[key] = ToValidUtf8(bytes);
    j[key + "_hex"] = HexBytes(bytes);
  }
}

}  // namespace simplexdb
