// kill -9 at random moments (fixed seeds): `convert --to dense`, `import
// --sparse`, `export` and `generate` are killed part-way, several times.
// After each kill the output folder holds nothing but the output's own
// temporaries, all of the one pattern `<output>.tmp.<pid>[.suffix|-suffix]`
// (storage/io/file.h); then one complete run of the same command removes
// them and succeeds, leaving only its output.
//
// Moments: a few uniform in (5%, 90%) of a complete run's time, measured
// first; and one just after the first temporary appears, so that at least
// one kill lands while something is being written.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/storage/store_test_util.h"
#include "tests/tools/cli_runner.h"

namespace simplexdb {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::RunCli;
using testing::SortedNames;
using testing::TempDir;

// Starts SIMPLEXDB_CLI with `args` (no shell), its output thrown away.
pid_t Start(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  std::string cli = SIMPLEXDB_CLI;
  argv.push_back(cli.data());
  std::vector<std::string> copy = args;
  for (std::string& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    const int null = open("/dev/null", O_RDWR);
    dup2(null, 0);
    dup2(null, 1);
    dup2(null, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// Waits for `pid` (reaping it, so its id is no longer a live process):
// the exit code, or -1 when a signal ended it.
int Wait(pid_t pid) {
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// True when `pid` has ended (and reaps it, storing its code in *code).
bool Ended(pid_t pid, int* code) {
  int status = 0;
  if (waitpid(pid, &status, WNOHANG) != pid) return false;
  *code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return true;
}

// True when `name` is `output`.tmp.<digits>, maybe followed by a suffix
// that begins with '.' or '-' (the pattern storage/io/file.h documents,
// spelled out here rather than taken from the code under test).
bool LooksLikeTemporaryOf(const std::string& name, const std::string& output) {
  const std::string prefix = output + ".tmp.";
  if (name.compare(0, prefix.size(), prefix) != 0) return false;
  size_t i = prefix.size();
  const size_t digits_begin = i;
  while (i < name.size() && name[i] >= '0' && name[i] <= '9') ++i;
  if (i == digits_begin) return false;
  return i == name.size() || name[i] == '.' || name[i] == '-';
}

// One command writing `outputs` (file names) into a folder.
struct Case {
  std::vector<std::string> outputs;
  std::function<std::vector<std::string>(const std::string& folder)> args;
};

// The names in `folder` that are neither `outputs` (which appear only by
// an atomic rename, complete: a kill may land just after one) nor their
// temporaries.
std::vector<std::string> Strangers(const std::string& folder,
                                   const std::vector<std::string>& outputs) {
  std::vector<std::string> strangers;
  for (const std::string& name : SortedNames(folder)) {
    if (std::find(outputs.begin(), outputs.end(), name) != outputs.end()) continue;
    const bool temporary = std::any_of(outputs.begin(), outputs.end(), [&](const std::string& o) {
      return LooksLikeTemporaryOf(name, o);
    });
    if (!temporary) strangers.push_back(name);
  }
  return strangers;
}

class KillNine : public ::testing::Test {
 protected:
  // A generated volume `name` of side `side` in the test's folder.
  std::string Volume(const std::string& name, int side) {
    const std::string path = dir_.path() + "/" + name;
    const std::string dims = std::to_string(side) + "," + std::to_string(side) + "," +
                             std::to_string(side);
    EXPECT_EQ(RunCli("generate --field perlin --dims " + dims + " --type uint16 -q -o " + path)
                  .exit_code,
              0);
    return path;
  }
  // Imports `volume` as the store `name` (a dense one, or with `flags`).
  std::string Store(const std::string& volume, const std::string& name,
                    const std::string& flags = "") {
    const std::string path = dir_.path() + "/" + name;
    EXPECT_EQ(RunCli("import " + volume + " " + flags + " -q -o " + path).exit_code, 0);
    return path;
  }

  void KillAndRerun(const Case& c, uint32_t seed) {
    // A complete run, timed.
    const std::string ref = dir_.path() + "/ref";
    fs::create_directory(ref);
    const Clock::time_point t0 = Clock::now();
    ASSERT_EQ(Wait(Start(c.args(ref))), 0) << "a complete run fails";
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    ASSERT_EQ(SortedNames(ref), c.outputs);
    fs::remove_all(ref);

    const std::string out = dir_.path() + "/out";
    fs::create_directory(out);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> moment(0.05, 0.9);
    for (int trial = 0; trial < 4; ++trial) {
      // The last trial kills just after a temporary of its own appears,
      // again until one is left (a short write may end first).
      for (int attempt = 0; attempt < (trial < 3 ? 1 : 20); ++attempt) {
        const std::vector<std::string> before = SortedNames(out);
        const pid_t pid = Start(c.args(out));
        int code = 0;
        bool ended = false;
        const auto fresh = [&] {  // a name this run made
          for (const std::string& n : SortedNames(out)) {
            if (!std::binary_search(before.begin(), before.end(), n)) return true;
          }
          return false;
        };
        if (trial < 3) {
          const double at = moment(rng) * seconds;
          const Clock::time_point deadline =
              Clock::now() + std::chrono::microseconds(static_cast<int64_t>(at * 1e6));
          while (!(ended = Ended(pid, &code)) && Clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }
        } else {
          while (!(ended = Ended(pid, &code)) && !fresh()) {
            std::this_thread::sleep_for(std::chrono::microseconds(200));
          }
          std::uniform_int_distribution<int64_t> extra_us(0, static_cast<int64_t>(seconds * 2e4));
          if (!ended) std::this_thread::sleep_for(std::chrono::microseconds(extra_us(rng)));
        }
        if (!ended) {
          kill(pid, SIGKILL);
          code = Wait(pid);
        }
        EXPECT_EQ(Strangers(out, c.outputs), std::vector<std::string>{})
            << "after kill " << trial << ", exit code " << code;
        // A run that finished (or was killed just after a rename) leaves
        // complete outputs: start afresh without them.
        for (const std::string& o : c.outputs) fs::remove(out + "/" + o);
        if (code != 0 && fresh()) break;
      }
    }
    const std::vector<std::string> left = SortedNames(out);
    EXPECT_FALSE(left.empty()) << "no kill left a temporary: the test proved nothing";

    // The next complete run removes them and succeeds.
    const testing::CommandResult done = [&] {
      std::string line;
      for (const std::string& a : c.args(out)) line += " '" + a + "'";
      return RunCli(line);
    }();
    EXPECT_EQ(done.exit_code, 0) << done.err;
    EXPECT_EQ(SortedNames(out), c.outputs) << "left before: " << ::testing::PrintToString(left);
  }

  TempDir dir_;
};

TEST_F(KillNine, Generate) {
  KillAndRerun({{"g.nrrd"},
                [](const std::string& folder) {
                  return std::vector<std::string>{"generate", "--field", "perlin", "--dims",
                                                  "161,161,161", "--type", "float32", "-q",
                                                  "-o", folder + "/g.nrrd"};
                }},
               101);
}

TEST_F(KillNine, Export) {
  const std::string store = Store(Volume("v.nrrd", 97), "v.sdb");
  KillAndRerun({{"e.nhdr", "e.raw"},
                [&](const std::string& folder) {
                  return std::vector<std::string>{"export", store, "-o", folder + "/e.raw"};
                }},
               202);
}

TEST_F(KillNine, ImportSparse) {
  const std::string volume = Volume("v.nrrd", 65);
  KillAndRerun({{"s.lmdb"},
                [&](const std::string& folder) {
                  return std::vector<std::string>{"import", volume, "--sparse", "-q", "-o",
                                                  folder + "/s.lmdb"};
                }},
               303);
}

TEST_F(KillNine, ConvertToDense) {
  const std::string store = Store(Volume("v.nrrd", 49), "v.lmdb", "--sparse");
  KillAndRerun({{"d.sdb"},
                [&](const std::string& folder) {
                  return std::vector<std::string>{"convert", store, "--to", "dense", "-q", "-o",
                                                  folder + "/d.sdb"};
                }},
               404);
}

}  // namespace
}  // namespace simplexdb
