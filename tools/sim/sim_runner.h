#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/sim_problem.h"
#include "sim/precision.h"
#include "sim/stability.h"
#include "sim/tet_mesh.h"

namespace dg::tools {

struct SimRunOptions {
  std::string out_dir = "out/sim";  // sim.xmf + sim.h5 (time series), final.vtu, summary.json
  bool write_output = true;
  int threads = 0;                  // as set by the caller's tbb::global_control; for the summary
  bool progress = true;             // progress on stderr
};

struct SimSummary {
  int nodes = 0, tets = 0;
  sim::Precision precision = sim::Precision::kFloat;
  int threads = 0;
  long long steps = 0;              // time steps of dt_s (substeps counted in substeps_per_step)
  int substeps_per_step = 1;
  double dt_s = 0, simulated_s = 0;
  double wall_s = 0;                // stepping only, output excluded
  double tet_steps_per_s = 0;       // tets x internal steps / wall_s
  double realtime_factor = 0;       // simulated seconds per wall second
  sim::StabilityReport stability;
  double max_displacement_m = 0;
  int max_displacement_node = -1;
  std::vector<std::pair<std::string, Eigen::Vector3d>> reactions_n;  // per prescribed condition
  Eigen::Matrix3Xd final_displacement_m;
  int output_steps = 0;
  std::string output_files;

  // The human-readable summary printed by `dynaguide sim`.
  std::string Describe() const;
};

// Runs a problem on its mesh in the problem's precision, writing outputs as it
// goes. On a dg::Error (inversion, blow-up, ...) the outputs written so far stay
// readable and are marked incomplete, and the error is rethrown.
SimSummary RunSimProblem(const io::SimProblem& problem, const sim::TetMesh& mesh, const SimRunOptions& options);

// What a run writes into out_dir (names and their temporaries): a run holds
// the folder (io::OutputFolderClaim) and removes what an earlier run left
// under these names before it writes.
std::vector<std::string> SimOutputNames();

}  // namespace dg::tools
