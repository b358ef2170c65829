#include "stages/fem_stage.h"

#include <cmath>

#include "io/h5_file.h"
#include "sim/error.h"

namespace dg::stages {

std::string FemStage::Options::Validate() const {
  if (!(std::isfinite(dt_s) && dt_s > 0)) return "dt_s must be positive (the paper uses 2e-4 s)";
  if (!(std::isfinite(fps) && fps > 0)) return "fps must be positive";
  if (dt_s * fps > 1) return "dt_s must not exceed one frame period (1 / fps)";
  if (!std::isfinite(phase_at_first_frame)) return "phase_at_first_frame must be finite";
  if (sampled_nodes < 0) return "sampled_nodes must be zero or positive";
  return {};
}

FemStage::FemStage(const Options& options, const sim::TetMesh& mesh, const sim::Material& material,
                   std::shared_ptr<const sim::CyclicMotionModel> motion,
                   std::shared_ptr<const sim::CyclicMotionModel> predictor, const std::vector<int>& fixed_nodes,
                   const sim::StabilityReport* stability)
    : options_(options), reference_S_m_(mesh.X_m), gap_(predictor, options.phase_at_first_frame) {
  if (const std::string problem = options_.Validate(); !problem.empty()) {
    throw Error("invalid FEM stage options: " + problem, "FEM stage options", "correct the option");
  }
  if (predictor && predictor->dofs() != 3 * mesh.num_nodes()) {
    throw Error("the predicting motion model has " + std::to_string(predictor->dofs() / 3) + " nodes, the mesh " +
                    std::to_string(mesh.num_nodes()),
                mesh.source, "predict with the motion recorded for this mesh");
  }
  sim::CoupledOptions coupled;
  coupled.mode = options_.mode;
  coupled.solver.dt_s = options_.dt_s;
  coupled.solver.damping_per_s = options_.damping_per_s;
  coupled.phase_at_start = options_.phase_at_first_frame;
  coupled.concurrent = options_.concurrent;
  coupled.inverse_interval_steps = options_.inverse_interval_steps;
  coupled.solver.launch_helper = options_.launch_helper;
  if (options_.precision == sim::Precision::kDouble) {
    simulation_ = std::make_unique<sim::CoupledSimulation<double>>(
        std::make_shared<const sim::TledModel<double>>(mesh, material), std::move(motion), fixed_nodes, coupled,
        stability);
  } else {
    simulation_ = std::make_unique<sim::CoupledSimulation<float>>(
        std::make_shared<const sim::TledModel<float>>(mesh, material), std::move(motion), fixed_nodes, coupled,
        stability);
  }
  sampled_nodes_ = SampledNodeIds(mesh.num_nodes(), options_.sampled_nodes);
}

Eigen::Matrix3Xd FemStage::first_displacement_S_m() const {
  Eigen::Matrix3Xd u = Eigen::Matrix3Xd::Zero(3, reference_S_m_.cols());
  std::visit(
      [&](const auto& simulation) {
        const auto start = simulation->displacement();
        for (Eigen::Index a = 0; a < u.cols(); ++a) {
          for (int i = 0; i < 3; ++i) u(i, a) = start[3 * a + i];
        }
      },
      simulation_);
  return u;
}

const sim::StabilityReport& FemStage::stability() const {
  return std::visit([](const auto& simulation) -> const sim::StabilityReport& { return simulation->stability(); },
                    simulation_);
}

FemFrameOutput FemStage::Process(int frame, const NodeTargets& targets, const PhaseEstimate* phase) {
  FemFrameOutput output;
  Process(frame, targets, &output, phase);
  return output;
}

void FemStage::Process(int frame, const NodeTargets& targets, FemFrameOutput* into, const PhaseEstimate* phase) {
  if (frame <= last_frame_) {
    throw Error("frame " + std::to_string(frame) + " comes after frame " + std::to_string(last_frame_),
                "FEM stage", "feed frames in increasing order (a serial node behind a sequencer)");
  }
  if (targets.displacement_S_m.size() != 3 * targets.nodes.size()) {
    throw Error("targets hold " + std::to_string(targets.displacement_S_m.size()) + " values for " +
                    std::to_string(targets.nodes.size()) + " nodes",
                "FEM stage, frame " + std::to_string(frame), "give 3 values per constrained node");
  }
  const int from_frame = std::max(last_frame_, 0);  // the simulation starts at frame 0's time
  last_frame_ = frame;
  std::visit([&](auto& simulation) { Step(*simulation, from_frame, frame, targets, phase, into); }, simulation_);
}

long long FemStage::StepOf(int frame) const { return std::llround(frame / (options_.fps * options_.dt_s)); }

template <typename T>
void FemStage::Step(sim::CoupledSimulation<T>& simulation, int from_frame, int frame, const NodeTargets& targets,
                    const PhaseEstimate* phase, FemFrameOutput* into) {
  const long long substeps = StepOf(frame) - simulation.steps_taken();
  if (phase && phase->valid) {
    const double frame_s = StepOf(frame) * options_.dt_s;
    // The estimate is of the frame's time; the simulation is still at the previous frame's.
    simulation.SteerPhase(phase->phase - phase->rate_hz * (frame_s - simulation.time_s()), phase->rate_hz,
                          std::max(options_.dt_s, 1 / options_.fps));
    gap_.FollowPhase(frame_s, phase->phase, phase->rate_hz);
  }
  // In surface mode nothing but the constraints drives the mesh; in volume
  // mode the tracked surface is only measured against, not imposed.
  const bool constrain = options_.mode != sim::SimulationMode::kVolume;
  // Nodes tied anew start where the simulation has them (Advance moves each
  // constrained node from its current displacement), and so do their paths.
  simulation.SetConstrainedNodes(constrain ? targets.nodes : std::vector<int>{});
  period_targets_m_.clear();
  if (constrain) {
    const std::span<const T> u = simulation.displacement();
    start_m_.clear();
    for (int a : targets.nodes) {
      for (int i = 0; i < 3; ++i) start_m_.push_back(u[3 * size_t(a) + i]);
    }
    gap_.Begin(targets, start_m_, simulation.time_s(), StepOf(frame) * options_.dt_s);
  }
  // One frame period per Advance: within a period the linear path is a motion the tissue makes.
  for (int f = from_frame + 1; f <= frame; ++f) {
    if (constrain) gap_.At(StepOf(f) * options_.dt_s, &period_targets_m_);
    simulation.Advance(static_cast<int>(StepOf(f) - simulation.steps_taken()), period_targets_m_);
  }

  FemFrameOutput& output = *into;
  FemFrameRecord& record = output.record;
  record = FemFrameRecord{.sampled_nodes_S_m = std::move(record.sampled_nodes_S_m)};  // keeps its capacity
  record.sampled_nodes_S_m.clear();
  record.frame = frame;
  record.step = simulation.steps_taken();
  record.time_s = simulation.time_s();
  record.substeps = static_cast<int>(substeps);
  record.frames_bridged = frame - from_frame;
  const std::span<const T> u = simulation.displacement();
  output.nodes_S_m = reference_S_m_;
  for (Eigen::Index a = 0; a < output.nodes_S_m.cols(); ++a) {
    for (int i = 0; i < 3; ++i) output.nodes_S_m(i, a) += u[3 * a + i];
  }
  for (int a : sampled_nodes_) {
    for (int i = 0; i < 3; ++i) record.sampled_nodes_S_m.push_back(static_cast<float>(output.nodes_S_m(i, a)));
  }
  record.kinetic_energy_j = simulation.solver().kinetic_energy_j();
  record.min_jacobian = simulation.solver().min_jacobian();
  record.constrained_nodes = static_cast<int>(targets.nodes.size());
  record.gated_features = targets.gated_features;
  double sum_sq = 0;
  for (size_t k = 0; k < targets.nodes.size(); ++k) {
    double d_sq = 0;
    for (int i = 0; i < 3; ++i) {
      const double d = double(u[3 * size_t(targets.nodes[k]) + i]) - targets.displacement_S_m[3 * k + i];
      d_sq += d * d;
    }
    sum_sq += d_sq;
    record.constraint_residual_max_mm = std::max(record.constraint_residual_max_mm, std::sqrt(d_sq) * 1e3);
  }
  if (!targets.nodes.empty()) record.constraint_residual_rms_mm = std::sqrt(sum_sq / targets.nodes.size()) * 1e3;
  record.dt_over_dt_critical = options_.dt_s / simulation.stability().dt_critical_s;
  const double motion_phase = simulation.PhaseAtStep(simulation.steps_taken());
  record.motion_phase = motion_phase - std::floor(motion_phase);
  record.motion_rate_hz = simulation.phase_rate_hz();
}

std::vector<int> SampledNodeIds(int nodes, int samples) {
  samples = std::min(nodes, samples);
  std::vector<int> ids;
  for (int k = 0; k < samples; ++k) ids.push_back(static_cast<int>(std::int64_t(k) * nodes / samples));
  return ids;
}

std::shared_ptr<const sim::CyclicMotionModel> LoadMotionModel(const std::string& scan_h5, int mesh_nodes,
                                                              double period_s, double smoothing) {
  const io::H5Reader scan(scan_h5);
  io::H5Shape shape;
  const std::vector<double> displacement = scan.Read<double>("/phases/node_displacement_m", &shape);
  if (shape.size() != 3 || shape[2] != 3 || shape[1] != size_t(mesh_nodes)) {
    std::string dims;
    for (size_t d : shape) dims += (dims.empty() ? "" : " x ") + std::to_string(d);
    throw Error("/phases/node_displacement_m is " + dims + ", expected phases x " + std::to_string(mesh_nodes) + " x 3",
                scan_h5, "use the motion recorded for the scene's mesh");
  }
  return std::make_shared<const sim::CyclicMotionModel>(displacement, static_cast<int>(shape[0]), 3 * mesh_nodes,
                                                        period_s, smoothing);
}

}  // namespace dg::stages
