// `dynaguide eval runtime`: error against run time.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>

#include "tools/eval/eval_subcommands.h"
#include "tools/eval/runtime_report.h"
#include "tools/eval/runtime_sweep.h"
#include "tools/job_program.h"

namespace dg::tools {
namespace {

struct RuntimeArguments {
  RuntimeOptions sweep;
  std::string from_logs, json;
  bool quiet = false;
};

void RunRuntimeCommand(RuntimeArguments& args) {
  args.sweep.progress = !args.quiet;
  if (!args.sweep.emit_jobs.empty()) args.sweep.program = JobProgramPath();
  if (!args.from_logs.empty()) args.sweep.out_dir = args.from_logs;
  const RuntimeResult result =
      args.from_logs.empty() ? RunRuntimeSweep(args.sweep) : ReadRuntimeLogs(args.from_logs, args.sweep.cycles);
  if (!args.sweep.emit_jobs.empty()) {
    std::printf(
        "dynaguide eval runtime: one run per line in %s; run them one at a time on the machine whose "
        "speed you measure (or one per node of a cluster), then\n  dynaguide report %s\n"
        "(or dynaguide eval runtime --from-logs %s) tabulates their logs\n",
        args.sweep.emit_jobs.c_str(), args.sweep.out_dir.c_str(), args.sweep.out_dir.c_str());
    return;
  }
  std::fputs(WriteRuntimeReport(result, args.sweep.out_dir).c_str(), stdout);
  if (!args.json.empty()) WriteRuntimeJson(result, args.json);
  std::printf("\nreport, table and plot in %s\n", args.sweep.out_dir.c_str());
}

}  // namespace

void AddRuntimeCommand(CLI::App& eval) {
  auto args = std::make_shared<RuntimeArguments>();
  CLI::App* runtime = eval.add_subcommand(
      "runtime", "Error against run time: mesh size, time step and threads swept on the phantom, from run logs");
  runtime->add_option("scene", args->sweep.scene, "A phantom's scene.yaml (default: the default phantom, seed 1)");
  runtime->add_option("--out", args->sweep.out_dir, "Output directory: runs/, report.md, runtime.csv, the plot")
      ->capture_default_str();
  runtime->add_flag("--quick", args->sweep.quick, "A 4-point sweep on the tiny phantom (tests, a first look)");
  runtime->add_option("--cycles", args->sweep.cycles, "Cardiac cycles of the error window from the simulation's start")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  runtime->add_option("--json", args->json, "Write per-point figures as JSON");
  runtime->add_option("--emit-jobs", args->sweep.emit_jobs,
                      "Write one `dynaguide run` command per point to this file instead of running them");
  runtime->add_option("--from-logs", args->from_logs,
                      "Rebuild the report from a sweep directory's logs (after its jobs ran elsewhere)");
  runtime->add_flag("--quiet", args->quiet, "No progress lines");
  runtime->callback([args] { RunRuntimeCommand(*args); });
}

}  // namespace dg::tools
