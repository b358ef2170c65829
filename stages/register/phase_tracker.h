#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "stages/register/fiducial_motion.h"
#include "stages/register/phase_estimate.h"
#include "stages/track/triangulator.h"

namespace dg::stages {

// The phase in [0, 1) at scan time tau of a beat made of cycles (starts
// increasing, each with its period), as a phantom's truth lists them
// (truth.h5 /cycles). @pre tau >= starts[0]; non-empty, equal sizes.
double CyclePhase(const std::vector<double>& starts_s, const std::vector<double>& periods_s, double tau_s);

// The difference a - b of two phases, wrapped into [-0.5, 0.5) cycles.
double PhaseDifference(double a, double b);

// One fiducial seen in a rectified pair: left pixel and disparity.
struct RectifiedSighting {
  bool valid = false;
  Eigen::Vector3d uvd_px = Eigen::Vector3d::Zero();  // (u_left, v, u_left - u_right), rectified
};

// Live cardiac phase (docs/phase.md). The registration fixes the pose and
// one phase shift over its window; a real beat then drifts from the scan's
// period. Every frame, this fits the tracked fiducials of the recent past,
// weighted towards the newest, against the scan's fiducial motion placed by
// the registration's pose: for frame k at time t_k of the window ending at
// t (now), fiducial i is expected at
//   x_ik = T_C_S (m_i + A (s_i(phi_k) - m_i)) + d,
// phi_k = phi + rate (t_k - t) back to the current cycle's start, and at the
// previous cycle's own rate before it (each beat has its own length)
// (s_i the scan's motion, interpolated by cyclic cubic Hermite splines;
// m_i its mean over the cycle; A the beat's amplitude; d a small offset),
// compared in rectified pixels and disparity, where the tracker's errors
// are about equal. The unknowns (phi, both rates, A, d) are solved by damped
// Gauss-Newton from the previous frame's answer carried forward, with weak
// priors on the rates, A and d so that a window in which the heart is at rest
// keeps the phase advancing at the last rate. Causal: a frame's estimate
// uses frames up to it. Stateful: frames in order; knows nothing of threads.
class PhaseTracker {
 public:
  struct Options {
    // The fit's window, in scan periods, and the age over which a frame's
    // weight falls by e: longer averages more tracking noise, shorter follows
    // a change of rate sooner. On phantoms with 10% period variation, 0.7 and
    // 0.35 gave the smallest largest error (docs/phase.md).
    double window_periods = 0.7;
    double decay_periods = 0.35;
    double pixel_sigma = 0.3;        // the tracker's error per coordinate (px)
    double rate_sigma = 0.15;        // prior on the rate, a fraction of the scan's
    double amplitude_sigma = 0.2;    // prior on A about 1
    double offset_sigma_m = 1.0e-3;  // prior on each axis of d
    int iterations = 4;
    std::string Validate() const;  // empty when valid
  };

  // @throws dg::Error for invalid options or motion, or a period that is not positive.
  PhaseTracker(const Options& options, FiducialMotion scan, const Triangulator& geometry, double period_s);

  // Adds frame t_s's sightings (one per scan fiducial, in its order) to the
  // window; before Start() the frames only fill it.
  // @throws dg::Error for another fiducial count, or a time not after the last.
  void Observe(double t_s, const std::vector<RectifiedSighting>& fiducials);

  // From now on, Estimate() fits: pose T_C_S, and the phase and rate at
  // time t_s to start from (the registration's (t + lambda) / T and 1 / T).
  void Start(const Eigen::Isometry3d& T_C_S, double t_s, double phase, double rate_hz);
  bool started() const { return started_; }

  // The phase at the newest observed frame's time. Invalid before Start() and
  // while fewer than three frames of the window have fiducials.
  PhaseEstimate Estimate();

 private:
  struct Frame {
    double t_s;
    std::vector<RectifiedSighting> fiducials;
  };
  static constexpr int kUnknowns = 7;  // phase, rate, previous rate, A, d (3)
  struct Unknowns {
    double phase = 0;  // unwrapped: whole cycles count
    double rate_hz = 0, previous_rate_hz = 0;
    double amplitude = 1;
    Eigen::Vector3d offset_C_m = Eigen::Vector3d::Zero();
  };
  // A window frame's phase, age_s before now, and its derivatives by phase, rate and previous rate.
  struct FramePhase {
    double phase, d_phase, d_rate, d_previous_rate;
  };
  static FramePhase PhaseOfAge(const Unknowns& x, double age_s);
  struct Normal {
    Eigen::Matrix<double, kUnknowns, kUnknowns> matrix;
    Eigen::Matrix<double, kUnknowns, 1> gradient;
    double weighted_squares = 0, weight_sum = 0;
  };
  // The weighted normal equations of the window and the priors at x.
  void Accumulate(const Unknowns& x, double now_s, Normal* normal) const;
  // Fiducial i's expected sighting at phase phi under amplitude A and offset
  // d, and optionally its derivatives by phi, A and d (columns).
  Eigen::Vector3d Expected(int fiducial, double phi, double amplitude, const Eigen::Vector3d& offset_C_m,
                           Eigen::Matrix<double, 3, 5>* d_dpAd = nullptr) const;
  // Fiducial i at phase phi in S, by the cyclic spline through the scan's
  // phases, and optionally its derivative by phi.
  Eigen::Vector3d ScanAt(int fiducial, double phi, Eigen::Vector3d* d_dphi = nullptr) const;

  Options options_;
  FiducialMotion scan_;
  std::vector<Eigen::Matrix3Xd> tangents_S_m_;  // per phase: d position / d phase (cycles)
  Eigen::Matrix3Xd mean_S_m_;
  const Triangulator& geometry_;
  double period_s_;
  std::vector<Frame> window_;

  bool started_ = false;
  Eigen::Isometry3d T_C_S_ = Eigen::Isometry3d::Identity();
  double t_s_ = 0;  // the time of the last answer
  Unknowns last_;
};

}  // namespace dg::stages
