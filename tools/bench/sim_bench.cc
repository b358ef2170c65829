#include "tools/bench/sim_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>

#include <tbb/global_control.h>

#include "io/gmsh_mesher.h"
#include "sim/error.h"
#include "sim/tled_solver.h"
#include "tools/json_text.h"
#include "tools/machine_info.h"

namespace dg::tools {
namespace {

constexpr double kPressDown_m = 1e-3;

struct BenchProblem {
  sim::TetMesh mesh;
  sim::BoundaryConditions conditions;
  sim::StabilityReport stability;
};

BenchProblem MakeBenchProblem(int target_tets) {
  BenchProblem problem;
  problem.mesh = io::MeshBox({Eigen::Vector3d(0.05, 0.05, 0.05), target_tets});
  for (int a : problem.mesh.node_sets.at("zmin")) {
    for (int axis = 0; axis < 3; ++axis) problem.conditions.fixed_dofs.push_back(3 * a + axis);
  }
  for (int a : problem.mesh.node_sets.at("zmax")) problem.conditions.prescribed_dofs.push_back(3 * a + 2);
  std::vector<int> constrained = problem.conditions.fixed_dofs;
  constrained.insert(constrained.end(), problem.conditions.prescribed_dofs.begin(),
                     problem.conditions.prescribed_dofs.end());
  problem.stability = sim::EstimateStability(problem.mesh, sim::Material{}, constrained);
  return problem;
}

template <typename T>
SimBenchRecord Measure(const BenchProblem& problem, int threads, const SimBenchOptions& options) {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  sim::SolverOptions solver_options;
  solver_options.dt_s = options.dt_s;
  sim::TledSolver<T> solver(std::make_shared<const sim::TledModel<T>>(problem.mesh, sim::Material{}),
                            problem.conditions, solver_options, &problem.stability);
  const std::vector<double> targets(problem.conditions.prescribed_dofs.size(), -kPressDown_m);
  const int steps = std::max(1, static_cast<int>(std::lround(options.simulated_per_repeat_s / options.dt_s)));
  solver.Advance(steps / 4 + 1, targets);  // warm caches and threads
  std::vector<double> rates;
  for (int r = 0; r < options.repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    solver.Advance(steps, targets);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    rates.push_back(double(problem.mesh.num_tets()) * steps * solver.substeps_per_step() / wall_s);
  }
  std::sort(rates.begin(), rates.end());
  SimBenchRecord record;
  record.mesh_tets = problem.mesh.num_tets();
  record.mesh_nodes = problem.mesh.num_nodes();
  record.threads = threads;
  record.precision = sizeof(T) == 4 ? "float" : "double";
  record.mode = options.mode;
  record.tet_steps_per_s = rates[rates.size() / 2];
  record.tet_steps_per_s_min = rates.front();
  record.tet_steps_per_s_max = rates.back();
  record.realtime_factor = record.tet_steps_per_s / problem.mesh.num_tets() * options.dt_s;
  record.dt_s = options.dt_s;
  record.dt_critical_s = problem.stability.dt_critical_s;
  record.steps_per_repeat = steps;
  record.repeats = options.repeats;
  return record;
}

}  // namespace

std::vector<SimBenchRecord> RunSimBench(const SimBenchOptions& options, bool progress) {
  if (options.mode != "forward") {
    throw Error("bench mode '" + options.mode + "' is not available yet", "dynaguide bench sim --mode",
                "use --mode forward; combined (inverse + forward) arrives with the image-constrained simulation");
  }
  if (options.repeats < 1) throw Error("--repeats must be at least 1", "dynaguide bench sim", "give e.g. 7");
  std::vector<SimBenchRecord> records;
  for (int target : options.tets) {
    const BenchProblem problem = MakeBenchProblem(target);
    for (const std::string& precision : options.precisions) {
      for (int threads : options.threads) {
        records.push_back(precision == "float" ? Measure<float>(problem, threads, options)
                                               : Measure<double>(problem, threads, options));
        if (progress) {
          const SimBenchRecord& r = records.back();
          std::fprintf(stderr, "bench sim: %d tets, %s, %d thread%s: %.1f M tet-steps/s (median of %d)\n",
                       r.mesh_tets, r.precision.c_str(), r.threads, r.threads > 1 ? "s" : "",
                       r.tet_steps_per_s / 1e6, r.repeats);
        }
      }
    }
  }
  return records;
}

void WriteSimBenchJson(const std::string& path, const std::vector<SimBenchRecord>& records) {
  std::ofstream out(path);
  if (!out) throw Error("cannot write benchmark results", path, "check the directory exists and is writable");
  const MachineInfo machine = ReadMachineInfo();
  out << "[\n";
  for (size_t i = 0; i < records.size(); ++i) {
    const SimBenchRecord& r = records[i];
    char line[1024];
    std::snprintf(line, sizeof line,
                  "  {\"mesh_tets\": %d, \"mesh_nodes\": %d, \"threads\": %d, \"precision\": %s, \"mode\": %s, "
                  "\"tet_steps_per_s\": %.6g, \"tet_steps_per_s_min\": %.6g, \"tet_steps_per_s_max\": %.6g, "
                  "\"realtime_factor\": %.6g, \"dt_s\": %.6g, \"dt_critical_s\": %.6g, \"steps_per_repeat\": %d, "
                  "\"repeats\": %d, \"cpu\": %s, \"logical_cores\": %d, \"simd\": %s, \"compiler\": %s}%s\n",
                  r.mesh_tets, r.mesh_nodes, r.threads, JsonQuoted(r.precision).c_str(), JsonQuoted(r.mode).c_str(), r.tet_steps_per_s,
                  r.tet_steps_per_s_min, r.tet_steps_per_s_max, r.realtime_factor, r.dt_s, r.dt_critical_s,
                  r.steps_per_repeat, r.repeats, JsonQuoted(machine.cpu_model).c_str(), machine.logical_cores,
                  JsonQuoted(machine.simd).c_str(), JsonQuoted(machine.compiler).c_str(), i + 1 < records.size() ? "," : "");
    out << line;
  }
  out << "]\n";
}

std::string SimBenchTable(const std::vector<SimBenchRecord>& records) {
  std::string table =
      "| tets | nodes | precision | threads | M tet-steps/s (median) | min-max | real-time factor | dt_cr ms |\n"
      "|---:|---:|---|---:|---:|---:|---:|---:|\n";
  for (const SimBenchRecord& r : records) {
    char line[256];
    std::snprintf(line, sizeof line, "| %d | %d | %s | %d | %.1f | %.1f-%.1f | %.2f | %.3f |\n", r.mesh_tets,
                  r.mesh_nodes, r.precision.c_str(), r.threads, r.tet_steps_per_s / 1e6, r.tet_steps_per_s_min / 1e6,
                  r.tet_steps_per_s_max / 1e6, r.realtime_factor, r.dt_critical_s * 1e3);
    table += line;
  }
  return table;
}

}  // namespace dg::tools
