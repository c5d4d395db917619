// Inputs the readers cannot read at positions: a FIFO given as a volume or a
// store is refused at once by its kind (exit 1), never waited on. Each run
// is under `timeout`, so a command that waits for a FIFO's writer fails the
// test (exit 124) instead of hanging it.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <string>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

using testing::TempDir;

struct Outcome {
  int exit_code;
  std::string err;
};

Outcome RunWithin20s(const std::string& dir, const std::string& args) {
  const std::string err = dir + "/err.txt";
  const int status = std::system(
      ("timeout 20 " + std::string(SIMPLEXDB_CLI) + " " + args + " </dev/null >/dev/null 2>" + err)
          .c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, testing::ReadWholeFile(err)};
}

TEST(InputRefusal, AFifoIsRefusedAsAVolumeOrAStoreWithoutWaiting) {
  TempDir dir;
  const std::string fifo = dir.path() + "/in.nrrd";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const std::string refused = fifo + ": cannot read: is a FIFO (expected a regular file)";
  for (const std::string& args :
       {"import " + fifo + " -q -o " + dir.path() + "/a.sdb",
        "import " + fifo + " --dims 2,2,2 --type uint8 -q -o " + dir.path() + "/b.sdb",
        "import " + fifo + " --sparse -q -o " + dir.path() + "/c.lmdb", "info " + fifo,
        "verify " + fifo, "extract " + fifo + " --error 0.5 -o " + dir.path() + "/m.vtu"}) {
    SCOPED_TRACE(args);
    const Outcome r = RunWithin20s(dir.path(), args);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(refused), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace simplexdb
