// Helpers for the stored reference files of the stores (tests/storage/
// dense/golden, tests/storage/sparse/golden): the seeded volume each was
// built from, and a fresh build of it that can replace the reference when
// SIMPLEXDB_REGENERATE_GOLDEN is set (a layout changed on purpose).
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>

#include "storage/volume/volume.h"
#include "tests/storage/store_test_util.h"
#include "util/status.h"

namespace simplexdb::testing {

// The volume a reference store is built from: TestVolume::Random's values.
struct GoldenVolume {
  int dimension;
  std::array<uint32_t, 4> dims;
  VoxelType type;
  uint64_t seed;

  TestVolume Make() const { return TestVolume::Random(dimension, dims, type, seed); }
};

// Writes `volume` as dir/in.nrrd and builds `fresh` from it with
// build(input, fresh); with SIMPLEXDB_REGENERATE_GOLDEN set, copies `fresh`
// over `reference`. Expects the build to succeed and `reference` to exist;
// false after a failed expectation.
inline bool BuildFreshGolden(const GoldenVolume& volume, const std::string& dir, const std::string& fresh,
                             const std::string& reference,
                             const std::function<Status(const VolumeInfo&, const std::string&)>& build) {
  const auto built = [&]() -> Status {
    SDB_RETURN_IF_ERROR(volume.Make().WriteNrrd(dir + "/in.nrrd"));
    SDB_ASSIGN_OR_RETURN(const VolumeInfo input, OpenVolume(dir + "/in.nrrd"));
    return build(input, fresh);
  }();
  EXPECT_TRUE(built.ok()) << built.ToString();
  if (!built.ok()) return false;
  if (std::getenv("SIMPLEXDB_REGENERATE_GOLDEN") != nullptr) {
    std::filesystem::copy_file(fresh, reference, std::filesystem::copy_options::overwrite_existing);
  }
  EXPECT_TRUE(std::filesystem::exists(reference)) << "missing reference file " << reference;
  return std::filesystem::exists(reference);
}

}  // namespace simplexdb::testing
