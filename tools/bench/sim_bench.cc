#include "tools/bench/sim_bench.h"

#include <malloc.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <random>
#include <thread>

#include <nlohmann/json.hpp>

#include "io/gmsh_mesher.h"
#include "io/gmsh_reader.h"
#include "sim/coupled_simulation.h"
#include "sim/error.h"
#include "sim/step_team.h"
#include "sim/tled_solver.h"
#include "tools/bench/bench_json.h"
#include "tools/bench/host_interruptions.h"
#include "tools/bench/machine_peaks.h"
#include "tools/bench/rounds.h"
#include "tools/bench/run_together.h"
#include "tools/json_text.h"
#include "tools/phantom/heart_motion.h"
#include "tools/phantom/phantom_spec.h"

namespace dg::tools {
namespace {

constexpr double kPressDown_m = 1e-3;

// Values scaled and joined with '/', one decimal each: "86.2/88.9".
std::string SlashJoined(const std::vector<double>& values, double scale) {
  std::string text;
  for (size_t i = 0; i < values.size(); ++i) text += Printed("%s%.1f", i == 0 ? "" : "/", values[i] * scale);
  return text;
}

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

// The forward problems, in groups timed in the same rounds: each target
// size's Gmsh box, or the given file, with its shuffled copy when asked (so
// that the two orders are compared over the same minutes of the host). Boxes
// asked for beside a file join the file's group, for the same reason.
std::vector<std::vector<BenchProblem>> ForwardProblems(const SimBenchOptions& options) {
  const bool file = !options.mesh_path.empty();
  std::vector<std::pair<std::string, sim::TetMesh>> meshes;
  if (file) meshes.emplace_back(options.mesh_path, io::ReadGmsh(options.mesh_path));
  if (!file || options.boxes_beside_file) {
    for (int target : options.tets) {
      meshes.emplace_back("Gmsh box", io::MeshBox({Eigen::Vector3d(0.05, 0.05, 0.05), target}));
    }
  }
  std::vector<std::vector<BenchProblem>> groups;
  for (auto& [name, mesh] : meshes) {
    std::vector<BenchProblem>& group = file && !groups.empty() ? groups.back() : groups.emplace_back();
    if (options.shuffled_too) group.push_back(MakeBenchProblem(name + ", nodes shuffled", ShuffleNodes(mesh)));
    group.push_back(MakeBenchProblem(name, std::move(mesh)));
  }
  return groups;
}

// Nanoseconds per pass of a StepTeam of `threads` workers with nothing to
// do: the barrier (and the serial section's call) a forward step pays once.
// A helper joins a run once its thread is free (sim/step_team.h), and passes
// the caller runs alone synchronise nothing: the clock runs over the 20,000
// passes from the first one every worker took part in (some 10 ms, short
// enough to sample between every round). 0, with a warning, when the
// workers have not all joined within a second.
double MeasureBarrierNs(int threads) {
  if (threads < 2) return 0;
  using Clock = std::chrono::steady_clock;
  constexpr int kSyncs = 20000;
  constexpr std::chrono::seconds kJoinLimit{1};
  sim::StepTeam team(threads);
  struct alignas(64) Joined {
    bool yes = false;  // written by one worker only
  };
  std::vector<Joined> joined(threads);
  const Clock::time_point called = Clock::now();
  Clock::time_point start, end;
  int first_full_pass = -1;
  team.Run(
      std::numeric_limits<int>::max(), [&](int worker, int) { joined[worker].yes = true; },
      [&](int pass) {  // serial: every worker of this pass has arrived
        if (first_full_pass >= 0) {
          if (pass - first_full_pass < kSyncs) return true;
          end = Clock::now();
          return false;
        }
        if (std::all_of(joined.begin(), joined.end(), [](const Joined& worker) { return worker.yes; })) {
          first_full_pass = pass;
          start = Clock::now();
        }
        return first_full_pass >= 0 || Clock::now() - called < kJoinLimit;
      });
  if (first_full_pass < 0) {
    std::fprintf(stderr, "bench sim: warning: the barrier of %d threads was not measured: its workers did not all "
                 "join a run within a second (is the machine busy?)\n", threads);
    return 0;
  }
  return std::chrono::duration<double, std::nano>(end - start).count() / kSyncs;
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
                          const std::vector<double>& rates, double resident_mb,
                          const sim::StabilityReport& stability, const SimBenchOptions& options) {
  SimBenchRecord record;
  record.mesh = name;
  record.mesh_tets = mesh.num_tets();
  record.mesh_nodes = mesh.num_nodes();
  record.threads = threads;
  record.precision = sim::PrecisionOf<T>();
  record.mode = mode;
  record.tet_steps_per_s = MedianOfSorted(rates);
  record.tet_steps_per_s_min = rates.front();
  record.tet_steps_per_s_max = rates.back();
  record.realtime_factor = record.tet_steps_per_s / mesh.num_tets() * options.dt_s;
  record.dt_s = options.dt_s;
  record.dt_critical_s = stability.dt_critical_s;
  record.steps_per_repeat = StepsPerRepeat(options);
  record.repeats = options.repeats;
  record.resident_mb = resident_mb;
  return record;
}

// The team a run on `threads` threads gets: as many workers as the process's
// parallelism allows, the model built for as many parts (docs/solver.md,
// "Subdomains").
int TeamSize(int threads) { return std::min(threads, sim::DefaultTeamSize()); }

// Samples, between rounds, the machine a team of each size that runs on more
// than one thread meets: its barrier, and what the host takes from that many
// cores (tools/bench/host_interruptions.h); and each core's speed alone at
// loads and stores (tools/bench/machine_peaks.h).
class MachineSamples {
 public:
  explicit MachineSamples(const std::vector<int>& threads)
      : core_load_store_(std::max(1u, std::thread::hardware_concurrency())) {
    for (int t : threads) {
      if (TeamSize(t) > 1) samples_[TeamSize(t)];
    }
  }
  void Sample() {
    for (auto& [team, samples] : samples_) {
      samples.barrier_ns.push_back(MeasureBarrierNs(team));
      samples.host.push_back(MeasureHostInterruptions(team, kHostSample));
    }
    const std::vector<double> now = EachCoreLoadStoreGbPerS(kCoreSample);
    for (size_t core = 0; core < core_load_store_.size(); ++core) core_load_store_[core].push_back(now[core]);
  }
  // Per core, the median of its samples; NaN for a core the process may not run on.
  std::vector<double> CoreLoadStore() const {
    std::vector<double> medians;
    for (std::vector<double> samples : core_load_store_) {
      std::erase_if(samples, [](double gb_s) { return std::isnan(gb_s); });
      std::sort(samples.begin(), samples.end());
      medians.push_back(samples.empty() ? std::numeric_limits<double>::quiet_NaN() : MedianOfSorted(samples));
    }
    return medians;
  }
  // Medians at `threads` threads; 0 on one.
  double BarrierNs(int threads) {
    Samples* samples = Find(threads);
    if (!samples) return 0;
    std::sort(samples->barrier_ns.begin(), samples->barrier_ns.end());
    return MedianOfSorted(samples->barrier_ns);
  }
  HostInterruptions Host(int threads) {
    Samples* samples = Find(threads);
    if (!samples) return {};
    auto median = [&](double HostInterruptions::*field) {
      std::vector<double> values;
      for (const HostInterruptions& host : samples->host) values.push_back(host.*field);
      std::sort(values.begin(), values.end());
      return MedianOfSorted(values);
    };
    return {median(&HostInterruptions::per_core_percent), median(&HostInterruptions::any_core_percent),
            median(&HostInterruptions::gaps_per_ms)};
  }

 private:
  // Long enough for some tens of the host's interruptions, short enough to
  // sample between every round.
  static constexpr std::chrono::milliseconds kHostSample{20};
  static constexpr std::chrono::milliseconds kCoreSample{10};
  std::vector<std::vector<double>> core_load_store_;  // per core
  struct Samples {
    std::vector<double> barrier_ns;
    std::vector<HostInterruptions> host;
  };
  Samples* Find(int threads) {
    const auto found = samples_.find(TeamSize(threads));
    return found == samples_.end() ? nullptr : &found->second;
  }
  std::map<int, Samples> samples_;
};

// Where the workers of `team` that joined spent a step of the timed repeats
// (its timing reset after the warm-up, when the solver had taken
// `steps_before`; a pass may hold several steps). A team of one records nothing.
template <typename T>
void RecordTeamTiming(sim::TledSolver<T>& solver, long long steps_before, SimBenchRecord* record) {
  std::vector<sim::StepTeam::WorkerTime> joined = solver.team().Timing();
  std::erase_if(joined, [](const sim::StepTeam::WorkerTime& time) { return time.passes == 0; });
  const double steps = double(solver.steps_taken() - steps_before);
  for (const sim::StepTeam::WorkerTime& time : joined) {
    const double per_step_us = 1e6 / steps;
    record->working_us_per_step.push_back(time.working_s * per_step_us);
    record->barrier_us_per_step += (time.waiting_s + time.serial_s) * per_step_us / double(joined.size());
    record->long_waits_us_per_step += time.long_waiting_s * per_step_us / double(joined.size());
  }
}

template <typename T>
std::unique_ptr<sim::TledSolver<T>> MakeForwardSolver(const BenchProblem& problem, int team,
                                                      const SimBenchOptions& options) {
  sim::SolverOptions solver_options;
  solver_options.dt_s = options.dt_s;
  solver_options.threads = team;
  return std::make_unique<sim::TledSolver<T>>(
      std::make_shared<const sim::TledModel<T>>(problem.mesh, sim::Material{}, team), problem.conditions,
      solver_options, &problem.stability);
}

// Repeats of `solvers`, all stepped at once, each on a thread and a core of
// its own when there are several (RunTogether). With several, `each_rates`
// gets, per solver, its tet-steps per second over its own time in each call
// of the timed repeats (cleared after the warm-up).
template <typename T>
TimedConfiguration ForwardConfiguration(const std::vector<std::unique_ptr<sim::TledSolver<T>>>& solvers,
                                        const BenchProblem& problem, const std::vector<double>& targets,
                                        const SimBenchOptions& options,
                                        std::vector<std::vector<double>>* each_rates = nullptr) {
  const int substeps = solvers.front()->substeps_per_step();
  TimedConfiguration timed;
  timed.steps_per_repeat = StepsPerRepeat(options) * substeps;
  timed.work_per_step = double(solvers.size()) * problem.mesh.num_tets();
  const double tets = problem.mesh.num_tets();
  if (each_rates) {
    each_rates->assign(solvers.size(), {});
    timed.after_warm_up = [each_rates] {
      for (std::vector<double>& rates : *each_rates) rates.clear();
    };
  }
  timed.advance = [&solvers, &targets, substeps, tets, each_rates](int steps) {
    if (solvers.size() == 1) {
      solvers.front()->Advance(steps / substeps, targets);
      return;
    }
    RunTogether(static_cast<int>(solvers.size()), [&](int t, std::chrono::steady_clock::time_point start) {
      solvers[t]->Advance(steps / substeps, targets);
      if (!each_rates) return;
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      (*each_rates)[t].push_back(double(steps) * tets / seconds);  // this thread's own list
    });
  };
  return timed;
}

// One record per problem of `group` and thread count: the solver on a team
// of that many threads and, beside it on 2 or more, as many one-thread
// solvers as threads, each on its own copy of the model, stepped at once
// (nothing shared: what the machine gives this kernel on those cores, the
// threaded rate's ceiling). All of the group's are timed in the same rounds.
template <typename T>
std::vector<SimBenchRecord> MeasureForward(const std::vector<BenchProblem>& group, const SimBenchOptions& options) {
  using Solvers = std::vector<std::unique_ptr<sim::TledSolver<T>>>;
  const size_t counts = options.threads.size();
  // Per problem: its targets, and per thread count its memory (measured with
  // nothing else alive), its team and its solvers sharing nothing. Sized
  // before any configuration refers to them.
  struct Measured {
    std::vector<double> targets, resident_mb;
    std::vector<Solvers> teams, apart;
    std::vector<std::vector<std::vector<double>>> apart_each_rates;  // per thread count, per solver
    std::vector<size_t> team_config, apart_config;  // indices into `timed`
    std::vector<long long> team_steps_timed_from;    // per thread count: the team's steps at the warm-up's end
  };
  std::vector<Measured> measured(group.size());
  std::vector<TimedConfiguration> timed;
  for (size_t p = 0; p < group.size(); ++p) {
    Measured& m = measured[p];
    m.targets.assign(group[p].conditions.prescribed_dofs.size(), -kPressDown_m);
    for (int threads : options.threads) {
      const auto solver = MakeForwardSolver<T>(group[p], TeamSize(threads), options);
      solver->Advance(1, m.targets);
      m.resident_mb.push_back(ResidentMegabytes());
    }
  }
  for (size_t p = 0; p < group.size(); ++p) {
    const BenchProblem& problem = group[p];
    Measured& m = measured[p];
    m.teams.resize(counts);
    m.apart.resize(counts);
    m.apart_each_rates.resize(counts);
    m.apart_config.assign(counts, 0);
    m.team_steps_timed_from.assign(counts, 0);
    for (size_t k = 0; k < counts; ++k) {
      m.teams[k].push_back(MakeForwardSolver<T>(problem, TeamSize(options.threads[k]), options));
      m.team_config.push_back(timed.size());
      timed.push_back(ForwardConfiguration<T>(m.teams[k], problem, m.targets, options));
      timed.back().after_warm_up = [&solver = *m.teams[k].front(), &from = m.team_steps_timed_from[k]] {
        solver.team().ResetTiming();
        from = solver.steps_taken();
      };
      if (options.threads[k] < 2) continue;
      for (int t = 0; t < options.threads[k]; ++t) m.apart[k].push_back(MakeForwardSolver<T>(problem, 1, options));
      m.apart_config[k] = timed.size();
      timed.push_back(ForwardConfiguration<T>(m.apart[k], problem, m.targets, options, &m.apart_each_rates[k]));
    }
  }
  MachineSamples machine(options.threads);
  TimeInRounds(timed, options.repeats, [&] { machine.Sample(); });

  std::vector<SimBenchRecord> records;
  for (size_t p = 0; p < group.size(); ++p) {
    const BenchProblem& problem = group[p];
    const Measured& m = measured[p];
    for (size_t k = 0; k < counts; ++k) {
      SimBenchRecord record = MakeRecord<T>(problem.name, problem.mesh, options.threads[k], "forward",
                                            timed[m.team_config[k]].rates, m.resident_mb[k], problem.stability,
                                            options);
      record.barrier_ns = machine.BarrierNs(options.threads[k]);
      record.host = machine.Host(options.threads[k]);
      record.core_load_store_gb_s = machine.CoreLoadStore();
      if (options.threads[k] > 1) {
        record.nothing_shared_tet_steps_per_s = MedianOfSorted(timed[m.apart_config[k]].rates);
        for (std::vector<double> rates : m.apart_each_rates[k]) {
          std::sort(rates.begin(), rates.end());
          record.each_core_alone_tet_steps_per_s.push_back(MedianOfSorted(rates));
        }
      }
      RecordTeamTiming(*m.teams[k].front(), m.team_steps_timed_from[k], &record);
      records.push_back(record);
    }
  }
  return records;
}

// The image-constrained simulation in one mode on the phantom, on a team of
// `team` workers, its constrained nodes (none in volume mode) set.
template <typename T>
std::unique_ptr<sim::CoupledSimulation<T>> MakeCoupled(const PhantomProblem& problem, sim::SimulationMode mode,
                                                       bool concurrent, int inverse_interval, int team,
                                                       const SimBenchOptions& options) {
  sim::CoupledOptions coupled;
  coupled.mode = mode;
  coupled.solver.dt_s = options.dt_s;
  coupled.solver.threads = team;
  coupled.concurrent = concurrent;
  coupled.inverse_interval_steps = inverse_interval;
  auto simulation = std::make_unique<sim::CoupledSimulation<T>>(
      std::make_shared<const sim::TledModel<T>>(problem.mesh, problem.material, team), problem.motion,
      problem.fixed_nodes, coupled, &problem.stability);
  if (mode != sim::SimulationMode::kVolume) simulation->SetConstrainedNodes(problem.constrained_nodes);
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

// Repeats of `simulation`, its constrained nodes following the motion model.
template <typename T>
TimedConfiguration CoupledConfiguration(sim::CoupledSimulation<T>& simulation, const PhantomProblem& problem,
                                        const SimBenchOptions& options) {
  TimedConfiguration timed;
  timed.steps_per_repeat = StepsPerRepeat(options);
  timed.work_per_step = problem.mesh.num_tets();
  timed.advance = [&simulation, motion = std::vector<T>(3 * size_t(problem.mesh.num_nodes())),
                   targets = std::vector<double>()](int steps) mutable {
    AdvanceFollowingMotion(simulation, steps, motion, targets);
  };
  return timed;
}

// The largest node distance from the motion model over one cardiac period,
// the constrained nodes led frame by frame at 30 Hz as a run leads them.
template <typename T>
double MotionError(const PhantomProblem& problem, sim::SimulationMode mode, int inverse_interval,
                   const SimBenchOptions& options) {
  const auto simulation = MakeCoupled<T>(problem, mode, true, inverse_interval, sim::DefaultTeamSize(), options);
  std::vector<T> motion(3 * size_t(problem.mesh.num_nodes()));
  std::vector<double> targets;
  const long long period_steps = std::llround(problem.motion->period_s() / options.dt_s);
  const int frame_steps = std::max(1, static_cast<int>(std::lround(1.0 / 30.0 / options.dt_s)));
  double largest = 0;
  while (simulation->steps_taken() < period_steps) {
    AdvanceFollowingMotion(*simulation, frame_steps, motion, targets);
    const std::span<const T> u = simulation->displacement();
    for (size_t a = 0; a < motion.size(); a += 3) {
      const double dx = double(u[a]) - motion[a], dy = double(u[a + 1]) - motion[a + 1],
                   dz = double(u[a + 2]) - motion[a + 2];
      largest = std::max(largest, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
  }
  return largest;
}

// One record per thread count: the concurrent scheme and, for the modes with
// recovered forces, the same run with inverse and forward one after the
// other, all timed in the same rounds.
template <typename T>
std::vector<SimBenchRecord> MeasureCoupled(const PhantomProblem& problem, const std::string& mode_name,
                                           int inverse_interval, const SimBenchOptions& options) {
  const sim::SimulationMode mode = sim::ParseSimulationMode(mode_name);
  const bool has_inverse = mode != sim::SimulationMode::kSurface;
  std::vector<double> resident_mb;  // each configuration's, with nothing else alive
  for (int threads : options.threads) {
    const auto simulation = MakeCoupled<T>(problem, mode, true, inverse_interval, TeamSize(threads), options);
    CoupledConfiguration<T>(*simulation, problem, options).advance(1);
    resident_mb.push_back(ResidentMegabytes());
  }
  std::vector<std::unique_ptr<sim::CoupledSimulation<T>>> simulations;
  std::vector<TimedConfiguration> timed;
  for (bool concurrent : {true, false}) {
    if (!concurrent && !has_inverse) continue;
    for (int threads : options.threads) {
      simulations.push_back(MakeCoupled<T>(problem, mode, concurrent, inverse_interval, TeamSize(threads), options));
      timed.push_back(CoupledConfiguration<T>(*simulations.back(), problem, options));
    }
  }
  MachineSamples machine(options.threads);
  TimeInRounds(timed, options.repeats, [&] { machine.Sample(); });

  const double motion_error_m = has_inverse ? MotionError<T>(problem, mode, inverse_interval, options) : 0;
  std::vector<SimBenchRecord> records;
  for (size_t k = 0; k < options.threads.size(); ++k) {
    SimBenchRecord record = MakeRecord<T>("phantom", problem.mesh, options.threads[k], mode_name, timed[k].rates,
                                          resident_mb[k], problem.stability, options);
    record.barrier_ns = machine.BarrierNs(options.threads[k]);
    record.host = machine.Host(options.threads[k]);
    record.core_load_store_gb_s = machine.CoreLoadStore();
    if (has_inverse) {
      record.sequential_tet_steps_per_s = MedianOfSorted(timed[options.threads.size() + k].rates);
      record.concurrent_gain = record.tet_steps_per_s / record.sequential_tet_steps_per_s;
      record.inverse_interval_steps = inverse_interval;
      record.motion_error_m = motion_error_m;
    }
    records.push_back(record);
  }
  return records;
}

}  // namespace

std::vector<SimBenchRecord> RunSimBench(const SimBenchOptions& options, bool progress) {
  if (options.repeats < 1) throw Error("--repeats must be at least 1", "dynaguide bench sim", "give e.g. 7");
  std::vector<SimBenchRecord> records;
  // Appends the records of one configuration's thread counts, and says them.
  auto add = [&](const std::vector<SimBenchRecord>& measured) {
    for (const SimBenchRecord& r : measured) {
      records.push_back(r);
      if (!progress) continue;
      std::fprintf(stderr, "bench sim: %s, %s, %d tets, %s, %d thread%s: %.1f M tet-steps/s (median of %d)\n",
                   r.mode.c_str(), r.mesh.c_str(), r.mesh_tets, sim::ToString(r.precision).c_str(), r.threads,
                   r.threads > 1 ? "s" : "", r.tet_steps_per_s / 1e6, r.repeats);
    }
  };
  for (const std::string& mode : options.modes) {
    if (mode != "forward") sim::ParseSimulationMode(mode);  // rejects an unknown mode before any work
  }
  for (const std::string& mode : options.modes) {
    if (mode == "forward") {
      for (const std::vector<BenchProblem>& group : ForwardProblems(options)) {
        for (sim::Precision precision : options.precisions) {
          add(precision == sim::Precision::kFloat ? MeasureForward<float>(group, options)
                                                  : MeasureForward<double>(group, options));
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
          add(precision == sim::Precision::kFloat ? MeasureCoupled<float>(problem, mode, interval, options)
                                                  : MeasureCoupled<double>(problem, mode, interval, options));
        }
      }
    }
  }
  for (SimBenchRecord& r : records) {
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
                                           {"each_core_alone_tet_steps_per_s", SignificantEach(r.each_core_alone_tet_steps_per_s, 6)},
                                           {"working_us_per_step", SignificantEach(r.working_us_per_step, 4)},
                                           {"barrier_us_per_step", Significant(r.barrier_us_per_step, 4)},
                                           {"long_waits_us_per_step", Significant(r.long_waits_us_per_step, 4)},
                                           {"host_took_percent", Significant(r.host.per_core_percent, 3)},
                                           {"host_took_any_core_percent", Significant(r.host.any_core_percent, 3)},
                                           {"host_gaps_per_ms", Significant(r.host.gaps_per_ms, 3)},
                                           {"core_load_store_gb_s", SignificantEach(r.core_load_store_gb_s, 3)},
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
      "barrier ns | nothing shared M (each core alone) | work us/step | at barrier us/step (long waits) | host took % (any core) | "
      "cores' L1 load/store GB/s | "
      "resident MB | real-time factor | concurrent gain | inverse every | motion error um | dt_cr ms |\n"
      "|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SimBenchRecord& r : records) {
    char gain[16] = "-", speedup[16] = "-", barrier[16] = "-", interval[16] = "-", error[16] = "-";
    char at_barrier[32] = "-", host[32] = "-";
    const std::string working = r.working_us_per_step.empty() ? "-" : SlashJoined(r.working_us_per_step, 1);
    std::string apart = "-";  // together, then each core alone: "166.0 (92.1/83.0)"
    if (!r.working_us_per_step.empty()) {
      std::snprintf(at_barrier, sizeof at_barrier, "%.1f (%.1f)", r.barrier_us_per_step, r.long_waits_us_per_step);
    }
    if (r.threads > 1) std::snprintf(host, sizeof host, "%.1f (%.1f)", r.host.per_core_percent, r.host.any_core_percent);
    if (r.nothing_shared_tet_steps_per_s > 0) {
      apart = Printed("%.1f", r.nothing_shared_tet_steps_per_s / 1e6);
      if (!r.each_core_alone_tet_steps_per_s.empty()) apart += " (" + SlashJoined(r.each_core_alone_tet_steps_per_s, 1e-6) + ")";
    }
    if (r.concurrent_gain > 0) std::snprintf(gain, sizeof gain, "%.2f", r.concurrent_gain);
    if (r.inverse_interval_steps > 0) {
      std::snprintf(interval, sizeof interval, "%d", r.inverse_interval_steps);
      std::snprintf(error, sizeof error, "%.1f", r.motion_error_m * 1e6);
    }
    if (r.speedup_over_1_thread > 0) std::snprintf(speedup, sizeof speedup, "%.2f", r.speedup_over_1_thread);
    if (r.barrier_ns > 0) std::snprintf(barrier, sizeof barrier, "%.0f", r.barrier_ns);
    table += Printed("| %s | %s | %d | %d | %s | %d | %.1f | %.1f-%.1f | %s | %s | %s | %s | %s | %s | %s | %.0f | %.2f | %s | %s | %s | %.3f |\n",
                     r.mode.c_str(), r.mesh.c_str(), r.mesh_tets, r.mesh_nodes, sim::ToString(r.precision).c_str(), r.threads,
                     r.tet_steps_per_s / 1e6, r.tet_steps_per_s_min / 1e6, r.tet_steps_per_s_max / 1e6, speedup,
                     barrier, apart.c_str(), working.c_str(), at_barrier, host, CoreLoadStoreText(r.core_load_store_gb_s).c_str(), r.resident_mb, r.realtime_factor, gain, interval, error, r.dt_critical_s * 1e3);
  }
  return table;
}

}  // namespace dg::tools
