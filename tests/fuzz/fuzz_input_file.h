// The volume readers take paths: the fuzz targets write each input to a file
// of their own, in a folder made once per process, and open it by name.
#ifndef SIMPLEXDB_TESTS_FUZZ_FUZZ_INPUT_FILE_H_
#define SIMPLEXDB_TESTS_FUZZ_FUZZ_INPUT_FILE_H_

#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "storage/volume/volume.h"

namespace simplexdb::fuzz {

// A folder for this process's inputs, under $TMPDIR (or /tmp), made on the
// first call and removed at exit.
inline const std::string& InputFolder() {
  static const std::string folder = [] {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") +
                          "/simplexdb-fuzz-XXXXXX";
    if (mkdtemp(pattern.data()) == nullptr) {
      std::perror("simplexdb fuzz: cannot make a folder for the inputs");
      std::abort();
    }
    static const std::string removed_at_exit = pattern;
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(removed_at_exit, ignored);
    });
    return pattern;
  }();
  return folder;
}

// Writes `size` bytes to InputFolder()/`name` (replacing it) and returns
// its path.
inline std::string WriteInput(const std::string& name, const uint8_t* data, size_t size) {
  const std::string path = InputFolder() + "/" + name;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size) || std::fclose(f) != 0) {
    std::perror(path.c_str());
    std::abort();
  }
  return path;
}

// Reads every voxel of `info` when it has at most `max_voxels` (the readers
// bound what a header may claim by the file, not by the fuzzer's memory
// limit), in pieces of varied size. A reader may fail; it must not crash.
inline void ReadAll(const VolumeInfo& info, uint64_t max_voxels = uint64_t{1} << 22) {
  if (info.voxel_count() > max_voxels) return;
  auto reader = VolumeReader::Open(info);
  if (!reader.ok()) return;
  std::vector<double> buffer(4099);
  uint64_t first = 0;
  size_t piece = 1;
  while (first < info.voxel_count()) {
    const size_t count =
        static_cast<size_t>(std::min<uint64_t>(piece, info.voxel_count() - first));
    if (!(*reader)->Read(first, count, buffer.data()).ok()) return;
    first += count;
    piece = piece * 3 % buffer.size() + 1;
  }
}

// The whole of a volume reader's target: writes the input as InputFolder()/
// `name`, opens it with `open`, and reads an accepted volume through.
inline int FuzzVolumeReader(const char* name, Result<VolumeInfo> (*open)(const std::string&), const uint8_t* data,
                            size_t size) {
  const std::string path = WriteInput(name, data, size);
  const Result<VolumeInfo> info = open(path);
  if (info.ok()) ReadAll(*info);
  return 0;
}

}  // namespace simplexdb::fuzz

#endif  // SIMPLEXDB_TESTS_FUZZ_FUZZ_INPUT_FILE_H_
