// How much memory this process holds, for the reports of import, convert
// and extract (`peak_memory_bytes`, `anonymous_memory_bytes`), and byte
// counts as people read them.
//
// Thread safety: reentrant (they read the kernel's figures). Errors: none;
// a figure the system does not give is 0.
#pragma once

#include <cstdint>
#include <string>

namespace simplexdb {

// Peak resident memory of this process, in bytes (getrusage). Counts the
// pages of memory-mapped files the process touched, which the kernel may
// drop at any time.
uint64_t PeakResidentBytes();

// Anonymous memory resident now (RssAnon of /proc/self/status): what the
// process allocated, without file pages; 0 where /proc is not readable.
uint64_t AnonymousResidentBytes();

// "1.5 GiB", "312 KiB", "17 B".
std::string HumanBytes(uint64_t bytes);

}  // namespace simplexdb
