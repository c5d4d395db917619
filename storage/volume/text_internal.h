// Text helpers of the volume readers (internal to storage/volume): trimming,
// case folding, splitting and strict number parsing of header text, and
// rewording a Status. Not installed as part of the API; no caller outside
// storage/volume should include it.
//
// Thread safety: pure functions. Lifetimes: the string_views returned point
// into the argument and live as long as it does.
#pragma once

#include <charconv>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "util/status.h"

namespace simplexdb::volume_internal {

// `s` without leading blanks (space, tab) and trailing blanks or '\r'.
std::string_view Trim(std::string_view s);

// `s` with ASCII A-Z folded to a-z (header fields and file extensions).
std::string Lower(std::string_view s);

// The non-empty runs of `s` between spaces and tabs.
std::vector<std::string_view> SplitWhitespace(std::string_view s);

// The integer spelled by all of `s` (no sign for unsigned types, no blanks),
// or nullopt if `s` is not exactly one in range.
template <class Int>
std::optional<Int> ParseInt(std::string_view s) {
  Int v{};
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

// The double spelled by all of `s` (a leading '+' allowed), or nullopt.
std::optional<double> ParseDouble(std::string_view s);

// The same failure (same code) with another message; OK stays OK.
Status WithMessage(const Status& s, const std::string& msg);

// The same failure with `prefix` ("file.nrrd: ") in front of its message.
Status Prefixed(const Status& s, const std::string& prefix);

}  // namespace simplexdb::volume_internal
