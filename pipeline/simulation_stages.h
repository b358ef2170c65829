#pragma once

#include <memory>
#include <string>
#include <vector>

#include "io/calibration.h"
#include "io/registration_file.h"
#include "io/scene.h"
#include "pipeline/packet_stage.h"
#include "pipeline/solver_helpers.h"
#include "sim/motion_model.h"
#include "sim/tet_mesh.h"
#include "stages/fem_stage.h"
#include "stages/register/phase_tracker.h"
#include "stages/register/registration_stage.h"
#include "stages/track/fiducial_tracker.h"
#include "stages/track/triangulator.h"

namespace dg::pipeline {

// The stages after tracking: registration, constraint
// mapping and the FEM step, as the graph sees them. The simulation starts at
// the first frame that carries a registration: its cardiac phase is the
// registered one, and constraints are tied to the mesh in its geometry there.

// register: packet.rectified -> packet.registration. Follows the fiducials
// (FiducialTracker, from their first-frame pixels) over the window, solves
// once on the frame that completes it (that frame waits for the solution),
// and hands the result to that frame and every later one. With live_phase it
// then keeps following the fiducials and estimates the heart's phase on every
// frame (stages::PhaseTracker, docs/phase.md) into packet.phase. Stateful.
// The tissue's depth is checked against the depth range (CheckWorkingDistance)
// where it is first known: at the first frame, for fiducials that match only
// outside the range (a range in the wrong unit finds none, and the
// registration would blame their tracking), and at the solution.
class RegisterAdapter final : public PacketStage {
 public:
  // first_uv_left_px: the fiducials' pixels in the first left frame (original,
  // distorted), in the scan's order. calibration: with its rectification.
  // @throws dg::Error for a first pixel outside the calibrated field, or
  // invalid options, motion or period (RegistrationStage).
  RegisterAdapter(const stages::RegistrationStage::Options& options, stages::FiducialMotion motion,
                  const io::StereoCalibration& calibration, double period_s,
                  const std::vector<Eigen::Vector2d>& first_uv_left_px, double near_m, double far_m,
                  bool live_phase);
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override;

 private:
  // @throws dg::Error (CheckWorkingDistance) when the first frame sees a
  // fiducial only outside the depth range.
  void CheckFirstFrameDepths(const FramePacket& packet, const std::vector<stages::FiducialObservation>& seen) const;
  // The frame's fiducials into the registration's window, solving when it is full.
  void Register(const FramePacket& packet, const std::vector<stages::FiducialObservation>& seen);
  // The frame's fiducials into the phase tracker's window.
  void ObservePhase(double t_s, const std::vector<stages::FiducialObservation>& seen);

  std::string name_ = "register";
  io::StereoCalibration calibration_;
  double near_m_, far_m_;
  std::vector<cv::Point2f> first_uv_left_R_px_;  // the fiducials' first pixels, rectified (unset: outside the field)
  Eigen::Matrix3Xd first_phase_fiducials_S_m_;   // the scan's fiducials at phase 0
  bool first_frame_ = true;
  stages::Triangulator geometry_;
  stages::FiducialTracker tracker_;
  stages::RegistrationStage stage_;
  std::unique_ptr<stages::PhaseTracker> phase_;  // null without live phase
  std::vector<stages::RectifiedSighting> phase_sightings_;  // this frame's (reused)
  std::shared_ptr<const stages::RegistrationResult> solve_;
  std::shared_ptr<const io::Registration> result_;  // solve_'s registration
};

// What constraint mapping and the FEM stage share: the scene's mesh, its
// mount and surface, the material, the scan's motion and the scene's
// simulation options.
struct SimulationSetup {
  sim::TetMesh mesh;
  std::vector<int> fixed_nodes, surface_nodes;
  sim::Material material;
  // The scan's motion as the simulation's driver: null in surface mode (no recovered forces).
  std::shared_ptr<const sim::CyclicMotionModel> motion;
  // The scan's motion as the constraints' predictor across dropped frames:
  // whenever the scene has one, in every mode (the same model as `motion` when that is set).
  std::shared_ptr<const sim::CyclicMotionModel> predictor;
  io::Scene::Simulation options;
  double fps = 30;
  // The mesh's stable time step with the mount held, estimated at load so
  // that an unstable dt_s is refused before the run starts, and the first
  // simulated frame does not pay for the estimate.
  sim::StabilityReport stability;

  // The motion model's phase at a registered frame: the live estimate when
  // the frame has one, else the registration's (t + lambda) / T.
  static double PhaseAt(const FramePacket& packet);
};

// @throws dg::Error for a scene without simulation, a mesh without the named
// fixed or surface set, an unreadable motion model, or a time step above the
// mesh's stable limit.
std::shared_ptr<const SimulationSetup> LoadSimulationSetup(const io::Scene& scene);

// constraints: packet.tracks (+ registration) -> packet.targets. Ties the
// features to surface nodes at the first registered frame. Stateful.
class ConstraintAdapter final : public PacketStage {
 public:
  // given: the scene's registration, or null when a register stage precedes.
  ConstraintAdapter(std::shared_ptr<const SimulationSetup> setup, std::shared_ptr<const io::Registration> given);
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "constraints";
  std::shared_ptr<const SimulationSetup> setup_;
  std::shared_ptr<const io::Registration> registration_;
  std::unique_ptr<stages::ConstraintMapper> mapper_;
  Eigen::Matrix3Xd predicted_;  // the scan's node displacements at this frame (reused)
};

// simulate: packet.targets -> packet.simulation: the FEM stage advanced to the
// frame's time, in round(1 / (fps dt)) substeps. Stateful.
class FemAdapter final : public PacketStage {
 public:
  explicit FemAdapter(std::shared_ptr<const SimulationSetup> setup)
      : setup_(std::move(setup)), helpers_(std::make_unique<SolverHelpers>()) {}
  const std::string& name() const override { return name_; }
  bool stateful() const override { return true; }
  bool parallel_inside() const override { return true; }
  void Process(FramePacket& packet) override;

 private:
  std::string name_ = "simulate";
  std::shared_ptr<const SimulationSetup> setup_;
  // An output no packet or overlay holds any more, else a new one.
  std::shared_ptr<stages::FemFrameOutput> FreeOutput();

  std::unique_ptr<SolverHelpers> helpers_;  // outlives fem_, whose solver launches on it
  std::unique_ptr<stages::FemStage> fem_;
  std::int64_t first_frame_ = 0;
  // The outputs handed out so far (packets and sinks share them; a frame
  // reuses one that only this pool holds): as many as are ever alive at once.
  std::vector<std::shared_ptr<stages::FemFrameOutput>> outputs_;
};

}  // namespace dg::pipeline
