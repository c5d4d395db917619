// Any bytes in a path or on stdin, and too little memory, end the CLI with a
// clear error or carry through: never "internal error" (exit 70).
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "storage/dense/dense_format.h"

#include "tests/storage/address_space_limit.h"
#include "tests/tools/cli_test_util.h"
#include "util/utf8.h"

namespace simplexdb {
namespace {

using testing::kAddressSpaceLimited;

std::string Quote(const std::string& s) { return "'" + s + "'"; }  // no ' in our paths

std::string FromHex(const std::string& hex) {
  std::string out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out += static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16));
  }
  return out;
}

// A small NRRD volume at `in`, imported into the dense store `store`.
void GenerateAndImport(const std::string& in, const std::string& store) {
  auto r = RunCli("generate --field perlin --dims 17,13,9 --type int16 --seed 3 -o " + Quote(in));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("import " + Quote(in) + " -o " + store + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

TEST(BytesCli, PathThatIsNotUtf8IsCarriedThroughInfoJsonAndConvert) {
  const TempDir dir;
  const std::string in = dir.path() + "/bad\xff" "name.nrrd";
  const std::string store = dir.path() + "/s.sdb";
  const std::string sparse = dir.path() + "/sp\xfe.lmdb";
  ASSERT_NO_FATAL_FAILURE(GenerateAndImport(in, store));

  // JSON: readable with U+FFFD, exact in "source_hex".
  nlohmann::json info = RunJson("info " + store + " --json");
  EXPECT_EQ(info["source"], "NRRD file " + dir.path() + "/bad\xEF\xBF\xBDname.nrrd");
  ASSERT_TRUE(info.contains("source_hex")) << info.dump();
  EXPECT_EQ(FromHex(info["source_hex"]), "NRRD file " + in);
  EXPECT_FALSE(info.contains("store_hex"));  // a UTF-8 path gets no hex

  // Text: the bytes as they are.
  auto r = RunCli("info " + store);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("NRRD file " + in), std::string::npos) << r.out;

  nlohmann::json report =
      RunJson("convert " + store + " --to sparse -o " + Quote(sparse) + " --json --quiet");
  ASSERT_TRUE(report.contains("store_hex")) << report.dump();
  EXPECT_EQ(FromHex(report["store_hex"]), sparse);

  // The sparse header is JSON: invalid bytes are stored as U+FFFD.
  nlohmann::json sparse_info = RunJson("info " + Quote(sparse) + " --json");
  EXPECT_EQ(FromHex(sparse_info["store_hex"]), sparse);
  EXPECT_NE(sparse_info["source"].get<std::string>().find("bad\xEF\xBF\xBDname.nrrd"),
            std::string::npos)
      << sparse_info.dump();
  EXPECT_EQ(RunCli("verify " + Quote(sparse)).exit_code, 0);
}

TEST(BytesCli, SourceLongerThanTheHeaderFieldIsCutBetweenCharacters) {
  const TempDir dir;
  // The dense header holds kDenseMaxSource (1024) bytes of "NRRD file <path>":
  // put a two-byte character across byte 1024, in a path of components of
  // é (a name has at most 255 bytes).
  constexpr size_t kMax = kDenseMaxSource;
  std::string e100;
  for (int i = 0; i < 100; ++i) e100 += "\xC3\xA9";  // é
  std::string sub, in, full;
  for (const std::string pad : {"", "x"}) {
    sub = dir.path() + "/" + pad + e100 + "/" + e100 + "/" + e100 + "/" + e100;
    in = sub + "/" + e100 + ".nrrd";
    full = "NRRD file " + in;
    if (Utf8SequenceLength(std::string_view(full).substr(kMax - 1)) == 2) break;  // cut inside
  }
  ASSERT_EQ(Utf8SequenceLength(std::string_view(full).substr(kMax - 1)), 2u)
      << "temporary directory too deep for this test";
  std::filesystem::create_directories(sub);
  const std::string store = dir.path() + "/s.sdb";
  ASSERT_NO_FATAL_FAILURE(GenerateAndImport(in, store));

  nlohmann::json info = RunJson("info " + store + " --json");
  EXPECT_EQ(info["source"], full.substr(0, kMax - 1));  // the whole characters that fit
  EXPECT_FALSE(info.contains("source_hex"));
  auto r = RunCli("info " + store);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(full.substr(0, kMax - 1)), std::string::npos);
  r = RunCli("convert " + store + " --to sparse -o " + dir.path() + "/s.lmdb --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("info " + dir.path() + "/s.lmdb --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Made through the per-node engine's store, which keeps 255 bytes of
  // source: the start of the dense store's, valid UTF-8 (JSON parsed it).
  const std::string sparse_source = nlohmann::json::parse(r.out)["source"];
  EXPECT_NE(sparse_source.find(full.substr(0, 100)), std::string::npos) << sparse_source;
}

TEST(BytesCli, CodesReportsBinaryLinesByNumberAndKeepsJsonValid) {
  std::string input;
  input += "0:1\xff\n";                    // line 1: invalid UTF-8
  input += std::string("0:\0" "1\n", 5);   // line 2: a NUL
  input += "0:1\r\n";                      // line 3: CRLF, a good code
  input += std::string(100000, 'A') + "\n";  // line 4: far too long
  input += "\xfe\xff\x80\n";               // line 5: no code at all
  input += "0:0\n";                        // line 6: a good code
  const auto r = RunCli("codes --hierarchy ht", input);
  EXPECT_EQ(r.exit_code, 1) << r.err;
  std::vector<nlohmann::json> lines;
  std::istringstream out(r.out);
  std::string line;
  while (std::getline(out, line)) {
    ASSERT_TRUE(IsValidUtf8(line)) << line;
    lines.push_back(nlohmann::json::parse(line));
  }
  ASSERT_EQ(lines.size(), 6u) << r.out;
  EXPECT_TRUE(lines[0].contains("error"));
  EXPECT_EQ(FromHex(lines[0]["code_hex"]), "0:1\xff");
  EXPECT_TRUE(lines[1].contains("error"));
  EXPECT_EQ(lines[1]["code"], std::string("0:\0" "1", 4));
  EXPECT_EQ(lines[2]["code"], "0:1");
  EXPECT_FALSE(lines[2].contains("error"));
  EXPECT_NE(lines[3]["error"].get<std::string>().find("100000 bytes"), std::string::npos);
  EXPECT_LE(lines[3]["code"].get<std::string>().size(), 256u);
  EXPECT_EQ(FromHex(lines[4]["code_hex"]), "\xfe\xff\x80");
  EXPECT_EQ(lines[5]["code"], "0:0");
  for (const char* number : {"line 1:", "line 2:", "line 4:", "line 5:"}) {
    EXPECT_NE(r.err.find(number), std::string::npos) << number << " in " << r.err;
  }
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
}

// Runs the CLI with its address space limited to `limit_bytes`; stdout is
// dropped, stderr returned in `err`.
int RunCliWithAddressLimit(const std::vector<std::string>& args, uint64_t limit_bytes,
                           const std::string& err_path, std::string* err) {
  const pid_t pid = fork();
  if (pid == 0) {
    const rlimit limit{limit_bytes, limit_bytes};
    setrlimit(RLIMIT_AS, &limit);
    const int null = open("/dev/null", O_WRONLY);
    const int e = open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (null < 0 || e < 0) _exit(127);
    dup2(null, 1);
    dup2(e, 2);
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(SIMPLEXDB_CLI));
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(SIMPLEXDB_CLI, argv.data());
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  *err = ReadWholeFile(err_path);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// Runs `args` under address-space limits from 16 MiB up by `step_mib` until
// a run fits (exit 0), at most `max_mib`. Every run below that must fail
// cleanly: exit 1 and `check(stderr)`, which EXPECTs what it must say and
// returns whether it named what did not fit. Expects a run to fit and one
// to have named it.
void ExpectCleanFailuresUntilItFits(const std::vector<std::string>& args, uint64_t max_mib,
                                    uint64_t step_mib, const std::string& err_path,
                                    const std::function<bool(const std::string&)>& check) {
  bool named = false, succeeded = false;
  for (uint64_t mib = 16; mib <= max_mib && !succeeded; mib += step_mib) {
    SCOPED_TRACE("address space limit " + std::to_string(mib) + " MiB");
    std::string err;
    const int code = RunCliWithAddressLimit(args, mib << 20, err_path, &err);
    if (code == 0) {
      succeeded = true;
      continue;
    }
    ASSERT_EQ(code, 1) << err;
    named = check(err) || named;
  }
  EXPECT_TRUE(succeeded);
  EXPECT_TRUE(named);
}

constexpr const char* kSanitized =
    "sanitizers reserve terabytes of address space: RLIMIT_AS cannot apply";

TEST(BytesCli, InMemoryUnderAnAddressSpaceLimitSaysWhatDidNotFit) {
  if (!kAddressSpaceLimited) GTEST_SKIP() << kSanitized;
  const TempDir dir;
  const std::string in = dir.path() + "/m.nrrd", store = dir.path() + "/m.sdb";
  auto r = RunCli("generate --field perlin --dims 161,161,161 --type float32 --seed 3 -o " + in);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli("import " + in + " -o " + store + " --quiet");  // ~18 MB of decoded blocks and bricks
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Raise the limit until the extract fits. Below that every run must fail
  // cleanly, and some limit falls between mapping the store and holding
  // its decoded blocks.
  ExpectCleanFailuresUntilItFits(
      {"extract", store, "--in-memory", "--error", "5%", "--format", "json"}, 1024, 4,
      dir.path() + "/err.txt", [&](const std::string& err) {
        EXPECT_EQ(err.find("internal error"), std::string::npos) << err;
        // Near an edge any small allocation may fail: main's last resort
        // says "not enough memory" without naming it.
        EXPECT_TRUE(err.find("not enough memory") != std::string::npos ||
                    err.find("cannot map: Cannot allocate memory") != std::string::npos)
            << err;
        return err.find("not enough memory for all ") != std::string::npos &&
               err.find(store + " decoded in memory") != std::string::npos;
      });
}

TEST(BytesCli, To4dUnderAnAddressSpaceLimitSaysWhatDidNotFit) {
  if (!kAddressSpaceLimited) GTEST_SKIP() << kSanitized;
  const TempDir dir;
  const std::string in = dir.path() + "/m.nrrd";
  auto r = RunCli("generate --field perlin --dims 129,129,129 --type float32 --seed 3 -o " + in);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ExpectCleanFailuresUntilItFits({"to4d", in, "-o", dir.path() + "/out.nrrd"}, 1024, 2,
                                 dir.path() + "/err.txt", [](const std::string& err) {
                                   // Near the edge any small allocation may fail: main's
                                   // last resort.
                                   EXPECT_NE(err.find("not enough memory"), std::string::npos)
                                       << err;
                                   return err.find(" as float64 values (") != std::string::npos;
                                 });
}

// generate's worker threads: an exception there used to abort (exit 134).
TEST(BytesCli, GenerateUnderAnAddressSpaceLimitSaysWhatDidNotFit) {
  if (!kAddressSpaceLimited) GTEST_SKIP() << kSanitized;
  const TempDir dir;
  ExpectCleanFailuresUntilItFits(
      {"generate", "--field", "perlin", "--dims", "129,129,129", "--type", "float32",
       "--threads", "2", "-o", dir.path() + "/g.nrrd"},
      2048, 4, dir.path() + "/err.txt", [](const std::string& err) {
        EXPECT_NE(err.find("not enough memory"), std::string::npos) << err;
        return err.find("not enough memory for a generated chunk") != std::string::npos;
      });
}

}  // namespace
}  // namespace simplexdb
