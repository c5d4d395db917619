// Whether a test runs at its long size. A test whose full sweep is a stress
// or scale run checks one representative case in the default suite and the
// whole sweep when SIMPLEXDB_LONG is set; the ctest entries labelled `long`
// set it (simplexdb_long_test in tests/CMakeLists.txt) and run the same
// test, so `ctest -L long` is where the sweep lives. Thread safety: reads
// the environment only.
#pragma once

#include <cstdlib>

namespace simplexdb::testing {

inline bool LongRun() { return std::getenv("SIMPLEXDB_LONG") != nullptr; }

}  // namespace simplexdb::testing
