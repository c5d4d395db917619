// libFuzzer target for the NRRD reader (storage/volume/nrrd_reader.cc): the
// header text, its fields, the data file forms (one name, LIST, a format
// with a range), encodings (raw, gzip, text) and line and byte skips. Each
// input is written as in.nrrd and opened; an accepted volume is read
// through. The reader must answer or fail cleanly: no crash, no read out of
// bounds, no allocation that the file does not back.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target nrrd_header_fuzz
//                  build/fuzz/tests/nrrd_header_fuzz -max_len=4096 -timeout=10
//                    -rss_limit_mb=2048 NEW_FOLDER tests/fuzz/corpus/nrrd_header
//   Replay (ctest): nrrd_header_fuzz_replay runs every saved input.
#include <cstddef>
#include <cstdint>

#include "storage/volume/volume.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return simplexdb::fuzz::FuzzVolumeReader("in.nrrd", &simplexdb::OpenNrrd, data, size);
}
