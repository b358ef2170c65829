// `dynaguide report RUN.h5`: the summary of a saved run, and its timing plot.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "tools/commands.h"
#include "tools/report/saved_run.h"
#include "tools/report/timing_plot.h"

namespace dg::tools {
namespace {

struct ReportArguments {
  std::string log_path;
  std::string plot_path;  // default: beside the log
};

void RunReportCommand(const ReportArguments& args) {
  const SavedRun run = ReadSavedRun(args.log_path);
  std::printf("dynaguide report: %s (%s policy, %d threads)\n%s", run.path.c_str(), run.policy.c_str(), run.threads,
              run.statistics.Text().c_str());
  if (!run.error.empty()) std::printf("error: %s\n", run.error.c_str());
  const std::string plot = args.plot_path.empty()
                               ? std::filesystem::path(args.log_path).replace_extension("").string() + "_timings.png"
                               : args.plot_path;
  WriteTimingPlot(run, plot);
  std::printf("timing plot: %s\n", plot.c_str());
}

}  // namespace

void AddReportCommand(CLI::App& app) {
  auto args = std::make_shared<ReportArguments>();
  CLI::App* command = app.add_subcommand("report", "Summarise a saved run log and plot its stage timings");
  command->add_option("log", args->log_path, "run.h5 written by dynaguide run")->required();
  command->add_option("--plot", args->plot_path, "Timing plot PNG (default: RUN_timings.png beside the log)");
  command->callback([args] { RunReportCommand(*args); });
}

}  // namespace dg::tools
