// `dynaguide sim [problem.yaml]`: runs a TLED problem, or the built-in example.
#include <cstdio>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "io/sim_problem.h"
#include "pipeline/stop_request.h"
#include "sim/error.h"
#include "sim/precision.h"
#include "tools/commands.h"
#include "tools/sim/builtin_problem.h"
#include "tools/sim/sim_runner.h"

namespace dg::tools {
namespace {

struct SimArguments {
  std::string problem_path;
  std::string out_dir = "out/sim";
  int tets = 0;
  int threads = 0;
  std::string precision;
  double duration_s = 0;
  bool print_example = false;
  bool no_output = false;
  bool quiet = false;
};

void RunSimCommand(const SimArguments& args) {
  if (args.print_example) {
    std::fputs(kBuiltinProblem, stdout);
    return;
  }
  io::SimProblem problem = args.problem_path.empty() ? io::ParseSimProblem(kBuiltinProblem, "<built-in example>", ".")
                                                     : io::ReadSimProblem(args.problem_path);
  if (args.tets > 0) {
    if (!problem.mesh.file.empty()) {
      throw Error("--tets applies to generated meshes, but the problem reads " + problem.mesh.file, problem.path,
                  "remesh the file, or drop --tets");
    }
    problem.mesh.tets = args.tets;
  }
  if (!args.precision.empty()) {
    problem.precision = sim::ParsePrecision(args.precision, "--precision");
  }
  if (args.duration_s > 0) problem.duration_s = args.duration_s;

  const int threads = args.threads > 0 ? args.threads : tbb::info::default_concurrency();
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  const sim::TetMesh mesh = io::LoadProblemMesh(problem.mesh);
  SimRunOptions options;
  options.out_dir = args.out_dir;
  options.write_output = !args.no_output;
  options.threads = threads;
  options.progress = !args.quiet;
  std::printf("dynaguide sim: %s\n", problem.path.c_str());
  std::fflush(stdout);  // before the progress lines on stderr
  pipeline::InstallStopOnSignals();  // a signal stops the stepping with its outputs finished (docs/interrupts.md)
  const SimSummary summary = RunSimProblem(problem, mesh, options);
  std::fputs(summary.Describe().c_str(), stdout);
}

}  // namespace

void AddSimCommand(CLI::App& app) {
  auto args = std::make_shared<SimArguments>();
  CLI::App* sim = app.add_subcommand("sim", "Run a TLED soft-tissue problem (no argument: the built-in example)");
  sim->add_option("problem", args->problem_path, "Problem YAML (see --print-example)")->check(CLI::ExistingFile);
  sim->add_option("--out", args->out_dir, "Output directory: sim.xmf/.h5 time series, final.vtu, summary.json")
      ->capture_default_str();
  sim->add_option("--tets", args->tets, "Target tetrahedron count of a generated mesh")->check(CLI::PositiveNumber);
  sim->add_option("--threads", args->threads, "Worker threads (default: all cores)")->check(CLI::PositiveNumber);
  sim->add_option("--precision", args->precision, "Kernel scalar, float or double, overriding the problem");
  sim->add_option("--duration", args->duration_s, "Simulated seconds, overriding the problem")
      ->check(CLI::PositiveNumber);
  sim->add_flag("--print-example", args->print_example, "Print the built-in problem (a template) and exit");
  sim->add_flag("--no-output", args->no_output, "Write no files (for timing)");
  sim->add_flag("--quiet", args->quiet, "No progress line");
  sim->callback([args] { RunSimCommand(*args); });
}

}  // namespace dg::tools
