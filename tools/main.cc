// simplexdb: the command-line front end of SimplexDB.
#include <cerrno>
#include <cstdio>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include <CLI/CLI.hpp>

#include "parallel/mpi_session.h"

#include "storage/dense/dense_format.h"
#include "storage/sparse/sparse_format.h"
#include "tools/cli_util.h"
#include "tools/commands.h"

int main(int argc, char** argv) {
  CLI::App app{
      "SimplexDB: an out-of-core storage engine for multiresolution scalar\n"
      "fields on nested simplicial meshes (Hierarchy of Tetrahedra, HT, in 3D;\n"
      "Hierarchy of Pentatopes, HP, in 4D).\n\n"
      "Location codes are written T:bits: the root simplex T, then one bit per\n"
      "level (0 = child 0), e.g. 2:10011. Run `simplexdb <command> --help` for\n"
      "the options of a command.",
      "simplexdb"};
  app.require_subcommand(1);
  app.set_version_flag("--version",
                       std::string("simplexdb ") + SIMPLEXDB_VERSION + " (writes dense stores of header version " +
                           std::to_string(simplexdb::kDenseFormatVersion) + ", sparse stores of header version " +
                           std::to_string(simplexdb::kSparseFormatVersion) + ")",
                       "Print the version and the store formats this build writes, then exit");
  simplexdb::tools::RegisterCodesCommand(app);
  simplexdb::tools::RegisterInspectCommand(app);
  simplexdb::tools::RegisterGenerateCommand(app);
  simplexdb::tools::RegisterTo4dCommand(app);
  simplexdb::tools::RegisterImportCommand(app);
  simplexdb::tools::RegisterInfoCommands(app);
  simplexdb::tools::RegisterExportCommand(app);
  simplexdb::tools::RegisterConvertCommand(app);
  simplexdb::tools::RegisterUpdateCommand(app);
  simplexdb::tools::RegisterExtractCommand(app);
  simplexdb::tools::RegisterIsosurfaceCommand(app);
  // Under an MPI launcher (mpirun) only: a plain run never touches MPI.
  std::unique_ptr<simplexdb::MpiSession> mpi;
  if (simplexdb::MpiSession::Launched()) {
    auto started = simplexdb::MpiSession::Start(&argc, &argv);
    if (!started.ok()) {
      std::fprintf(stderr, "simplexdb: %s\n", std::string(started.status().message()).c_str());
      return 1;
    }
    mpi = *std::move(started);
    // Only import (one store, built by every rank), extract and isosurface
    // (in pieces) run on several ranks; the others would each do the whole.
    const std::string command = argc > 1 ? argv[1] : "";
    if (mpi->size() > 1 && command != "extract" && command != "import" && command != "isosurface" && command.rfind("-", 0) != 0) {
      if (mpi->rank() == 0) {
        std::fprintf(stderr, "simplexdb: %s: under mpirun with %d ranks only import, extract and isosurface run; run %s "
                     "without mpirun\n", command.c_str(), mpi->size(), command.c_str());
      }
      return 2;
    }
  }
  // Several ranks print one message: rank 0's (errors are agreed among
  // ranks first: tools/extract_command.cc, Together).
  const bool prints = mpi == nullptr || mpi->rank() == 0;
  int code = 0;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help is success; usage errors are 2 (printed once under mpirun).
    code = (prints ? app.exit(e) : e.get_exit_code()) == 0 ? 0 : 2;
  } catch (const simplexdb::tools::CommandError& e) {
    if (prints) std::fprintf(stderr, "simplexdb: %s\n", e.what());
    return e.exit_code();
  } catch (const std::bad_alloc&) {
    // A last resort: the large allocations report what they were for
    // ("not enough memory for <what> (<size>)") themselves.
    std::fprintf(stderr, "simplexdb: not enough memory to finish this command\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "simplexdb: internal error: %s\n", e.what());
    return 70;
  }
  // Every result printed to stdout is checked here, once: a full disk or a
  // closed stdout is an error, not a success with lost output. (A pipe whose
  // reader left ends the process by SIGPIPE, as for other Unix tools.)
  const simplexdb::Status out = simplexdb::tools::FinishStandardOutput(errno);
  if (!out.ok()) {
    std::fprintf(stderr, "simplexdb: %s\n", std::string(out.message()).c_str());
    return code == 0 ? 1 : code;
  }
  return code;
}
