#pragma once

#include <memory>
#include <span>
#include <vector>

#include "sim/motion_model.h"
#include "stages/constraints/constraint_mapper.h"

namespace dg::stages {

// The constrained nodes' targets at the frame times between the simulation's
// state and a new frame's targets, so that across dropped frames the
// constraints follow a motion the tissue can make instead of a straight line
// over hundreds of milliseconds of heartbeat.
//
// With the scan's cyclic motion model (the predictor), a node's target at time
// t is the model's displacement at t plus the node's residual (its
// displacement minus the model's) interpolated linearly in time between the
// start and the new frame: the large periodic motion comes from the model,
// only the small residual is interpolated.
//
// Without one, each target moves from the node's start towards its new target
// no faster than any tracked target has been seen to move between simulated
// frames (the tissue's fastest observed speed). What a gap leaves of the way
// is covered in the following frames at that speed: a node lags rather than
// jumps. Until a speed has been seen the targets hold.
//
// A gap of one frame period gives the new targets at its end in both cases
// (with no predictor, once the motion has been seen). Stateful: Begin() per
// simulated frame, in order.
class GapTargets {
 public:
  // predictor: the scan's motion, or null. phase_at_zero: its phase at t = 0.
  GapTargets(std::shared_ptr<const sim::CyclicMotionModel> predictor, double phase_at_zero);

  // A new frame's targets at time to_s; start_m: the constrained nodes'
  // displacements at from_s (3 per node of `targets`, in its order), where
  // the simulation has them. @pre from_s <= to_s (equal at the first frame,
  // whose targets only start the speed bound); targets' nodes increase.
  void Begin(const NodeTargets& targets, std::span<const double> start_m, double from_s, double to_s);

  // The targets at time t_s, from_s < t_s <= to_s, into out (3 per node of
  // the targets given to Begin()).
  void At(double t_s, std::vector<double>* out) const;

  // From now on the predictor's phase at time t is phase + rate_hz (t - t_s):
  // the heart's phase as the video shows it (docs/phase.md).
  void FollowPhase(double t_s, double phase, double rate_hz);

  bool predicts() const { return predictor_ != nullptr; }
  // Without a predictor: the speed bound so far (m/s).
  double speed_limit_m_per_s() const { return speed_limit_m_per_s_; }

 private:
  // The predictor's displacement of node a at time t_s into out[0..2].
  void Predict(int node, double t_s, double* out) const;
  // Raises the speed bound by the motion of the nodes tracked at both the previous frame and this one.
  void ObserveSpeed(const NodeTargets& targets, double elapsed_s);

  std::shared_ptr<const sim::CyclicMotionModel> predictor_;
  // The predictor's phase is anchor_phase_ + rate_hz_ (t - anchor_t_s_).
  double anchor_t_s_ = 0, anchor_phase_ = 0, rate_hz_ = 0;
  double from_s_ = 0, to_s_ = 0;
  std::vector<int> nodes_;
  std::vector<double> start_m_, target_m_;
  // With a predictor: residual (displacement - model) at from_s and at to_s.
  std::vector<double> residual_from_m_, residual_to_m_;
  // Without one: the previous frame's tracked targets, and the speed bound.
  std::vector<int> previous_nodes_;
  std::vector<double> previous_target_m_;
  double speed_limit_m_per_s_ = 0;
};

}  // namespace dg::stages
