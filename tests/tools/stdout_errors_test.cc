// A command whose results cannot be written to stdout fails: with stdout
// on /dev/full every command that prints exits 1 with "simplexdb: cannot
// write to standard output: No space left on device" (tools/main.cc checks
// stdout once after the command). /dev/full is only ever written to here,
// as a child's stdout, never named as an output.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

using testing::ReadWholeFile;
using testing::RunCli;
using testing::TempDir;

class StdoutErrors : public ::testing::Test {
 protected:
  void SetUp() override {
    if (access("/dev/full", W_OK) != 0) GTEST_SKIP() << "no /dev/full here";
    const std::string d = dir_.path();
    ASSERT_EQ(RunCli("generate --field perlin --dims 17,17,17 --type uint8 -q -o " + d + "/v.nrrd")
                  .exit_code,
              0);
    ASSERT_EQ(RunCli("import " + d + "/v.nrrd -q -o " + d + "/v.sdb").exit_code, 0);
    ASSERT_EQ(RunCli("import " + d + "/v.nrrd --sparse -q -o " + d + "/v.lmdb").exit_code, 0);
    ASSERT_EQ(RunCli("extract " + d + "/v.sdb --error 5% --format codes -o " + d + "/m.codes")
                  .exit_code,
              0);
    std::ofstream(d + "/codes.txt") << "2:10011\n0:1\n";
  }

  // Runs `args` with stdin from codes.txt and stdout on /dev/full.
  testing::CommandResult RunToFullStdout(const std::string& args) {
    const std::string err = dir_.path() + "/err.txt";
    const std::string cmd = std::string(SIMPLEXDB_CLI) + " " + args + " <" + dir_.path() +
                            "/codes.txt >/dev/full 2>" + err;
    const int status = std::system(cmd.c_str());
    testing::CommandResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.err = ReadWholeFile(err);
    return r;
  }

  TempDir dir_;
};

TEST_F(StdoutErrors, EveryCommandThatPrintsFailsOnAFullStdout) {
  const std::string d = dir_.path();
  const std::string commands[] = {
      "info " + d + "/v.sdb",
      "info --json " + d + "/v.sdb",
      "info --json " + d + "/v.lmdb",
      "verify " + d + "/v.sdb",
      "verify " + d + "/v.lmdb",
      "extract " + d + "/v.sdb --error 5%",  // JSON to stdout
      "extract " + d + "/v.sdb --error 0 --format json -o -",
      "extract " + d + "/v.lmdb --error 5%",
      "codes --hierarchy ht",
      "inspect --hierarchy ht 2:10011",
      "conformity " + d + "/m.codes",
      "generate --field sphere --dims 9,9,9 -o " + d + "/g.nrrd",
      "import " + d + "/v.nrrd --json -o " + d + "/w.sdb",
      "import " + d + "/v.nrrd -o " + d + "/w.sdb",
      "convert " + d + "/v.sdb --to sparse --json -o " + d + "/w.lmdb",
      "export " + d + "/v.sdb -o " + d + "/e.nrrd",
      "--help",
      "import --help",
  };
  for (const std::string& c : commands) {
    SCOPED_TRACE(c);
    const testing::CommandResult r = RunToFullStdout(c);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find("simplexdb: cannot write to standard output: No space left on device"),
              std::string::npos)
        << r.err;
  }
  // The same commands to a working stdout succeed: the check is no blanket
  // failure.
  EXPECT_EQ(RunCli("info --json " + d + "/v.sdb").exit_code, 0);
  EXPECT_EQ(RunCli("codes --hierarchy ht", "2:10011\n").exit_code, 0);
  EXPECT_EQ(RunCli("extract " + d + "/v.sdb --error 5%").exit_code, 0);
}

// Many lines, so that stdio writes (and fails) during the command and not
// only in the final flush: the reason is still reported.
TEST_F(StdoutErrors, AWriteThatFailedDuringTheCommandIsReported) {
  std::string many;
  for (int i = 0; i < 2000; ++i) many += "2:10011\n";
  std::ofstream(dir_.path() + "/codes.txt") << many;
  const testing::CommandResult r = RunToFullStdout("codes --hierarchy ht");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_NE(r.err.find("cannot write to standard output: No space left on device"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace simplexdb
