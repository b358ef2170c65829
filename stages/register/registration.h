#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/calibration.h"
#include "io/registration_file.h"
#include "stages/register/fiducial_assignment.h"
#include "stages/register/fiducial_motion.h"
#include "stages/register/fiducial_tracks.h"

namespace dg::io {
class H5Writer;
}

namespace dg::stages {

struct RegistrationOptions {
  // The global search tries this many phase shifts per scan phase, evenly
  // over one period: the cost is not convex in the shift, and its basins are
  // about a phase wide.
  int search_steps_per_phase = 2;
  int refined_candidates = 3;     // the best local minima of the search refined jointly
  double robust_scale_px = 3.0;   // Cauchy loss scale: residuals well above it barely pull
  double outlier_px = 10.0;       // residuals above it are outliers: not in PnP's consensus nor in the statistics
  int max_iterations = 100;

  // The registration checks itself and refuses rather than report a
  // confident wrong answer (docs/registration.md):
  // the markers' mean positions fitting the scan's within this (rms, left
  // image) explain the tracks (the fiducial assignment's test);
  double assignment_tolerance_px = 1.5;
  // kept residuals with an rms above it: the motion does not explain the
  // tracks, and the robust fit no longer tells inliers from outliers (half of
  // outlier_px; the phantom's tracked markers give 0.5 px, the paper's real
  // phantom a mean of 0.47 mm, a few pixels at an endoscope's distance);
  double max_rms_px = 5.0;
  // more of the sightings than this beyond outlier_px: the tracks follow something else;
  double max_outlier_fraction = 0.3;
  // another distinct minimum within this factor of the best's cost: not unique.
  double min_runner_up_ratio = 1.5;

  std::string Validate() const;  // empty when valid
};

struct RegistrationResult {
  io::Registration registration;
  // Which scan fiducial each track follows: the order given, unless another
  // assignment explains the tracks and the given one does not.
  FiducialAssignment assignment;
  // The best distinct local minimum after the winner (its cost over the
  // winner's; infinite when every candidate converged to the winner).
  double runner_up_cost_ratio = 0;
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
