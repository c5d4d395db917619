// libFuzzer target for the NIfTI-1 reader (storage/volume/nifti_reader.cc):
// the 348-byte header (either byte order), dims, datatype, vox_offset,
// scaling and units, then the voxels. Each input is written as in.nii and
// opened; an accepted volume is read through. The reader must answer or
// fail cleanly: no crash, no read out of bounds, no allocation that the
// file does not back.
//
//   Fuzz (clang):  cmake -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++
//                    -DSIMPLEXDB_FUZZ=ON -DSIMPLEXDB_BUILD_BENCH=OFF (one line)
//                  cmake --build build/fuzz --target nifti_header_fuzz
//                  build/fuzz/tests/nifti_header_fuzz -max_len=4096 -timeout=10
//                    -rss_limit_mb=2048 NEW_FOLDER tests/fuzz/corpus/nifti_header
//   Replay (ctest): nifti_header_fuzz_replay runs every saved input.
#include <cstddef>
#include <cstdint>

#include "storage/volume/volume.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return simplexdb::fuzz::FuzzVolumeReader("in.nii", &simplexdb::OpenNifti, data, size);
}
