// `dynaguide eval stability`: the solver on stiff and extreme cases.
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "tools/eval/eval_subcommands.h"
#include "tools/eval/stability_report.h"
#include "tools/eval/stability_study.h"
#include "tools/job_program.h"

namespace dg::tools {
namespace {

struct StabilityArguments {
  StabilityOptions study;
  std::string json;
  bool from_logs = false;
  bool quiet = false;
  std::string cell;    // one job of --emit-jobs
  std::string bisect;  // one job of --emit-jobs
};

// One job: one cell or one bisection, writing its log under --out.
void RunJob(const StabilityArguments& args) {
  const tbb::global_control control(tbb::global_control::max_allowed_parallelism,
                                    args.study.threads > 0 ? args.study.threads : 1);
  const StudyMesh mesh = MakeStudyMesh(args.study.tets);
  if (!args.cell.empty()) {
    const CellSpec spec = CellSpec::Parse(args.cell);
    const CellResult result = RunCell(mesh, spec);
    WriteCellLog(result, CellLogPath(args.study.out_dir, spec));
    std::printf("%s: %s%s%s\n", spec.Name().c_str(), OutcomeName(result.outcome).c_str(),
                result.message.empty() ? "" : ": ", result.message.c_str());
    return;
  }
  const BisectionCase bisection_case = BisectionCase::Parse(args.bisect);
  const BisectionResult result = BisectStabilityLimit(mesh, bisection_case);
  WriteBisectionLog(result, BisectionLogPath(args.study.out_dir, bisection_case));
  std::printf("%s: limit %.4g ms, %.3f x the assembled estimate, %.2f x the per-element bound\n",
              bisection_case.Name().c_str(), result.limit_s() * 1e3, result.ratio_to_estimate(),
              result.ratio_to_element_bound());
}

void RunStabilityCommand(StabilityArguments& args) {
  args.study.progress = !args.quiet;
  if (!args.study.emit_jobs.empty()) args.study.program = JobProgramPath();
  if (!args.cell.empty() || !args.bisect.empty()) return RunJob(args);
  const StabilityResult result =
      args.from_logs ? ReadStabilityLogs(args.study.out_dir) : RunStabilityStudy(args.study);
  if (!args.study.emit_jobs.empty()) {
    std::printf("dynaguide eval stability: one cell or bisection per line in %s; run them (GNU parallel, a Slurm "
                "array), then\n  dynaguide eval stability --from-logs --out %s\nmerges their logs into the report\n",
                args.study.emit_jobs.c_str(), args.study.out_dir.c_str());
    return;
  }
  std::fputs(WriteStabilityReport(result, args.study.out_dir).c_str(), stdout);
  if (!args.json.empty()) WriteStabilityJson(result, args.json);
  std::printf("\nreport (stability.md), stability.csv, bisection.csv, stability_heatmap.png and the logs in %s\n",
              args.study.out_dir.c_str());
}

}  // namespace

void AddStabilityCommand(CLI::App& eval) {
  auto args = std::make_shared<StabilityArguments>();
  CLI::App* command = eval.add_subcommand(
      "stability", "The solver over E x nu x dt x motion x guard: each cell stable, refused, substepped, inversion "
                   "or blow-up; true limits by bisection; table, CSV, heat map, logs");
  command->add_option("--out", args->study.out_dir, "Output directory: cells/, bisection/, stability.md, CSV, PNG")
      ->capture_default_str();
  command->add_flag("--quick", args->study.quick, "A small grid (72 cells, 2 bisections) for tests and CI");
  command->add_option("--threads", args->study.threads, "Cells run at once (default: all cores)")
      ->check(CLI::PositiveNumber);
  command->add_option("--tets", args->study.tets, "The mesh's target tetrahedron count")
      ->check(CLI::Range(100, 200000))
      ->capture_default_str();
  command->add_option("--json", args->json, "Write every cell's and bisection's figures as JSON");
  command->add_option("--emit-jobs", args->study.emit_jobs,
                      "Write one command per cell and bisection to this file instead of running them");
  command->add_flag("--from-logs", args->from_logs,
                    "Run nothing: rewrite the report from the logs under --out (after --emit-jobs' jobs ran)");
  command->add_flag("--quiet", args->quiet, "No progress lines");
  // The jobs --emit-jobs writes; hidden from --help.
  command->add_option("--cell", args->cell, "Run one cell, e.g. E3k_nu0.45_dt0.2ms_default_refuse")->group("");
  command->add_option("--bisect", args->bisect, "Bisect one case, e.g. E3k_nu0.45_default")->group("");
  command->callback([args] { RunStabilityCommand(*args); });
}

}  // namespace dg::tools
