// Runs the `simplexdb` binary under test as a child process.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace simplexdb::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs `SIMPLEXDB_CLI args` with `input` on stdin (sh -c quoting is the
// caller's business).
inline CommandResult RunCli(const std::string& args, const std::string& input = "") {
  // A fresh directory per run: ctest runs tests in parallel processes.
  std::string dir_template = ::testing::TempDir() + "/simplexdb_cli_XXXXXX";
  const char* made = mkdtemp(dir_template.data());
  if (made == nullptr) ADD_FAILURE() << "mkdtemp failed in " << ::testing::TempDir();
  const std::string dir = made ? made : ::testing::TempDir();
  const std::string in_path = dir + "/cli_in.txt";
  const std::string out_path = dir + "/cli_out.txt";
  const std::string err_path = dir + "/cli_err.txt";
  std::ofstream(in_path, std::ios::binary) << input;
  const std::string cmd = std::string(SIMPLEXDB_CLI) + " " + args + " <" + in_path + " >" +
                          out_path + " 2>" + err_path;
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = ReadWholeFile(out_path);
  r.err = ReadWholeFile(err_path);
  std::remove(in_path.c_str());
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  if (made != nullptr) rmdir(made);
  return r;
}

}  // namespace simplexdb::testing
