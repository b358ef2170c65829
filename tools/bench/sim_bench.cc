#include "tools/bench/sim_bench.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <numeric>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "io/gmsh_mesher.h"
#include "io/gmsh_reader.h"
#include "sim/coupled_simulation.h"
#include "sim/error.h"
#include "sim/step_team.h"
#include "sim/tled_solver.h"
#include "tools/bench/bench_json.h"
#include "tools/json_text.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools {
namespace {

constexpr double kPressDown_m = 1e-3;

struct BenchProblem {
  std::string name;
  sim::TetMesh mesh;
  sim::BoundaryConditions conditions;
  sim::StabilityReport stability;
};

// The mesh's lowest z face fixed, its highest pressed down.
BenchProblem MakeBenchProblem(std::string name, sim::TetMesh mesh) {
  BenchProblem problem;
  problem.name = std::move(name);
  problem.mesh = std::move(mesh);
  const Eigen::Matrix<double, 3, 2> box = sim::BoundingBox(problem.mesh);
  const double tolerance_m = 1e-6 * (box.col(1) - box.col(0)).norm();
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  for (int a : sim::NodesNearPlane(problem.mesh, box.col(0), up, tolerance_m)) {
    for (int axis = 0; axis < 3; ++axis) problem.conditions.fixed_dofs.push_back(3 * a + axis);
  }
  for (int a : sim::NodesNearPlane(problem.mesh, box.col(1), up, tolerance_m)) {
    problem.conditions.prescribed_dofs.push_back(3 * a + 2);
  }
  std::vector<int> constrained = problem.conditions.fixed_dofs;
  constrained.insert(constrained.end(), problem.conditions.prescribed_dofs.begin(),
                     problem.conditions.prescribed_dofs.end());
  problem.stability = sim::EstimateStability(problem.mesh, sim::Material{}, constrained);
  return problem;
}

// The same mesh with its nodes listed in a random (fixed) order.
sim::TetMesh ShuffleNodes(const sim::TetMesh& mesh) {
  std::vector<int> new_id(mesh.num_nodes());
  std::iota(new_id.begin(), new_id.end(), 0);
  std::shuffle(new_id.begin(), new_id.end(), std::mt19937(20261201));
  sim::TetMesh shuffled = mesh;
  for (int a = 0; a < mesh.num_nodes(); ++a) shuffled.X_m.col(new_id[a]) = mesh.X_m.col(a);
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (int c = 0; c < 4; ++c) shuffled.tets(c, e) = new_id[mesh.tets(c, e)];
  }
  for (auto& [name, nodes] : shuffled.node_sets) {
    for (int& a : nodes) a = new_id[a];
    std::sort(nodes.begin(), nodes.end());
  }
  return shuffled;
}

// The forward problems: each target size's Gmsh box, or the given file; each
// also shuffled when asked.
std::vector<BenchProblem> ForwardProblems(const SimBenchOptions& options) {
  std::vector<std::pair<std::string, sim::TetMesh>> meshes;
  if (!options.mesh_path.empty()) {
    meshes.emplace_back(options.mesh_path, io::ReadGmsh(options.mesh_path));
  } else {
    for (int target : options.tets) {
      meshes.emplace_back("Gmsh box", io::MeshBox({Eigen::Vector3d(0.05, 0.05, 0.05), target}));
    }
  }
  std::vector<BenchProblem> problems;
  for (auto& [name, mesh] : meshes) {
    if (options.shuffled_too) problems.push_back(MakeBenchProblem(name + ", nodes shuffled", ShuffleNodes(mesh)));
    problems.push_back(MakeBenchProblem(name, std::move(mesh)));
  }
  return problems;
}

// Nanoseconds per pass of a StepTeam of `threads` workers with nothing to
// do: the barrier (and the serial section's call) a forward step pays once.
double MeasureBarrierNs(int threads) {
  if (threads < 2) return 0;
  sim::StepTeam team(threads);
  constexpr int kSyncs = 200000;
  auto run = [&] { team.Run(kSyncs, [](int, int) {}, [](int) { return true; }); };
  run();  // wakes the workers and warms the lines the barrier uses
  const auto start = std::chrono::steady_clock::now();
  run();
  return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count() / kSyncs;
}

// The phantom's mesh and motion as `dynaguide phantom` makes them.
struct PhantomProblem {
  sim::TetMesh mesh;
  sim::Material material;
  std::shared_ptr<const sim::CyclicMotionModel> motion;
  std::vector<int> fixed_nodes, constrained_nodes;
  sim::StabilityReport stability;
};

PhantomProblem MakePhantomProblem(int target_tets) {
  phantom::PhantomSpec spec = phantom::PresetSpec("default");
  spec.tets = target_tets;
  PhantomProblem problem;
  problem.mesh = io::MeshTruncatedEllipsoid({spec.semi_axes_m, spec.centre_height_m, spec.tets});
  problem.material = spec.material;
  const phantom::HeartMotion heart(spec, spec.period_s());
  const int N = problem.mesh.num_nodes();
  std::vector<double> displacement;
  for (int k = 0; k < spec.phases; ++k) {
    const phantom::MotionState state = phantom::HeartMotion::NominalState(double(k) / spec.phases);
    for (int a = 0; a < N; ++a) {
      const Eigen::Vector3d u = heart.Deform(problem.mesh.X_m.col(a), state) - problem.mesh.X_m.col(a);
      displacement.insert(displacement.end(), u.data(), u.data() + 3);
    }
  }
  problem.motion = std::make_shared<const sim::CyclicMotionModel>(displacement, spec.phases, 3 * N, spec.period_s());
  problem.fixed_nodes = problem.mesh.node_sets.at("base");
  int free_surface = 0;
  for (int a : problem.mesh.node_sets.at("surface")) {
    if (std::binary_search(problem.fixed_nodes.begin(), problem.fixed_nodes.end(), a)) continue;
    if (free_surface++ % 3 == 0) problem.constrained_nodes.push_back(a);
  }
  std::vector<int> fixed_dofs;
  for (int a : problem.fixed_nodes) {
    for (int i = 0; i < 3; ++i) fixed_dofs.push_back(3 * a + i);
  }
  problem.stability = sim::EstimateStability(problem.mesh, problem.material, fixed_dofs);
  return problem;
}

int StepsPerRepeat(const SimBenchOptions& options) {
  return std::max(1, static_cast<int>(std::lround(options.simulated_per_repeat_s / options.dt_s)));
}

// Times `repeats` calls of advance(steps) after a warm-up; sorted tet-steps per second.
template <typename Advance>
std::vector<double> TimeRepeats(int tets, int steps, int repeats, Advance advance) {
  advance(steps / 4 + 1);  // warm caches and threads
  std::vector<double> rates;
  for (int r = 0; r < repeats; ++r) {
    const auto start = std::chrono::steady_clock::now();
    advance(steps);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    rates.push_back(double(tets) * steps / wall_s);
  }
  std::sort(rates.begin(), rates.end());
  return rates;
}

// The process's resident memory now (VmRSS of /proc/self/status), MB, once
// the heap the run's earlier configurations freed is returned to the system,
// so that the figure is this configuration's; 0 where /proc cannot tell.
double ResidentMegabytes() {
  malloc_trim(0);
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      double kilobytes = 0;
      status >> kilobytes;
      return kilobytes / 1024;
    }
    status.ignore(1 << 20, '\n');
  }
  return 0;
}

template <typename T>
SimBenchRecord MakeRecord(const std::string& name, const sim::TetMesh& mesh, int threads, const std::string& mode,
                          const std::vector<double>& rates, const sim::StabilityReport& stability,
                          const SimBenchOptions& options) {
  SimBenchRecord record;
  record.mesh = name;
  record.mesh_tets = mesh.num_tets();
  record.mesh_nodes = mesh.num_nodes();
  record.threads = threads;
  record.precision = sim::PrecisionOf<T>();
  record.mode = mode;
  record.tet_steps_per_s = rates[rates.size() / 2];
  record.tet_steps_per_s_min = rates.front();
  record.tet_steps_per_s_max = rates.back();
  record.realtime_factor = record.tet_steps_per_s / mesh.num_tets() * options.dt_s;
  record.dt_s = options.dt_s;
  record.dt_critical_s = stability.dt_critical_s;
  record.steps_per_repeat = StepsPerRepeat(options);
  record.repeats = options.repeats;
  record.resident_mb = ResidentMegabytes();
  return record;
}

// The same problem stepped by `threads` one-thread solvers at once, each on
// its own model: what the machine gives this kernel on that many cores with
// nothing shared, the ceiling for one solver on `threads` threads. Sorted
// tet-steps per second, all solvers together.
template <typename T>
std::vector<double> MeasureNothingShared(const BenchProblem& problem, int threads, const SimBenchOptions& options) {
  sim::SolverOptions solver_options;
  solver_options.dt_s = options.dt_s;
  solver_options.threads = 1;
  std::vector<std::unique_ptr<sim::TledSolver<T>>> solvers;
  for (int t = 0; t < threads; ++t) {
    solvers.push_back(std::make_unique<sim::TledSolver<T>>(
        std::make_shared<const sim::TledModel<T>>(problem.mesh, sim::Material{}, 1), problem.conditions,
        solver_options, &problem.stability));
  }
  const std::vector<double> targets(problem.conditions.prescribed_dofs.size(), -kPressDown_m);
  const int substeps = solvers.front()->substeps_per_step();
  return TimeRepeats(threads * problem.mesh.num_tets(), StepsPerRepeat(options) * substeps, options.repeats,
                     [&](int steps) {
                       std::vector<std::thread> running;
                       for (auto& solver : solvers) {
                         running.emplace_back([&solver, &targets, steps, substeps] {
                           solver->Advance(steps / substeps, targets);
                         });
                       }
                       for (std::thread& thread : running) thread.join();
                     });
}

template <typename T>
SimBenchRecord Measure(const BenchProblem& problem, int threads, const SimBenchOptions& options) {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  sim::SolverOptions solver_options;
  solver_options.dt_s = options.dt_s;
  sim::TledSolver<T> solver(std::make_shared<const sim::TledModel<T>>(problem.mesh, sim::Material{}),
                            problem.conditions, solver_options, &problem.stability);
  const std::vector<double> targets(problem.conditions.prescribed_dofs.size(), -kPressDown_m);
  const std::vector<double> rates =
      TimeRepeats(problem.mesh.num_tets(), StepsPerRepeat(options) * solver.substeps_per_step(), options.repeats,
                  [&](int steps) { solver.Advance(steps / solver.substeps_per_step(), targets); });
  SimBenchRecord record = MakeRecord<T>(problem.name, problem.mesh, threads, "forward", rates, problem.stability, options);
  if (threads > 1) {
    const std::vector<double> apart = MeasureNothingShared<T>(problem, threads, options);
    record.nothing_shared_tet_steps_per_s = apart[apart.size() / 2];
  }
  return record;
}

// The image-constrained simulation in one mode on the phantom, its
// constrained nodes (none in volume mode) set.
template <typename T>
sim::CoupledSimulation<T> MakeCoupled(const PhantomProblem& problem, sim::SimulationMode mode, bool concurrent,
                                      int inverse_interval, const SimBenchOptions& options) {
  sim::CoupledOptions coupled;
  coupled.mode = mode;
  coupled.solver.dt_s = options.dt_s;
  coupled.concurrent = concurrent;
  coupled.inverse_interval_steps = inverse_interval;
  sim::CoupledSimulation<T> simulation(std::make_shared<const sim::TledModel<T>>(problem.mesh, problem.material),
                                       problem.motion, problem.fixed_nodes, coupled, &problem.stability);
  if (mode != sim::SimulationMode::kVolume) simulation.SetConstrainedNodes(problem.constrained_nodes);
  return simulation;
}

// Advances `steps`, the constrained nodes reaching the motion model at the
// end (`motion` and `targets`: the caller's buffers, reused between calls).
template <typename T>
void AdvanceFollowingMotion(sim::CoupledSimulation<T>& simulation, int steps, std::vector<T>& motion,
                            std::vector<double>& targets) {
  simulation.MotionAtStep(simulation.steps_taken() + steps, motion);
  targets.clear();
  for (int a : simulation.constrained_nodes()) targets.insert(targets.end(), &motion[3 * a], &motion[3 * a] + 3);
  simulation.Advance(steps, targets);
}

template <typename T>
std::vector<double> MeasureCoupledRates(const PhantomProblem& problem, sim::SimulationMode mode, bool concurrent,
                                        int inverse_interval, int threads, const SimBenchOptions& options) {
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, threads);
  sim::CoupledSimulation<T> simulation = MakeCoupled<T>(problem, mode, concurrent, inverse_interval, options);
  std::vector<T> motion(3 * size_t(problem.mesh.num_nodes()));
  std::vector<double> targets;
  return TimeRepeats(problem.mesh.num_tets(), StepsPerRepeat(options), options.repeats,
                     [&](int steps) { AdvanceFollowingMotion(simulation, steps, motion, targets); });
}

// The largest node distance from the motion model over one cardiac period,
// the constrained nodes led frame by frame at 30 Hz as a run leads them.
template <typename T>
double MotionError(const PhantomProblem& problem, sim::SimulationMode mode, int inverse_interval,
                   const SimBenchOptions& options) {
  sim::CoupledSimulation<T> simulation = MakeCoupled<T>(problem, mode, true, inverse_interval, options);
  std::vector<T> motion(3 * size_t(problem.mesh.num_nodes()));
  std::vector<double> targets;
  const long long period_steps = std::llround(problem.motion->period_s() / options.dt_s);
  const int frame_steps = std::max(1, static_cast<int>(std::lround(1.0 / 30.0 / options.dt_s)));
  double largest = 0;
  while (simulation.steps_taken() < period_steps) {
    AdvanceFollowingMotion(simulation, frame_steps, motion, targets);
    const std::span<const T> u = simulation.displacement();
    for (size_t a = 0; a < motion.size(); a += 3) {
      const double dx = double(u[a]) - motion[a], dy = double(u[a + 1]) - motion[a + 1],
                   dz = double(u[a + 2]) - motion[a + 2];
      largest = std::max(largest, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  }
  return largest;
}

template <typename T>
SimBenchRecord MeasureCoupled(const PhantomProblem& problem, const std::string& mode_name, int inverse_interval,
                              int threads, const SimBenchOptions& options) {
  const sim::SimulationMode mode = sim::ParseSimulationMode(mode_name);
  SimBenchRecord record = MakeRecord<T>("phantom", problem.mesh, threads, mode_name,
                                        MeasureCoupledRates<T>(problem, mode, true, inverse_interval, threads, options),
                                        problem.stability, options);
  if (mode != sim::SimulationMode::kSurface) {
    const std::vector<double> sequential =
        MeasureCoupledRates<T>(problem, mode, false, inverse_interval, threads, options);
    record.sequential_tet_steps_per_s = sequential[sequential.size() / 2];
    record.concurrent_gain = record.tet_steps_per_s / record.sequential_tet_steps_per_s;
    record.inverse_interval_steps = inverse_interval;
    record.motion_error_m = MotionError<T>(problem, mode, inverse_interval, options);
  }
  return record;
}

}  // namespace

std::vector<SimBenchRecord> RunSimBench(const SimBenchOptions& options, bool progress) {
  if (options.repeats < 1) throw Error("--repeats must be at least 1", "dynaguide bench sim", "give e.g. 7");
  std::vector<SimBenchRecord> records;
  auto report = [&] {
    const SimBenchRecord& r = records.back();
    if (!progress) return;
    std::fprintf(stderr, "bench sim: %s, %s, %d tets, %s, %d thread%s: %.1f M tet-steps/s (median of %d)\n",
                 r.mode.c_str(), r.mesh.c_str(), r.mesh_tets, sim::ToString(r.precision).c_str(), r.threads,
                 r.threads > 1 ? "s" : "", r.tet_steps_per_s / 1e6, r.repeats);
  };
  for (const std::string& mode : options.modes) {
    if (mode != "forward") sim::ParseSimulationMode(mode);  // rejects an unknown mode before any work
  }
  for (const std::string& mode : options.modes) {
    if (mode == "forward") {
      for (const BenchProblem& problem : ForwardProblems(options)) {
        for (sim::Precision precision : options.precisions) {
          for (int threads : options.threads) {
            records.push_back(precision == sim::Precision::kFloat ? Measure<float>(problem, threads, options)
                                                   : Measure<double>(problem, threads, options));
            report();
          }
        }
      }
      continue;
    }
    // Surface mode has no recovered forces: one interval stands for all.
    const std::vector<int> intervals =
        mode == "surface" ? std::vector<int>{options.inverse_intervals.front()} : options.inverse_intervals;
    for (int target : options.tets) {
      const PhantomProblem problem = MakePhantomProblem(target);
      for (int interval : intervals) {
        for (sim::Precision precision : options.precisions) {
          for (int threads : options.threads) {
            records.push_back(precision == sim::Precision::kFloat
                                  ? MeasureCoupled<float>(problem, mode, interval, threads, options)
                                  : MeasureCoupled<double>(problem, mode, interval, threads, options));
            report();
          }
        }
      }
    }
  }
  for (SimBenchRecord& r : records) {
    r.barrier_ns = MeasureBarrierNs(r.threads);
    for (const SimBenchRecord& one : records) {
      if (one.threads == 1 && one.mesh == r.mesh && one.mesh_tets == r.mesh_tets && one.mode == r.mode &&
          one.precision == r.precision && one.inverse_interval_steps == r.inverse_interval_steps) {
        r.speedup_over_1_thread = r.tet_steps_per_s / one.tet_steps_per_s;
      }
    }
  }
  return records;
}

void WriteSimBenchJson(const std::string& path, const std::vector<SimBenchRecord>& records) {
  std::vector<std::string> texts;
  for (const SimBenchRecord& r : records) {
    const nlohmann::ordered_json record = {{"mesh", r.mesh},
                                           {"mesh_tets", r.mesh_tets},
                                           {"mesh_nodes", r.mesh_nodes},
                                           {"threads", r.threads},
                                           {"precision", sim::ToString(r.precision)},
                                           {"mode", r.mode},
                                           {"tet_steps_per_s", Significant(r.tet_steps_per_s, 6)},
                                           {"tet_steps_per_s_min", Significant(r.tet_steps_per_s_min, 6)},
                                           {"tet_steps_per_s_max", Significant(r.tet_steps_per_s_max, 6)},
                                           {"speedup_over_1_thread", Significant(r.speedup_over_1_thread, 4)},
                                           {"barrier_ns", Significant(r.barrier_ns, 4)},
                                           {"nothing_shared_tet_steps_per_s", Significant(r.nothing_shared_tet_steps_per_s, 6)},
                                           {"resident_mb", Significant(r.resident_mb, 4)},
                                           {"realtime_factor", Significant(r.realtime_factor, 6)},
                                           {"dt_s", Significant(r.dt_s, 6)},
                                           {"dt_critical_s", Significant(r.dt_critical_s, 6)},
                                           {"steps_per_repeat", r.steps_per_repeat},
                                           {"repeats", r.repeats},
                                           {"sequential_tet_steps_per_s", Significant(r.sequential_tet_steps_per_s, 6)},
                                           {"concurrent_gain", Significant(r.concurrent_gain, 4)},
                                           {"inverse_interval_steps", r.inverse_interval_steps},
                                           {"motion_error_m", Significant(r.motion_error_m, 4)}};
    texts.push_back(JsonText(record, -1));
  }
  WriteBenchJson(path, texts);
}

std::string SimBenchTable(const std::vector<SimBenchRecord>& records) {
  std::string table =
      "| mode | mesh | tets | nodes | precision | threads | M tet-steps/s (median) | min-max | x 1 thread | "
      "barrier ns | nothing shared M | resident MB | real-time factor | concurrent gain | inverse every | motion error um | dt_cr ms |\n"
      "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SimBenchRecord& r : records) {
    char gain[16] = "-", speedup[16] = "-", barrier[16] = "-", interval[16] = "-", error[16] = "-", apart[16] = "-";
    if (r.nothing_shared_tet_steps_per_s > 0) std::snprintf(apart, sizeof apart, "%.1f", r.nothing_shared_tet_steps_per_s / 1e6);
    if (r.concurrent_gain > 0) std::snprintf(gain, sizeof gain, "%.2f", r.concurrent_gain);
    if (r.inverse_interval_steps > 0) {
      std::snprintf(interval, sizeof interval, "%d", r.inverse_interval_steps);
      std::snprintf(error, sizeof error, "%.1f", r.motion_error_m * 1e6);
    }
    if (r.speedup_over_1_thread > 0) std::snprintf(speedup, sizeof speedup, "%.2f", r.speedup_over_1_thread);
    if (r.barrier_ns > 0) std::snprintf(barrier, sizeof barrier, "%.0f", r.barrier_ns);
    table += Printed("| %s | %s | %d | %d | %s | %d | %.1f | %.1f-%.1f | %s | %s | %s | %.0f | %.2f | %s | %s | %s | %.3f |\n",
                     r.mode.c_str(), r.mesh.c_str(), r.mesh_tets, r.mesh_nodes, sim::ToString(r.precision).c_str(), r.threads,
                     r.tet_steps_per_s / 1e6, r.tet_steps_per_s_min / 1e6, r.tet_steps_per_s_max / 1e6, speedup,
                     barrier, apart, r.resident_mb, r.realtime_factor, gain, interval, error, r.dt_critical_s * 1e3);
  }
  return table;
}

}  // namespace dg::tools
