// `dynaguide eval protocol`: the paper's validation protocol on phantoms.
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "tools/commands.h"
#include "tools/eval/eval_subcommands.h"
#include "tools/eval/protocol.h"
#include "tools/job_program.h"

namespace dg::tools {
namespace {

struct EvalArguments {
  ProtocolOptions protocol;
  std::string json;
  bool quiet = false;
};

void RunProtocolCommand(EvalArguments& args) {
  args.protocol.progress = !args.quiet;
  if (!args.protocol.emit_jobs.empty()) args.protocol.program = JobProgramPath();
  const ProtocolResult result = RunProtocol(args.protocol);
  if (!args.protocol.emit_jobs.empty()) {
    std::printf("dynaguide eval protocol: one run per line in %s; run them (GNU parallel, a Slurm array), then\n"
                "  dynaguide report %s\nmerges their logs into the tables\n",
                args.protocol.emit_jobs.c_str(), args.protocol.out_dir.c_str());
    return;
  }
  std::fputs(WriteProtocolReport(result, args.protocol.out_dir).c_str(), stdout);
  if (!args.json.empty()) WriteProtocolJson(result, args.json);
  std::printf("\nreport, tables and plots in %s\n", args.protocol.out_dir.c_str());
}

}  // namespace

void AddEvalCommand(CLI::App& app) {
  CLI::App* eval = app.add_subcommand("eval", "Evaluate against ground truth: the paper's validation protocol");
  eval->require_subcommand(1);
  auto args = std::make_shared<EvalArguments>();
  CLI::App* protocol = eval->add_subcommand(
      "protocol", "Surface, volume and combined modes on phantoms: Tables 1 and 2 and Fig. 2 of the paper, from run logs");
  protocol->add_option("scene", args->protocol.scene, "A phantom's scene.yaml (default: the default phantom per seed)");
  protocol->add_option("--seeds", args->protocol.seeds, "Phantom seeds when no scene is given (e.g. 1,2,3)")
      ->delimiter(',')
      ->capture_default_str();
  protocol->add_option("--policy", args->protocol.policies,
                       "Policies each mode runs under: offline (lossless), realtime (paced to the video, drops "
                       "frames), or both")
      ->delimiter(',')
      ->capture_default_str();
  phantom::AddBeatOptions(protocol, &args->protocol.beat);
  protocol->add_option("--out", args->protocol.out_dir, "Output directory: runs/, report.md, CSV tables, PNG figures")
      ->capture_default_str();
  protocol->add_option("--threads", args->protocol.threads, "Threads per run (default: all cores)")
      ->check(CLI::PositiveNumber);
  protocol->add_option("--cycles", args->protocol.cycles, "Cardiac cycles evaluated from the simulation's start")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  protocol->add_option("--json", args->json, "Write per-mode figures as JSON");
  protocol->add_option("--emit-jobs", args->protocol.emit_jobs,
                       "Write one `dynaguide run` command per run to this file instead of running them");
  protocol->add_flag("--truth-registration", args->protocol.truth_registration,
                    "Give the runs the truth's registration (the modes' errors without the registration's)");
  protocol->add_flag("--constant-phase", args->protocol.constant_phase,
                     "Simulate at the registration's constant phase shift instead of the live phase");
  protocol->add_flag("--quiet", args->quiet, "No progress lines");
  protocol->callback([args] { RunProtocolCommand(*args); });
  AddStabilityCommand(*eval);
  AddRuntimeCommand(*eval);
}

}  // namespace dg::tools
