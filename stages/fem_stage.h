#pragma once

#include <memory>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "sim/coupled_simulation.h"
#include "sim/motion_model.h"
#include "sim/precision.h"
#include "sim/tet_mesh.h"
#include "stages/constraints/constraint_mapper.h"
#include "stages/constraints/gap_targets.h"
#include "stages/register/phase_estimate.h"

namespace dg::stages {

// What the FEM stage logs for one video frame (the run log's /sim).
struct FemFrameRecord {
  int frame = 0;
  long long step = 0;                      // simulation step reached: round(t_j / dt)
  double time_s = 0;                       // step * dt
  int substeps = 0;                        // steps taken for this frame
  int frames_bridged = 0;                  // frame periods advanced: 1, more after dropped frames, 0 at the start
  std::vector<float> sampled_nodes_S_m;    // 3 per sampled node (FemStage::sampled_nodes()), scan frame
  double kinetic_energy_j = 0;
  double min_jacobian = 0;                 // smallest element J at the last step
  int constrained_nodes = 0;
  int gated_features = 0;                  // tied features left out as outliers (ConstraintMapper)
  // |node displacement - target| over this frame's constrained nodes at the
  // frame's time: zero where the simulation holds them (surface, combined),
  // the forces-only model's miss of the tracked surface in volume mode.
  double constraint_residual_rms_mm = 0, constraint_residual_max_mm = 0;
  double dt_over_dt_critical = 0;          // stability margin
  // The phase of the motion driving the inverse simulation at this step, in
  // [0, 1), and its rate (cycles per second): the live estimate, steered (docs/phase.md).
  double motion_phase = 0, motion_rate_hz = 0;
};

struct FemFrameOutput {
  Eigen::Matrix3Xd nodes_S_m;  // every node's position, scan frame, for the overlays
  FemFrameRecord record;
};

// The FEM step of the graph: per video frame j, advances
// the image-constrained simulation (sim/coupled_simulation.h) to step
// round(t_j / dt), t_j = j / fps, so the simulation clock never drifts from
// the video's: one frame period at a time (166 or 167 substeps at 30 fps and
// 0.2 ms), with the constrained nodes' targets interpolated linearly across
// each period's substeps. When frames were dropped before frame j, it bridges
// the gap period by period, the targets at each skipped frame's time given by
// GapTargets (the scan's motion plus the interpolated residual when the stage
// has a predictor, else a bounded speed), never one straight line across the
// gap. Runs in float, as the paper's GPU solver did, or in double when asked.
// Stateful: frames in increasing order, one at a time (a serial node).
class FemStage {
 public:
  struct Options {
    sim::SimulationMode mode = sim::SimulationMode::kCombined;
    double dt_s = 2e-4;
    double damping_per_s = 75;         // the paper's alpha
    double fps = 30;
    double phase_at_first_frame = 0;   // the registration's cardiac phase of frame 0
    int sampled_nodes = 256;           // nodes logged per frame (SampledNodeIds)
    bool concurrent = true;            // inverse beside forward (false: one after the other)
    int inverse_interval_steps = sim::kDefaultInverseIntervalSteps;  // steps per level of recovered forces
    sim::Precision precision = sim::Precision::kFloat;  // the simulation's scalar
    sim::HelperLauncher launch_helper; // where the solver's helper workers run (empty: the caller's TBB arena)
    std::string Validate() const;      // empty when valid
  };

  // `motion` drives the inverse simulation (null in surface mode). `predictor`
  // (may be null) predicts the constraints across dropped frames: the scan's
  // motion whenever the scene has one, in surface mode too, where it applies
  // no force. fixed_nodes: the mount's. `stability` (optional): the mesh's
  // estimate with the mount held, when the caller made it ahead (else made here).
  // @throws dg::Error for invalid options, a motion model for another mesh,
  // an unstable time step or a degenerate motion model (sim::CoupledSimulation).
  FemStage(const Options& options, const sim::TetMesh& mesh, const sim::Material& material,
           std::shared_ptr<const sim::CyclicMotionModel> motion,
           std::shared_ptr<const sim::CyclicMotionModel> predictor, const std::vector<int>& fixed_nodes,
           const sim::StabilityReport* stability = nullptr);

  // The node displacements at frame 0 (the motion model at the registered
  // phase, zero without one): what ConstraintMapper needs.
  Eigen::Matrix3Xd first_displacement_S_m() const;

  // `phase` (optional): the heart's phase at this frame as the video shows it;
  // the motion driving the inverse simulation and predicting the constraints
  // is steered onto it over the next frame period (docs/phase.md). Without
  // it, the phase runs on from phase_at_first_frame at the last rate.
  // @pre frames increase. @throws dg::Error for a frame earlier than the last
  // one, a target on a fixed node, or a simulation failure (inversion, blow-up).
  FemFrameOutput Process(int frame, const NodeTargets& targets, const PhaseEstimate* phase = nullptr);
  // The same into `output`, reusing its storage.
  void Process(int frame, const NodeTargets& targets, FemFrameOutput* output, const PhaseEstimate* phase = nullptr);

  const std::vector<int>& sampled_nodes() const { return sampled_nodes_; }
  const sim::StabilityReport& stability() const;

 private:
  template <typename T>
  void Step(sim::CoupledSimulation<T>& simulation, int from_frame, int frame, const NodeTargets& targets,
            const PhaseEstimate* phase, FemFrameOutput* into);
  long long StepOf(int frame) const;

  Options options_;
  Eigen::Matrix3Xd reference_S_m_;
  std::variant<std::unique_ptr<sim::CoupledSimulation<float>>, std::unique_ptr<sim::CoupledSimulation<double>>>
      simulation_;
  std::vector<int> sampled_nodes_;
  int last_frame_ = -1;
  GapTargets gap_;
  std::vector<double> start_m_, period_targets_m_;  // scratch, kept from frame to frame
};

// The nodes a FEM stage logs: `samples` ids spread evenly over 0..nodes-1
// (all of them when samples >= nodes).
std::vector<int> SampledNodeIds(int nodes, int samples);

// The scan's motion model from an HDF5 file with /phases/node_displacement_m
// [phase, node, xyz] (as `dynaguide phantom` writes scan.h5).
// @throws dg::Error for a missing file or dataset, or a node count other than the mesh's.
std::shared_ptr<const sim::CyclicMotionModel> LoadMotionModel(const std::string& scan_h5, int mesh_nodes,
                                                              double period_s, double smoothing = 0.0);

}  // namespace dg::stages
