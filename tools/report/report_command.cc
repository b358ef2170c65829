// `dynaguide report RUN.h5`: the summary of a saved run, its timing plot and its overlays' layer-age plot.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

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
  std::string plot_path;  // default: beside the log; the layer-age plot goes beside it
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
  if (run.overlay_names.empty()) {
    fmt::print("layer age plot: none, the run log has no /composite (a run without overlays)\n");
    return;
  }
  // Beside the timing plot, named after the log as the default timing plot is.
  const std::string age_plot = (std::filesystem::path(plot).parent_path() /
                                (std::filesystem::path(args.log_path).stem().string() + "_layer_age.png"))
                                   .string();
  WriteLayerAgePlot(run, age_plot);
  fmt::print("layer age plot: {}\n", age_plot);
  for (const LayerAgeSummary& summary : SummarizeLayerAges(run)) fmt::print("  {}\n", summary.Text());
}

}  // namespace

void AddReportCommand(CLI::App& app) {
  auto args = std::make_shared<ReportArguments>();
  CLI::App* command = app.add_subcommand("report",
                                         "Summarise a saved run log and plot its stage timings and layer ages, or "
                                         "tabulate a directory of evaluation runs");
  command->add_option("log", args->log_path, "run.h5 written by dynaguide run, or a directory of them (eval)")
      ->required();
  command->add_option("--cycles", args->cycles, "A directory's evaluation window, in cardiac cycles")
      ->capture_default_str();
  command->add_option("--plot", args->plot_path,
                      "Timing plot PNG (default: RUN_timings.png beside the log); RUN_layer_age.png goes beside it");
  command->callback([args] { RunReportCommand(*args); });
}

}  // namespace dg::tools
