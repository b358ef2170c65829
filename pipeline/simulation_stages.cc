#include "pipeline/simulation_stages.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "io/gmsh_reader.h"
#include "pipeline/scene_geometry.h"
#include "sim/coupled_simulation.h"
#include "sim/error.h"
#include "sim/log.h"

namespace dg::pipeline {
namespace {

const std::vector<int>& NodeSet(const sim::TetMesh& mesh, const std::string& name, const std::string& scene_path) {
  const auto found = mesh.node_sets.find(name);
  if (found == mesh.node_sets.end()) {
    throw Error("the mesh has no node set '" + name + "'", scene_path,
                "name a physical group of the mesh in mesh.fixed_set / mesh.surface_set");
  }
  return found->second;
}

}  // namespace

RegisterAdapter::RegisterAdapter(const stages::RegistrationStage::Options& options, stages::FiducialMotion motion,
                                 const io::StereoCalibration& calibration, double period_s,
                                 const std::vector<Eigen::Vector2d>& first_uv_left_px, double near_m, double far_m,
                                 bool live_phase)
    : calibration_(calibration),
      near_m_(near_m),
      far_m_(far_m),
      first_phase_fiducials_S_m_(motion.positions_S_m.empty() ? Eigen::Matrix3Xd() : motion.positions_S_m.front()),
      geometry_(calibration),
      tracker_(stages::StartFiducialTracker(geometry_, first_uv_left_px, near_m, far_m)),
      stage_(options, motion, calibration, period_s) {
  if (live_phase) phase_ = std::make_unique<stages::PhaseTracker>(stages::PhaseTracker::Options{}, std::move(motion),
                                                                  geometry_, period_s);
  for (const Eigen::Vector2d& uv : first_uv_left_px) {
    Eigen::Vector2d uv_R(-1, -1);
    geometry_.LeftToRectified(uv, &uv_R);  // StartFiducialTracker refused a pixel outside the field
    first_uv_left_R_px_.emplace_back(static_cast<float>(uv_R.x()), static_cast<float>(uv_R.y()));
  }
}

void RegisterAdapter::CheckFirstFrameDepths(const FramePacket& packet,
                                            const std::vector<stages::FiducialObservation>& seen) const {
  // Fiducials the range did not match are searched along the whole row once:
  // found there, their depth is measured, and it lies outside the range.
  if (std::all_of(seen.begin(), seen.end(), [](const stages::FiducialObservation& o) { return o.valid; })) return;
  stages::StereoMatcher::Options whole_row;
  whole_row.min_disparity_px = 0;
  whole_row.max_disparity_px = packet.rectified.left.cols - 1;
  const std::vector<stages::StereoMatch> matches =
      stages::StereoMatcher(whole_row).Match(packet.rectified.left, packet.rectified.right, first_uv_left_R_px_);
  std::vector<double> depths_m;
  bool outside = false;
  for (size_t i = 0; i < seen.size(); ++i) {
    const Eigen::Vector2d uv(first_uv_left_R_px_[i].x, first_uv_left_R_px_[i].y);
    if (seen[i].valid) {
      depths_m.push_back(geometry_.Triangulate(uv, seen[i].uv_left_R_px.x - seen[i].uv_right_R_px.x).z());
    } else if (matches[i].valid && matches[i].disparity_px > 0) {
      depths_m.push_back(geometry_.Triangulate(uv, matches[i].disparity_px).z());
      outside = true;
    }
  }
  if (!outside) return;
  CheckWorkingDistance(depths_m, "the fiducials, matched in the first stereo pair,", calibration_, near_m_, far_m_,
                       "stage 'register', frame " + std::to_string(packet.index),
                       "check the calibration (its T in metres) is the camera's that recorded the video");
}

void RegisterAdapter::Process(FramePacket& packet) {
  if (!result_ || phase_) {
    const std::vector<stages::FiducialObservation> seen =
        tracker_.Process(packet.rectified.left, packet.rectified.right);
    if (phase_) ObservePhase(packet.t_s, seen);
    if (!result_) Register(packet, seen);
  }
  packet.registration = result_;
  packet.registration_solve = solve_;
  if (phase_ && result_) {
    if (!phase_->started()) {
      phase_->Start(Eigen::Isometry3d(result_->T_C_S), packet.t_s,
                    (packet.t_s + result_->phase_shift_s) / result_->period_s, 1 / result_->period_s);
    }
    packet.phase = phase_->Estimate();
  }
}

void RegisterAdapter::ObservePhase(double t_s, const std::vector<stages::FiducialObservation>& seen) {
  phase_sightings_.resize(seen.size());
  for (size_t i = 0; i < seen.size(); ++i) {
    phase_sightings_[i].valid = seen[i].valid;
    phase_sightings_[i].uvd_px = {seen[i].uv_left_R_px.x, seen[i].uv_left_R_px.y,
                                  seen[i].uv_left_R_px.x - seen[i].uv_right_R_px.x};
  }
  phase_->Observe(t_s, phase_sightings_);
}

void RegisterAdapter::Register(const FramePacket& packet, const std::vector<stages::FiducialObservation>& seen) {
  if (first_frame_) CheckFirstFrameDepths(packet, seen);
  first_frame_ = false;
  std::vector<stages::FiducialSighting> sightings;
  for (const stages::FiducialObservation& observation : seen) {
    sightings.push_back(stages::SightingFromRectified(observation, geometry_));
  }
  if (!stage_.Process(packet.t_s, std::move(sightings))) return;
  solve_ = std::make_shared<const stages::RegistrationResult>(stage_.Solve());
  result_ = std::shared_ptr<const io::Registration>(solve_, &solve_->registration);
  Logger("pipeline").info("registered at frame {}: phase shift {:.2f} ms, residual {:.3f} / {:.3f} px", packet.index,
                          1e3 * result_->phase_shift_s, result_->left.mean_px, result_->right.mean_px);
  // The pose places the scan: its fiducials' depths, before any frame is simulated with it.
  CheckWorkingDistance(DepthsInCamera(result_->T_C_S, first_phase_fiducials_S_m_),
                       "the scan's fiducials, placed by the registration,", calibration_, near_m_, far_m_,
                       "stage 'register', frame " + std::to_string(packet.index),
                       "check the scan's fiducials are in metres (scan.h5 /phases/fiducials_S_m)");
}

double SimulationSetup::PhaseAt(const FramePacket& packet) {
  if (packet.phase.valid) return packet.phase.phase;
  return (packet.t_s + packet.registration->phase_shift_s) / packet.registration->period_s;
}

std::shared_ptr<const SimulationSetup> LoadSimulationSetup(const io::Scene& scene) {
  if (!scene.simulation) throw Error("the scene has no simulation", scene.path, "add a simulation: block");
  auto setup = std::make_shared<SimulationSetup>();
  setup->mesh = io::ReadGmsh(scene.mesh.file, scene.mesh.metres_per_unit);
  CheckSceneGeometry(scene, setup->mesh);
  setup->fixed_nodes = NodeSet(setup->mesh, scene.mesh.fixed_set, scene.path);
  setup->surface_nodes = NodeSet(setup->mesh, scene.mesh.surface_set, scene.path);
  setup->material = scene.material;
  setup->options = *scene.simulation;
  setup->fps = scene.video.fps;
  std::vector<int> fixed_dofs;
  for (int a : setup->fixed_nodes) {
    for (int i = 0; i < 3; ++i) fixed_dofs.push_back(3 * a + i);
  }
  setup->stability = sim::EstimateStability(setup->mesh, setup->material, fixed_dofs);
  const double safety = sim::DefaultStabilitySafety(setup->material.poissons_ratio);
  const double safe_dt_s = safety * setup->stability.dt_critical_s;
  if (setup->options.dt_s > safe_dt_s) {
    char limit[32];
    std::snprintf(limit, sizeof limit, "%.4g ms", safe_dt_s * 1e3);
    const std::string excess = setup->stability.TimeStepExcess(setup->options.dt_s, safety);
    if (setup->options.time_step_policy != sim::TimeStepPolicy::kSubstep) {
      throw Error("simulation.dt_s: " + excess, scene.path,
                  "set simulation.dt_s at or below " + std::string(limit) +
                      ", let the run substep (simulation.time_step_policy: substep), or mesh more coarsely or "
                      "with better-shaped elements near the limiting node");
    }
    // The simulation then steps at the largest stable fraction of dt_s; a
    // frame takes that many more steps (FemStage: round(1 / (fps dt))).
    const int substeps = static_cast<int>(std::ceil(setup->options.dt_s / safe_dt_s));
    Logger("pipeline").info("simulation.dt_s = {:.4g} ms split into {} substeps of {:.4g} ms: {}",
                            setup->options.dt_s * 1e3, substeps, setup->options.dt_s / substeps * 1e3, excess);
    setup->options.dt_s /= substeps;
  }
  const auto load_motion = [&] {
    return stages::LoadMotionModel(scene.preoperative->motion, setup->mesh.num_nodes(), scene.preoperative->period_s,
                                   setup->options.motion_smoothing);
  };
  if (setup->options.mode != sim::SimulationMode::kSurface) {
    setup->motion = setup->predictor = load_motion();
  } else if (scene.preoperative) {
    // Surface mode runs without the scan's node motion; it only predicts across dropped frames when it has it.
    try {
      setup->predictor = load_motion();
    } catch (const Error& e) {
      Logger("pipeline").warn("surface mode without the scan's node motion ({}): across dropped frames the "
                              "constraints move at the fastest tracked speed instead of following the scan",
                              e.what());
    }
  }
  return setup;
}

ConstraintAdapter::ConstraintAdapter(std::shared_ptr<const SimulationSetup> setup,
                                     std::shared_ptr<const io::Registration> given)
    : setup_(std::move(setup)), registration_(std::move(given)) {}

void ConstraintAdapter::Process(FramePacket& packet) {
  if (!registration_) registration_ = packet.registration;
  packet.registration = registration_;
  if (!registration_) {  // before the registration: nothing to tie to
    packet.targets.nodes.clear();
    packet.targets.displacement_S_m.clear();
    packet.targets.features.clear();
    return;
  }
  if (!mapper_) {
    // The mesh's geometry at this frame: the scan's motion at the registered phase.
    const sim::TetMesh& mesh = setup_->mesh;
    Eigen::Matrix3Xd first = Eigen::Matrix3Xd::Zero(3, mesh.num_nodes());
    if (setup_->motion) {
      setup_->motion->Evaluate<double>(SimulationSetup::PhaseAt(packet),
                                       std::span<double>(first.data(), first.size()));
    }
    stages::ConstraintMapper::Options options;
    options.max_tie_distance_m = setup_->options.max_tie_distance_m;
    options.outlier_gate_min_m = setup_->options.outlier_gate_min_m;
    options.outlier_gate_scale = setup_->options.outlier_gate_scale;
    options.neighbour_radius_m = setup_->options.outlier_neighbour_radius_m;
    mapper_ = std::make_unique<stages::ConstraintMapper>(options, mesh.X_m, first, setup_->surface_nodes,
                                                         setup_->fixed_nodes,
                                                         Eigen::Isometry3d(registration_->T_C_S));
  }
  // The scan's motion at this frame's phase is what the outlier gate measures the features against.
  const Eigen::Matrix3Xd* prediction = nullptr;
  if (setup_->predictor) {
    predicted_.resize(3, setup_->mesh.num_nodes());
    setup_->predictor->Evaluate<double>(SimulationSetup::PhaseAt(packet),
                                        std::span<double>(predicted_.data(), predicted_.size()));
    prediction = &predicted_;
  }
  mapper_->Process(packet.tracks.points, prediction, &packet.targets);  // into the packet's lists, reused
}

std::shared_ptr<stages::FemFrameOutput> FemAdapter::FreeOutput() {
  for (const std::shared_ptr<stages::FemFrameOutput>& output : outputs_) {
    if (output.use_count() == 1) {
      // Pairs with the release of the last other owner's reference, so its
      // reads of the output happen before this frame writes over it.
      std::atomic_thread_fence(std::memory_order_acquire);
      return output;
    }
  }
  return outputs_.emplace_back(std::make_shared<stages::FemFrameOutput>());
}

void FemAdapter::Process(FramePacket& packet) {
  if (!packet.registration) return;  // the simulation starts at the first registered frame
  if (!fem_) {
    stages::FemStage::Options options;
    options.mode = setup_->options.mode;
    options.dt_s = setup_->options.dt_s;
    options.damping_per_s = setup_->options.damping_per_s;
    options.fps = setup_->fps;
    options.phase_at_first_frame = SimulationSetup::PhaseAt(packet);
    options.sampled_nodes = setup_->options.sampled_nodes;
    options.concurrent = setup_->options.concurrent;
    options.inverse_interval_steps = setup_->options.inverse_interval_steps;
    options.precision = setup_->options.precision;
    options.launch_helper = helpers_->launcher();
    fem_ = std::make_unique<stages::FemStage>(options, setup_->mesh, setup_->material, setup_->motion,
                                              setup_->predictor, setup_->fixed_nodes, &setup_->stability);
    first_frame_ = packet.index;
    Logger("pipeline").info("simulation starts at frame {} ({} mode, {}, dt {} ms, critical dt {:.3f} ms)",
                            packet.index, sim::ToString(setup_->options.mode),
                            sim::ToString(setup_->options.precision), 1e3 * options.dt_s,
                            1e3 * fem_->stability().dt_critical_s);
  }
  std::shared_ptr<stages::FemFrameOutput> output = FreeOutput();
  fem_->Process(static_cast<int>(packet.index - first_frame_), packet.targets, output.get(), &packet.phase);
  packet.simulation = std::move(output);
}

}  // namespace dg::pipeline
