#include "pipeline/mesh_series_sink.h"

#include <span>

#include <tbb/task_arena.h>

#include "sim/error.h"
#include "sim/inverse_dynamics.h"
#include "sim/tled_model.h"
#include "stages/fem_stage.h"

namespace dg::pipeline {
namespace {

constexpr char kTiedName[] = "tied";
constexpr char kForceName[] = "recovered_force_n";

io::XdmfSeriesOptions SeriesOptions() {
  io::XdmfSeriesOptions options;
  options.deformed_geometry = true;
  // A run may last minutes: the .xmf is rewritten at a sixteenth's growth and
  // at the end, so that its rewrites do not grow with the square of the frames.
  options.xmf_every_step = false;
  return options;
}

}  // namespace

MeshSeriesSink::MeshSeriesSink(const std::string& path, std::shared_ptr<const SimulationSetup> setup)
    : setup_(std::move(setup)), writer_(path, setup_->mesh, SeriesOptions()) {
  const int nodes = setup_->mesh.num_nodes();
  fields_.point_data.emplace_back(kTiedName, Eigen::RowVectorXd::Zero(nodes));
  if (setup_->motion) {
    sim::SolverOptions options;
    options.dt_s = setup_->options.dt_s;
    options.damping_per_s = setup_->options.damping_per_s;
    recovery_ = std::make_unique<sim::ForceRecovery<double>>(
        std::make_shared<const sim::TledModel<double>>(setup_->mesh, setup_->material), options);
    for (std::vector<double>& level : motion_m_) level.resize(3 * size_t(nodes));
    forces_n_.resize(3 * size_t(nodes));
    fields_.point_data.emplace_back(kForceName, Eigen::MatrixXd::Zero(3, nodes));
  }
}

MeshSeriesSink::~MeshSeriesSink() = default;

void MeshSeriesSink::RecoverForces(double phase, double rate_hz) {
  const sim::CyclicMotionModel& motion = *setup_->motion;
  const double dt_s = setup_->options.dt_s;
  for (int level = 0; level < 3; ++level) {
    motion.Evaluate<double>(phase + (level - 1) * dt_s * rate_hz, std::span<double>(motion_m_[level]));
  }
  // ForceRecovery runs its loops under tbb::parallel_for; an arena of one slot
  // keeps them on this thread, off the workers the graph's stages run on.
  tbb::task_arena alone(1);
  alone.execute([&] { recovery_->Recover(motion_m_[0], motion_m_[1], motion_m_[2], forces_n_); });
}

void MeshSeriesSink::Consume(const FramePacket& packet) {
  if (!packet.simulation) return;
  const stages::FemFrameOutput& simulation = *packet.simulation;
  displacement_m_ = simulation.nodes_S_m - setup_->mesh.X_m;
  Eigen::MatrixXd& tied = fields_.point_data[0].second;
  tied.setZero();
  for (int node : packet.targets.nodes) tied(0, node) = 1;
  if (recovery_) {
    RecoverForces(simulation.record.motion_phase, simulation.record.motion_rate_hz);
    fields_.point_data[1].second = Eigen::Map<const Eigen::MatrixXd>(forces_n_.data(), 3, setup_->mesh.num_nodes());
  }
  writer_.Append(packet.t_s, displacement_m_, fields_);
}

void MeshSeriesSink::Finish(bool complete) { writer_.Close(complete); }

}  // namespace dg::pipeline
