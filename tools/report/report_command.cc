// `dynaguide report RUN.h5`: the summary of a saved run, and its timing plot.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "tools/commands.h"
#include "tools/eval/protocol.h"
#include "tools/eval/runtime_report.h"
#include "tools/eval/stability_report.h"
#include "tools/report/saved_run.h"
#include "tools/report/timing_plot.h"

namespace dg::tools {
namespace {

struct ReportArguments {
  std::string log_path;
  std::string plot_path;  // default: beside the log
  double cycles = 3;      // a directory's evaluation window
};

void RunReportCommand(const ReportArguments& args) {
  if (std::filesystem::is_directory(args.log_path + "/cells")) {
    // A `dynaguide eval stability` directory (or its --emit-jobs run elsewhere): its report from the cell logs.
    std::fputs(WriteStabilityReport(ReadStabilityLogs(args.log_path), args.log_path).c_str(), stdout);
    std::printf("\nreport, CSV and heat map in %s\n", args.log_path.c_str());
    return;
  }
  if (IsRuntimeSweepDir(args.log_path)) {
    // A `dynaguide eval runtime` directory (or its --emit-jobs run elsewhere): its report from the point logs.
    std::fputs(WriteRuntimeReport(ReadRuntimeLogs(args.log_path, args.cycles), args.log_path).c_str(), stdout);
    std::printf("\nreport, CSV and plot in %s\n", args.log_path.c_str());
    return;
  }
  if (std::filesystem::is_directory(args.log_path)) {
    // A directory of evaluation runs (`dynaguide eval protocol`, or its --emit-jobs run elsewhere): the tables.
    const ProtocolResult result = ReadProtocolLogs(args.log_path, args.cycles);
    std::fputs(WriteProtocolReport(result, args.log_path).c_str(), stdout);
    std::printf("\nreport, tables and plots in %s\n", args.log_path.c_str());
    return;
  }
  const SavedRun run = ReadSavedRun(args.log_path);
  std::printf("dynaguide report: %s (%s policy, %d threads)\n%s", run.path.c_str(), run.policy.c_str(), run.threads,
              run.statistics.Text().c_str());
  if (!run.error.empty()) std::printf("error: %s\n", run.error.c_str());
  const std::string plot = args.plot_path.empty()
                               ? std::filesystem::path(args.log_path).replace_extension("").string() + "_timings.png"
                               : args.plot_path;
  const PlotClipping clipping = WriteTimingPlot(run, plot);
  std::printf("timing plot: %s\n", plot.c_str());
  if (clipping.points_above > 0) {
    std::printf("  its y axis ends at %.3g ms: %d stage times above it are marked on the top edge (largest %.3g ms)\n",
                clipping.y_axis_max, clipping.points_above, clipping.largest_y);
  }
}

}  // namespace

void AddReportCommand(CLI::App& app) {
  auto args = std::make_shared<ReportArguments>();
  CLI::App* command = app.add_subcommand(
      "report", "Summarise a saved run log and plot its stage timings, or tabulate a directory of evaluation runs");
  command->add_option("log", args->log_path, "run.h5 written by dynaguide run, or a directory of them (eval)")
      ->required();
  command->add_option("--cycles", args->cycles, "A directory's evaluation window, in cardiac cycles")
      ->capture_default_str();
  command->add_option("--plot", args->plot_path, "Timing plot PNG (default: RUN_timings.png beside the log)");
  command->callback([args] { RunReportCommand(*args); });
}

}  // namespace dg::tools
