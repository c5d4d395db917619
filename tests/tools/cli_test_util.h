// What the end-to-end tests of the `simplexdb` command share: running it
// (cli_runner.h), temporary folders and volumes (store_test_util.h), the
// JSON a command prints, and the inputs of every command that writes a file.
//
// The tests in tests/tools are written in namespace simplexdb; the names
// they all use are brought into it here, once.
#pragma once

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {

namespace testing {

// What `r` printed on stdout, parsed as JSON (throws when it is none).
inline nlohmann::json Json(const CommandResult& r) { return nlohmann::json::parse(r.out); }

// Runs `args`, which must succeed, and returns what it printed on stdout as
// JSON. A failure (exit code other than 0, or stdout that is not JSON) is a
// test failure naming `args` and stderr, and returns an empty object, so
// that the checks that follow fail rather than throw. Keep the result in a
// non-const json: operator[] of a missing key is null there, undefined on a
// const one.
inline nlohmann::json RunJson(const std::string& args) {
  const CommandResult r = RunCli(args);
  EXPECT_EQ(r.exit_code, 0) << args << ": " << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out, nullptr, /*allow_exceptions=*/false);
  if (r.exit_code == 0 && !j.is_discarded()) return j;
  ADD_FAILURE() << args << ": no JSON on stdout: " << r.out;
  return nlohmann::json::object();
}

// Writes into the folder `d` the inputs of every command that writes a
// file: v.nrrd, a 3D uint8 Perlin field with `dims` ("X,Y,Z"); v4.nrrd, a
// 4D one of 9^4 points; and the stores built from them: v.sdb and v4.sdb
// (dense), v.lmdb (sparse). A command that fails is a fatal failure: call
// it under ASSERT_NO_FATAL_FAILURE.
inline void MakeEveryCommandsInputs(const std::string& d, const std::string& dims) {
  struct Input {
    std::string name, dims;
  };
  for (const Input& in : {Input{"v", dims}, Input{"v4", "9,9,9,9"}}) {
    const std::string volume = d + "/" + in.name + ".nrrd";
    const CommandResult r =
        RunCli("generate --field perlin --dims " + in.dims + " --type uint8 -q -o " + volume);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(RunCli("import " + volume + " -q -o " + d + "/" + in.name + ".sdb").exit_code, 0);
  }
  ASSERT_EQ(RunCli("import " + d + "/v.nrrd --sparse -q -o " + d + "/v.lmdb").exit_code, 0);
}

}  // namespace testing

using testing::Json;
using testing::ReadVolumeValues;
using testing::ReadWholeFile;
using testing::RunCli;
using testing::RunJson;
using testing::TempDir;
namespace fs = std::filesystem;

}  // namespace simplexdb
