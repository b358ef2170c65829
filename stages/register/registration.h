#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/registration_file.h"
#include "stages/register/fiducial_motion.h"

namespace dg::io {
class H5Writer;
}

namespace dg::stages {

// One fiducial in one video frame, in each eye's original (distorted) pixels.
struct FiducialSighting {
  bool in_left = false, in_right = false;
  Eigen::Vector2d uv_left_px = Eigen::Vector2d::Zero(), uv_right_px = Eigen::Vector2d::Zero();
};

// The registration window: frame times t_s[j] (video time, seconds) and the
// sightings frames[j][i] of fiducial i, in the scan's fiducial order.
struct FiducialTracks {
  std::vector<double> t_s;
  std::vector<std::vector<FiducialSighting>> frames;
};

struct RegistrationOptions {
  // The global search tries this many phase shifts per scan phase, evenly
  // over one period: the cost is not convex in the shift, and its basins are
  // about a phase wide.
  int search_steps_per_phase = 2;
  int refined_candidates = 3;     // the best local minima of the search refined jointly
  double robust_scale_px = 3.0;   // Cauchy loss scale: residuals well above it barely pull
  double outlier_px = 10.0;       // residuals above it are outliers: not in PnP's consensus nor in the statistics
  int max_iterations = 100;

  std::string Validate() const;  // empty when valid
};

struct RegistrationResult {
  io::Registration registration;
  // The global search's profile: robust cost (px^2) after PnP at each shift.
  std::vector<double> search_shift_s, search_cost;
  int iterations = 0;  // of the joint refinement that won
};

// Spatiotemporal registration (paper section 2.2):
// minimises sum_ij rho(|pL(T s_i(t_j + lambda)) - tL_ij|^2) + rho(|pR(...) - tR_ij|^2)
// over T_C_S and lambda, rho a Cauchy loss. The shift is searched over one
// period; at each candidate the pose comes from RANSAC PnP on the left view;
// the best candidates are refined jointly (Ceres, automatic derivatives);
// the covariance is Ceres' at the optimum, scaled by the residual variance.
// Candidates are searched in parallel (TBB); the result does not depend on the thread count.
// @throws dg::Error for invalid options or motion, fewer than 3 fiducials, a
//   window shorter than one period, a frame with another fiducial count, a
//   fiducial never seen in one eye, or no candidate with a pose.
RegistrationResult RegisterScanToVideo(const FiducialMotion& motion, const io::StereoCalibration& calibration,
                                       double period_s, const FiducialTracks& tracks,
                                       const RegistrationOptions& options);

// The run log's /registration: the registration (io::WriteRegistrationH5)
// and the search profile (search/shift_s, search/cost_px2).
void WriteRegistrationLog(const RegistrationResult& result, io::H5Writer* file, const std::string& group);

}  // namespace dg::stages
