// Outputs that writing would destroy are refused before anything is
// written (tools/cli_util.h CheckOutput, storage/io/file.h ResolveOutput):
// an input of the command by any name, a device, a FIFO, a directory, a
// symlink (written through with --force when it points to a regular file,
// the link kept), a dangling symlink. Exit 1, the output named, no
// temporary left, the file that was there unchanged.
//
// No test here names a real device as an output: a broken check run as
// root would replace it. The character device is a node made in a
// temporary folder (as root; skipped otherwise).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "tests/tools/cli_test_util.h"

namespace simplexdb {
namespace {

using testing::SortedNames;

class OutputRefusal : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string d = dir_.path();
    ASSERT_NO_FATAL_FAILURE(testing::MakeEveryCommandsInputs(d, "9,9,9"));
    for (const char* name : {"t0", "t1"}) {  // a time series
      ASSERT_EQ(RunCli("generate --field perlin --dims 9,9,9 --type uint8 -q -o " + d + "/" +
                       name + ".nrrd")
                    .exit_code,
                0);
    }
  }

  // Runs `args` and expects exit 1 naming `output` with `words`, and the
  // folder's names and the bytes of `kept` as they were.
  void ExpectRefused(const std::string& args, const std::string& output, const std::string& words,
                     const std::string& kept) {
    SCOPED_TRACE(args);
    const std::vector<std::string> before = SortedNames(dir_.path());
    const std::string bytes = ReadWholeFile(kept);
    const testing::CommandResult r = RunCli(args);
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_NE(r.err.find(output + ": cannot write: " + words), std::string::npos) << r.err;
    EXPECT_EQ(SortedNames(dir_.path()), before);  // no temporary, nothing new
    EXPECT_EQ(ReadWholeFile(kept), bytes);
  }

  // Every command that writes a file, with OUT for its output.
  std::vector<std::string> Commands() const {
    const std::string d = dir_.path();
    return {
        "generate --field perlin --dims 9,9,9 --type uint8 -q -o OUT",
        "to4d " + d + "/v.nrrd -q -o OUT",
        "import " + d + "/v.nrrd -q -o OUT",
        "import " + d + "/v.nrrd --sparse -q -o OUT",
        "convert " + d + "/v.sdb --to sparse -q -o OUT",
        "convert " + d + "/v.lmdb --to dense -q -o OUT",
        "export " + d + "/v.sdb -o OUT",
        "extract " + d + "/v.sdb --error 5% --format vtu -o OUT",
        "extract " + d + "/v.sdb --error 5% --format codes -o OUT",
        "extract " + d + "/v.sdb --error 5% --format json -o OUT",
        "extract " + d + "/v4.sdb --error 5% --format pvd --slices 0,2 -o OUT",
    };
  }

  static std::string With(std::string text, const std::string& output) {
    text.replace(text.find("OUT"), 3, output);
    return text;
  }

  TempDir dir_;
};

TEST_F(OutputRefusal, TheInputItselfByAnyName) {
  const std::string d = dir_.path();
  const std::string v = d + "/v.nrrd";
  ASSERT_EQ(link(v.c_str(), (d + "/hard.nrrd").c_str()), 0);
  fs::create_symlink("v.nrrd", d + "/soft.nrrd");
  for (const std::string& out : {v, d + "/./v.nrrd", d + "/hard.nrrd"}) {
    ExpectRefused("import " + v + " -q -o " + out, out, "is the input", v);
  }
  // A symlink to the input is the input, with --force too.
  ExpectRefused("import " + v + " -q --force -o " + d + "/soft.nrrd", d + "/soft.nrrd",
                "is the input", v);
  ExpectRefused("import " + v + " --sparse -q -o " + v, v, "is the input", v);
  // Any file of a time series.
  ExpectRefused("import " + d + "/t0.nrrd " + d + "/t1.nrrd -q -o " + d + "/t1.nrrd",
                d + "/t1.nrrd", "is the input", d + "/t1.nrrd");
  ExpectRefused("convert " + d + "/v.sdb --to sparse -q -o " + d + "/v.sdb", d + "/v.sdb",
                "is the input", d + "/v.sdb");
  ExpectRefused("convert " + d + "/v.lmdb --to dense -q -o " + d + "/v.lmdb", d + "/v.lmdb",
                "is the input", d + "/v.lmdb");
  ExpectRefused("export " + d + "/v.sdb -o " + d + "/v.sdb", d + "/v.sdb", "is the input",
                d + "/v.sdb");
  ExpectRefused("extract " + d + "/v.sdb --error 5% --format json -o " + d + "/v.sdb",
                d + "/v.sdb", "is the input", d + "/v.sdb");
  ExpectRefused("to4d " + v + " -q -o " + v, v, "is the input", v);
  // The data file a detached header names is an input too.
  ASSERT_EQ(RunCli("export " + d + "/v.sdb -o " + d + "/e.raw").exit_code, 0);
  ExpectRefused("import " + d + "/e.nhdr -q -o " + d + "/e.raw", d + "/e.raw", "is the input",
                d + "/e.raw");
  ExpectRefused("to4d " + d + "/e.nhdr -q -o " + d + "/e.raw", d + "/e.raw", "is the input",
                d + "/e.raw");
  ExpectRefused("import " + v + " --mask " + d + "/e.nhdr -q -o " + d + "/e.raw", d + "/e.raw",
                "is the input", d + "/e.raw");
}

TEST_F(OutputRefusal, AFifoADirectoryAndADanglingSymlink) {
  const std::string d = dir_.path();
  const std::string fifo = d + "/fifo";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
  fs::create_directory(d + "/folder");
  fs::create_symlink("nowhere", d + "/dangling");
  for (const std::string& c : Commands()) {
    ExpectRefused(With(c, fifo), fifo, "is a FIFO", d + "/v.nrrd");
    EXPECT_TRUE(fs::is_fifo(fifo));
    ExpectRefused(With(c, d + "/folder"), d + "/folder", "is a directory", d + "/v.nrrd");
    ExpectRefused(With(c, d + "/dangling") + " --force", d + "/dangling", "is a dangling symlink",
                  d + "/v.nrrd");
    EXPECT_TRUE(fs::is_symlink(d + "/dangling"));
  }
}

TEST_F(OutputRefusal, ACharacterDevice) {
  const std::string null = dir_.path() + "/null";
  // A node of /dev/null's numbers in the test's own folder: replacing it
  // would harm nothing.
  if (mknod(null.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) {
    GTEST_SKIP() << "cannot make a device node here (not root)";
  }
  for (const std::string& c : Commands()) {
    ExpectRefused(With(c, null), null, "is a character device", dir_.path() + "/v.nrrd");
    EXPECT_TRUE(fs::is_character_file(null));
  }
}

TEST_F(OutputRefusal, ASymlinkUnlessForcedThenItsTargetIsReplacedAndTheLinkKept) {
  const std::string d = dir_.path();
  fs::create_directory(d + "/real");
  std::ofstream(d + "/real/target") << "old";
  fs::create_symlink("real/target", d + "/link");
  for (const std::string& c : Commands()) {
    ExpectRefused(With(c, d + "/link"), d + "/link", "is a symlink", d + "/real/target");
    EXPECT_TRUE(fs::is_symlink(d + "/link"));
  }
  const testing::CommandResult r = RunCli("import " + d + "/v.nrrd -q --force -o " + d + "/link");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::is_symlink(d + "/link"));
  EXPECT_EQ(fs::read_symlink(d + "/link"), "real/target");
  EXPECT_EQ(SortedNames(d + "/real"), std::vector<std::string>{"target"});
  EXPECT_EQ(RunCli("verify -q " + d + "/link").exit_code, 0);
  EXPECT_EQ(ReadWholeFile(d + "/real/target").substr(0, 8), "SIMPLXDB");  // a store now
  const testing::CommandResult s =
      RunCli("convert " + d + "/v.sdb --to sparse -q --force -o " + d + "/link");
  ASSERT_EQ(s.exit_code, 0) << s.err;
  EXPECT_TRUE(fs::is_symlink(d + "/link"));
  EXPECT_EQ(SortedNames(d + "/real"), std::vector<std::string>{"target"});
  EXPECT_EQ(RunCli("verify -q " + d + "/real/target").exit_code, 0);
}

TEST(OutputRefusalHelp, ForceIsExplained) {
  for (const char* command : {"import", "convert", "export", "extract", "generate", "to4d"}) {
    SCOPED_TRACE(command);
    const testing::CommandResult r = RunCli(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("--force"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("symlink"), std::string::npos) << r.out;
  }
}

// Issue 40: every command's --help shows it used, and extract's says what
// its bound guarantees.
TEST(CommandHelp, EveryCommandHasAnExample) {
  for (const char* command : {"import", "extract", "export", "convert", "update", "info", "verify", "codes",
                              "inspect", "generate", "to4d"}) {
    SCOPED_TRACE(command);
    const testing::CommandResult r = RunCli(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("Example"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(std::string("simplexdb ") + command), std::string::npos) << r.out;
  }
  const testing::CommandResult r = RunCli("extract --help");
  EXPECT_NE(r.out.find("differs from the linear interpolation of its vertices' values by at\nmost --error"),
            std::string::npos)
      << r.out;
}

}  // namespace
}  // namespace simplexdb
