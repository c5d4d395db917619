// BuildProgress: how long work in storage/ (a dense build, a conversion to
// the sparse store, a sparse update) reports how far it is. The work calls
// a caller's std::function<void(const BuildProgress&)> a few times a second
// from one thread (never concurrently), the last time with done == total;
// tools/ prints it on a terminal.
//
// Thread safety: a plain value. Lifetimes: `phase` points to a string
// literal, valid for the whole program. Errors: none.
#pragma once

#include <cstdint>

namespace simplexdb {

struct BuildProgress {
  const char* phase;  // "field" or "errors" (dense build), "nodes" (to sparse), "units" (update)
  uint64_t done;
  uint64_t total;
  double seconds;     // since the work started
};

}  // namespace simplexdb
