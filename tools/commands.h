#pragma once

namespace CLI {
class App;
}

namespace dg::tools {

// Each subcommand lives in its own folder and adds itself to the command line.
// Its callback throws dg::Error on bad input; main() prints it and exits 1.
void AddSimCommand(CLI::App& app);
void AddBenchCommand(CLI::App& app);  // the group and every benchmark
CLI::App* AddBenchGroup(CLI::App& app);  // the group alone, for its benchmarks to add to
void AddSimBench(CLI::App& bench);
void AddCalibrateCommand(CLI::App& app);
void AddEvalCommand(CLI::App& app);
void AddExportCommand(CLI::App& app);
void AddMeshCommand(CLI::App& app);
void AddOverlayCommand(CLI::App& app);
void AddPhantomCommand(CLI::App& app);
void AddPreopCommand(CLI::App& app);
void AddReportCommand(CLI::App& app);
void AddRunCommand(CLI::App& app);
void AddTrackCommand(CLI::App& app);
void AddRegisterCommand(CLI::App& app);

}  // namespace dg::tools
