// The dynaguide command. The solver's commands (sim, mesh, bench sim) run in
// this program, which links the solver, its file formats and Gmsh and nothing
// of video, CT or surfaces; it starts in a fraction of the full program's time
// and steps in a fraction of its memory. Every other command line, --help and
// a mistyped one included, goes unchanged to dynaguide-full beside it
// (tools/programs.h), which holds every command.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include <CLI/CLI.hpp>

#include "sim/error.h"
#include "tools/command_line.h"
#include "tools/commands.h"
#include "tools/programs.h"

namespace {

const CLI::App* Subcommand(const CLI::App& command, const std::string& name) {
  try {
    return command.get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    return nullptr;
  }
}

// Whether the subcommands argv names first are this program's: the first
// word, and the next while the one before requires a subcommand of its own
// (`bench sim`, `mesh box`).
bool RunsHere(const CLI::App& app, int argc, char** argv) {
  const CLI::App* command = &app;
  for (int i = 1; i < argc; ++i) {
    command = Subcommand(*command, argv[i]);
    if (!command) return false;
    if (command->get_require_subcommand_min() == 0) return true;
  }
  return false;
}

// Replaces this process with dynaguide-full on the same command line; returns
// only when that cannot start.
int RunFullProgram(char** argv) {
  using dg::tools::kFullProgram;
  try {
    const std::string path = dg::tools::ProgramBesideThis(kFullProgram);
    execv(path.c_str(), argv);
    throw dg::Error(std::string("cannot start ") + kFullProgram + ": " + std::strerror(errno), path,
                    std::string("it holds every command but sim, mesh and bench sim and is built and installed "
                                "with dynaguide (cmake --build, cmake --install): keep the two in one directory"));
  } catch (const dg::Error& e) {
    std::fprintf(stderr, "dynaguide: error: %s\n", e.what());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{dg::tools::kCommandDescription, "dynaguide"};
  app.require_subcommand(1);
  dg::tools::AddSimCommand(app);
  dg::tools::AddMeshCommand(app);
  dg::tools::AddSimBench(*dg::tools::AddBenchGroup(app));
  if (!RunsHere(app, argc, argv)) return RunFullProgram(argv);
  return dg::tools::RunCommandLine(app, argc, argv);
}
