// Every command that writes an output reports an output folder that cannot
// hold it by the output's name, in the errno table's words
// (storage/io/file.h), never by a temporary's or a scratch file's name:
// "<output>: cannot create: No such file or directory" for a missing
// folder, "...: Not a directory" when the folder is a regular file.
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "tests/tools/cli_test_util.h"

namespace simplexdb {
namespace {

class OutputErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_NO_FATAL_FAILURE(testing::MakeEveryCommandsInputs(dir_.path(), "17,17,17"));
    std::ofstream(dir_.path() + "/file") << "x";
  }

  // Each command (with OUT for its output's folder) fails naming the output.
  void ExpectEveryCommandFails(const std::string& folder, const std::string& words) {
    const std::string d = dir_.path();
    struct Command {
      std::string args, output;
    };
    const std::vector<Command> commands = {
        {"generate --field perlin --dims 9,9,9 --type uint8 -q -o OUT/g.nrrd", "OUT/g.nrrd"},
        {"import " + d + "/v.nrrd -q -o OUT/d.sdb", "OUT/d.sdb"},
        {"import " + d + "/v.nrrd --sparse -q -o OUT/s.lmdb", "OUT/s.lmdb"},
        {"convert " + d + "/v.sdb --to sparse -q -o OUT/s.lmdb", "OUT/s.lmdb"},
        {"convert " + d + "/v.lmdb --to dense -q -o OUT/d.sdb", "OUT/d.sdb"},
        {"export " + d + "/v.sdb -o OUT/e.nrrd", "OUT/e.nrrd"},
        {"export " + d + "/v.sdb -o OUT/e.raw", "OUT/e.raw"},
        {"extract " + d + "/v.sdb --error 5% --format vtu -o OUT/m.vtu", "OUT/m.vtu"},
        {"extract " + d + "/v.sdb --error 5% --format codes -o OUT/m.codes", "OUT/m.codes"},
        {"extract " + d + "/v.sdb --error 5% --format json -o OUT/m.json", "OUT/m.json"},
        {"extract " + d + "/v4.sdb --error 5% --format pvd --slices 0,2 -o OUT/m.pvd",
         "OUT/m.pvd"},
    };
    const auto with_folder = [&](std::string text) {
      for (size_t at; (at = text.find("OUT")) != std::string::npos;) text.replace(at, 3, folder);
      return text;
    };
    for (const Command& c : commands) {
      SCOPED_TRACE(c.args);
      const testing::CommandResult r = RunCli(with_folder(c.args));
      EXPECT_EQ(r.exit_code, 1) << r.err;
      EXPECT_NE(r.err.find(with_folder(c.output) + ": cannot create: " + words), std::string::npos)
          << r.err;
      EXPECT_EQ(r.err.find(".tmp."), std::string::npos) << r.err;
    }
  }

  TempDir dir_;
};

TEST_F(OutputErrors, AMissingFolderIsNamedByTheOutput) {
  ExpectEveryCommandFails(dir_.path() + "/no/such", "No such file or directory");
}

TEST_F(OutputErrors, AFolderThatIsAFileIsNamedByTheOutput) {
  ExpectEveryCommandFails(dir_.path() + "/file", "Not a directory");
}

}  // namespace
}  // namespace simplexdb
