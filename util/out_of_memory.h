// The Status for an allocation that failed. The sites that allocate in
// proportion to the input (a store held in memory, decoded blocks, meshes,
// volume buffers) catch std::bad_alloc and return this, so a user reads
// what did not fit and how large it was, not "std::bad_alloc".
//
// Thread safety: pure functions.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "util/status.h"

namespace simplexdb {

// "1234567890 bytes, 1177.4 MiB"
inline std::string DescribeByteCount(uint64_t bytes) {
  char mib[32];
  std::snprintf(mib, sizeof mib, "%.1f", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return std::to_string(bytes) + " bytes, " + mib + " MiB";
}

// ResourceExhausted "not enough memory for <what> (<size>)", `size` in words
// ("12 million simplices") when the byte count is not known.
inline Status NotEnoughMemory(std::string_view what, std::string_view size) {
  return Status::ResourceExhausted("not enough memory for " + std::string(what) + " (" +
                                   std::string(size) + ")");
}

// ResourceExhausted "not enough memory for <what> (<bytes> bytes, <MiB> MiB)".
inline Status NotEnoughMemory(std::string_view what, uint64_t bytes) {
  return NotEnoughMemory(what, DescribeByteCount(bytes));
}

}  // namespace simplexdb
