// The subcommands of the `simplexdb` tool. Each Register* function adds one
// subcommand (its options, --help text and callback) to the application.
//
// Conventions: results go to stdout, diagnostics to stderr; exit status 0 on
// success and non-zero with a one-line reason otherwise (tools/main.cc turns
// a thrown CommandError into that).
#pragma once

#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

namespace simplexdb::tools {

// A failure the user caused or can fix: printed as "simplexdb: <what>" and
// turned into `exit_code`.
class CommandError : public std::runtime_error {
 public:
  explicit CommandError(const std::string& what, int exit_code = 1)
      : std::runtime_error(what), exit_code_(exit_code) {}
  int exit_code() const { return exit_code_; }

 private:
  int exit_code_;
};

// The operations behind them are ops/'s, one function each, which the
// Python package calls too: a command parses its options into the
// operation's request, calls it, and prints the report.
void RegisterCodesCommand(CLI::App& app);
void RegisterInspectCommand(CLI::App& app);
void RegisterImportCommand(CLI::App& app);
void RegisterInfoCommands(CLI::App& app);    // info, verify
void RegisterExportCommand(CLI::App& app);
void RegisterGenerateCommand(CLI::App& app);
void RegisterTo4dCommand(CLI::App& app);     // generate_command.cc
void RegisterConvertCommand(CLI::App& app);  // convert_command.cc
void RegisterUpdateCommand(CLI::App& app);   // convert_command.cc
void RegisterExtractCommand(CLI::App& app);  // extract, conformity
void RegisterIsosurfaceCommand(CLI::App& app);

}  // namespace simplexdb::tools
