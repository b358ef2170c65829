// dynaguide-full: every subcommand of the dynaguide command, with the video,
// CT and surface libraries they need. `dynaguide` hands it every command line
// it does not run itself (tools/programs.h).
#include <CLI/CLI.hpp>

#include "tools/command_line.h"
#include "tools/commands.h"

int main(int argc, char** argv) {
  CLI::App app{dg::tools::kCommandDescription, "dynaguide"};
  app.require_subcommand(1);
  dg::tools::AddSimCommand(app);
  dg::tools::AddBenchCommand(app);
  dg::tools::AddCalibrateCommand(app);
  dg::tools::AddEvalCommand(app);
  dg::tools::AddExportCommand(app);
  dg::tools::AddMeshCommand(app);
  dg::tools::AddOverlayCommand(app);
  dg::tools::AddPhantomCommand(app);
  dg::tools::AddPreopCommand(app);
  dg::tools::AddRunCommand(app);
  dg::tools::AddReportCommand(app);
  dg::tools::AddTrackCommand(app);
  dg::tools::AddRegisterCommand(app);
  return dg::tools::RunCommandLine(app, argc, argv);
}
