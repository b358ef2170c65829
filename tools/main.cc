// The dynaguide command: one binary, one subcommand per task.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "pipeline/stop_request.h"
#include "sim/error.h"
#include "tools/commands.h"

int main(int argc, char** argv) {
  CLI::App app{"dynaguide: image-constrained soft-tissue simulation for surgical guidance"};
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const dg::pipeline::Interrupted& e) {
    // `run` and `sim` stopped by SIGINT or SIGTERM, their outputs finished and
    // marked incomplete: the exit status a shell gives a process the signal ended.
    std::fprintf(stderr, "dynaguide: %s\n", e.what());
    return e.exit_code();
  } catch (const dg::Error& e) {
    std::fprintf(stderr, "dynaguide: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynaguide: unexpected error: %s\n", e.what());
    return 2;
  }
  return 0;
}
