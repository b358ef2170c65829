#pragma once

#include <string>
#include <vector>

#include "sim/coupled_simulation.h"
#include "sim/precision.h"
#include "tools/bench/host_interruptions.h"

namespace dg::tools {

struct SimBenchOptions {
  // forward: the TLED solver alone on Gmsh boxes; combined, volume, surface:
  // the image-constrained simulation (sim/coupled_simulation.h) on the phantom.
  std::vector<std::string> modes{"forward"};
  std::vector<int> tets{5000, 20000, 80000};  // the phantom modes' default is the default phantom's 8000
  std::vector<int> threads{1, 2};
  // forward: a Gmsh .msh file (metres) instead of the generated boxes, in its
  // own node order: its lowest z face fixed, its highest pressed down.
  std::string mesh_path;
  bool shuffled_too = false;  // forward: also each mesh with its nodes in a random order
  // forward with a file: also the generated boxes of `tets`, timed in the
  // same rounds as the file, so that the two compare over the same minutes.
  bool boxes_beside_file = false;
  std::vector<sim::Precision> precisions{sim::Precision::kFloat, sim::Precision::kDouble};
  // combined and volume: forward steps per level of recovered forces
  // (sim::CoupledOptions::inverse_interval_steps), each measured.
  std::vector<int> inverse_intervals{sim::kDefaultInverseIntervalSteps};
  // Timed runs per configuration, in rounds that run every thread count's
  // configurations in turn (tools/bench/rounds.h); the median is reported.
  int repeats = 7;
  double simulated_per_repeat_s = 0.05;  // 250 steps of 0.2 ms
  double dt_s = 2e-4;
};

// One line of the saved table: the interface users script against.
struct SimBenchRecord {
  std::string mesh;  // where the mesh came from: "Gmsh box", "phantom", a file; ", nodes shuffled"
  int mesh_tets = 0;
  int mesh_nodes = 0;
  int threads = 0;
  sim::Precision precision = sim::Precision::kFloat;
  std::string mode;
  double tet_steps_per_s = 0;      // median over repeats
  double tet_steps_per_s_min = 0, tet_steps_per_s_max = 0;
  double realtime_factor = 0;      // simulated seconds per wall second at dt_s
  double dt_s = 0;
  double dt_critical_s = 0;
  int steps_per_repeat = 0, repeats = 0;
  // combined and volume only (else 0): the same run with inverse and forward
  // one after the other, and the concurrent scheme's gain over it.
  double sequential_tet_steps_per_s = 0;
  double concurrent_gain = 0;
  // combined and volume only (else 0): forward steps per level of recovered
  // forces, and the largest distance of a node from the motion model over one
  // cardiac period (sampled at 30 Hz), metres: the scheme's error, since the
  // recovered forces alone (volume) or with the surface following the motion
  // model (combined) should reproduce it.
  int inverse_interval_steps = 0;
  double motion_error_m = 0;
  // The rate over the same configuration's on 1 thread, timed in the same rounds (0 if not measured).
  double speedup_over_1_thread = 0;
  // The solver's barrier (a sim::StepTeam pass with no work), per pass, at
  // this thread count, the median of samples taken between the rounds; a
  // forward step has one.
  double barrier_ns = 0;
  // forward on 2 or more threads only (else 0): as many one-thread solvers as
  // threads, each on its own copy of the model, stepped at once, all their
  // tet-steps per second together: the machine's rate for this kernel on
  // that many cores with nothing shared, timed in the same rounds.
  double nothing_shared_tet_steps_per_s = 0;
  // The same one-thread solvers, each timed to its own end (else empty): one
  // rate a core, the median over the repeats. Their rate together is bound by
  // the slowest; a team that balances its work is bound by their sum. When
  // they differ, one thread's rate (on whichever core it ran) and the second
  // core's share of two differ for this kernel, measured in the same rounds.
  std::vector<double> each_core_alone_tet_steps_per_s;
  // forward on 2 or more threads only (else empty and 0): where the solver's
  // workers spent a step of the timed repeats (sim::StepTeam::Timing), us:
  // each worker's work, the workers' mean time at the barrier (waiting for
  // the others, or running the serial section), and of that the waits of
  // 10 us or more (a worker stopped, not behind by its share of the work).
  std::vector<double> working_us_per_step;
  double barrier_us_per_step = 0;
  double long_waits_us_per_step = 0;
  // On 2 or more threads (else 0): what the host took from that many cores,
  // the median of samples taken between the rounds (tools/bench/host_interruptions.h).
  HostInterruptions host;
  // Each logical core alone, between the rounds: L1 loads and stores, GB/s,
  // the median of its samples (tools/bench/machine_peaks.h). When the cores
  // differ, so do one thread's rate and the second core's share of two.
  std::vector<double> core_load_store_gb_s;
  // The process's resident memory with this configuration alone built and
  // stepped, the heap earlier configurations freed returned: its arrays, the
  // heap, and the pages of the libraries the program maps (docs/benchmarks.md).
  double resident_mb = 0;
};

// Forward TLED throughput on Gmsh boxes (5 cm, the paper's material, base
// fixed, top pressed down 1 mm) or on a mesh file, and the image-constrained simulation's on the
// phantom's mesh (its 4D CT's motion model, mount fixed, every third free
// surface node following the motion model as tracked features would), for
// every combination of the options. Tet-steps count each simulated step once
// per element, whatever the inverse simulation adds.
std::vector<SimBenchRecord> RunSimBench(const SimBenchOptions& options, bool progress);

// Writes the records as a JSON list, each with the machine it ran on.
void WriteSimBenchJson(const std::string& path, const std::vector<SimBenchRecord>& records);

// A plain-text table of the records, for the terminal and the README.
std::string SimBenchTable(const std::vector<SimBenchRecord>& records);

}  // namespace dg::tools
